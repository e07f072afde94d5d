// Unit tests of the coupling schemes' message orders: the sequences each scheme allows, and what it refuses.
#define BOOST_TEST_MODULE bridge_MessageOrder
#include <boost/test/unit_test.hpp>

#include "cplscheme/MessageOrder.hpp"
#include "railcosim/CouplingScheme.hpp"

using namespace railcosim;
using cplscheme::makeMessageOrder;

BOOST_AUTO_TEST_CASE(just_in_time_alternates_forces_first) {
  auto order = makeMessageOrder(CouplingScheme::JustInTime);
  for (std::uint64_t w = 0; w < 5; ++w) {
    BOOST_TEST(order->forcesAllowed(w, 0));
    BOOST_TEST(!order->forcesAllowed(w, 1)); // no scheme without iteration repeats a window
    order->forcesExchanged(w, 0);
    BOOST_TEST(!order->forcesAllowed(w + 1, 0)); // one window ahead at most
    BOOST_TEST(order->kinematicsAllowed(w));
    order->kinematicsExchanged(w);
  }
  BOOST_TEST(order->forcesWindows() == 5u);
  BOOST_TEST(order->kinematicsWindows() == 5u);
  BOOST_TEST(order->expectedForces() == "window 5");
}

BOOST_AUTO_TEST_CASE(predictive_alternates_kinematics_first) {
  auto order = makeMessageOrder(CouplingScheme::Predictive);
  BOOST_TEST(order->kinematicsAllowed(0)); // the FEM steps first
  order->kinematicsExchanged(0);
  BOOST_TEST(!order->kinematicsAllowed(1)); // not before the forces of window 0
  for (std::uint64_t w = 0; w < 5; ++w) {
    BOOST_TEST(!order->forcesAllowed(w + 1, 0));
    BOOST_TEST(order->forcesAllowed(w, 0));
    order->forcesExchanged(w, 0);
    BOOST_TEST(order->kinematicsAllowed(w + 1));
    order->kinematicsExchanged(w + 1);
  }
  BOOST_TEST(order->kinematicsWindows() == 6u); // one state more than force windows: the FEM's first step
}

BOOST_AUTO_TEST_CASE(implicit_repeats_a_window_or_opens_the_next) {
  auto order = makeMessageOrder(CouplingScheme::Implicit);
  BOOST_TEST(order->forcesBlockedBecause().empty());
  BOOST_TEST(!order->forcesAllowed(0, 1)); // nothing to repeat yet
  order->forcesExchanged(0, 0);
  BOOST_TEST(!order->forcesBlockedBecause().empty()); // the kinematics of pass 0 come first
  BOOST_TEST(order->kinematicsIteration() == 0u);
  BOOST_TEST(order->kinematicsAllowed(0));
  order->kinematicsExchanged(0);
  BOOST_TEST(order->forcesAllowed(0, 1));  // pass 1 of window 0
  BOOST_TEST(order->forcesAllowed(1, 0));  // or window 1
  BOOST_TEST(!order->forcesAllowed(0, 2)); // passes are not skipped
  BOOST_TEST(!order->forcesAllowed(2, 0)); // nor windows
  BOOST_TEST(order->expectedForces() == "window 1 or for window 0 (iteration 1)");
  order->forcesExchanged(0, 1);
  BOOST_TEST(order->kinematicsIteration() == 1u);
  BOOST_TEST(!order->kinematicsAllowed(1));
  order->kinematicsExchanged(0);
  order->forcesExchanged(1, 0);
  BOOST_TEST(order->forcesWindows() == 2u);
  BOOST_TEST(order->kinematicsAllowed(1));
}

BOOST_AUTO_TEST_CASE(checkpoints_are_taken_at_window_boundaries_only) {
  // Just-in-time: after the kinematics of window w-1, before the forces of window w.
  auto jit = makeMessageOrder(CouplingScheme::JustInTime);
  BOOST_TEST(jit->checkpointAllowed(0));
  jit->forcesExchanged(0, 0);
  BOOST_TEST(!jit->checkpointAllowed(1)); // the forces of window 0 are not answered yet
  jit->kinematicsExchanged(0);
  BOOST_TEST(!jit->checkpointAllowed(0));
  BOOST_TEST(jit->checkpointAllowed(1));
  // Predictive: the FEM is one step ahead at every boundary.
  auto predictive = makeMessageOrder(CouplingScheme::Predictive);
  BOOST_TEST(!predictive->checkpointAllowed(0)); // the FEM's first step is not answered yet
  predictive->kinematicsExchanged(0);
  BOOST_TEST(predictive->checkpointAllowed(0));
  predictive->forcesExchanged(0, 0);
  BOOST_TEST(!predictive->checkpointAllowed(1));
  predictive->kinematicsExchanged(1);
  BOOST_TEST(predictive->checkpointAllowed(1));
  // Implicit: a checkpoint accepts the last pass; the window is not repeated after it.
  auto implicit = makeMessageOrder(CouplingScheme::Implicit);
  implicit->forcesExchanged(0, 0);
  BOOST_TEST(!implicit->checkpointAllowed(1));
  implicit->kinematicsExchanged(0);
  BOOST_TEST(implicit->forcesAllowed(0, 1));
  BOOST_TEST(implicit->checkpointAllowed(1));
  implicit->checkpointExchanged(1);
  BOOST_TEST(!implicit->forcesAllowed(0, 1));
  BOOST_TEST(implicit->forcesAllowed(1, 0));
  BOOST_TEST(implicit->expectedForces() == "window 1");
}

BOOST_AUTO_TEST_CASE(a_resumed_order_continues_at_the_boundary) {
  auto jit = makeMessageOrder(CouplingScheme::JustInTime);
  jit->resumeAt(800);
  BOOST_TEST(jit->forcesAllowed(800, 0));
  BOOST_TEST(!jit->forcesAllowed(0, 0));
  BOOST_TEST(!jit->kinematicsAllowed(799));
  auto predictive = makeMessageOrder(CouplingScheme::Predictive);
  predictive->resumeAt(800);
  BOOST_TEST(predictive->forcesAllowed(800, 0)); // the FEM's state at t_801 is already known
  BOOST_TEST(!predictive->kinematicsAllowed(800));
  predictive->forcesExchanged(800, 0);
  BOOST_TEST(predictive->kinematicsAllowed(801));
  auto implicit = makeMessageOrder(CouplingScheme::Implicit);
  implicit->resumeAt(800);
  BOOST_TEST(implicit->forcesAllowed(800, 0));
  BOOST_TEST(!implicit->forcesAllowed(799, 1)); // the last window before the checkpoint was accepted
}

BOOST_AUTO_TEST_CASE(scheme_names_are_one_table) {
  for (CouplingScheme scheme : {CouplingScheme::JustInTime, CouplingScheme::Predictive, CouplingScheme::Implicit}) {
    BOOST_TEST((parseCouplingScheme(toString(scheme)) == scheme));
    BOOST_TEST(knownCouplingSchemes().find(toString(scheme)) != std::string::npos);
  }
}
