// The stand-in FEM and DEM processes over real ipc and tcp: checked results, start orders, killed and frozen peers.
#define BOOST_TEST_MODULE integration_dummies
#include <boost/test/unit_test.hpp>

#include "ProcessHarness.hpp"

#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

namespace {

using railcosim::test::contains;
using railcosim::test::Process;
using railcosim::test::sleepSeconds;
using railcosim::test::uniqueName;
using Clock = std::chrono::steady_clock;

using railcosim::test::announcedEndpoint;
using railcosim::test::ReservedPort;

/// The FEM dummy announces its bound endpoint at level info; every test reads it from there.
struct InfoLogging {
  InfoLogging() { setenv("RAILCOSIM_LOG", "info", 1); }
};
BOOST_TEST_GLOBAL_FIXTURE(InfoLogging);

enum class Transport { Ipc, Tcp };

/// Both dummies on a fresh endpoint, in the order asked. ipc: a unique socket file. tcp, FEM first: the
/// FEM binds port '*' (the kernel picks a free one) and the DEM connects to the announced endpoint;
/// tcp, DEM first: a port reserved until the FEM has bound it. No two tests can meet on one endpoint.
struct Pair {
  std::unique_ptr<Process> fem, dem;
  std::string endpoint;
};

Pair startPair(Transport transport, std::vector<std::string> femArguments, std::vector<std::string> demArguments,
               bool femFirst = true) {
  Pair pair;
  auto withEndpoint = [](std::vector<std::string> arguments, const std::string& endpoint) {
    arguments.insert(arguments.begin(), {"--endpoint", endpoint});
    return arguments;
  };
  if (transport == Transport::Ipc) {
    pair.endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
    if (femFirst) {
      pair.fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, withEndpoint(femArguments, pair.endpoint));
      sleepSeconds(0.3);
      pair.dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, withEndpoint(demArguments, pair.endpoint));
    } else {
      pair.dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, withEndpoint(demArguments, pair.endpoint));
      sleepSeconds(0.3);
      pair.fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, withEndpoint(femArguments, pair.endpoint));
    }
  } else if (femFirst) {
    pair.fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, withEndpoint(femArguments, "tcp://127.0.0.1:*"));
    pair.endpoint = announcedEndpoint(*pair.fem);
    BOOST_REQUIRE(!pair.endpoint.empty());
    pair.dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, withEndpoint(demArguments, pair.endpoint));
  } else {
    ReservedPort port;
    pair.endpoint = port.endpoint();
    pair.dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, withEndpoint(demArguments, pair.endpoint));
    sleepSeconds(0.3);
    pair.fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, withEndpoint(femArguments, pair.endpoint));
    BOOST_REQUIRE(announcedEndpoint(*pair.fem) == pair.endpoint);
  }
  return pair;
}

/// A full run: both dummies exit 0; the DEM dummy compares every window's kinematics with the
/// closed-form spring-mass response (it exits 1 if any value is off by more than 1e-9 relative).
void runPair(Transport transport, const std::string& scheme, bool femFirst, int windows) {
  Pair pair = startPair(transport, {"--timeout", "20", "--scheme", scheme, "--nodes", "400"},
                        {"--timeout", "20", "--scheme", scheme, "--windows", std::to_string(windows)}, femFirst);
  auto& fem = pair.fem;
  auto& dem = pair.dem;
  const int demExit = dem->wait(60);
  const int femExit = fem->wait(10);
  BOOST_TEST(demExit == 0, "DEM dummy exit " << demExit << ", stderr: " << dem->errors());
  BOOST_TEST(femExit == 0, "FEM dummy exit " << femExit << ", stderr: " << fem->errors());
  BOOST_TEST_MESSAGE(dem->output() << fem->output());
  BOOST_TEST(contains(dem->output(), "railcosim_dummy_dem: OK " + std::to_string(windows) + " windows"));
  BOOST_TEST(contains(fem->output(), "railcosim_dummy_fem: OK " + std::to_string(windows) + " windows"));
  // One Forces and one Kinematics per window; predictive also reads the FEM's state after the last window's
  // forces (the surface of a next window), as the YADE engine does.
  const int exchanges = 2 * windows + (scheme == "predictive" ? 1 : 0);
  BOOST_TEST(contains(dem->output(), std::to_string(exchanges) + " exchanges"));
}

} // namespace

