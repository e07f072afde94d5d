// Restart checkpoints between real participants over ipc: the order at a window boundary and its answer, the
// handshake of a resumed pair, and what is refused (inside a window, a FEM side that cannot save, mismatched starts).
#define BOOST_TEST_MODULE integration_restart_protocol
#include <boost/test/unit_test.hpp>

#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

#include "InterfaceFixtures.hpp"

#include <unistd.h>

#include <atomic>
#include <future>
#include <sstream>

using namespace railcosim;

namespace {

using test::square;
using test::uniqueEndpoint;

NodalKinematics restingAt(double time) { return test::restingAt(square(), time); }

ParticipantConfig config(const std::string& name, const std::string& endpoint, const std::string& resumedFrom = "",
                         std::uint64_t resumedWindow = 0) {
  ParticipantConfig c{name, endpoint, 10.0, 1.0, "justInTime"};
  c.resumedFrom = resumedFrom;
  c.resumedWindow = resumedWindow;
  return c;
}

ForceMessage forcesOf(std::uint64_t window) {
  ForceMessage forces;
  forces.window = window;
  forces.time = 1e-4 * static_cast<double>(window + 1);
  forces.forces.assign(12, -1.0);
  return forces;
}

template <class Exception, class Call>
std::string messageOf(Call call) {
  try {
    call();
  } catch (const Exception& error) {
    return error.what();
  }
  BOOST_FAIL("expected exception not thrown");
  return {};
}

bool contains(const std::string& text, const std::string& fragment) {
  const bool found = text.find(fragment) != std::string::npos;
  if (!found) BOOST_TEST_MESSAGE("'" << fragment << "' not in: " << text);
  return found;
}

} // namespace

BOOST_AUTO_TEST_CASE(a_checkpoint_is_ordered_at_a_window_boundary_and_answered_with_the_files) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(config("fem", endpoint));
    participant.initialize(square(), 1e-4, restingAt(0.0));
    std::vector<std::string> seen;
    while (true) {
      FemIncoming incoming = participant.receive();
      if (incoming.kind == FemIncoming::Kind::Finalized) break;
      if (incoming.kind == FemIncoming::Kind::Checkpoint) {
        seen.push_back(incoming.checkpoint.name + " " + std::to_string(incoming.checkpoint.window));
        BOOST_TEST(incoming.checkpoint.time == 3e-4);
        CheckpointFile file{"fem", "fem_state.bin", "", 123, 0xcbf43926u};
        participant.confirmCheckpoint(incoming.checkpoint.window, {file});
        continue;
      }
      participant.sendKinematics(incoming.forces.window, restingAt(incoming.forces.time));
    }
    BOOST_TEST(participant.statistics().exchanges == 10u); // the checkpoint's messages are not exchanges
    return seen;
  });
  DemParticipant dem(config("dem", endpoint));
  dem.initialize();
  for (std::uint64_t window = 0; window < 5; ++window) {
    if (window == 3) {
      const std::vector<CheckpointFile> files = dem.orderCheckpoint({3, 3e-4, "window-00000003"});
      BOOST_TEST(files.size() == 1u);
      BOOST_TEST(files[0].name == "fem_state.bin");
      BOOST_TEST(files[0].bytes == 123u);
      BOOST_TEST(files[0].crc32 == 0xcbf43926u);
    }
    dem.sendForces(forcesOf(window));
    dem.receiveKinematics(window);
  }
  dem.finalize();
  BOOST_TEST(fem.get() == std::vector<std::string>({"window-00000003 3"}));
}

BOOST_AUTO_TEST_CASE(a_checkpoint_inside_a_window_is_refused) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(config("fem", endpoint));
    participant.initialize(square(), 1e-4, restingAt(0.0));
    while (auto forces = participant.receiveForces())
      participant.sendKinematics(forces->window, restingAt(forces->time));
  });
  DemParticipant dem(config("dem", endpoint));
  dem.initialize();
  dem.sendForces(forcesOf(0));
  const std::string message = messageOf<Error>([&] { dem.orderCheckpoint({1, 1e-4, "window-00000001"}); });
  BOOST_TEST(contains(message, "orderCheckpoint: window 1"));
  BOOST_TEST(contains(message, "at a window boundary"));
  dem.receiveKinematics(0);
  dem.finalize();
  fem.get();
}

BOOST_AUTO_TEST_CASE(a_fem_side_that_cannot_save_refuses_the_order) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(config("fem", endpoint));
    participant.initialize(square(), 1e-4, restingAt(0.0));
    return messageOf<Error>([&] { participant.receiveForces(); });
  });
  DemParticipant dem(config("dem", endpoint));
  dem.initialize();
  const std::string demSide = messageOf<PeerLostError>([&] { dem.orderCheckpoint({0, 0.0, "window-00000000"}); });
  BOOST_TEST(contains(fem.get(), "a FEM side that saves checkpoints reads with receive()"));
  BOOST_TEST(contains(demSide, "cannot save"));
}

