// Unit tests of the Hertz–Mindlin (Thornton) kernels: equivalent properties, normal law, damping, tangential.
#define BOOST_TEST_MODULE kernels_hertz_mindlin
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "ImpactSimulation.hpp"
#include "kernels/HertzMindlin.hpp"

using namespace railcosim::kernels;

namespace {

// Granite-like spheres (softened to E = 1e8 Pa so the impact needs few steps; the restitution of the
// Hertzian dashpot does not depend on E, R, m or the speed, which the tests below exploit).
constexpr double youngModulus = 1.0e8; // [Pa]
constexpr double poissonRatio = 0.3;
constexpr double radius = 0.01;    // [m]
constexpr double density = 2600.0; // [kg/m³]
const double mass = density * 4.0 / 3.0 * M_PI * radius * radius * radius;

HertzMindlinParams likeSpheres(double dampingRatio) {
  const double shear = shearModulus(youngModulus, poissonRatio);
  return HertzMindlinParams{effectiveYoungModulus(youngModulus, poissonRatio, youngModulus, poissonRatio),
                            effectiveShearModulus(shear, poissonRatio, shear, poissonRatio),
                            effectiveRadius(radius, radius), effectiveMass(mass, mass), dampingRatio};
}

// Hertz collision time for an undamped impact, t_c = 2.868 (m*² / (R* E*² v))^{1/5}
// (Johnson 1985, Contact Mechanics §11.4, written with F = (4/3)E*√R* δ^{3/2}).
double hertzCollisionTime(const HertzMindlinParams& p, double speed) {
  return 2.868 * std::pow(p.effectiveMass * p.effectiveMass /
                              (p.effectiveRadius * p.effectiveYoungModulus * p.effectiveYoungModulus * speed),
                          0.2);
}

} // namespace