BOOST_AUTO_TEST_CASE(ipc_just_in_time_fem_first) { runPair(Transport::Ipc, "justInTime", true, 300); }
BOOST_AUTO_TEST_CASE(ipc_just_in_time_dem_first) { runPair(Transport::Ipc, "justInTime", false, 300); }
BOOST_AUTO_TEST_CASE(tcp_just_in_time_fem_first) { runPair(Transport::Tcp, "justInTime", true, 300); }
BOOST_AUTO_TEST_CASE(tcp_just_in_time_dem_first) { runPair(Transport::Tcp, "justInTime", false, 300); }
BOOST_AUTO_TEST_CASE(ipc_predictive_dem_first) { runPair(Transport::Ipc, "predictive", false, 300); }
BOOST_AUTO_TEST_CASE(tcp_predictive_fem_first) { runPair(Transport::Tcp, "predictive", true, 300); }

/// Implicit scheme with the particles acting as a stiff spring bed on the surface: the DEM dummy
/// compares every accepted window with the monolithic solution of the same coupled system (it exits 1
/// beyond 100 x the convergence tolerance). Returns the DEM dummy's summary line.
std::string runImplicit(const std::string& contactStiffness, const std::vector<std::string>& iterationOptions,
                        int expectedExit) {
  const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
  Process fem(RAILCOSIM_DUMMY_FEM,
              {"--endpoint", endpoint, "--timeout", "20", "--scheme", "implicit", "--nodes", "16"});
  std::vector<std::string> demArguments{
      "--endpoint",          endpoint,        "--timeout", "20", "--scheme", "implicit", "--windows", "500",
      "--contact-stiffness", contactStiffness};
  demArguments.insert(demArguments.end(), iterationOptions.begin(), iterationOptions.end());
  Process dem(RAILCOSIM_DUMMY_DEM, demArguments);
  BOOST_TEST(dem.wait(60) == expectedExit);
  BOOST_TEST(fem.wait(10) == 0);
  BOOST_TEST_MESSAGE(dem.output() << dem.errors() << fem.output());
  return dem.output() + dem.errors();
}

BOOST_AUTO_TEST_CASE(implicit_matches_the_monolithic_solution) {
  // Spring bed 5e9 N/m per node against 1e6 N/m and 1 kg per node, window 1e-4 s: one fixed-point pass
  // amplifies the interface error by C KC = 5e9 (1 - cos(1e-4 w)) / 1e6 = 25 (w = 1000 rad/s), so only a
  // relaxed iteration can converge. Aitken reaches 1e-10 in about 3 passes per window.
  const std::string out = runImplicit("5e9", {}, 0);
  BOOST_TEST(contains(out, "railcosim_dummy_dem: OK 500 windows"));
  BOOST_TEST(contains(out, "0 not converged"));
  // A soft bed (C KC = 0.025) needs fewer passes than the stiff one.
  const std::string soft = runImplicit("5e6", {}, 0);
  BOOST_TEST(contains(soft, "railcosim_dummy_dem: OK 500 windows"));
}

BOOST_AUTO_TEST_CASE(implicit_without_relaxation_diverges_on_a_stiff_bed_and_says_so) {
  // ω = 1 without Aitken: the error grows 25x per pass; the DEM side stops at window 0 and reports it.
  const std::string out = runImplicit("5e9", {"--no-aitken", "--relaxation", "1", "--max-iterations", "20"}, 1);
  BOOST_TEST(contains(out, "window 0 did not converge within 20 passes"));
  // The exact constant relaxation ω = 1/(1 + C KC) = 1/26 converges without Aitken.
  const std::string exact = runImplicit("5e9", {"--no-aitken", "--relaxation", "0.0384615384615"}, 0);
  BOOST_TEST(contains(exact, "railcosim_dummy_dem: OK 500 windows"));
}

