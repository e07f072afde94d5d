// Tests R3/R4 of Irazábal 2017 §5.3.2: rigid fibres bouncing without dissipation conserve total energy.
#define BOOST_TEST_MODULE rotation_fibres
#include <boost/test/unit_test.hpp>

#include "RotationScenes.hpp"

using namespace railcosim;
using kernels::RotationScheme;

// Note: our fibres are straight chains and the contacts frictionless, so every contact force passes through
// the fibre axis; the spin about the axis stays zero and the gyroscopic term ω' × I'ω' vanishes for this
// axisymmetric body. R3/R4 therefore check the coupling of the rotation schemes with contact forces and
// the orientation update, not the gyroscopic terms (ZvW and RK4 give the same energy error here); the
// gyroscopic terms are checked by R1 and the tumbling test in RotationSchemesTest.cpp.

// Δt. The thesis uses 1e-7 s for its (unpublished) fibre; ours has Hertz contact durations of ~1 ms
// (m ≈ 0.17 kg, R = 0.02 m, E* ≈ 2.7e7 Pa, impact speed ≈ 3 m/s), so Δt = 2e-6 s resolves every impact
// with ~500 steps, well inside the accuracy range, and keeps the tests to about two seconds.
constexpr double kTimeStep = 2e-6;
// Acceptance: the thesis criterion, total-energy error below 0.3 % of the initial energy (§5.3.2).
constexpr double kEnergyTolerance = 3e-3;
// Sharper bound for our set-up: velocity Verlet through a Hertz impact resolved with N ≈ 500 steps has a
// transient energy error of order N⁻² ≈ 4e-6 of the impact energy; 1e-5 is above that and 300 times
// tighter than the thesis criterion, so a rotation scheme that injects energy at impacts is caught.
constexpr double kResolvedEnergyTolerance = 1e-5;

BOOST_AUTO_TEST_CASE(r3_single_fibre_conserves_energy) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4}) {
    const auto r = rotationscenes::runSingleFibre(scheme, kTimeStep, 0.8);
    BOOST_TEST_MESSAGE("R3 " << kernels::rotationSchemeName(scheme) << ": E0 = " << r.initialEnergy
                             << " J, max |E - E0|/E0 = " << r.maxRelativeEnergyError
                             << ", max |w| = " << r.maxAngularSpeed << " rad/s");
    BOOST_TEST(r.maxRelativeEnergyError < kEnergyTolerance);
    BOOST_TEST(r.maxRelativeEnergyError < kResolvedEnergyTolerance);
    // The tilted fibre lands on one end and must start spinning: otherwise the test exercises no rotation.
    BOOST_TEST(r.maxAngularSpeed > 1.0);
  }
}

BOOST_AUTO_TEST_CASE(r4_nine_fibres_conserve_energy) {
  for (RotationScheme scheme : {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4}) {
    const auto r = rotationscenes::runNineFibres(scheme, kTimeStep, 0.6);
    BOOST_TEST_MESSAGE("R4 " << kernels::rotationSchemeName(scheme) << ": E0 = " << r.initialEnergy
                             << " J, max |E - E0|/E0 = " << r.maxRelativeEnergyError << ", fibre-fibre contact steps = "
                             << r.sphereSphereContactSteps << ", max |w| = " << r.maxAngularSpeed << " rad/s");
    BOOST_TEST(r.maxRelativeEnergyError < kEnergyTolerance);
    BOOST_TEST(r.maxRelativeEnergyError < kResolvedEnergyTolerance);
    // Particle–particle collisions must occur (the point of R4 over R3).
    BOOST_TEST(r.sphereSphereContactSteps > 0);
  }
}
