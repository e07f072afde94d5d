// Unit tests of the composed contact law: keyword selection, parameter mixing, equality with its sub-models, history
// and μ routing, and the two path scenarios (ContactLawScenarios.hpp) on the composition itself.
#define BOOST_TEST_MODULE kernels_contact_law
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <iomanip>
#include <limits>
#include <stdexcept>
#include <string>

#include "ContactLawScenarios.hpp"
#include "ImpactSimulation.hpp"
#include "kernels/ContactLaw.hpp"

using namespace railcosim::kernels;
namespace scenario = railcosim::testing::scenario;

namespace {

const double infinity = std::numeric_limits<double>::infinity();

// Two granite pebbles of R = 4.72 mm (R* = 2.36 mm, m* = 1.2e-3 kg), restitution 0.5, μ0 = 0.7, the
// stress-dependent friction parameters set (they act only between different clusters).
ContactLaw graniteContact(const std::string& normal, bool differentClusters) {
  ContactMaterial m{60e9, 0.25, 0.5, 0.7};
  if (normal != "hertz") {
    m.roughnessRms = 2.61e-5;
    m.fractalDimension = 2.13;
    m.plasticUnloading = normal == "pohrt_popov_plastic";
  }
  m.frictionExponent = -0.15;
  m.maxContactStress = 5.0e6;
  ContactLaw law = mixContactLaw(m, m, ContactPairOptions{differentClusters, false});
  setContactGeometry(law, 4.72e-3, 4.72e-3, 2.4e-3, 2.4e-3);
  return law;
}

const Vec3 normal{0.0, 0.0, 1.0};

} // namespace

BOOST_AUTO_TEST_CASE(keywords_select_the_rows_of_the_registry) {
  ContactLawKeywords keywords;
  keywords.normal = "pohrt_popov_plastic";
  keywords.tangential = "stiffness_ratio";
  keywords.friction = "stress_dependent";
  keywords.rolling = "brof";
  const ContactLawConfig c = selectContactLaw(keywords);
  BOOST_TEST(c.normal == subModelIndex<PohrtPopovPlasticNormalModel>(NormalModels{}));
  BOOST_TEST(c.tangential == subModelIndex<StiffnessRatioTangentialModel>(TangentialModels{}));
  BOOST_TEST(c.friction == subModelIndex<StressDependentFrictionModel>(FrictionModels{}));
  BOOST_TEST(c.rolling == subModelIndex<BoundedRollingFrictionModel>(RollingModels{}));
  BOOST_TEST(describe(c) == "pohrt_popov_plastic + viscous_restitution + stiffness_ratio + stress_dependent + brof");
  BOOST_TEST(normalHistorySlots(c) == 2);
  BOOST_TEST(normalHistorySlots(selectContactLaw(ContactLawKeywords{})) == 0);
  // An unknown keyword is refused with the known ones of its kind.
  keywords.normal = "jkr";
  try {
    selectContactLaw(keywords);
    BOOST_FAIL("an unknown normal keyword was accepted");
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    BOOST_TEST(what.find("'jkr' is not a normal sub-model") != std::string::npos);
    BOOST_TEST(what.find("'pohrt_popov_plastic'") != std::string::npos);
  }
}

// The selection is what runs: the same contact evaluated under each normal keyword gives that row's kernel.
BOOST_AUTO_TEST_CASE(the_selected_normal_row_is_the_one_evaluated) {
  const double overlap = 3e-5;
  const ContactKinematics k{overlap, 0.0, normal, Vec3{0, 0, 0}, Vec3{0, 0, 0}};
  const ContactLaw hertz = graniteContact("hertz", false);
  const ContactLaw elastic = graniteContact("pohrt_popov", false);
  const ContactLaw plastic = graniteContact("pohrt_popov_plastic", false);
  BOOST_TEST(contactLawForces(hertz, ContactHistory{}, k).normalForce ==
             hertzElasticNormalForce(hertz.params.hertzMindlin, overlap));
  BOOST_TEST(contactLawForces(elastic, ContactHistory{}, k).normalForce ==
             pohrtPopovElasticForce(elastic.params.pohrtPopov, overlap));
  const ContactLawResult r = contactLawForces(plastic, ContactHistory{}, k);
  const PlasticNormalResult direct = pohrtPopovElastoPlasticForce(plastic.params.pohrtPopov, overlap, 0.0, 0.0);
  BOOST_TEST(r.normalForce == direct.force);
  BOOST_TEST(r.history.normal.plasticOverlap == direct.plasticOverlap);
  // Rough and smooth laws differ at this overlap by far more than round-off, so a wrong dispatch would show.
  BOOST_TEST(std::fabs(r.normalForce / contactLawForces(hertz, ContactHistory{}, k).normalForce - 1.0) > 0.1);
}

