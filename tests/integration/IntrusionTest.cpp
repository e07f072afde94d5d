// Stray and hostile connections to a running coupled pair (stand-in FEM and DEM): the run must finish intact.
#define BOOST_TEST_MODULE integration_intrusion
#include <boost/test/unit_test.hpp>

#include "ProcessHarness.hpp"

#include <sys/un.h>
#include <zmq.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace {

using railcosim::test::announcedEndpoint;
using railcosim::test::Clock;
using railcosim::test::contains;
using railcosim::test::Process;
using railcosim::test::sleepSeconds;
using railcosim::test::uniqueName;

struct Environment {
  Environment() {
    setenv("RAILCOSIM_LOG", "info", 1);  // the FEM dummy announces its bound endpoint
    setenv("RAILCOSIM_BRIDGE_TOKEN", "3f1c9a7e55d04b2a8e6f0c1d2b3a4958", 1);
  }
};
BOOST_TEST_GLOBAL_FIXTURE(Environment);

/// A raw stream socket connected to the endpoint's address (tcp or ipc), as any program could open it.
int rawConnect(const std::string& endpoint) {
  if (endpoint.rfind("ipc://", 0) == 0) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, endpoint.c_str() + 6, sizeof(address.sun_path) - 1);
    BOOST_REQUIRE(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
    return fd;
  }
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<std::uint16_t>(std::stoi(endpoint.substr(endpoint.rfind(':') + 1))));
  BOOST_REQUIRE(::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
  return fd;
}

/// Writes as much of `bytes` as the peer takes (it may hang up early); returns the bytes written.
std::size_t writeAll(int fd, const std::vector<unsigned char>& bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + written, bytes.size() - written, MSG_NOSIGNAL);
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  return written;
}

std::vector<unsigned char> randomBytes(std::size_t count, unsigned seed) {
  std::mt19937 generator(seed);
  std::vector<unsigned char> bytes(count);
  for (auto& byte : bytes) byte = static_cast<unsigned char>(generator());
  return bytes;
}

/// The opening a ZeroMQ 3.0 peer sends (signature, version, mechanism NULL), then one long frame header
/// announcing a 1 TB message.
std::vector<unsigned char> terabyteAnnouncement() {
  std::vector<unsigned char> bytes(64, 0);
  bytes[0] = 0xFF;
  bytes[9] = 0x7F;
  bytes[10] = 3;
  std::memcpy(&bytes[12], "NULL", 4);
  bytes.push_back(0x02);  // long message frame
  const std::uint64_t size = 1'000'000'000'000ULL;
  for (int shift = 56; shift >= 0; shift -= 8) bytes.push_back(static_cast<unsigned char>(size >> shift));
  return bytes;
}

/// A ZeroMQ PAIR peer that connects, sends one message and closes: the second-peer case that aborted
/// libzmq 4.3.4 (stream_engine_base.cpp:331) with heartbeats on. `password` empty: NULL mechanism.
void zeromqPeerSendsAndCloses(const std::string& endpoint, const std::string& password) {
  void* context = zmq_ctx_new();
  void* socket = zmq_socket(context, ZMQ_PAIR);
  if (!password.empty()) {
    zmq_setsockopt(socket, ZMQ_PLAIN_USERNAME, "railcosim", 9);
    zmq_setsockopt(socket, ZMQ_PLAIN_PASSWORD, password.data(), password.size());
  }
  const int linger = 200;
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof(linger));
  BOOST_REQUIRE(zmq_connect(socket, endpoint.c_str()) == 0);
  const std::vector<unsigned char> message = randomBytes(100, 7);
  zmq_send(socket, message.data(), message.size(), ZMQ_DONTWAIT);
  sleepSeconds(0.3);  // long enough for the handshake and the refusal
  zmq_close(socket);
  zmq_ctx_term(context);
}

long residentHighWaterKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

/// Runs a pair for ~4 s (700 windows, 5 ms of pretend computing each) and, meanwhile, every intrusion:
/// raw connect-and-close, random bytes, a 1 TB frame announcement, 200 MB of junk, ZeroMQ peers with no
/// or a wrong token that send one message and close, and a second DEM participant with the right token.
/// Both dummies must finish with their closed-form check passed (exit 0).
void survivesIntrusions(bool overIpc) {
  const std::string requested = overIpc ? "ipc:///tmp/" + uniqueName() + ".sock" : "tcp://127.0.0.1:*";
  Process fem(RAILCOSIM_DUMMY_FEM, {"--endpoint", requested, "--timeout", "30"});
  const std::string endpoint = announcedEndpoint(fem);
  BOOST_REQUIRE(!endpoint.empty());
  Process dem(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "30", "--windows", "700", "--compute-ms", "5"});
  fem.awaitError("coupled with DEM participant", 10.0);
  const long residentBefore = residentHighWaterKiB(fem.pid());

  const auto start = Clock::now();
  ::close(rawConnect(endpoint));
  int fd = rawConnect(endpoint);
  writeAll(fd, randomBytes(4096, 1));
  ::close(fd);
  fd = rawConnect(endpoint);
  writeAll(fd, terabyteAnnouncement());
  sleepSeconds(0.1);
  ::close(fd);
  fd = rawConnect(endpoint);
  const std::size_t junkTaken = writeAll(fd, randomBytes(200'000'000, 2));
  ::close(fd);
  zeromqPeerSendsAndCloses(endpoint, "");
  zeromqPeerSendsAndCloses(endpoint, "not-the-run-token");
  Process intruder(RAILCOSIM_DUMMY_DEM, {"--endpoint", endpoint, "--timeout", "10", "--windows", "5"});
  const int intruderExit = intruder.wait(20);
  const double attackSeconds = std::chrono::duration<double>(Clock::now() - start).count();
  BOOST_TEST_REQUIRE(dem.running(), "the intrusions ended the run; DEM stderr: " << dem.errors());
  const long residentAfter = residentHighWaterKiB(fem.pid());

  const int demExit = dem.wait(60);
  const int femExit = fem.wait(10);
  BOOST_TEST_MESSAGE("intrusions took " << attackSeconds << " s; FEM took " << junkTaken << " junk bytes; FEM peak RSS "
                     << residentBefore << " -> " << residentAfter << " KiB");
  BOOST_TEST(demExit == 0, "DEM exit " << demExit << ": " << dem.errors());
  BOOST_TEST(femExit == 0, "FEM exit " << femExit << ": " << fem.errors());
  BOOST_TEST(contains(dem.output(), "railcosim_dummy_dem: OK 700 windows"));
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
  BOOST_TEST(fem.wait(20) == 2);  // no participant joined within its 8 s
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
