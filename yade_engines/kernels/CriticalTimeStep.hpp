// Critical time-step estimates for the contact laws (Rayleigh wave and contact-oscillator criteria).
#pragma once

#include <cmath>

#include "kernels/HertzMindlin.hpp"
#include "railcosim/HostDevice.hpp"
#include "kernels/MathConstants.hpp"

namespace railcosim::kernels {

// Rayleigh-wave time T_R = π R sqrt(ρ/G) / (0.1631 ν + 0.8766) (O'Sullivan & Bray 2004; Irazábal 2017
// §3.5). Use Δt = 0.1–0.3 T_R for the smallest particle. Material-only: ignores damping and contact law. [s]
RAILCOSIM_HOST_DEVICE inline double rayleighTimeStep(double radius, double density, double shearModulus,
                                                     double poissonRatio) {
  return pi * radius * std::sqrt(density / shearModulus) / (0.1631 * poissonRatio + 0.8766);
}

// Stability limit of the central-difference (leapfrog / velocity-Verlet) update for one mass on a
// spring with viscous damping ratio ζ: Δt_c = (2/ω)(sqrt(1 + ζ²) − ζ), ω = sqrt(k/m) (Belytschko, Liu
// & Moran 2000, §6.3). Heavily damped contacts (e → 0 gives ζ ≈ 14) need a ≈28× smaller step. [s]
RAILCOSIM_HOST_DEVICE inline double springCriticalTimeStep(double mass, double stiffness, double dampingRatio) {
  return 2.0 * std::sqrt(mass / stiffness) * (std::sqrt(1.0 + dampingRatio * dampingRatio) - dampingRatio);
}

// Largest overlap of an undamped Hertz impact at approach speed v (energy balance
// ½ m* v² = (8/15) E* √R* δ^{5/2}). [m]
RAILCOSIM_HOST_DEVICE inline double hertzMaximumOverlap(const HertzMindlinParams& p, double impactVelocity) {
  return std::pow(15.0 * p.effectiveMass * impactVelocity * impactVelocity /
                      (16.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius)),
                  0.4);
}

// Overlap of a Hertz contact carrying the elastic normal force F: δ = (3F / (4 E* sqrt(R*)))^{2/3), the inverse
// of hertzElasticNormalForce (Johnson 1985, eq. 4.23). [m]
RAILCOSIM_HOST_DEVICE inline double hertzOverlapAtForce(const HertzMindlinParams& p, double normalForce) {
  return std::pow(3.0 * normalForce / (4.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius)), 2.0 / 3.0);
}

// Hertz–Mindlin contact step at overlap δ: the stiffest mode is either the normal spring k_n or the tangential
// spring k_t acting through translation AND rotation of solid spheres (effective inverse mass 1/m + R²/I = 3.5/m,
// so 3.5 k_t). [s]
RAILCOSIM_HOST_DEVICE inline double hertzCriticalTimeStepAtOverlap(const HertzMindlinParams& p, double overlap) {
  const double normalStiffness = hertzNormalStiffness(p, overlap);
  const double rotationalTangentialStiffness = 3.5 * mindlinTangentialStiffness(p, overlap);
  const double stiffness =
      normalStiffness > rotationalTangentialStiffness ? normalStiffness : rotationalTangentialStiffness;
  return springCriticalTimeStep(p.effectiveMass, stiffness, p.dampingRatio);
}

// Hertz–Mindlin contact step for the largest expected impact speed (at δ_max of that impact). Take 0.2–0.5 of
// this value to leave room for several simultaneous contacts per particle. [s]
RAILCOSIM_HOST_DEVICE inline double hertzCriticalTimeStep(const HertzMindlinParams& p, double impactVelocity) {
  return hertzCriticalTimeStepAtOverlap(p, hertzMaximumOverlap(p, impactVelocity));
}

// The same for a contact held at the normal force F (a loaded bed: the largest force a contact carries). [s]
RAILCOSIM_HOST_DEVICE inline double hertzCriticalTimeStepAtForce(const HertzMindlinParams& p, double normalForce) {
  return hertzCriticalTimeStepAtOverlap(p, hertzOverlapAtForce(p, normalForce));
}

} // namespace railcosim::kernels
