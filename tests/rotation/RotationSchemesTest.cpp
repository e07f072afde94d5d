// Tests R1 (free precession) and R2 (sphere under T = 1e5·eᵗ) of Irazábal 2017 §5.3.2 against closed forms.
#define BOOST_TEST_MODULE rotation_schemes
#include <boost/test/unit_test.hpp>

#include <cmath>

#include "RotationScenes.hpp"

using namespace railcosim;
using kernels::RotationScheme;

// R1 tolerances. ZvW advances ω' with the explicit midpoint rule, whose amplification for the precession
// (rate p = 50 rad/s, x = pΔt = 0.05) has phase error x³/6 per step: 500 steps → 0.0104 rad on an
// amplitude of 1 rad/s, i.e. |ω' − ω'_exact| ≈ 0.010 rad/s. 0.02 rad/s (2 % of the transverse amplitude,
// 0.02 % of |ω|) allows for that estimate with margin and still fails any scheme that is only first order.
constexpr double kZvWPrecessionTolerance = 0.02;
// RK4 (Munjiza's form) conserves H exactly, but its final increment q(ω̄, Δt) rotates about the mean
// angular velocity without the commutator (Magnus) term, so q, and with it ω' = I'⁻¹ q* H q, is only second
// order: the same estimate and bound apply (measured 0.0104 rad/s for both).
// The direct scheme's half kicks amplify the precession by (1 + x²/4) per step: after 500 steps the
// amplitude is 1.367× too large, |ω' − ω'_exact| ≈ 0.37 rad/s. "Visibly fails" is asserted as > 0.2 rad/s,
// ten times the tolerance the correct schemes meet.
constexpr double kDirectMinimumPrecessionError = 0.2;

BOOST_AUTO_TEST_CASE(r1_zhao_van_wachem_and_rk4_follow_precession) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4}) {
    const auto r = rotationscenes::runFreePrecession(scheme, 1e-3);
    BOOST_TEST_MESSAGE("R1 " << kernels::rotationSchemeName(scheme) << " dt=1e-3: max|w'-exact| = "
                             << r.maxBodyOmegaError << " rad/s, H direction error = " << r.maxMomentumDirectionError);
    BOOST_TEST(r.maxBodyOmegaError < kZvWPrecessionTolerance);
    // Orientation: q I' ω'_exact q* must stay on H0. The 0.0104 rad phase error tilts I'ω' by
    // ≈ 2·0.0104/|H0| = 2e-4 relative; 1e-3 leaves a factor 5.
    BOOST_TEST(r.maxMomentumDirectionError < 1e-3);
  }
}

BOOST_AUTO_TEST_CASE(r1_direct_scheme_visibly_fails) {
  const auto r = rotationscenes::runFreePrecession(RotationScheme::direct, 1e-3);
  BOOST_TEST_MESSAGE("R1 direct dt=1e-3: max|w'-exact| = " << r.maxBodyOmegaError << " rad/s");
  BOOST_TEST(r.maxBodyOmegaError > kDirectMinimumPrecessionError);
}

BOOST_AUTO_TEST_CASE(r1_convergence_orders) {
  // Halving Δt divides the error by 2^order: ZvW and RK4 are second order (ratio ≈ 4), the direct scheme first
  // order (ratio ≈ 2). Bands [3, 5] and [1.6, 2.6] separate the two orders with room for the
  // higher-order terms still present at Δt = 1e-3 (x = 0.05).
  const double zvwCoarse = rotationscenes::runFreePrecession(RotationScheme::zhaoVanWachem, 1e-3).maxBodyOmegaError;
  const double zvwFine = rotationscenes::runFreePrecession(RotationScheme::zhaoVanWachem, 5e-4).maxBodyOmegaError;
  const double rk4Coarse = rotationscenes::runFreePrecession(RotationScheme::rungeKutta4, 1e-3).maxBodyOmegaError;
  const double rk4Fine = rotationscenes::runFreePrecession(RotationScheme::rungeKutta4, 5e-4).maxBodyOmegaError;
  const double directCoarse = rotationscenes::runFreePrecession(RotationScheme::direct, 1e-3).maxBodyOmegaError;
  const double directFine = rotationscenes::runFreePrecession(RotationScheme::direct, 5e-4).maxBodyOmegaError;
  BOOST_TEST_MESSAGE("R1 error ratio dt/(dt/2): ZvW " << zvwCoarse / zvwFine << ", RK4 " << rk4Coarse / rk4Fine
                                                      << ", direct " << directCoarse / directFine);
  BOOST_TEST(zvwCoarse / zvwFine > 3.0);
  BOOST_TEST(zvwCoarse / zvwFine < 5.0);
  BOOST_TEST(rk4Coarse / rk4Fine > 3.0); // second order, see kZvWPrecessionTolerance
  BOOST_TEST(rk4Coarse / rk4Fine < 5.0);
  BOOST_TEST(directCoarse / directFine > 1.6);
  BOOST_TEST(directCoarse / directFine < 2.6);
}

