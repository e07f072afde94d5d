// Record and replay: a recorded pair run played back from either side into a fresh live participant.
#define BOOST_TEST_MODULE integration_replay
#include <boost/test/unit_test.hpp>

#include "ProcessHarness.hpp"

#include <cstdlib>
#include <string>
#include <vector>

namespace {

using railcosim::test::contains;
using railcosim::test::Process;
using railcosim::test::uniqueName;

/// The stand-in DEM's arguments; `--contact-stiffness` makes the forces depend on the surface position,
/// so a replayed FEM side that answered wrongly would change them.
std::vector<std::string> demArguments(const std::string& endpoint, const std::string& scheme, const std::string& load) {
  std::vector<std::string> arguments{"--endpoint", endpoint,    "--timeout", "20",     "--scheme",
                                     scheme,       "--windows", "40",        "--load", load};
  if (scheme == "implicit") arguments.insert(arguments.end(), {"--contact-stiffness", "5e9"});
  return arguments;
}

/// Records a run of the stand-ins (the FEM side records), then plays the FEM side back into a fresh
/// stand-in DEM and the DEM side back into a fresh stand-in FEM. Both solvers are deterministic, so every
/// answer must come back bit for bit (the replay's tolerance is 1e-12 relative; 0 is measured).
void recordAndReplay(const std::string& scheme) {
  const std::string recording = "/tmp/" + uniqueName() + ".rec";
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    setenv("RAILCOSIM_BRIDGE_RECORD", recording.c_str(), 1);
    Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--scheme", scheme, "--nodes", "16"});
    unsetenv("RAILCOSIM_BRIDGE_RECORD");
    Process dem(RAILCOSIM_DUMMY_DEM, demArguments(endpoint, scheme, "-1000"));
    BOOST_TEST(dem.wait(30) == 0, dem.errors());
    BOOST_TEST(fem.wait(10) == 0, fem.errors());
  }
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    Process replay(RAILCOSIM_REPLAY,
                   {"--recording", recording, "--play", "fem", "--endpoint", endpoint, "--timeout", "20"});
    Process dem(RAILCOSIM_DUMMY_DEM, demArguments(endpoint, scheme, "-1000"));
    BOOST_TEST(dem.wait(30) == 0, dem.errors());
    BOOST_TEST(replay.wait(10) == 0, replay.output() << replay.errors());
    BOOST_TEST(contains(replay.output(), "railcosim_replay: OK played the fem side"), replay.output());
    BOOST_TEST(contains(replay.output(), "largest relative difference 0.000e+00"), replay.output());
  }
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--scheme", scheme, "--nodes", "16"});
    Process replay(RAILCOSIM_REPLAY,
                   {"--recording", recording, "--play", "dem", "--endpoint", endpoint, "--timeout", "20"});
    BOOST_TEST(replay.wait(30) == 0, replay.output() << replay.errors());
    BOOST_TEST(fem.wait(10) == 0, fem.errors());
    BOOST_TEST(contains(replay.output(), "railcosim_replay: OK played the dem side"), replay.output());
    BOOST_TEST(contains(replay.output(), "largest relative difference 0.000e+00"), replay.output());
  }
  {
    // A live DEM side that changed (a heavier block) is caught: its forces differ from the recorded ones.
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    Process replay(RAILCOSIM_REPLAY,
                   {"--recording", recording, "--play", "fem", "--endpoint", endpoint, "--timeout", "20"});
    Process dem(RAILCOSIM_DUMMY_DEM, demArguments(endpoint, scheme, "-1001"));
    dem.wait(30); // its own oracle fails too: the replayed surface does not answer its load
    BOOST_TEST(replay.wait(10) == 1, replay.output() << replay.errors());
    BOOST_TEST(contains(replay.output(), "railcosim_replay: DIFFERENT"), replay.output());
  }
  std::remove(recording.c_str());
}

} // namespace

