// Window iteration of the implicit scheme against linear fixed points with known solutions.
#define BOOST_TEST_MODULE bridge_implicit_coupling
#include <boost/test/unit_test.hpp>

#include "railcosim/Error.hpp"
#include "railcosim/ImplicitCoupling.hpp"
#include "railcosim/StateStream.hpp"

#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>

using namespace railcosim;
using Outcome = ImplicitWindowIteration::Outcome;

namespace {

// A one-node "FEM" whose end position answers the assumed one linearly: z_end = b + a z_assumed.
// The fixed point z* = b / (1 - a) is what a converged window must return. |a| > 1 is a stiff
// coupling: plain fixed-point passes (ω = 1) diverge there.
struct LinearAnswer {
  double a, b;
  NodalKinematics operator()(const std::vector<double>& assumed) const {
    NodalKinematics end;
    end.positions = {0.0, 0.0, b + a * assumed[2]};
    return end;
  }
  double fixedPoint() const { return b / (1.0 - a); }
};

struct Run {
  Outcome outcome;
  int passes;
  double z;
};

Run iterate(ImplicitSettings settings, const LinearAnswer& answer, bool touched = true) {
  ImplicitWindowIteration window(settings, {0.0, 0.0, 0.0}, 1e-3);
  NodalKinematics accepted;
  accepted.positions = {0.0, 0.0, 0.0};
  window.startWindow(accepted);
  for (int pass = 1;; ++pass) {
    const NodalKinematics end = answer(window.assumedEnd());
    const Outcome outcome = window.judge(end, touched);
    if (outcome != Outcome::Repeat) return {outcome, pass, end.positions[2]};
  }
}

} // namespace

BOOST_AUTO_TEST_CASE(aitken_solves_a_linear_fixed_point_in_three_passes) {
  // Secant (Aitken) relaxation is exact for a linear map after two residuals: pass 1 and 2 measure,
  // pass 3 lands on z* (up to round-off), whatever the slope; contraction (a = 0.5), overshoot
  // (a = -5, plain iteration diverges) and expansion (a = 3) alike.
  for (double a : {0.5, -5.0, 3.0, -0.9}) {
    const LinearAnswer answer{a, 1e-4};
    ImplicitSettings settings;
    settings.tolerance = 1e-9;
    const Run run = iterate(settings, answer);
    BOOST_TEST_CONTEXT("slope " << a) {
      BOOST_TEST((run.outcome == Outcome::Converged));
      BOOST_TEST(run.passes <= 4);
      // The converged answer differs from z* by the residual test's limit at most (1e-9 relative).
      BOOST_TEST(std::abs(run.z - answer.fixedPoint()) <= 2e-9 * std::abs(answer.fixedPoint()));
    }
  }
}

BOOST_AUTO_TEST_CASE(constant_relaxation_fails_where_it_must_and_converges_where_it_can) {
  ImplicitSettings settings;
  settings.aitken = false;
  settings.relaxation = 1.0;
  settings.tolerance = 1e-9;
  settings.maxIterations = 40;
  // Plain passes on a = -5: the error grows 5x per pass; the window gives up after maxIterations.
  const Run diverging = iterate(settings, {-5.0, 1e-4});
  BOOST_TEST((diverging.outcome == Outcome::GaveUp));
  BOOST_TEST(diverging.passes == 40);
  // ω = 1/(1 - a) = 1/6 is the exact relaxation for a = -5: one corrective pass suffices.
  settings.relaxation = 1.0 / 6.0;
  const Run exact = iterate(settings, {-5.0, 1e-4});
  BOOST_TEST((exact.outcome == Outcome::Converged));
  BOOST_TEST(exact.passes == 2);
  // Contraction a = 0.5 with ω = 1: error halves per pass; 1e-9 relative needs about log2(1e9) ≈ 30 passes.
  settings.relaxation = 1.0;
  const Run slow = iterate(settings, {0.5, 1e-4});
  BOOST_TEST((slow.outcome == Outcome::Converged));
  BOOST_TEST(slow.passes >= 25);
  BOOST_TEST(slow.passes <= 35);
}

BOOST_AUTO_TEST_CASE(window_without_contact_converges_at_once) {
  // Forces that did not touch the surface cannot depend on where it was assumed to be.
  const Run run = iterate(ImplicitSettings{}, {-5.0, 1e-4}, false);
  BOOST_TEST((run.outcome == Outcome::Converged));
  BOOST_TEST(run.passes == 1);
}