// Tumbling asymmetric body. With ωΔt = 0.01 a second-order scheme's invariant error is of the order of its
// truncation term (ωΔt)²/2 = 5e-5 (measured: ZvW 8.4e-6 in E, 1.3e-5 in H; RK4 2.8e-6 in E). RK4 carries
// H as its state, so |H| drifts only by round-off over 4000 steps (measured 5e-15; bound 1e-12). The
// direct scheme drifts at first order, ∝ ωΔt (measured 6e-3 in E): asserted above 1e-3.
constexpr double kTumblingInvariantTolerance = 5e-5;

BOOST_AUTO_TEST_CASE(tumbling_asymmetric_body_keeps_its_invariants) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4, RotationScheme::direct}) {
    const auto r = rotationscenes::runTumblingBody(scheme, 1e-3);
    BOOST_TEST_MESSAGE("tumbling " << kernels::rotationSchemeName(scheme) << " dt=1e-3: |dE|/E0 = "
                                   << r.maxRelativeEnergyError << ", |dH|/|H0| = " << r.maxRelativeMomentumError
                                   << ", min w'_y = " << r.minBodyOmegaY);
    // The intermediate-axis flip must happen, or the test exercised no gyroscopic coupling.
    BOOST_TEST(r.minBodyOmegaY < -9.0);
    if (scheme == RotationScheme::direct) {
      BOOST_TEST(r.maxRelativeEnergyError > 1e-3);
    } else {
      BOOST_TEST(r.maxRelativeEnergyError < kTumblingInvariantTolerance);
      BOOST_TEST(r.maxRelativeMomentumError < kTumblingInvariantTolerance);
    }
  }
  BOOST_TEST(rotationscenes::runTumblingBody(RotationScheme::rungeKutta4, 1e-3).maxRelativeMomentumError < 1e-12);
}

// R2 tolerance. The scheme is velocity Verlet on θ for a sphere; its global position error for θ'' = a(t)
// is ≈ (Δt²/6)∫a' dt + (Δt²/12)∫(a'(t) − a'(0)) dt ≈ 1.9e-7 rad at t = 1 s with Δt = 1e-4 and
// a = 54.26 eᵗ s⁻². 1e-6 rad (2.6e-8 of θ = 38.97 rad) leaves a factor 5 for round-off of 1e4 increments.
constexpr double kSphereAngleTolerance = 1e-6;

BOOST_AUTO_TEST_CASE(r2_sphere_angle_matches_closed_form) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4}) {
    const auto r = rotationscenes::runSphereUnderExponentialTorque(scheme, 1e-4);
    BOOST_TEST_MESSAGE("R2 " << kernels::rotationSchemeName(scheme) << " dt=1e-4: theta_exact = " << r.exactAngle
                             << " rad, |sum dtheta - exact| = " << r.angleError
                             << " rad, quaternion error = " << r.orientationError);
    // Derived constant: θ_y(1 s) = 38.972 rad.
    BOOST_TEST(std::abs(r.exactAngle - 38.972) < 1e-3);
    BOOST_TEST(r.angleError < kSphereAngleTolerance);
    // |q − q_exact| ≈ |Δθ|/2 for a small angle error: the same bound applies.
    BOOST_TEST(r.orientationError < kSphereAngleTolerance);
  }
}