BOOST_AUTO_TEST_CASE(mixing_follows_the_pair_rules) {
  // Two different materials: E*, G* (Irazábal eq. 3.27), mean γ (3.27e), smaller μ, means of the rough inputs over
  // the rough material only, plastic because the rough one asks for it, larger η_r.
  ContactMaterial a{60e9, 0.25, 0.5, 0.7};
  a.roughnessRms = 2e-5;
  a.fractalDimension = 2.2;
  a.plasticUnloading = true;
  a.rollingFriction = 0.1;
  const ContactMaterial b{30e9, 0.2, 0.8, 0.4, 0.0, 0.0, false, 0.0, 0.0, 1.0};
  ContactLaw law = mixContactLaw(a, b, ContactPairOptions{false, true});
  setContactGeometry(law, 0.01, infinity, 0.5, infinity);
  const ContactParams& p = law.params;
  BOOST_TEST(p.hertzMindlin.effectiveYoungModulus == 1.0 / ((1 - 0.0625) / 60e9 + (1 - 0.04) / 30e9),
             boost::test_tools::tolerance(1e-14));
  const double shearA = 60e9 / 2.5, shearB = 30e9 / 2.4;
  BOOST_TEST(p.hertzMindlin.effectiveShearModulus == 1.0 / (1.75 / shearA + 1.8 / shearB),
             boost::test_tools::tolerance(1e-14));
  BOOST_TEST(p.hertzMindlin.dampingRatio == 0.5 * (dampingRatioFromRestitution(0.5) + dampingRatioFromRestitution(0.8)),
             boost::test_tools::tolerance(1e-14));
  BOOST_TEST(p.friction.baseFrictionCoefficient == 0.4);
  BOOST_TEST(p.pohrtPopov.roughnessRms == 2e-5);
  BOOST_TEST(p.pohrtPopov.fractalDimension == 2.2);
  BOOST_TEST(p.pohrtPopov.effectiveRadius == 0.01); // prepared for the flat: R* = R1
  BOOST_TEST(p.hertzMindlin.effectiveMass == 0.5);  // a wall has infinite mass: m* = m1
  BOOST_TEST(describe(law.config) == "pohrt_popov_plastic + viscous_restitution + stiffness_ratio + coulomb + brof");
  BOOST_TEST(rollingArm(law) == 1.0 * 0.01);
  // Stress-dependent friction needs both flags of the pair and members of different clusters.
  ContactMaterial c = b;
  c.frictionExponent = -0.15;
  c.maxContactStress = 5e6;
  BOOST_TEST(describe(mixContactLaw(c, c, ContactPairOptions{true, false}).config) ==
             "hertz + viscous_restitution + mindlin_incremental + stress_dependent + none");
  BOOST_TEST(describe(mixContactLaw(c, c, ContactPairOptions{false, false}).config) ==
             "hertz + viscous_restitution + mindlin_incremental + coulomb + none");
  // Two bodies of prescribed motion: no dashpot (m* = 0 instead of ∞).
  setContactGeometry(law, 0.01, infinity, infinity, infinity);
  BOOST_TEST(law.params.hertzMindlin.effectiveMass == 0.0);
  // Invalid materials are refused with the value.
  ContactMaterial bad = b;
  bad.plasticUnloading = true;
  BOOST_CHECK_THROW(mixContactLaw(a, bad), std::invalid_argument);
  bad = b;
  bad.restitution = 1.5;
  BOOST_CHECK_THROW(mixContactLaw(a, bad), std::invalid_argument);
}