BOOST_AUTO_TEST_CASE(predictor_and_surface_motion) {
  // Window start at rest with a uniform acceleration: the first assumed end is P + V dt + A dt²/2,
  // and the surface moves linearly there (V = (P~ - P)/dt, no acceleration).
  ImplicitWindowIteration window(ImplicitSettings{}, {0.0, 0.0, 1.0}, 0.5);
  NodalKinematics accepted;
  accepted.positions = {0.0, 0.0, 1.0};
  accepted.velocities = {0.0, 2.0, 0.0};
  accepted.accelerations = {4.0, 0.0, 0.0};
  window.startWindow(accepted);
  BOOST_TEST(window.assumedEnd()[0] == 0.5); // 4 * 0.25 / 2
  BOOST_TEST(window.assumedEnd()[1] == 1.0); // 2 * 0.5
  BOOST_TEST(window.assumedEnd()[2] == 1.0);
  BOOST_TEST(window.surfaceStart().velocities[0] == 1.0);
  BOOST_TEST(window.surfaceStart().velocities[1] == 2.0);
  BOOST_TEST(window.surfaceStart().accelerations.empty());
  BOOST_TEST(window.iteration() == 0u);
}

BOOST_AUTO_TEST_CASE(bad_settings_are_named) {
  auto rejects = [](std::function<void(ImplicitSettings&)> change, const std::string& word) {
    ImplicitSettings settings;
    change(settings);
    try {
      settings.validate();
      BOOST_FAIL("accepted a bad " + word);
    } catch (const Error& error) {
      BOOST_TEST(std::string(error.what()).find(word) != std::string::npos);
    }
  };
  rejects([](ImplicitSettings& s) { s.tolerance = 0.0; }, "tolerance");
  rejects([](ImplicitSettings& s) { s.maxIterations = 0; }, "maxIterations");
  rejects([](ImplicitSettings& s) { s.relaxation = 1.5; }, "relaxation");
  rejects([](ImplicitSettings& s) { s.absoluteTolerance = -1.0; }, "absoluteTolerance");
}

BOOST_AUTO_TEST_CASE(saved_state_goes_on_bit_for_bit_with_aitkens_factor) {
  // Two windows of a stiff linear interface (slope -5): the iteration is saved in the middle of the first window
  // (after two passes, Aitken's factor already computed) and at the boundary between the windows (the factor carried
  // over); a copy restored from either state must give every later pass bit for bit, whatever the original does.
  ImplicitSettings settings;
  settings.tolerance = 1e-12;
  const LinearAnswer answer{-5.0, 1e-4};
  auto bits = [](double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    return b;
  };
  auto run = [&](ImplicitWindowIteration& window, int passes, std::vector<std::uint64_t>& trace) {
    for (int pass = 0; pass < passes; ++pass) {
      const NodalKinematics end = answer(window.assumedEnd());
      const Outcome outcome = window.judge(end, true);
      trace.insert(trace.end(), {bits(window.assumedEnd()[2]), bits(window.relaxation()), bits(window.residualNorm()),
                                 static_cast<std::uint64_t>(outcome), window.iteration()});
      if (outcome != Outcome::Repeat) {
        NodalKinematics accepted = end;
        accepted.velocities = {0.0, 0.0, 1e-3};
        window.startWindow(accepted);
      }
    }
  };
  for (int savedAfter : {2, 6}) {
    ImplicitWindowIteration original(settings, {0.0, 0.0, 0.0}, 1e-3);
    NodalKinematics start;
    start.positions = {0.0, 0.0, 0.0};
    original.startWindow(start);
    std::vector<std::uint64_t> before, expected, resumed;
    run(original, savedAfter, before);
    std::ostringstream saved;
    StateWriter writer(saved);
    original.writeState(writer);
    run(original, 8, expected);

    ImplicitWindowIteration restored(settings, {0.0, 0.0, 0.0}, 1e-3);
    std::istringstream in(saved.str());
    StateReader reader(in, "of the test");
    restored.readState(reader);
    run(restored, 8, resumed);
    BOOST_TEST_CONTEXT("saved after " << savedAfter << " passes") { BOOST_TEST(resumed == expected); }
  }
  // A state of another interface is refused.
  ImplicitWindowIteration original(settings, {0.0, 0.0, 0.0}, 1e-3);
  original.startWindow(NodalKinematics{0.0, {0.0, 0.0, 0.0}, {}, {}});
  std::ostringstream saved;
  StateWriter writer(saved);
  original.writeState(writer);
  ImplicitWindowIteration other(settings, {0.0, 0.0, 1.0}, 1e-3);
  std::istringstream in(saved.str());
  StateReader reader(in, "of the test");
  BOOST_CHECK_THROW(other.readState(reader), CheckpointError);
}