/// Kills one side with SIGKILL mid-run; the survivor must exit 2 with a clear message in < 10 s.
void killMidRun(Transport transport, bool killDem) {
  Pair pair = startPair(transport, {"--timeout", "60", "--compute-ms", "2"},
                        {"--timeout", "60", "--windows", "1000000", "--compute-ms", "2"});
  Process& fem = *pair.fem;
  Process& dem = *pair.dem;
  const std::string endpoint = pair.endpoint;
  sleepSeconds(1.0);
  BOOST_REQUIRE(fem.running() && dem.running());
  Process& victim = killDem ? dem : fem;
  Process& survivor = killDem ? fem : dem;
  const auto killed = Clock::now();
  victim.signal(SIGKILL);
  const int code = survivor.wait(15);
  const double seconds = std::chrono::duration<double>(Clock::now() - killed).count();
  BOOST_TEST_MESSAGE("survivor reported the loss after " << seconds << " s: " << survivor.errors());
  BOOST_TEST(code == 2);
  BOOST_TEST(seconds < 10.0); // required bound; a killed process closes its sockets, so ~immediate
  const std::string message = survivor.errors();
  BOOST_TEST(contains(message, killDem ? "peer 'dem' disconnected" : "peer 'fem' disconnected"));
  BOOST_TEST(contains(message, endpoint));
  BOOST_TEST(contains(message, killDem ? "DEM process probably died" : "FEM process probably died"));
  BOOST_TEST(contains(message, "window"));
}

BOOST_AUTO_TEST_CASE(killed_dem_is_reported_by_the_fem_over_ipc) { killMidRun(Transport::Ipc, true); }
BOOST_AUTO_TEST_CASE(killed_fem_is_reported_by_the_dem_over_tcp) { killMidRun(Transport::Tcp, false); }

BOOST_AUTO_TEST_CASE(frozen_fem_is_detected_by_keepalive) {
  // SIGSTOP keeps the sockets open, so only the keepalive can tell: 0.3 s interval, silent after 0.9 s.
  Pair pair = startPair(Transport::Tcp, {"--timeout", "60", "--heartbeat", "0.3"},
                        {"--timeout", "60", "--heartbeat", "0.3", "--windows", "1000000", "--compute-ms", "2"});
  Process& fem = *pair.fem;
  Process& dem = *pair.dem;
  sleepSeconds(1.0);
  const auto stopped = Clock::now();
  fem.signal(SIGSTOP);
  const int code = dem.wait(15);
  const double seconds = std::chrono::duration<double>(Clock::now() - stopped).count();
  fem.signal(SIGKILL);
  BOOST_TEST_MESSAGE("frozen peer reported after " << seconds << " s: " << dem.errors());
  BOOST_TEST(code == 2);
  BOOST_TEST(seconds < 10.0);
  BOOST_TEST(contains(dem.errors(), "process is frozen"));
}

BOOST_AUTO_TEST_CASE(fem_ending_early_stops_the_dem_with_a_clear_message) {
  const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "20"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "100"});
  BOOST_TEST(fem.wait(30) == 0);
  BOOST_TEST(dem.wait(30) == 2);
  BOOST_TEST(contains(dem.errors(), "finalized the run"));
  BOOST_TEST(contains(dem.errors(), "kinematics of window 20"));
}

BOOST_AUTO_TEST_CASE(missing_fem_times_out_with_advice) {
  const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
  const auto start = Clock::now();
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "1.5"});
  BOOST_TEST(dem.wait(20) == 2);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  BOOST_TEST(seconds < 6.0); // 1.5 s timeout + process start; bounded well below the 60 s default
  BOOST_TEST(contains(dem.errors(), "within 1.5 s"));
  BOOST_TEST(contains(dem.errors(), "no FEM participant ever connected"));
  BOOST_TEST(contains(dem.errors(), "raise timeoutSeconds"));
}

BOOST_AUTO_TEST_CASE(mismatched_schemes_are_refused_at_the_handshake) {
  const std::string endpoint = "ipc:///tmp/" + uniqueName() + ".sock";
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--scheme", "predictive"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "50"});
  BOOST_TEST(fem.wait(30) == 3); // protocol error
  BOOST_TEST(dem.wait(30) != 0); // told by the FEM's Abort (exit 2), or saw the same mismatch itself
  BOOST_TEST(contains(fem.errors(), "same couplingScheme"));
  BOOST_TEST(contains(dem.errors(), "same couplingScheme"));
}