BOOST_AUTO_TEST_CASE(hertz_composition_equals_its_sub_models) {
  const ContactLaw law = graniteContact("hertz", false);
  const HertzMindlinParams& p = law.params.hertzMindlin;
  const ContactKinematics k{2e-5, 0.01, normal, Vec3{1e-8, -2e-8, 0.0}, Vec3{0.02, 0.01, 0.0}};
  const ContactLawResult r = contactLawForces(law, ContactHistory{}, k);
  BOOST_TEST(r.normalForce == hertzNormalForce(p, k.overlap, k.overlapRate));
  const auto tangential = mindlinTangentialForce(p, Vec3{0, 0, 0}, normal, k.overlap, 0.0, k.shearIncrement,
                                                 k.shearVelocity, 0.7, r.normalForce);
  BOOST_TEST(r.shearForce.x == tangential.force.x, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(r.shearForce.y == tangential.force.y, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(r.history.previousTangentialStiffness == mindlinTangentialStiffness(p, k.overlap));
  BOOST_TEST(r.frictionCoefficient == 0.7);
  BOOST_TEST(r.rollingResistanceMoment == 0.0); // rolling "none"
}

BOOST_AUTO_TEST_CASE(coulomb_cap_uses_the_constant_coefficient) {
  const ContactLaw law = graniteContact("hertz", false);
  const ContactKinematics k{2e-5, 0.0, normal, Vec3{1e-3, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}};
  const ContactLawResult r = contactLawForces(law, ContactHistory{}, k);
  BOOST_TEST(r.sliding);
  BOOST_TEST(norm(r.shearForce) == 0.7 * r.normalForce, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(r.shearForce.x < 0.0); // opposes the displacement of body 2
}

BOOST_AUTO_TEST_CASE(stress_dependent_friction_only_where_enabled) {
  // A heavily loaded contact (peak pressure ≫ 5 MPa): the cluster–cluster contact gets a lower μ,
  // the same contact flagged as cluster–wall keeps μ0.
  const ContactKinematics k{5e-5, 0.0, normal, Vec3{1e-3, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}};
  const ContactLaw betweenClusters = graniteContact("hertz", true);
  const ContactLawResult between = contactLawForces(betweenClusters, {}, k);
  const ContactLawResult wall = contactLawForces(graniteContact("hertz", false), {}, k);
  const ContactParams& p = betweenClusters.params;
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
  const ContactLaw law = graniteContact("pohrt_popov_plastic", false);
  ContactHistory history{};
  const double peak = 6e-5;
  ContactLawResult r{};
  for (int i = 1; i <= 200; ++i) {
    r = contactLawForces(law, history, ContactKinematics{peak * i / 200, 0.0, normal, {0, 0, 0}, {0, 0, 0}});
    history = r.history;
  }
  const auto direct = pohrtPopovElastoPlasticForce(law.params.pohrtPopov, peak, 0.0, 0.0);
  BOOST_TEST(history.normal.maxNormalForce == direct.maxNormalForce, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(history.normal.plasticOverlap == direct.plasticOverlap, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(r.tangentialStiffness == law.params.tangentialStiffnessRatio * direct.stiffness,
             boost::test_tools::tolerance(1e-12));
  // k_t/k_n = 4G*/E* is Tolomeo & McDowell's eq. 7 ratio for like materials.
  BOOST_TEST(law.params.tangentialStiffnessRatio == tangentialToNormalStiffnessRatio(0.25),
             boost::test_tools::tolerance(1e-14));
  for (int i = 199; i >= 0; --i) {
    r = contactLawForces(law, history, ContactKinematics{peak * i / 200, 0.0, normal, {0, 0, 0}, {0, 0, 0}});
    history = r.history;
    if (peak * i / 200 <= direct.plasticOverlap) BOOST_TEST(r.normalForce == 0.0);
  }
  BOOST_TEST(history.normal.plasticOverlap == direct.plasticOverlap, boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(elasto_plastic_branch_switch_keeps_the_tangential_force) {
  // Mindlin's correction releases tangential force as the contact area shrinks, i.e. while the overlap falls. Reloaded
  // past F_max, the elasto-plastic law leaves its stiffer Hertzian reloading branch for the softer virgin one: k_t
  // drops while the overlap (and the area) grows, so the stored force must stay whole. Path: load to 60 µm, unload to
  // 48 µm, shear at rest to 30 % of the Coulomb limit, reload to 72 µm without shear.
  const ContactLaw law = graniteContact("pohrt_popov_plastic", false);
  const double peak = 6e-5;
  const double rate = 1e-6; // a slow approach: its dashpot force is below 1e-6 of F_n
  ContactHistory history{};
  ContactLawResult r{};
  auto step = [&](double overlap, double overlapRate, const Vec3& shear) {
    r = contactLawForces(law, history, ContactKinematics{overlap, overlapRate, normal, shear, {0, 0, 0}});
    history = r.history;
  };
  for (int i = 1; i <= 200; ++i) step(peak * i / 200, rate, {0, 0, 0});
  for (int i = 1; i <= 40; ++i) step(peak * (1.0 - 0.2 * i / 40), -rate, {0, 0, 0});
  const double shear = 0.3 * law.params.friction.baseFrictionCoefficient * r.normalForce / r.tangentialStiffness;
  for (int i = 1; i <= 20; ++i) step(0.8 * peak, 0.0, {shear / 20, 0, 0});
  const double stored = norm(history.elasticShearForce);
  const double maxBeforeReloading = history.normal.maxNormalForce;
  BOOST_TEST_REQUIRE(!r.sliding);
  double lowestStiffnessRatio = 1.0;
  for (int i = 1; i <= 240; ++i) {
    const double previous = history.previousTangentialStiffness;
    step(peak * (0.8 + 0.4 * i / 240), rate, {0, 0, 0});
    lowestStiffnessRatio = std::min(lowestStiffnessRatio, r.tangentialStiffness / previous);
    BOOST_TEST(norm(history.elasticShearForce) == stored, boost::test_tools::tolerance(1e-12));
  }
  // The path did cross the switch: F_max grew, and one step's k_t fell (to about 0.69 here: Tolomeo & McDowell eq. 6's
  // virgin slope against the Hertzian reloading slope at the same force).
  BOOST_TEST(history.normal.maxNormalForce > maxBeforeReloading);
  BOOST_TEST(lowestStiffnessRatio < 0.8);
  // Unloading from there releases force again, as the area shrinks.
  for (int i = 1; i <= 20; ++i) step(peak * (1.2 - 0.1 * i / 20), -rate, {0, 0, 0});
  BOOST_TEST(norm(history.elasticShearForce) < stored);
}

BOOST_AUTO_TEST_CASE(rolling_resistance_is_the_brof_budget_share) {
  ContactMaterial m{60e9, 0.25, 0.5, 0.7};
  m.rollingFriction = 0.2;
  ContactLaw law = mixContactLaw(m, m, ContactPairOptions{false, true});
  setContactGeometry(law, 0.01, 0.01, 1.0, 1.0);
  const ContactLawResult r = contactLawForces(law, {}, ContactKinematics{1e-5, 0.0, normal, {0, 0, 0}, {0, 0, 0}});
  // e_c = η_r R1R2/(R1 + R2) = 0.2 × 5 mm (Irazábal eqs. 5.2–5.3), budget share e_c |F_n|.
  BOOST_TEST(r.rollingResistanceMoment == 0.2 * 0.005 * r.normalForce, boost::test_tools::tolerance(1e-14));
  // Where the caller says no body is a sphere, the same materials get no rolling resistance.
  ContactLaw noSphere = mixContactLaw(m, m, ContactPairOptions{false, false});
  setContactGeometry(noSphere, 0.01, 0.01, 1.0, 1.0);
  BOOST_TEST(contactLawForces(noSphere, {}, ContactKinematics{1e-5, 0.0, normal, {0, 0, 0}, {0, 0, 0}})
                 .rollingResistanceMoment == 0.0);
}

// ---------------------------------------------------------------------------------------------------
// The path scenarios on the composition itself.
// ---------------------------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(scenario_elasto_plastic_cycle_gives_the_closed_forms) {
  ContactLaw law = mixContactLaw(scenario::roughPlasticGranite(), scenario::roughPlasticGranite());
  setContactGeometry(law, scenario::radius, infinity, scenario::mass, infinity);
  BOOST_TEST(describe(law.config) == "pohrt_popov_plastic + viscous_restitution + stiffness_ratio + coulomb + none");
  scenario::CycleRecorder recorder;
  ContactHistory history{};
  double overlap = 0.0;
  bool unloading = false;
  for (long step = 0; step < 100000 && !recorder.done; ++step) {
    overlap += unloading ? -scenario::cycleStep : scenario::cycleStep;
    const ContactLawResult r =
        contactLawForces(law, history, ContactKinematics{overlap, 0.0, Vec3{0, 0, 1}, Vec3{0, 0, 0}, Vec3{0, 0, 0}});
    history = r.history;
    recorder.sample(overlap, r.normalForce, unloading);
    if (!unloading && r.normalForce >= scenario::cyclePeakForce) unloading = true;
  }
  BOOST_TEST_REQUIRE(recorder.done);
  BOOST_TEST_MESSAGE(std::setprecision(9)
                     << "kernel cycle: F_max " << recorder.peakForce << " N at δ_max " << recorder.peakOverlap
                     << " m, force vanishes in [" << recorder.zeroOverlap << ", " << recorder.releaseOverlap
                     << "] m, closed-form δ_p " << scenario::plasticOverlap(recorder.peakOverlap, recorder.peakForce)
                     << " m; errors: peak " << recorder.peakForceError() << ", unloading "
                     << recorder.unloadingForceError());
  BOOST_TEST(recorder.peakForceError() < scenario::peakForceTolerance);
  BOOST_TEST(recorder.plasticOverlapStepsOutside() <= scenario::plasticOverlapStepTolerance);
  BOOST_TEST(recorder.unloadingForceError() < scenario::unloadingForceTolerance);
  // The kernel's own δ_p is the closed form of its F_max (the same formula, independent arithmetic).
  BOOST_TEST(
      history.normal.plasticOverlap == scenario::plasticOverlap(recorder.peakOverlap, history.normal.maxNormalForce),
      boost::test_tools::tolerance(1e-9));
}

BOOST_AUTO_TEST_CASE(scenario_impact_gives_the_restitution) {
  ContactLaw law = mixContactLaw(scenario::smoothGranite(), scenario::smoothGranite());
  setContactGeometry(law, scenario::radius, infinity, scenario::mass, infinity);
  ContactHistory history{};
  // YADE's leapfrog in the relative coordinate (ImpactSimulation.hpp), the force from the composed law.
  const auto outcome = railcosim::kernels::testing::simulateHeadOnImpact(
      scenario::mass, scenario::impactSpeed, scenario::impactTimeStep, [&](double overlap, double rate) {
        const ContactLawResult r =
            contactLawForces(law, history, ContactKinematics{overlap, rate, Vec3{0, 0, 1}, {0, 0, 0}, {0, 0, 0}});
        history = r.history;
        return r.normalForce;
      });
  const double restitution = outcome.reboundSpeed / scenario::impactSpeed;
  BOOST_TEST_MESSAGE(std::setprecision(9) << "kernel impact: e = " << restitution << " in "
                                          << outcome.contactTime / scenario::impactTimeStep << " steps of contact");
  BOOST_TEST(std::fabs(restitution / scenario::impactRestitution - 1.0) < scenario::restitutionTolerance);
}
