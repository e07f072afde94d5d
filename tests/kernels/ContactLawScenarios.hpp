// The two scenarios every path of the contact law must reproduce, with their closed-form oracles and tolerances.
//
// A granite sphere against a flat of the same granite (Tolomeo & McDowell 2022, Table 1 material; R* = R, m* = m):
//  1. a quasi-static elasto-plastic Pohrt–Popov cycle: approach at 1e-8 m per step until F_n ≥ 500 N, withdraw at
//     the same rate until the force vanishes;
//  2. a head-on impact of the smooth (Hertz) sphere at 0.5 m/s with restitution e = 0.5.
// Paths: the composition itself (tests/kernels/TestContactLaw.cpp), the polyhedra step on the CPU
// (tests/polyhedra/PolyhedraContactTest.cpp) and on CUDA (tests/polyhedra/PolyhedraGpuComparison.cpp); the YADE
// pair law and the sphere–FE-surface contacts repeat the same numbers in yade_engines/checks/contact_law_paths.py.
// No Boost here: the GPU comparison, a plain executable, includes it too.
#pragma once

#include <cmath>

#include "kernels/ContactLaw.hpp"

namespace railcosim::testing::scenario {

constexpr double pi = 3.14159265358979323846;

// Material and body.
constexpr double youngModulus = 60e9;                                        // E [Pa]
constexpr double poissonRatio = 0.25;                                        // ν [-]
constexpr double density = 2650.0;                                           // [kg/m³]
constexpr double friction = 0.7;                                             // μ [-]
constexpr double fractalDimension = 2.13;                                    // D_f [-]
constexpr double roughnessRms = 2.61e-5;                                     // h [m]
constexpr double radius = 4.72e-3;                                           // R [m]; against the flat R* = R
constexpr double mass = 4.0 / 3.0 * pi * radius * radius * radius * density; // [kg]

// Cycle.
constexpr double cycleSpeed = 0.01;    // approach and withdrawal [m/s]
constexpr double cycleTimeStep = 1e-6; // [s]: 1e-8 m per step
constexpr double cycleStep = cycleSpeed * cycleTimeStep;
constexpr double cyclePeakForce = 500.0; // turn back at the first step with F_n ≥ this [N]

// Impact.
constexpr double impactRestitution = 0.5; // e [-]
constexpr double impactSpeed = 0.5;       // [m/s]
// Hertz contact time 2.868 (m*²/(R* E*² v))^{1/5} = 4.06e-5 s: about 2000 steps per contact.
constexpr double impactTimeStep = 2e-8; // [s]

// E* of like materials, E/(2(1 − ν²)) (written out, not taken from the kernels: it is part of the oracle). [Pa]
constexpr double effectiveYoungModulus = youngModulus / (2.0 * (1.0 - poissonRatio * poissonRatio));

inline kernels::ContactMaterial roughPlasticGranite() {
  // e = 1: no dashpot, so the prescribed quasi-static cycle sees the elastic-plastic law alone.
  return kernels::ContactMaterial{youngModulus, poissonRatio, 1.0, friction, roughnessRms, fractalDimension, true};
}

inline kernels::ContactMaterial smoothGranite() {
  return kernels::ContactMaterial{youngModulus, poissonRatio, impactRestitution, friction};
}

// ---------------------------------------------------------------------------------------------------
// Oracles.
// ---------------------------------------------------------------------------------------------------

// Virgin curve at δ: the kernel's closed form (Tolomeo & McDowell 2022 eq. 1 integrated from F = 0, checked against
// the paper in TestPohrtPopov.cpp); here it tests that a path hands the law the right E*, R*, D_f and h. [N]
inline double virginForce(double overlap) {
  const kernels::PohrtPopovParams p =
      kernels::makePohrtPopovParams(effectiveYoungModulus, radius, fractalDimension, roughnessRms);
  return kernels::pohrtPopovElasticForce(p, overlap);
}

// Plastic overlap after unloading from (δ_max, F_max): δ_p = δ_max − (3F_max/(4E*√R*))^{2/3} (eq. 6 in overlap). [m]
inline double plasticOverlap(double peakOverlap, double peakForce) {
  return peakOverlap - std::pow(3.0 * peakForce / (4.0 * effectiveYoungModulus * std::sqrt(radius)), 2.0 / 3.0);
}

// Hertzian unloading branch from δ_p: F = (4/3)E*√R*(δ − δ_p)^{3/2}, zero below δ_p. [N]
inline double unloadingForce(double overlap, double plastic) {
  return overlap > plastic ? 4.0 / 3.0 * effectiveYoungModulus * std::sqrt(radius) * std::pow(overlap - plastic, 1.5)
                           : 0.0;
}

// ---------------------------------------------------------------------------------------------------
// What a path reports and how far it may be from the oracles.
// ---------------------------------------------------------------------------------------------------

// Fed with every step of the cycle (the overlap and normal force of that step's evaluation).
class CycleRecorder {
public:
  // `unloading`: from the turn on. A path whose bodies move after the forces of a step (YADE's integrator) reaches
  // one step deeper than where it turns: the deepest sample is the peak, whichever phase reports it.
  void sample(double overlap, double force, bool unloading) {
    if (!unloading || overlap > peakOverlap) {
      if (overlap > peakOverlap) {
        peakOverlap = overlap;
        peakForce = force;
      }
      return;
    }
    if (done) return;
    const double middle = peakOverlap - 0.5 * (peakOverlap - plasticOverlap(peakOverlap, peakForce));
    if (force > 0.0) {
      releaseOverlap = overlap;
      if (middleOverlap < 0.0 && overlap <= middle) {
        middleOverlap = overlap;
        middleForce = force;
      }
    } else {
      zeroOverlap = overlap;
      done = true;
    }
  }

