// Unit tests of the composed ballast contact law: it must equal its sub-models and route history and μ.
#define BOOST_TEST_MODULE kernels_ballast_contact
#include <boost/test/unit_test.hpp>

#include <cmath>

#include "kernels/BallastContact.hpp"

using namespace railcosim::kernels;

namespace {

BallastContactParams graniteContact(NormalModel model, bool stressDependent) {
  const double youngModulus = 60e9;
  const double poissonRatio = 0.25;
  const double shear = shearModulus(youngModulus, poissonRatio);
  const double radius = 4.72e-3; // two pebbles with R* = 2.36 mm
  BallastContactParams p{};
  p.normalModel = model;
  p.hertzMindlin = HertzMindlinParams{effectiveYoungModulus(youngModulus, poissonRatio, youngModulus, poissonRatio),
                                      effectiveShearModulus(shear, poissonRatio, shear, poissonRatio),
                                      effectiveRadius(radius, radius), 1.2e-3, dampingRatioFromRestitution(0.5)};
  p.pohrtPopov =
      makePohrtPopovParams(p.hertzMindlin.effectiveYoungModulus, p.hertzMindlin.effectiveRadius, 2.13, 2.61e-5);
  p.tangentialStiffnessRatio = tangentialToNormalStiffnessRatio(poissonRatio);
  p.friction = StressDependentFrictionParams{0.7, -0.15, 5.0e6};
  p.stressDependentFriction = stressDependent;
  return p;
}

const Vec3 normal{0.0, 0.0, 1.0};

} // namespace

BOOST_AUTO_TEST_CASE(hertz_composition_equals_its_sub_models) {
  const BallastContactParams p = graniteContact(NormalModel::Hertz, false);
  const ContactKinematics k{2e-5, 0.01, normal, Vec3{1e-8, -2e-8, 0.0}, Vec3{0.02, 0.01, 0.0}};
  const BallastContactResult r = ballastContactForces(p, BallastContactHistory{}, k);
  BOOST_TEST(r.normalForce == hertzNormalForce(p.hertzMindlin, k.overlap, k.overlapRate));
  const auto tangential = mindlinTangentialForce(p.hertzMindlin, Vec3{0, 0, 0}, normal, k.overlap, 0.0,
                                                 k.shearIncrement, k.shearVelocity, 0.7, r.normalForce);
  BOOST_TEST(r.shearForce.x == tangential.force.x, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(r.shearForce.y == tangential.force.y, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(r.history.previousTangentialStiffness == mindlinTangentialStiffness(p.hertzMindlin, k.overlap));
  BOOST_TEST(r.frictionCoefficient == 0.7);
}

BOOST_AUTO_TEST_CASE(coulomb_cap_uses_the_constant_coefficient) {
  const BallastContactParams p = graniteContact(NormalModel::Hertz, false);
  const ContactKinematics k{2e-5, 0.0, normal, Vec3{1e-3, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}};
  const BallastContactResult r = ballastContactForces(p, BallastContactHistory{}, k);
  BOOST_TEST(r.sliding);
  BOOST_TEST(norm(r.shearForce) == 0.7 * r.normalForce, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(r.shearForce.x < 0.0); // opposes the displacement of body 2
}

BOOST_AUTO_TEST_CASE(stress_dependent_friction_only_where_enabled) {
  // A heavily loaded contact (peak pressure ≫ 5 MPa): the cluster–cluster contact gets a lower μ,
  // the same contact flagged as cluster–wall keeps μ0.
  const ContactKinematics k{5e-5, 0.0, normal, Vec3{1e-3, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}};
  const BallastContactResult between = ballastContactForces(graniteContact(NormalModel::Hertz, true), {}, k);
  const BallastContactResult wall = ballastContactForces(graniteContact(NormalModel::Hertz, false), {}, k);
  const BallastContactParams p = graniteContact(NormalModel::Hertz, true);
  BOOST_TEST(
      between.frictionCoefficient == stressDependentFrictionCoefficient(p.friction, p.hertzMindlin.effectiveRadius,
                                                                        k.overlap, between.normalForce),
      boost::test_tools::tolerance(1e-14));
  BOOST_TEST(between.frictionCoefficient < 0.7);
  BOOST_TEST(wall.frictionCoefficient == 0.7);
  BOOST_TEST(norm(between.shearForce) == between.frictionCoefficient * between.normalForce,
             boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(elasto_plastic_history_is_carried_through_the_composition) {
  // Load to 60 µm and back in 200 steps each; the composed law must reproduce the sub-model's plastic
  // overlap and end with zero force, and its tangential stiffness is k_r k_n on each branch.
  const BallastContactParams p = graniteContact(NormalModel::PohrtPopovElastoPlastic, false);
  BallastContactHistory history{};
  const double peak = 6e-5;
  BallastContactResult r{};
  for (int i = 1; i <= 200; ++i) {
    r = ballastContactForces(p, history, ContactKinematics{peak * i / 200, 0.0, normal, {0, 0, 0}, {0, 0, 0}});
    history = r.history;
  }
  const auto direct = pohrtPopovElastoPlasticForce(p.pohrtPopov, peak, 0.0, 0.0);
  BOOST_TEST(history.maxNormalForce == direct.maxNormalForce, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(history.plasticOverlap == direct.plasticOverlap, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(r.tangentialStiffness == p.tangentialStiffnessRatio * direct.stiffness,
             boost::test_tools::tolerance(1e-12));
  for (int i = 199; i >= 0; --i) {
    r = ballastContactForces(p, history, ContactKinematics{peak * i / 200, 0.0, normal, {0, 0, 0}, {0, 0, 0}});
    history = r.history;
    if (peak * i / 200 <= direct.plasticOverlap) BOOST_TEST(r.normalForce == 0.0);
  }
  BOOST_TEST(history.plasticOverlap == direct.plasticOverlap, boost::test_tools::tolerance(1e-12));
}
