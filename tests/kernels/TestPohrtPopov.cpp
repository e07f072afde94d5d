// Unit tests of the Pohrt–Popov normal laws against Tolomeo & McDowell (2022) Table 1 and closed forms.
#define BOOST_TEST_MODULE kernels_pohrt_popov
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <stdexcept>

#include "kernels/HertzMindlin.hpp"
#include "kernels/PohrtPopov.hpp"

using namespace railcosim::kernels;

namespace {

// Tolomeo & McDowell (2022) Table 1: granite, E = 60 GPa, ν = 0.25, R* = 2.36 mm, D_f = 2.13, h = 26.1 µm.
constexpr double graniteYoungModulus = 60e9;
constexpr double granitePoissonRatio = 0.25;
const double tableEffectiveModulus =
    effectiveYoungModulus(graniteYoungModulus, granitePoissonRatio, graniteYoungModulus, granitePoissonRatio);
constexpr double tableRadius = 2.36e-3;
constexpr double tableFractalDimension = 2.13;
constexpr double tableRoughness = 2.61e-5;

PohrtPopovParams tableParams() {
  return makePohrtPopovParams(tableEffectiveModulus, tableRadius, tableFractalDimension, tableRoughness);
}

// Eq. 1 exactly as printed (first branch), written out here independently of the kernel's prefactor C.
double equationOneStiffness(const PohrtPopovParams& p, double force) {
  const double sqrtArea = std::sqrt(p.fullContactArea);
  return M_PI / 10.0 * p.fractalDimension * p.effectiveYoungModulus * sqrtArea *
         std::pow(force / (p.roughnessRms * p.effectiveYoungModulus * sqrtArea), 0.2567 * p.fractalDimension);
}

// Overlap at which the elastic law carries `force`, by bisection (the law is monotonic).
double overlapAtForce(const PohrtPopovParams& p, double force) {
  double low = 0.0;
  double high = 1e-2;
  for (int i = 0; i < 200; ++i) {
    const double middle = 0.5 * (low + high);
    (pohrtPopovElasticForce(p, middle) < force ? low : high) = middle;
  }
  return 0.5 * (low + high);
}

} // namespace

BOOST_AUTO_TEST_CASE(table_one_full_contact_area_and_transition_force) {
  const PohrtPopovParams p = tableParams();
  // E* = E/(2(1 − ν²)) = 32.0 GPa (paper §2.1).
  BOOST_TEST(p.effectiveYoungModulus == 32.0e9, boost::test_tools::tolerance(1e-12));
  // Recomputed A0 = 6.689e-7 m² and F(A0) = 1776 N (Tolomeo & McDowell 2022 eqs. 3-4; the paper prints the
  // rounded 6.68e-7 m² and 1775 N). 4-digit reference values: relative tolerance 1e-4 and 0.5 N.
  BOOST_TEST(p.fullContactArea == 6.689e-7, boost::test_tools::tolerance(1e-4));
  BOOST_TEST(std::fabs(p.transitionForce - 1776.0) < 0.5);
  // Against the paper's own rounded numbers (3 and 4 significant digits, truncated): within 0.2 %.
  BOOST_TEST(p.fullContactArea == 6.68e-7, boost::test_tools::tolerance(2e-3));
  BOOST_TEST(p.transitionForce == 1775.0, boost::test_tools::tolerance(2e-3));
  BOOST_TEST_MESSAGE("A0 = " << p.fullContactArea << " m², F(A0) = " << p.transitionForce << " N");
}

