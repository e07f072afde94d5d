// Stray and hostile connections to a running coupled pair (stand-in FEM and DEM): the run must finish intact.
#define BOOST_TEST_MODULE integration_intrusion
#include <boost/test/unit_test.hpp>

#include "Intrusions.hpp"
#include "ProcessHarness.hpp"

#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace {

using railcosim::test::announcedEndpoint;
using railcosim::test::Clock;
using railcosim::test::contains;
using railcosim::test::Process;
using railcosim::test::sleepSeconds;
using railcosim::test::uniqueName;
namespace intrusion = railcosim::test::intrusion;

struct Environment {
  Environment() {
    setenv("RAILCOSIM_LOG", "info", 1); // the FEM dummy announces its bound endpoint
    setenv("RAILCOSIM_BRIDGE_TOKEN", "3f1c9a7e55d04b2a8e6f0c1d2b3a4958", 1);
  }
};
BOOST_TEST_GLOBAL_FIXTURE(Environment);

long residentHighWaterKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

/// Runs a pair for at least 10 s (2000 windows, 5 ms of pretend computing each: the intrusions take 1-4 s
/// on a loaded 2-core machine, so they all happen mid-run) and, meanwhile, every intrusion:
/// raw connect-and-close, random bytes, a 1 TB frame announcement, 200 MB of junk, ZeroMQ peers with no
/// or a wrong token that send one message and close, and a second DEM participant with the right token.
/// Both dummies must finish with their closed-form check passed (exit 0).
void survivesIntrusions(bool overIpc) {
  const std::string requested = overIpc ? "ipc:///tmp/" + uniqueName() + ".sock" : "tcp://127.0.0.1:*";
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", requested, "--timeout", "30"});
  const std::string endpoint = announcedEndpoint(fem);
  BOOST_REQUIRE(!endpoint.empty());
  Process dem(RAILCOSIM_DUMMY_DEM,
              {"--endpoint", endpoint, "--timeout", "30", "--windows", "2000", "--compute-ms", "5"});
  fem.awaitError("coupled with DEM participant", 10.0);
  const long residentBefore = residentHighWaterKiB(fem.pid());

  const auto start = Clock::now();
  std::size_t junkTaken = 0;
  for (const auto& attack : intrusion::all()) {
    const std::size_t taken = attack.run(endpoint);
    if (attack.name == "junk") junkTaken = taken;
  }
  Process intruder(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "10", "--windows", "5"});
  const int intruderExit = intruder.wait(20);
  const double attackSeconds = std::chrono::duration<double>(Clock::now() - start).count();
  BOOST_TEST_REQUIRE(dem.running(), "the intrusions ended the run; DEM stderr: " << dem.errors());
  const long residentAfter = residentHighWaterKiB(fem.pid());

  const int demExit = dem.wait(90);
  const int femExit = fem.wait(10);
  BOOST_TEST_MESSAGE("intrusions took " << attackSeconds << " s; FEM took " << junkTaken << " junk bytes; FEM peak RSS "
                                        << residentBefore << " -> " << residentAfter << " KiB");
  BOOST_TEST(demExit == 0, "DEM exit " << demExit << ": " << dem.errors());
  BOOST_TEST(femExit == 0, "FEM exit " << femExit << ": " << fem.errors());
  BOOST_TEST(contains(dem.output(), "railcosim_dummy_dem: OK 2000 windows"));
  // The second participant is told plainly why it cannot join, within its own 10 s timeout.
  BOOST_TEST(intruderExit == 2);
  BOOST_TEST(contains(intruder.errors(), "refused this participant"));
  // ZeroMQ-speaking intruders are refused by the admission handler (two wrong-token/no-token peers or the
  // second participant: at least 2 lines), the others fail ZeroMQ's handshake and are dropped silently.
  BOOST_TEST(contains(fem.errors(), "refused a connection"));
  BOOST_TEST(contains(fem.errors(), "a participant already joined this run"));
  // Junk is dropped at the first bytes that are not a ZeroMQ greeting, not buffered: the FEM's peak
  // resident memory grows by far less than the 200 MB offered (20 MB leaves room for the allocator).
  BOOST_TEST(residentAfter - residentBefore < 20'000);
}

} // namespace