BOOST_AUTO_TEST_CASE(equivalent_properties_follow_the_thesis_definitions) {
  // Like spheres: R* = R/2, m* = m/2, E* = E/(2(1 − ν²)), G* = G/(2(2 − ν)).
  const HertzMindlinParams p = likeSpheres(0.0);
  BOOST_TEST(p.effectiveRadius == radius / 2.0, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(p.effectiveMass == mass / 2.0, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(p.effectiveYoungModulus == youngModulus / (2.0 * (1.0 - poissonRatio * poissonRatio)),
             boost::test_tools::tolerance(1e-14));
  const double shear = youngModulus / (2.0 * (1.0 + poissonRatio));
  BOOST_TEST(p.effectiveShearModulus == shear / (2.0 * (2.0 - poissonRatio)), boost::test_tools::tolerance(1e-14));
  // A wall (infinite radius and mass) reduces to the particle's own values (thesis eq. 4.1).
  const double infinity = std::numeric_limits<double>::infinity();
  BOOST_TEST(effectiveRadius(radius, infinity) == radius);
  BOOST_TEST(effectiveMass(mass, infinity) == mass);
}

BOOST_AUTO_TEST_CASE(normal_force_is_the_integral_of_the_thornton_stiffness) {
  // Oracle: F(δ) = ∫0^δ k_n(s) ds with k_n = 2E*sqrt(R* s), integrated by Simpson's rule on a √-mapped
  // grid (s = u², smooth integrand) — independent of the closed form in the kernel.
  const HertzMindlinParams p = likeSpheres(0.0);
  const double overlap = 2.0e-4;
  const int intervals = 2000;
  const double uMax = std::sqrt(overlap);
  const double du = uMax / intervals;
  double integral = 0.0;
  for (int i = 0; i <= intervals; ++i) {
    const double u = i * du;
    const double weight = (i == 0 || i == intervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    integral += weight * hertzNormalStiffness(p, u * u) * 2.0 * u; // ds = 2u du
  }
  integral *= du / 3.0;
  // Simpson on a smooth integrand with 2000 intervals is accurate to far below 1e-9.
  BOOST_TEST(hertzElasticNormalForce(p, overlap) == integral, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(hertzElasticNormalForce(p, -1e-6) == 0.0);
  BOOST_TEST(hertzNormalForce(p, -1e-6, 5.0) == 0.0);
}

BOOST_AUTO_TEST_CASE(undamped_impact_matches_hertz_collision_time_and_conserves_energy) {
  const HertzMindlinParams p = likeSpheres(0.0);
  const double speed = 1.0;
  const double collisionTime = hertzCollisionTime(p, speed);
  const auto outcome = railcosim::kernels::testing::simulateHeadOnImpact(
      p.effectiveMass, speed, collisionTime / 5000.0,
      [&](double overlap, double rate) { return hertzNormalForce(p, overlap, rate); });
  // 2.868 is quoted to 4 digits and the leapfrog error at 5000 steps per impact is ~1e-4: 0.2 %.
  BOOST_TEST(outcome.contactTime == collisionTime, boost::test_tools::tolerance(2e-3));
  // Elastic: rebound speed equals approach speed to the integrator's O(Δt) energy error.
  BOOST_TEST(outcome.reboundSpeed == speed, boost::test_tools::tolerance(1e-3));
}

BOOST_AUTO_TEST_CASE(restitution_is_achieved_in_a_simulated_two_sphere_impact) {
  // The acceptance: e achieved within 2 % for e ∈ {0.2, 0.5, 0.8}; checked at two speeds
  // because the Hertzian dashpot c ∝ δ^{1/4} must give a speed-independent e.
  for (const double restitution : {0.2, 0.5, 0.8}) {
    for (const double speed : {0.1, 2.0}) {
      const HertzMindlinParams p = likeSpheres(dampingRatioFromRestitution(restitution));
      const double collisionTime = hertzCollisionTime(p, speed);
      const auto outcome = railcosim::kernels::testing::simulateHeadOnImpact(
          p.effectiveMass, speed, collisionTime / 5000.0,
          [&](double overlap, double rate) { return hertzNormalForce(p, overlap, rate); });
      BOOST_TEST_MESSAGE("target e = " << restitution << ", v = " << speed
                                       << " m/s: achieved e = " << outcome.reboundSpeed / speed);
      BOOST_TEST_CONTEXT("e = " << restitution << ", v = " << speed) {
        BOOST_TEST(outcome.reboundSpeed / speed == restitution, boost::test_tools::tolerance(0.02));
      }
    }
  }
}

BOOST_AUTO_TEST_CASE(linear_spring_dashpot_relation_would_miss_the_hertzian_restitution) {
  // Guards against swapping in the classical linear spring–dashpot relation ln e = −πγ/sqrt(1 − γ²):
  // its γ for e = 0.2 gives a clearly different restitution in the Hertzian impact.
  const double restitution = 0.2;
  const double logE = std::log(restitution);
  const double linearGamma = -logE / std::sqrt(M_PI * M_PI + logE * logE); // linear oscillator
  const HertzMindlinParams p = likeSpheres(linearGamma);
  const double collisionTime = hertzCollisionTime(p, 1.0);
  const auto outcome = railcosim::kernels::testing::simulateHeadOnImpact(
      p.effectiveMass, 1.0, collisionTime / 5000.0,
      [&](double overlap, double rate) { return hertzNormalForce(p, overlap, rate); });
  BOOST_TEST(std::fabs(outcome.reboundSpeed - restitution) / restitution > 0.05);
  BOOST_TEST(dampingRatioFromRestitution(1.0) == 0.0);
  BOOST_CHECK_THROW(validateRestitution(1.2), std::invalid_argument);
}

BOOST_AUTO_TEST_CASE(tangential_spring_sticks_then_slides_at_the_coulomb_limit) {
  const HertzMindlinParams p = likeSpheres(0.0);
  const double overlap = 1.0e-4;
  const double normalForce = hertzElasticNormalForce(p, overlap);
  const double friction = 0.5;
  const double stiffness = mindlinTangentialStiffness(p, overlap);
  const Vec3 normal{0.0, 0.0, 1.0};
  const Vec3 increment{1.0e-7, 0.0, 0.0};
  Vec3 history{0.0, 0.0, 0.0};
  // Stick: at constant overlap the force is −k_t s, k_t = 8G*a (eq. 3.25b), as long as it is below μF_n.
  const int stickSteps = 10;
  for (int i = 0; i < stickSteps; ++i) {
    const auto r =
        mindlinTangentialForce(p, history, normal, overlap, overlap, increment, Vec3{0, 0, 0}, friction, normalForce);
    BOOST_TEST(!r.sliding);
    history = r.elasticForce;
  }
  BOOST_TEST(history.x == -8.0 * p.effectiveShearModulus * std::sqrt(p.effectiveRadius * overlap) * stickSteps * 1e-7,
             boost::test_tools::tolerance(1e-12));
  // Slide: keep shearing; |F_t| saturates at μ F_n and the stored elastic force equals it.
  const double slipDistance = 3.0 * friction * normalForce / stiffness;
  const auto sliding = mindlinTangentialForce(p, history, normal, overlap, overlap, Vec3{slipDistance, 0, 0},
                                              Vec3{0, 0, 0}, friction, normalForce);
  BOOST_TEST(sliding.sliding);
  BOOST_TEST(norm(sliding.force) == friction * normalForce, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(sliding.elasticForce.x == sliding.force.x);
  // Reversal after sliding unloads elastically from the friction level: one small step back removes k_t Δs.
  const auto reversed = mindlinTangentialForce(p, sliding.elasticForce, normal, overlap, overlap, Vec3{-1.0e-7, 0, 0},
                                               Vec3{0, 0, 0}, friction, normalForce);
  BOOST_TEST(!reversed.sliding);
  BOOST_TEST(reversed.force.x == -friction * normalForce + stiffness * 1.0e-7, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(unloading_scales_the_stored_force_by_the_contact_radius_ratio) {
  // Over many unloading steps the per-step factors sqrt(δ_n/δ_{n−1}) telescope to sqrt(δ_end/δ_start)
  // (eq. 3.20): the stored force follows the shrinking contact radius a ∝ sqrt(δ).
  const HertzMindlinParams p = likeSpheres(0.0);
  const Vec3 normal{0.0, 0.0, 1.0};
  Vec3 history{0.0, -2.0, 0.0};
  const double startOverlap = 2.0e-4;
  const double endOverlap = 0.5e-4;
  const int steps = 37;
  double previous = startOverlap;
  for (int i = 1; i <= steps; ++i) {
    const double overlap = startOverlap + (endOverlap - startOverlap) * i / steps;
    history = mindlinTangentialForce(p, history, normal, overlap, previous, Vec3{0, 0, 0}, Vec3{0, 0, 0}, 10.0, 1e9)
                  .elasticForce;
    previous = overlap;
  }
  BOOST_TEST(history.y == -2.0 * std::sqrt(endOverlap / startOverlap), boost::test_tools::tolerance(1e-12));
  // Loading (growing overlap) leaves the stored force unchanged when there is no tangential motion.
  const auto loading =
      mindlinTangentialForce(p, history, normal, 1.1 * endOverlap, endOverlap, Vec3{0, 0, 0}, Vec3{0, 0, 0}, 10.0, 1e9);
  BOOST_TEST(loading.elasticForce.y == history.y);
}

BOOST_AUTO_TEST_CASE(history_is_rotated_into_the_new_tangent_plane_keeping_its_magnitude) {
  const HertzMindlinParams p = likeSpheres(0.0);
  const Vec3 tiltedNormal = Vec3{0.0, std::sin(0.1), std::cos(0.1)};
  const Vec3 history{0.0, 3.0, 0.0};
  const auto r = mindlinTangentialForce(p, history, tiltedNormal, 1e-4, 1e-4, Vec3{0, 0, 0}, Vec3{0, 0, 0}, 10.0, 1e9);
  BOOST_TEST(std::fabs(dot(r.elasticForce, tiltedNormal)) < 1e-14);
  BOOST_TEST(norm(r.elasticForce) == 3.0, boost::test_tools::tolerance(1e-14));
}

BOOST_AUTO_TEST_CASE(tangential_dashpot_uses_the_tangential_stiffness) {
  // c_t = 2γ sqrt(m* k_t) (eq. 3.26b, erratum 5): check the viscous part of the trial force.
  const HertzMindlinParams p = likeSpheres(0.3);
  const double overlap = 1e-4;
  const Vec3 velocity{0.01, 0.0, 0.0};
  const auto r =
      mindlinTangentialForce(p, Vec3{0, 0, 0}, Vec3{0, 0, 1}, overlap, overlap, Vec3{0, 0, 0}, velocity, 10.0, 1e9);
  const double expected = -2.0 * 0.3 * std::sqrt(p.effectiveMass * mindlinTangentialStiffness(p, overlap)) * 0.01;
  BOOST_TEST(r.force.x == expected, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(r.elasticForce.x == 0.0);
}

BOOST_AUTO_TEST_CASE(invalid_parameters_are_rejected_with_context) {
  HertzMindlinParams p = likeSpheres(0.1);
  BOOST_CHECK_NO_THROW(validate(p));
  p.effectiveRadius = -1.0;
  BOOST_CHECK_EXCEPTION(validate(p, "Ip2 test"), std::invalid_argument, [](const std::invalid_argument& error) {
    return std::string(error.what()).find("effectiveRadius") != std::string::npos &&
           std::string(error.what()).find("Ip2 test") != std::string::npos;
  });
}