BOOST_AUTO_TEST_CASE(stiffness_is_continuous_at_the_transition_to_hertz) {
  const PohrtPopovParams p = tableParams();
  // Eq. 3: both branches equal 2E*sqrt(A0/π) at F(A0) = 2.953e7 N/m (Tolomeo & McDowell 2022 eq. 3).
  const double roughBranch = equationOneStiffness(p, p.transitionForce);
  const double hertzBranch = hertzStiffnessFromForce(p.effectiveYoungModulus, p.effectiveRadius, p.transitionForce);
  BOOST_TEST(roughBranch == hertzBranch, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(hertzBranch == 2.0 * p.effectiveYoungModulus * std::sqrt(p.fullContactArea / M_PI),
             boost::test_tools::tolerance(1e-9));
  BOOST_TEST(hertzBranch == 2.953e7, boost::test_tools::tolerance(1e-3)); // 4 digits, as derived from eq. 3
  // In overlap: one-sided finite differences of the force on either side of δ_A0 agree. The step 1e-10 m
  // is 1e-6 of δ_A0, so curvature contributes < 1e-5 relative; the tolerance is 1e-4.
  const double step = 1e-10;
  const double left = (pohrtPopovElasticForce(p, p.transitionOverlap - step) -
                       pohrtPopovElasticForce(p, p.transitionOverlap - 2 * step)) /
                      step;
  const double right = (pohrtPopovElasticForce(p, p.transitionOverlap + 2 * step) -
                        pohrtPopovElasticForce(p, p.transitionOverlap + step)) /
                       step;
  BOOST_TEST(left == right, boost::test_tools::tolerance(1e-4));
  // And the force itself is continuous there.
  BOOST_TEST(pohrtPopovElasticForce(p, p.transitionOverlap * (1 - 1e-12)) ==
                 pohrtPopovElasticForce(p, p.transitionOverlap * (1 + 1e-12)),
             boost::test_tools::tolerance(1e-9));
}

BOOST_AUTO_TEST_CASE(closed_form_starts_from_zero_and_satisfies_equation_one) {
  const PohrtPopovParams p = tableParams();
  BOOST_TEST(pohrtPopovElasticForce(p, 0.0) == 0.0);
  BOOST_TEST(pohrtPopovElasticForce(p, -1e-6) == 0.0);
  // dF/dδ of the closed form equals eq. 1 at the current force; central differences with a step of
  // 1e-5 δ give a truncation error ~1e-10 relative, so 1e-6 is a safe tolerance.
  for (const double force : {0.1, 1.0, 10.0, 100.0, 1000.0}) {
    const double overlap = overlapAtForce(p, force);
    const double step = 1e-5 * overlap;
    const double slope =
        (pohrtPopovElasticForce(p, overlap + step) - pohrtPopovElasticForce(p, overlap - step)) / (2 * step);
    BOOST_TEST_CONTEXT("F = " << force << " N") {
      BOOST_TEST(slope == equationOneStiffness(p, force), boost::test_tools::tolerance(1e-6));
      BOOST_TEST(pohrtPopovElasticStiffness(p, overlap) == equationOneStiffness(p, force),
                 boost::test_tools::tolerance(1e-6));
    }
  }
  // Above F(A0) it is Hertz: tangent k = (6E*²FR)^{1/3} (eq. 1, second branch).
  const double overlap = overlapAtForce(p, 3000.0);
  BOOST_TEST(pohrtPopovElasticStiffness(p, overlap) ==
                 hertzStiffnessFromForce(p.effectiveYoungModulus, p.effectiveRadius, 3000.0),
             boost::test_tools::tolerance(1e-6));
  // The rough law is softer than Hertz below F(A0): derived from eqs. 1-5, k_PP/k_Hertz = 0.541 at 100 N.
  BOOST_TEST(
      equationOneStiffness(p, 100.0) / hertzStiffnessFromForce(p.effectiveYoungModulus, p.effectiveRadius, 100.0) ==
          0.541,
      boost::test_tools::tolerance(2e-3));
}

BOOST_AUTO_TEST_CASE(load_unload_leaves_the_closed_form_plastic_overlap) {
  const PohrtPopovParams p = tableParams();
  // Derived from eq. 6 (3 significant digits): δ_p after unloading from F_max.
  const double maxForces[] = {10.0, 100.0, 500.0, 1000.0, 1776.0};
  const double tabulatedPlastic[] = {9.83e-6, 2.28e-5, 3.60e-5, 4.08e-5, 4.25e-5};
  for (int c = 0; c < 5; ++c) {
    const double maxOverlap = overlapAtForce(p, maxForces[c]);
    // Load in 2000 steps through the kernel, keeping its history.
    double maxNormalForce = 0.0;
    double plasticOverlap = 0.0;
    for (int i = 1; i <= 2000; ++i) {
      const auto r = pohrtPopovElastoPlasticForce(p, maxOverlap * i / 2000.0, maxNormalForce, plasticOverlap);
      BOOST_REQUIRE(r.virginLoading);
      maxNormalForce = r.maxNormalForce;
      plasticOverlap = r.plasticOverlap;
    }
    // Oracle: the paper's incremental unloading rule, F ← F + k_Hertz(F) Δδ with k = (6E*²FR)^{1/3}
    // (eq. 6), integrated with 2e5 steps of RK2 until F reaches 0: the overlap there is δ_p.
    double force = maxNormalForce;
    double overlap = maxOverlap;
    const double step = maxOverlap / 2e5;
    while (force > 0.0) {
      const double half =
          force - 0.5 * step * hertzStiffnessFromForce(p.effectiveYoungModulus, p.effectiveRadius, force);
      if (half <= 0.0) break; // the force vanishes within this last step (error < one step)
      force -= step * hertzStiffnessFromForce(p.effectiveYoungModulus, p.effectiveRadius, half);
      overlap -= step;
    }
    BOOST_TEST_CONTEXT("F_max = " << maxForces[c] << " N") {
      // RK2 with 2e5 steps near the F^{1/3} singularity at F = 0: error below 1e-3 of δ_max.
      BOOST_TEST(std::fabs(plasticOverlap - overlap) < 1e-3 * maxOverlap);
      BOOST_TEST(plasticOverlap == tabulatedPlastic[c], boost::test_tools::tolerance(6e-3)); // 3 digits
      // Unloading follows Hertz from the stored maximum and never becomes tensile.
      const auto halfway =
          pohrtPopovElastoPlasticForce(p, 0.5 * (plasticOverlap + maxOverlap), maxNormalForce, plasticOverlap);
      BOOST_TEST(!halfway.virginLoading);
      BOOST_TEST(halfway.force == hertzForceFromOverlap(p.effectiveYoungModulus, p.effectiveRadius,
                                                        0.5 * (maxOverlap - plasticOverlap)),
                 boost::test_tools::tolerance(1e-12));
      const auto below = pohrtPopovElastoPlasticForce(p, 0.9 * plasticOverlap, maxNormalForce, plasticOverlap);
      BOOST_TEST(below.force == 0.0);
      BOOST_TEST(below.plasticOverlap == plasticOverlap);
    }
    BOOST_TEST_MESSAGE("F_max = " << maxForces[c] << " N: delta_p = " << plasticOverlap << " m (incremental " << overlap
                                  << " m)");
  }
}

BOOST_AUTO_TEST_CASE(reloading_rejoins_the_virgin_curve_at_the_stored_maximum) {
  const PohrtPopovParams p = tableParams();
  const double firstPeak = overlapAtForce(p, 300.0);
  auto state = pohrtPopovElastoPlasticForce(p, firstPeak, 0.0, 0.0);
  state = pohrtPopovElastoPlasticForce(p, firstPeak, state.maxNormalForce, state.plasticOverlap);
  BOOST_TEST(state.virginLoading); // at δ_max both curves meet: still virgin
  // Unload to 30 % of the way down, reload to just below δ_max: Hertzian, below F_max.
  const double partial = state.plasticOverlap + 0.3 * (firstPeak - state.plasticOverlap);
  const auto unloaded = pohrtPopovElastoPlasticForce(p, partial, state.maxNormalForce, state.plasticOverlap);
  BOOST_TEST(!unloaded.virginLoading);
  const auto almost =
      pohrtPopovElastoPlasticForce(p, firstPeak * (1 - 1e-9), state.maxNormalForce, state.plasticOverlap);
  BOOST_TEST(!almost.virginLoading);
  BOOST_TEST(almost.force == 300.0, boost::test_tools::tolerance(1e-6)); // reaches F_max continuously
  // Beyond δ_max the virgin curve (softer than the Hertz reload) takes over and δ_p grows.
  const auto beyond = pohrtPopovElastoPlasticForce(p, 1.2 * firstPeak, state.maxNormalForce, state.plasticOverlap);
  BOOST_TEST(beyond.virginLoading);
  BOOST_TEST(beyond.force == pohrtPopovElasticForce(p, 1.2 * firstPeak));
  BOOST_TEST(beyond.plasticOverlap > state.plasticOverlap);
  // The unloading stiffness exceeds the virgin stiffness at the same force (the paper's observation).
  BOOST_TEST(unloaded.stiffness > equationOneStiffness(p, unloaded.force));
}

BOOST_AUTO_TEST_CASE(above_the_transition_the_plastic_overlap_stops_growing) {
  // Past F(A0) the virgin curve is itself Hertz shifted by Δ, so δ_p stays Δ = 4.25e-5 m (Tolomeo & McDowell 2022 eq.
  // 3).
  const PohrtPopovParams p = tableParams();
  const auto state = pohrtPopovElastoPlasticForce(p, overlapAtForce(p, 5000.0), 0.0, 0.0);
  BOOST_TEST(state.plasticOverlap == p.hertzOverlapShift, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(p.hertzOverlapShift == 4.25e-5, boost::test_tools::tolerance(2e-3));
}

BOOST_AUTO_TEST_CASE(tangential_stiffness_ratio_of_equation_seven) {
  // k_s/k_n = 2(1 − ν)/(2 − ν) = 6/7 for ν = 0.25, and it equals the Mindlin/Hertz ratio 4G*/E*.
  BOOST_TEST(tangentialToNormalStiffnessRatio(0.25) == 6.0 / 7.0, boost::test_tools::tolerance(1e-14));
  for (const double nu : {0.1, 0.25, 0.3, 0.49}) {
    const double shear = shearModulus(graniteYoungModulus, nu);
    const double ratio = 4.0 * effectiveShearModulus(shear, nu, shear, nu) /
                         effectiveYoungModulus(graniteYoungModulus, nu, graniteYoungModulus, nu);
    BOOST_TEST(tangentialToNormalStiffnessRatio(nu) == ratio, boost::test_tools::tolerance(1e-13));
  }
}

BOOST_AUTO_TEST_CASE(invalid_roughness_inputs_are_rejected) {
  BOOST_CHECK_NO_THROW(validate(tableParams()));
  BOOST_CHECK_THROW(validate(makePohrtPopovParams(tableEffectiveModulus, tableRadius, 3.2, tableRoughness)),
                    std::invalid_argument);
  BOOST_CHECK_THROW(validate(makePohrtPopovParams(tableEffectiveModulus, tableRadius, 2.13, 0.0)),
                    std::invalid_argument);
}