  // Relative deviation of the peak force from the virgin curve at the peak overlap.
  double peakForceError() const { return std::fabs(peakForce / virginForce(peakOverlap) - 1.0); }
  // How far the closed-form δ_p lies outside [first overlap with zero force, last overlap with force], in steps.
  double plasticOverlapStepsOutside() const {
    const double expected = plasticOverlap(peakOverlap, peakForce);
    const double outside =
        expected > releaseOverlap ? expected - releaseOverlap : (expected < zeroOverlap ? zeroOverlap - expected : 0.0);
    return outside / cycleStep;
  }
  // Relative deviation of the force halfway down the unloading branch from Hertz about the closed-form δ_p.
  double unloadingForceError() const {
    return std::fabs(middleForce / unloadingForce(middleOverlap, plasticOverlap(peakOverlap, peakForce)) - 1.0);
  }

  double peakOverlap = 0.0, peakForce = 0.0;
  double releaseOverlap = 0.0; // last unloading overlap with force
  double zeroOverlap = 0.0;    // first unloading overlap without force
  double middleOverlap = -1.0, middleForce = 0.0;
  bool done = false;
};

// Tolerances, the same on every path (measured on all of them: 4e-16, 0, 7e-16 and e = 0.49999):
//  - peak force against the virgin curve: the path and the oracle evaluate the same closed form at the overlap the
//    path reports, so only the order of the arithmetic differs (~1e-15); 1e-10 leaves that a wide margin, while a
//    path handing the law a wrong E*, R*, D_f or h by even 1e-6 fails;
//  - plastic overlap: the force vanishes at the closed-form δ_p, between two steps of the withdrawal, so the oracle
//    must fall inside the bracket; 0.01 step (1e-10 m) of slack for the round-off of the positions;
//  - unloading branch: Hertz in (δ − δ_p) with δ_p from the path's own (δ_max, F_max); the rounding of δ − δ_p
//    (≈1.5e-5 m) is ~1e-15 relative: 1e-10.
constexpr double peakForceTolerance = 1e-10;
constexpr double plasticOverlapStepTolerance = 0.01;
constexpr double unloadingForceTolerance = 1e-10;
// Restitution: the damping ratio comes from Thornton, Cummins & Cleary's fit of e(γ) for the Hertzian contact;
// its residual and the O(Δt) error of where the contact starts and ends with ~2000 steps per contact are each
// below 1e-4 (TestHertzMindlin.cpp measures 0.5000); 1e-3 leaves a factor 10, while a damping ratio 1 % off
// moves e by about 0.5 % and fails.
constexpr double restitutionTolerance = 1e-3;

} // namespace railcosim::testing::scenario
