// Unit tests of the stress-dependent friction coefficient (Irazábal 2017 §6.3.4).
#define BOOST_TEST_MODULE kernels_stress_dependent_friction
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <stdexcept>

#include "kernels/HertzMindlin.hpp"
#include "kernels/StressDependentFriction.hpp"

using namespace railcosim::kernels;

namespace {

// Thesis calibration: μ0 = 0.6, γ = −0.15, σ_c,max = 5.17 MPa, computed for E = 0.24 GPa (ν = 0.2 assumed).
const StressDependentFrictionParams thesisFriction{0.6, -0.15, 5.17e6};
const double thesisModulus = effectiveYoungModulus(0.24e9, 0.2, 0.24e9, 0.2);
constexpr double subSphereRadius = 0.0045; // [m], back-calculated from Irazábal 2017's calibration
const double pairRadius = effectiveRadius(subSphereRadius, subSphereRadius);

HertzMindlinParams hertz() { return HertzMindlinParams{thesisModulus, 1.0, pairRadius, 1.0, 0.0}; }

// Textbook Hertz peak pressure p0 = (6 F E*² / (π³ R*²))^{1/3} (Johnson 1985 eq. 4.24), independent of
// the thesis' eq. 6.3 form used by the kernel.
double hertzPeakPressure(double force) {
  return std::cbrt(6.0 * force * thesisModulus * thesisModulus / (M_PI * M_PI * M_PI * pairRadius * pairRadius));
}

} // namespace

BOOST_AUTO_TEST_CASE(friction_curve_is_a_power_law_of_peak_pressure_above_the_critical_stress) {
  // For an elastic Hertz contact F_n/F_n,c = σ0/σ_c,max, so μ = μ0 (σ0/σ_c,max)^γ above the critical
  // stress and μ0 below, with σ0 the textbook peak pressure; the curve μ(F) is swept over 5 decades of δ.
  for (double overlap = 1e-8; overlap < 1e-3; overlap *= 1.7) {
    const double force = hertzElasticNormalForce(hertz(), overlap);
    const double pressureRatio = hertzPeakPressure(force) / thesisFriction.maxContactStress;
    const double expected = pressureRatio > 1.0 ? 0.6 * std::pow(pressureRatio, -0.15) : 0.6;
    BOOST_TEST_CONTEXT("delta = " << overlap << " m, F = " << force << " N") {
      BOOST_TEST(stressDependentFrictionCoefficient(thesisFriction, pairRadius, overlap, force) == expected,
                 boost::test_tools::tolerance(1e-10));
    }
  }
}

BOOST_AUTO_TEST_CASE(friction_is_continuous_and_decreasing_past_the_critical_force) {
  const double overlap = 1e-5;
  const double critical = criticalNormalForce(thesisFriction, pairRadius, overlap);
  BOOST_TEST(critical == 2.0 / 3.0 * M_PI * pairRadius * overlap * 5.17e6, boost::test_tools::tolerance(1e-14));
  BOOST_TEST(stressDependentFrictionCoefficient(thesisFriction, pairRadius, overlap, critical) == 0.6);
  BOOST_TEST(stressDependentFrictionCoefficient(thesisFriction, pairRadius, overlap, critical * (1 + 1e-9)) == 0.6,
             boost::test_tools::tolerance(1e-9));
  // Doubling the force above F_n,c multiplies μ by 2^γ = 0.9013.
  const double atTwo = stressDependentFrictionCoefficient(thesisFriction, pairRadius, overlap, 2 * critical);
  const double atFour = stressDependentFrictionCoefficient(thesisFriction, pairRadius, overlap, 4 * critical);
  BOOST_TEST(atTwo == 0.6 * std::pow(2.0, -0.15), boost::test_tools::tolerance(1e-12));
  BOOST_TEST(atFour / atTwo == std::pow(2.0, -0.15), boost::test_tools::tolerance(1e-12));
}

BOOST_AUTO_TEST_CASE(model_is_inactive_without_a_critical_stress_or_exponent) {
  const StressDependentFrictionParams noStress{0.6, -0.15, 0.0};
  const StressDependentFrictionParams noExponent{0.6, 0.0, 5.17e6};
  BOOST_TEST(stressDependentFrictionCoefficient(noStress, pairRadius, 1e-5, 1e6) == 0.6);
  BOOST_TEST(stressDependentFrictionCoefficient(noExponent, pairRadius, 1e-5, 1e6) == 0.6);
}

BOOST_AUTO_TEST_CASE(critical_stress_from_one_particle_weight) {
  // Eqs. 6.7–6.9 define σ_c,max as the peak pressure under one mean particle's weight: at that load
  // the contact is exactly critical, and σ_c,max equals the textbook p0 of that force.
  const double volume = 8.0e-6; // [m³]
  const double density = 2700.0;
  const double gravity = 9.81;
  const double stress = maxContactStressFromParticleWeight(volume, density, gravity, thesisModulus, pairRadius);
  const double weight = volume * density * gravity;
  BOOST_TEST(stress == hertzPeakPressure(weight), boost::test_tools::tolerance(1e-12));
  const StressDependentFrictionParams derived{0.6, -0.15, stress};
  const double overlap = std::pow(3.0 * weight / (4.0 * thesisModulus * std::sqrt(pairRadius)), 2.0 / 3.0);
  BOOST_TEST(criticalNormalForce(derived, pairRadius, overlap) == weight, boost::test_tools::tolerance(1e-12));
  // Back-calculated from Irazábal 2017's calibration (ch. 6): E* = 0.125 GPa and
  // F/R*² = 4.57e4 N/m² give the thesis' 5.17 MPa (3 significant digits: tolerance 0.3 %).
  const double backRadius = 0.002;
  const double backWeight = 4.57e4 * backRadius * backRadius;
  const double unitVolume = backWeight / (density * gravity);
  BOOST_TEST(maxContactStressFromParticleWeight(unitVolume, density, gravity, 0.125e9, backRadius) == 5.17e6,
             boost::test_tools::tolerance(3e-3));
  BOOST_CHECK_NO_THROW(validate(thesisFriction));
  BOOST_CHECK_THROW(validate(StressDependentFrictionParams{0.6, 0.15, 5e6}), std::invalid_argument);
}
