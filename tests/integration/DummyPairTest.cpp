// The stand-in FEM and DEM processes over real ipc and tcp: checked results, start orders, killed and frozen peers.
#define BOOST_TEST_MODULE integration_dummies
#include <boost/test/unit_test.hpp>

#include <arpa/inet.h>
#include <csignal>
#include <fcntl.h>
#include <memory>
#include <fstream>
#include <netinet/in.h>
#include <spawn.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <vector>

extern char** environ;

namespace {

using Clock = std::chrono::steady_clock;

std::string uniqueName() {
  static std::atomic<int> counter{0};
  return "railcosim-it-" + std::to_string(getpid()) + "-" + std::to_string(counter++);
}

std::string ipcEndpoint() { return "ipc:///tmp/" + uniqueName() + ".sock"; }

/// A free loopback port: bind port 0, read it back, release it (another test could race for it,
/// but each ctest process asks the kernel, which hands out ports round-robin).
std::string tcpEndpoint() {
  const int probe = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  BOOST_REQUIRE(bind(probe, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
  socklen_t length = sizeof(address);
  getsockname(probe, reinterpret_cast<sockaddr*>(&address), &length);
  close(probe);
  return "tcp://127.0.0.1:" + std::to_string(ntohs(address.sin_port));
}

/// A dummy process with stdout and stderr captured in files.
class Process {
public:
  Process(const std::string& program, std::vector<std::string> arguments) {
    const std::string base = "/tmp/" + uniqueName();
    outPath_ = base + ".out";
    errPath_ = base + ".err";
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, outPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, errPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    arguments.insert(arguments.begin(), program);
    std::vector<char*> argv;
    for (auto& argument : arguments) argv.push_back(argument.data());
    argv.push_back(nullptr);
    const int status = posix_spawn(&pid_, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    BOOST_REQUIRE_MESSAGE(status == 0, "cannot start " << program);
  }
  ~Process() {
    if (running()) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    unlink(outPath_.c_str());
    unlink(errPath_.c_str());
  }
  bool running() const { return !finished_; }
  void signal(int number) { kill(pid_, number); }
  /// Waits at most `seconds`; returns the exit code, or -1 if still running (then fails the test).
  int wait(double seconds) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
    while (!finished_) {
      int status = 0;
      const pid_t done = waitpid(pid_, &status, WNOHANG);
      if (done == pid_) {
        finished_ = true;
        exitCode_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      if (Clock::now() > deadline) {
        BOOST_ERROR("process did not end within " << seconds << " s; stderr: " << errors());
        return -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return exitCode_;
  }
  std::string output() const { return read(outPath_); }
  std::string errors() const { return read(errPath_); }

private:
  static std::string read(const std::string& path) {
    std::ifstream file(path);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
  }
  pid_t pid_ = 0;
  bool finished_ = false;
  int exitCode_ = -1;
  std::string outPath_, errPath_;
};

bool contains(const std::string& text, const std::string& fragment) {
  const bool found = text.find(fragment) != std::string::npos;
  if (!found) BOOST_TEST_MESSAGE("'" << fragment << "' not in: " << text);
  return found;
}

void sleepSeconds(double seconds) { std::this_thread::sleep_for(std::chrono::duration<double>(seconds)); }

/// A full run: both dummies exit 0; the DEM dummy compares every window's kinematics with the
/// closed-form spring-mass response (it exits 1 if any value is off by more than 1e-9 relative).
void runPair(const std::string& endpoint, const std::string& scheme, bool femFirst, int windows) {
  const std::vector<std::string> femArguments{"--endpoint", endpoint, "--timeout", "20", "--scheme", scheme,
                                              "--nodes", "400"};
  const std::vector<std::string> demArguments{"--endpoint", endpoint, "--timeout", "20", "--scheme", scheme,
                                              "--windows", std::to_string(windows)};
  std::unique_ptr<Process> fem, dem;
  if (femFirst) {
    fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, femArguments);
    sleepSeconds(0.3);
    dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, demArguments);
  } else {
    dem = std::make_unique<Process>(RAILCOSIM_DUMMY_DEM, demArguments);
    sleepSeconds(0.3);
    fem = std::make_unique<Process>(RAILCOSIM_DUMMY_FEM, femArguments);
  }
  const int demExit = dem->wait(60);
  const int femExit = fem->wait(10);
  BOOST_TEST(demExit == 0, "DEM dummy exit " << demExit << ", stderr: " << dem->errors());
  BOOST_TEST(femExit == 0, "FEM dummy exit " << femExit << ", stderr: " << fem->errors());
  BOOST_TEST_MESSAGE(dem->output() << fem->output());
  BOOST_TEST(contains(dem->output(), "railcosim_dummy_dem: OK " + std::to_string(windows) + " windows"));
  BOOST_TEST(contains(fem->output(), "railcosim_dummy_fem: OK " + std::to_string(windows) + " windows"));
  BOOST_TEST(contains(dem->output(), std::to_string(2 * windows) + " exchanges"));
}

} // namespace

BOOST_AUTO_TEST_CASE(ipc_just_in_time_fem_first) { runPair(ipcEndpoint(), "justInTime", true, 300); }
BOOST_AUTO_TEST_CASE(ipc_just_in_time_dem_first) { runPair(ipcEndpoint(), "justInTime", false, 300); }
BOOST_AUTO_TEST_CASE(tcp_just_in_time_fem_first) { runPair(tcpEndpoint(), "justInTime", true, 300); }
BOOST_AUTO_TEST_CASE(tcp_just_in_time_dem_first) { runPair(tcpEndpoint(), "justInTime", false, 300); }
BOOST_AUTO_TEST_CASE(ipc_predictive_dem_first) { runPair(ipcEndpoint(), "predictive", false, 300); }
BOOST_AUTO_TEST_CASE(tcp_predictive_fem_first) { runPair(tcpEndpoint(), "predictive", true, 300); }

/// Implicit scheme with the particles acting as a stiff spring bed on the surface: the DEM dummy
/// compares every accepted window with the monolithic solution of the same coupled system (it exits 1
/// beyond 100 x the convergence tolerance). Returns the DEM dummy's summary line.
std::string runImplicit(const std::string& contactStiffness, const std::vector<std::string>& iterationOptions, int expectedExit) {
  const std::string endpoint = ipcEndpoint();
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--scheme", "implicit", "--nodes", "16"});
  std::vector<std::string> demArguments{"--endpoint", endpoint, "--timeout", "20", "--scheme", "implicit", "--windows", "500",
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
void killMidRun(const std::string& endpoint, bool killDem) {
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "60", "--compute-ms", "2"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "60", "--windows", "1000000",
                                    "--compute-ms", "2"});
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
  BOOST_TEST(seconds < 10.0);  // required bound; a killed process closes its sockets, so ~immediate
  const std::string message = survivor.errors();
  BOOST_TEST(contains(message, killDem ? "peer 'dem' disconnected" : "peer 'fem' disconnected"));
  BOOST_TEST(contains(message, endpoint));
  BOOST_TEST(contains(message, killDem ? "DEM process probably died" : "FEM process probably died"));
  BOOST_TEST(contains(message, "window"));
}

BOOST_AUTO_TEST_CASE(killed_dem_is_reported_by_the_fem_over_ipc) { killMidRun(ipcEndpoint(), true); }
BOOST_AUTO_TEST_CASE(killed_fem_is_reported_by_the_dem_over_tcp) { killMidRun(tcpEndpoint(), false); }

BOOST_AUTO_TEST_CASE(frozen_fem_is_detected_by_keepalive) {
  // SIGSTOP keeps the sockets open, so only the keepalive can tell: 0.3 s interval, silent after 0.9 s.
  const std::string endpoint = tcpEndpoint();
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "60", "--heartbeat", "0.3"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "60", "--heartbeat", "0.3", "--windows",
                                    "1000000", "--compute-ms", "2"});
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
  const std::string endpoint = ipcEndpoint();
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "20"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "100"});
  BOOST_TEST(fem.wait(30) == 0);
  BOOST_TEST(dem.wait(30) == 2);
  BOOST_TEST(contains(dem.errors(), "finalized the run"));
  BOOST_TEST(contains(dem.errors(), "kinematics of window 20"));
}

BOOST_AUTO_TEST_CASE(missing_fem_times_out_with_advice) {
  const std::string endpoint = ipcEndpoint();
  const auto start = Clock::now();
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "1.5"});
  BOOST_TEST(dem.wait(20) == 2);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  BOOST_TEST(seconds < 6.0);  // 1.5 s timeout + process start; bounded well below the 60 s default
  BOOST_TEST(contains(dem.errors(), "within 1.5 s"));
  BOOST_TEST(contains(dem.errors(), "no FEM participant ever connected"));
  BOOST_TEST(contains(dem.errors(), "raise timeoutSeconds"));
}

BOOST_AUTO_TEST_CASE(mismatched_schemes_are_refused_at_the_handshake) {
  const std::string endpoint = ipcEndpoint();
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", endpoint, "--timeout", "20", "--scheme", "predictive"});
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "20", "--windows", "50"});
  BOOST_TEST(fem.wait(30) == 3);  // protocol error
  BOOST_TEST(dem.wait(30) != 0);  // told by the FEM's Abort (exit 2), or saw the same mismatch itself
  BOOST_TEST(contains(fem.errors(), "same couplingScheme"));
  BOOST_TEST(contains(dem.errors(), "same couplingScheme"));
}