BOOST_AUTO_TEST_CASE(run_over_ipc_survives_intrusions) { survivesIntrusions(true); }
BOOST_AUTO_TEST_CASE(run_over_tcp_survives_intrusions) { survivesIntrusions(false); }

BOOST_AUTO_TEST_CASE(wrong_token_is_refused_with_a_clear_message) {
  const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "8"});
  announcedEndpoint(fem);
  const std::string token = std::getenv("RAILCOSIM_BRIDGE_TOKEN");
  setenv("RAILCOSIM_BRIDGE_TOKEN", "some-other-run", 1);
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "5"});
  setenv("RAILCOSIM_BRIDGE_TOKEN", token.c_str(), 1);
  const auto start = Clock::now();
  BOOST_TEST(dem.wait(30) == 2);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  // Refused at the first handshake, not after the 20 s timeout.
  BOOST_TEST(seconds < 5.0);
  BOOST_TEST(contains(dem.errors(), "run tokens differ"));
  BOOST_TEST(contains(fem.errors(), "wrong run token"));
  BOOST_TEST(fem.wait(20) == 2); // no participant joined within its 8 s
}

BOOST_AUTO_TEST_CASE(tcp_on_a_network_interface_needs_a_token) {
  const std::string token = std::getenv("RAILCOSIM_BRIDGE_TOKEN");
  unsetenv("RAILCOSIM_BRIDGE_TOKEN");
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", "tcp://0.0.0.0:*", "--timeout", "5"});
  setenv("RAILCOSIM_BRIDGE_TOKEN", token.c_str(), 1);
  BOOST_TEST(fem.wait(10) != 0);
  BOOST_TEST(contains(fem.errors(), "without a run token"));
}

BOOST_AUTO_TEST_CASE(star_host_binds_loopback_only) {
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", "tcp://*:*", "--timeout", "5"});
  const std::string endpoint = announcedEndpoint(fem);
  BOOST_TEST(contains(endpoint, "tcp://127.0.0.1:"));
}

BOOST_AUTO_TEST_CASE(ipc_participant_of_another_user_is_refused) {
  // The socket file is made writable for everybody (umask 0), so only the admission handler's user check
  // (SO_PEERCRED) stands between a process of another user and the run. Needs root to start that process.
  if (::geteuid() != 0) {
    BOOST_TEST_MESSAGE("skipped: needs root to run a participant as user nobody");
    return;
  }
  // nobody may not reach the build tree (a checkout under /root): run a copy from a world-readable folder.
  const std::string folder = "/tmp/" + uniqueName();
  BOOST_REQUIRE(::mkdir(folder.c_str(), 0755) == 0);
  const std::string dem = folder + "/railcosim_dummy_dem";
  {
    std::ifstream from(RAILCOSIM_DUMMY_DEM, std::ios::binary);
    std::ofstream to(dem, std::ios::binary);
    to << from.rdbuf();
  }
  ::chmod(dem.c_str(), 0755);
  const std::string endpoint = "ipc://" + folder + "/run.sock";
  const mode_t previous = ::umask(0);
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "8"});
  announcedEndpoint(fem);
  ::umask(previous);
  Process intruder("/usr/bin/setpriv", {"--reuid=nobody", "--regid=nogroup", "--clear-groups", dem, "--endpoint",
                                        endpoint, "--timeout", "10", "--windows", "3"});
  BOOST_TEST(intruder.wait(20) == 2);
  BOOST_TEST(contains(intruder.errors(), "refused this participant"));
  BOOST_TEST(contains(fem.errors(), "process of another user"));
  fem.wait(20);
  ::unlink(dem.c_str());
  ::rmdir(folder.c_str());
}
