// Unit tests of the critical time-step estimates: stability of the actual leapfrog update and Hertz impact.
#define BOOST_TEST_MODULE kernels_critical_time_step
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <cmath>

#include "ImpactSimulation.hpp"
#include "kernels/CriticalTimeStep.hpp"

using namespace railcosim::kernels;

namespace {

// Leapfrog as in YADE's NewtonIntegrator (damping force from the lagged half-step velocity): does a
// mass–spring–dashpot stay bounded over 5000 steps?
bool leapfrogStaysBounded(double mass, double stiffness, double dampingRatio, double timeStep) {
  const double damping = viscousDampingCoefficient(dampingRatio, mass, stiffness);
  double position = 1.0;
  double velocity = 0.0;
  for (int step = 0; step < 5000; ++step) {
    velocity += timeStep * (-stiffness * position - damping * velocity) / mass;
    position += timeStep * velocity;
    if (std::fabs(position) > 1e6) return false;
  }
  return true;
}

} // namespace

BOOST_AUTO_TEST_CASE(spring_limit_separates_stable_from_unstable_leapfrog) {
  // The estimate must be sharp: 2 % below it the update is stable, 2 % above it diverges — for the
  // undamped case and for damping ratios up to γ(e = 0) ≈ 14.2, where the step shrinks ≈ 28×.
  const double mass = 0.3;
  const double stiffness = 4.0e5;
  for (const double dampingRatio :
       {0.0, 0.2, dampingRatioFromRestitution(0.2), 2.0, dampingRatioFromRestitution(0.0)}) {
    const double critical = springCriticalTimeStep(mass, stiffness, dampingRatio);
    BOOST_TEST_CONTEXT("damping ratio " << dampingRatio) {
      BOOST_TEST(leapfrogStaysBounded(mass, stiffness, dampingRatio, 0.98 * critical));
      BOOST_TEST(!leapfrogStaysBounded(mass, stiffness, dampingRatio, 1.02 * critical));
    }
  }
  const double undamped = springCriticalTimeStep(mass, stiffness, 0.0);
  BOOST_TEST(undamped / springCriticalTimeStep(mass, stiffness, dampingRatioFromRestitution(0.0)) == 28.5,
             boost::test_tools::tolerance(0.02)); // Irazábal 2017 quotes "≈ 28×"
}

BOOST_AUTO_TEST_CASE(hertz_maximum_overlap_matches_a_simulated_impact) {
  const double radius = 0.02;
  const double mass = 2600.0 * 4.0 / 3.0 * M_PI * radius * radius * radius;
  const HertzMindlinParams p{effectiveYoungModulus(5e9, 0.25, 5e9, 0.25), 1e9, effectiveRadius(radius, radius),
                             effectiveMass(mass, mass), 0.0};
  const double speed = 3.0;
  const double overlap = hertzMaximumOverlap(p, speed);
  const double step = 0.1 * springCriticalTimeStep(p.effectiveMass, hertzNormalStiffness(p, overlap), 0.0) / 50.0;
  const auto outcome = railcosim::kernels::testing::simulateHeadOnImpact(
      p.effectiveMass, speed, step, [&](double delta, double rate) { return hertzNormalForce(p, delta, rate); });
  // The simulated peak is sampled once per step (≈ 1000 steps per impact): 1e-3 relative.
  BOOST_TEST(outcome.maximumOverlap == overlap, boost::test_tools::tolerance(1e-3));
  // The contact step is governed by the stiffer of k_n and 3.5 k_t at that overlap.
  const double expected = springCriticalTimeStep(
      p.effectiveMass, std::max(hertzNormalStiffness(p, overlap), 3.5 * mindlinTangentialStiffness(p, overlap)), 0.0);
  BOOST_TEST(hertzCriticalTimeStep(p, speed) == expected, boost::test_tools::tolerance(1e-14));
}

BOOST_AUTO_TEST_CASE(hertz_step_at_a_force_is_the_step_at_the_overlap_carrying_it) {
  const HertzMindlinParams p{effectiveYoungModulus(1e10, 0.27, 1e10, 0.27), 1e9, 0.004, 0.04, 0.4};
  // The overlap inverts the elastic force law ...
  for (const double force : {1.0, 250.0, 5000.0}) {
    BOOST_TEST(hertzElasticNormalForce(p, hertzOverlapAtForce(p, force)) == force, boost::test_tools::tolerance(1e-12));
  }
  // ... and an impact whose peak overlap carries F gives the same step as the contact held at F.
  const double overlap = hertzMaximumOverlap(p, 2.0);
  BOOST_TEST(hertzCriticalTimeStepAtForce(p, hertzElasticNormalForce(p, overlap)) == hertzCriticalTimeStep(p, 2.0),
             boost::test_tools::tolerance(1e-12));
  // Hertz stiffness grows as F^(1/3): 8x the force, half the squared step.
  const double ratio = hertzCriticalTimeStepAtForce(p, 8000.0) / hertzCriticalTimeStepAtForce(p, 1000.0);
  BOOST_TEST(ratio * ratio == 0.5, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(rayleigh_step_for_the_thesis_rolling_benchmark_material) {
  // Irazábal 2017 §3.5: for ρ = 1056 kg/m³, E = 4e7 Pa, ν = 0.49, T_R ≈ 0.0291 R s (3 digits: 0.2 %).
  const double radius = 0.1;
  const double rayleigh = rayleighTimeStep(radius, 1056.0, shearModulus(4.0e7, 0.49), 0.49);
  BOOST_TEST(rayleigh == 0.0291 * radius, boost::test_tools::tolerance(2e-3));
  // Halving the radius halves it, and a stiffer material shortens it as 1/sqrt(G).
  BOOST_TEST(rayleighTimeStep(radius / 2, 1056.0, shearModulus(4.0e7, 0.49), 0.49) == rayleigh / 2,
             boost::test_tools::tolerance(1e-14));
  BOOST_TEST(rayleighTimeStep(radius, 1056.0, 4.0 * shearModulus(4.0e7, 0.49), 0.49) == rayleigh / 2,
             boost::test_tools::tolerance(1e-14));
}
