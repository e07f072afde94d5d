// Surface motion inside a window: exact for uniformly accelerated motion; predictive start reaches P1.
#define BOOST_TEST_MODULE bridge_window_interpolation
#include <boost/test/unit_test.hpp>

#include "railcosim/Error.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include <cmath>
#include <random>

using namespace railcosim;

BOOST_AUTO_TEST_CASE(taylor_extrapolation_is_exact_for_uniform_acceleration) {
  // Dyadic values: every product and sum below is exactly representable, so the closed form
  // x(t) = x0 + v0 t + a t^2 / 2, v(t) = v0 + a t must be reproduced bit for bit.
  NodalKinematics start;
  start.positions = {1.5, -2.25, 0.125, 3.0, 0.0, -0.5};
  start.velocities = {0.5, 4.0, -1.0, 0.0, 2.0, 0.25};
  start.accelerations = {-9.8125, 0.0, 2.0, 1.0, -0.5, 8.0};
  std::vector<double> positions, velocities;
  for (double tau : {0.0, 0.0625, 0.25, 1.0}) {
    extrapolateSurface(start, tau, positions, velocities);
    for (std::size_t i = 0; i < 6; ++i) {
      const double exactPosition =
          start.positions[i] + start.velocities[i] * tau + 0.5 * start.accelerations[i] * tau * tau;
      const double exactVelocity = start.velocities[i] + start.accelerations[i] * tau;
      BOOST_TEST(positions[i] == exactPosition);
      BOOST_TEST(velocities[i] == exactVelocity);
    }
  }
}

BOOST_AUTO_TEST_CASE(taylor_extrapolation_matches_closed_form_for_random_motion) {
  // Arbitrary (non-dyadic) data: agreement to a few ulps of the largest term.
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> value(-10.0, 10.0);
  NodalKinematics start;
  for (int i = 0; i < 300; ++i) {
    start.positions.push_back(value(random));
    start.velocities.push_back(value(random));
    start.accelerations.push_back(100.0 * value(random));
  }
  std::vector<double> positions, velocities;
  const double tau = 3.7e-5;
  extrapolateSurface(start, tau, positions, velocities);
  for (std::size_t i = 0; i < start.positions.size(); ++i) {
    const double exactPosition =
        start.positions[i] + start.velocities[i] * tau + start.accelerations[i] * tau * tau / 2;
    BOOST_TEST(std::abs(positions[i] - exactPosition) <= 4e-16 * std::abs(start.positions[i]) + 1e-20);
    BOOST_TEST(std::abs(velocities[i] - (start.velocities[i] + start.accelerations[i] * tau)) <= 4e-15);
  }
}

BOOST_AUTO_TEST_CASE(missing_velocity_and_acceleration_count_as_zero) {
  NodalKinematics start;
  start.positions = {1.0, 2.0, 3.0};
  std::vector<double> positions, velocities;
  extrapolateSurface(start, 0.5, positions, velocities);
  BOOST_TEST(positions == start.positions);
  BOOST_TEST(velocities == std::vector<double>(3, 0.0));
  start.velocities = {1.0, 1.0}; // wrong size
  BOOST_CHECK_THROW(extrapolateSurface(start, 0.5, positions, velocities), Error);
}

BOOST_AUTO_TEST_CASE(predictive_start_reaches_the_window_end_position) {
  std::mt19937_64 random(3);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  NodalKinematics atStart, atEnd;
  atStart.time = 0.2;
  for (int i = 0; i < 600; ++i) {
    atStart.positions.push_back(value(random));
    atEnd.positions.push_back(atStart.positions.back() + 1e-4 * value(random));
  }
  const double femTimeStep = 1e-4;
  const NodalKinematics start = predictiveStart(atStart, atEnd, femTimeStep);
  BOOST_TEST(start.time == 0.2);
  BOOST_TEST(start.positions == atStart.positions);
  BOOST_TEST(start.accelerations == std::vector<double>(600, 0.0));
  std::vector<double> positions, velocities;
  extrapolateSurface(start, femTimeStep, positions, velocities);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    // P0 + ((P1 - P0) / dt) dt: two roundings on the increment, far below 1e-15 m for |P| <= 1 m.
    BOOST_TEST(std::abs(positions[i] - atEnd.positions[i]) <= 1e-15);
    BOOST_TEST(velocities[i] == start.velocities[i]); // A = 0: constant velocity
  }
  // Dyadic case: reproduced exactly.
  NodalKinematics p0, p1;
  p0.positions = {0.5, -1.0, 2.0};
  p1.positions = {0.625, -1.5, 2.0};
  const NodalKinematics exact = predictiveStart(p0, p1, 0.25);
  extrapolateSurface(exact, 0.25, positions, velocities);
  BOOST_TEST(positions == p1.positions);
}

BOOST_AUTO_TEST_CASE(predictive_start_rejects_bad_input) {
  NodalKinematics a, b;
  a.positions = {0, 0, 0};
  b.positions = {0, 0, 0, 1, 1, 1};
  BOOST_CHECK_THROW(predictiveStart(a, b, 1e-4), Error);
  BOOST_CHECK_THROW(predictiveStart(a, a, 0.0), Error);
  BOOST_CHECK_THROW(predictiveStart(a, a, std::nan("")), Error);
}

BOOST_AUTO_TEST_CASE(scheme_names) {
  BOOST_TEST((parseCouplingScheme("justInTime") == CouplingScheme::JustInTime));
  BOOST_TEST((parseCouplingScheme("Just-In-Time") == CouplingScheme::JustInTime));
  BOOST_TEST((parseCouplingScheme("PREDICTIVE") == CouplingScheme::Predictive));
  BOOST_TEST(toString(CouplingScheme::JustInTime) == "justInTime");
  BOOST_TEST(toString(CouplingScheme::Predictive) == "predictive");
  BOOST_TEST((parseCouplingScheme(toString(CouplingScheme::Predictive)) == CouplingScheme::Predictive));
  BOOST_TEST((parseCouplingScheme("Implicit") == CouplingScheme::Implicit));
  BOOST_TEST(toString(CouplingScheme::Implicit) == "implicit");
  try {
    parseCouplingScheme("semiImplicit");
    BOOST_FAIL("no Error thrown");
  } catch (const Error& error) {
    // The message names the bad input and the accepted names.
    BOOST_TEST(std::string(error.what()).find("semiImplicit") != std::string::npos);
    BOOST_TEST(std::string(error.what()).find("implicit") != std::string::npos);
  }
}