BOOST_AUTO_TEST_CASE(just_in_time_replays_both_sides) { recordAndReplay("justInTime"); }
BOOST_AUTO_TEST_CASE(predictive_replays_both_sides) { recordAndReplay("predictive"); }
BOOST_AUTO_TEST_CASE(implicit_replays_both_sides) { recordAndReplay("implicit"); }

BOOST_AUTO_TEST_CASE(restart_checkpoints_are_replayed_on_both_sides) {
  // A predictive run with a checkpoint every 10 windows, recorded; each side played back into a fresh stand-in of the
  // other: the orders, the forces and kinematics, and the FEM side's files (names, sizes, CRC-32) come back equal.
  const std::string folder = "/tmp/" + uniqueName() + "-checkpoints";
  setenv("RAILCOSIM_CHECKPOINT_DIR", folder.c_str(), 1);
  const std::string recording = "/tmp/" + uniqueName() + ".rec";
  std::vector<std::string> dem = demArguments("", "predictive", "-1000");
  dem.insert(dem.end(), {"--checkpoint-every", "1e-3"});
  auto withEndpoint = [](std::vector<std::string> arguments, const std::string& endpoint) {
    arguments[1] = endpoint;
    return arguments;
  };
  const std::vector<std::string> fem{"--timeout", "20", "--scheme", "predictive", "--nodes", "16"};
  auto femAt = [&](const std::string& endpoint) {
    std::vector<std::string> arguments{"--endpoint", endpoint};
    arguments.insert(arguments.end(), fem.begin(), fem.end());
    return arguments;
  };
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    setenv("RAILCOSIM_BRIDGE_RECORD", recording.c_str(), 1);
    Process femProcess(RAILCOSIM_DUMMY_FEM, femAt(endpoint));
    unsetenv("RAILCOSIM_BRIDGE_RECORD");
    Process demProcess(RAILCOSIM_DUMMY_DEM, withEndpoint(dem, endpoint));
    BOOST_TEST(demProcess.wait(30) == 0, demProcess.errors());
    BOOST_TEST(femProcess.wait(10) == 0, femProcess.errors());
  }
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    Process replay(RAILCOSIM_REPLAY,
                   {"--recording", recording, "--play", "fem", "--endpoint", endpoint, "--timeout", "20"});
    Process demProcess(RAILCOSIM_DUMMY_DEM, withEndpoint(dem, endpoint));
    BOOST_TEST(demProcess.wait(30) == 0, demProcess.errors());
    BOOST_TEST(replay.wait(10) == 0, replay.output() << replay.errors());
    BOOST_TEST(contains(replay.output(), "largest relative difference 0.000e+00"), replay.output());
  }
  {
    const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    Process femProcess(RAILCOSIM_DUMMY_FEM, femAt(endpoint));
    Process replay(RAILCOSIM_REPLAY,
                   {"--recording", recording, "--play", "dem", "--endpoint", endpoint, "--timeout", "20"});
    BOOST_TEST(replay.wait(30) == 0, replay.output() << replay.errors());
    BOOST_TEST(femProcess.wait(10) == 0, femProcess.errors());
    BOOST_TEST(contains(replay.output(), "largest relative difference 0.000e+00"), replay.output());
  }
  unsetenv("RAILCOSIM_CHECKPOINT_DIR");
  std::remove(recording.c_str());
  std::system(("rm -rf '" + folder + "'").c_str());
}

BOOST_AUTO_TEST_CASE(a_file_that_is_not_a_recording_is_refused_in_one_line) {
  const std::string path = "/tmp/" + uniqueName() + ".rec";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("hello\n", f);
    std::fclose(f);
  }
  Process replay(RAILCOSIM_REPLAY, {"--recording", path, "--play", "fem", "--endpoint", "ipc:///tmp/unused.sock"});
  BOOST_TEST(replay.wait(10) == 1);
  BOOST_TEST(contains(replay.errors(), "not a railcosim recording"), replay.errors());
  std::remove(path.c_str());
}