BOOST_AUTO_TEST_CASE(both_sides_must_resume_from_the_same_checkpoint) {
  struct Case {
    std::string demFrom;
    std::uint64_t demWindow;
    std::string femFrom;
    std::uint64_t femWindow;
    std::string expected;
  };
  const Case cases[] = {
      {"window-00000010", 10, "", 0,
       "resumed from restart checkpoint window-00000010 (window 10) but this side from a fresh start"},
      {"", 0, "window-00000010", 10,
       "resumed from a fresh start but this side from restart checkpoint window-00000010 (window 10)"},
      {"window-00000020", 20, "window-00000010", 10,
       "window-00000020 (window 20) but this side from restart checkpoint"},
  };
  for (const Case& c : cases) {
    const std::string endpoint = uniqueEndpoint();
    auto fem = std::async(std::launch::async, [&] {
      FemParticipant participant(config("fem", endpoint, c.femFrom, c.femWindow));
      return messageOf<ProtocolError>([&] { participant.initialize(square(), 1e-4, restingAt(0.0)); });
    });
    DemParticipant dem(config("dem", endpoint, c.demFrom, c.demWindow));
    const std::string demSide = messageOf<PeerLostError>([&] { dem.initialize(); });
    const std::string femSide = fem.get();
    BOOST_TEST(contains(femSide, c.expected));
    BOOST_TEST(contains(femSide, "both sides must start from the same checkpoint"));
    BOOST_TEST(contains(demSide, c.expected)); // the DEM side is told why
  }
}

BOOST_AUTO_TEST_CASE(a_resumed_pair_continues_at_the_window_boundary) {
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    FemParticipant participant(config("fem", endpoint, "window-00000010", 10));
    participant.initialize(square(), 1e-4, restingAt(0.0));
    std::uint64_t last = 0;
    while (auto forces = participant.receiveForces()) {
      last = forces->window;
      participant.sendKinematics(forces->window, restingAt(forces->time));
    }
    return last;
  });
  DemParticipant dem(config("dem", endpoint, "window-00000010", 10));
  dem.initialize();
  BOOST_CHECK_THROW(dem.sendForces(forcesOf(0)), Error); // window 0 was long ago
  for (std::uint64_t window = 10; window < 13; ++window) {
    dem.sendForces(forcesOf(window));
    BOOST_TEST(dem.receiveKinematics(window).time == forcesOf(window).time);
  }
  dem.finalize();
  BOOST_TEST(fem.get() == 12u);
}

BOOST_AUTO_TEST_CASE(a_scheme_resumes_only_from_its_own_state) {
  // A predictive pair runs three windows; the DEM scheme's state then refuses another scheme and another window length.
  const std::string endpoint = uniqueEndpoint();
  auto fem = std::async(std::launch::async, [&] {
    ParticipantConfig c = config("fem", endpoint);
    c.couplingScheme = "predictive";
    FemParticipant participant(c);
    participant.initialize(square(), 1e-4, restingAt(0.0));
    auto scheme = FemCouplingScheme::create(participant, 4);
    std::vector<double> forces;
    NodalKinematics end = restingAt(0.0);
    while (scheme->beginStep(forces) == FemCouplingScheme::Action::Solve) {
      end.time += 1e-4;
      scheme->endStep(end);
    }
  });
  ParticipantConfig c = config("dem", endpoint);
  c.couplingScheme = "predictive";
  DemParticipant dem(c);
  const InterfaceSetup setup = dem.initialize();
  SchemeSettings settings;
  settings.scheme = CouplingScheme::Predictive;
  auto scheme = DemCouplingScheme::create(settings, dem, setup);
  for (int window = 0; window < 3; ++window)
    scheme->completeWindow(std::vector<double>(12, -1.0), 1e-4 * (window + 1), true);
  std::ostringstream saved;
  scheme->writeState(saved);
  dem.finalize();
  fem.get();

  DemParticipant unconnected(config("dem", uniqueEndpoint(), "window-00000003", 3));
  {
    std::istringstream in(saved.str());
    auto resumed = DemCouplingScheme::resume(settings, unconnected, setup, in);
    BOOST_TEST(resumed->window() == 3u);
    std::vector<double> p1, v1, p2, v2;
    resumed->surfaceAt(5e-5, p1, v1);
    scheme->surfaceAt(5e-5, p2, v2);
    BOOST_TEST(p1 == p2);
    BOOST_TEST(v1 == v2);
  }
  SchemeSettings implicit;
  implicit.scheme = CouplingScheme::Implicit;
  std::istringstream asImplicit(saved.str());
  BOOST_TEST(
      contains(messageOf<CheckpointError>([&] { DemCouplingScheme::resume(implicit, unconnected, setup, asImplicit); }),
               "coupled with the predictive scheme, this run with the implicit scheme"));
  InterfaceSetup otherStep = setup;
  otherStep.femTimeStep = 2e-4;
  std::istringstream withOtherStep(saved.str());
  BOOST_TEST(contains(
      messageOf<CheckpointError>([&] { DemCouplingScheme::resume(settings, unconnected, otherStep, withOtherStep); }),
      "resume with the FEM time step of the interrupted run"));
}
