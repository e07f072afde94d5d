// The libzmq 4.3.4 abort at close (exit 134 of a stand-in participant): reproduced by a raw ZeroMQ peer.
//
// A channel that closes (its pipe terminating, a large message still unsent) while its peer sends one
// more message and then hangs up: the incoming message cannot be queued, so libzmq stops reading that
// connection; the hang-up (EPOLLHUP) then marks it failed, and with ZeroMQ heartbeats on, the next
// heartbeat timer calls out_event() on it and hits `zmq_assert (!_io_error)` (stream_engine_base.cpp:331):
// SIGABRT. This is the predictive run's end (the FEM is a window ahead) that killed a dummy DEM once
// (exit 134 = SIGABRT). With ZeroMQ heartbeats on (railcosim before protocol version 3) this test ends in
// that assertion every time; the channel must close normally.
#define BOOST_TEST_MODULE integration_shutdown_race
#include <boost/test/unit_test.hpp>

#include "com/Channel.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

using railcosim::com::Channel;
using railcosim::com::ChannelOptions;
using railcosim::com::Side;

void readExactly(int fd, unsigned char* data, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::recv(fd, data + done, size - done, 0);
    BOOST_REQUIRE_MESSAGE(n > 0, "the channel closed the connection during the handshake");
    done += static_cast<std::size_t>(n);
  }
}

void writeAll(int fd, const std::string& bytes) {
  BOOST_REQUIRE(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size()));
}

/// Reads one ZMTP 3 command frame (flags 0x04 short or 0x06 long) and returns its name.
std::string readCommand(int fd) {
  unsigned char flags = 0;
  readExactly(fd, &flags, 1);
  std::uint64_t size = 0;
  if (flags == 0x06) {
    unsigned char bytes[8];
    readExactly(fd, bytes, 8);
    for (unsigned char byte : bytes) size = size << 8 | byte;
  } else {
    unsigned char byte = 0;
    readExactly(fd, &byte, 1);
    size = byte;
  }
  std::vector<unsigned char> body(size);
  readExactly(fd, body.data(), body.size());
  return std::string(body.begin() + 1, body.begin() + 1 + body[0]);
}

std::string shortCommand(const std::string& body) { return std::string{'\x04', static_cast<char>(body.size())} + body; }

/// READY with Socket-Type PAIR (ZMTP 3, RFC 23): name, then property name and 4-byte big-endian value size.
std::string ready() {
  return shortCommand(std::string("\x05READY\x0bSocket-Type\x00\x00\x00\x04PAIR", 6 + 12 + 4 + 4));
}

/// Server half of a ZMTP 3.0 handshake with the channel (mechanism NULL or PLAIN, whichever it asks for).
/// libzmq sends its greeting in steps: the 10-byte signature, the major version once it has ours, the
/// rest once it has our major version.
void handshake(int fd) {
  unsigned char signature[10];
  readExactly(fd, signature, 10);
  std::string greeting(64, '\0');
  greeting[0] = '\xff';
  greeting[9] = '\x7f';
  greeting[10] = 3; // major version
  writeAll(fd, greeting.substr(0, 11));
  unsigned char rest[54];
  readExactly(fd, rest, 54); // major, minor, mechanism[20], as-server, filler[31]
  const std::string mechanism(reinterpret_cast<char*>(rest + 2), strnlen(reinterpret_cast<char*>(rest + 2), 20));
  std::memcpy(&greeting[12], mechanism.data(), mechanism.size());
  greeting[32] = 1; // as-server
  writeAll(fd, greeting.substr(11));
  if (mechanism == "PLAIN") {
    BOOST_REQUIRE(readCommand(fd) == "HELLO");
    writeAll(fd, shortCommand("\x07WELCOME"));
    BOOST_REQUIRE(readCommand(fd) == "INITIATE");
  } else {
    BOOST_REQUIRE(readCommand(fd) == "READY");
  }
  writeAll(fd, ready());
}

} // namespace

BOOST_AUTO_TEST_CASE(closing_while_the_peer_sends_and_hangs_up_does_not_abort) {
  const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  BOOST_REQUIRE(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
  socklen_t length = sizeof(address);
  getsockname(listener, reinterpret_cast<sockaddr*>(&address), &length);
  BOOST_REQUIRE(::listen(listener, 1) == 0);
  const std::string endpoint = "tcp://127.0.0.1:" + std::to_string(ntohs(address.sin_port));

  int closing[2];
  BOOST_REQUIRE(::pipe(closing) == 0);
  const pid_t child = ::fork();
  if (child == 0) {
    std::signal(SIGABRT, SIG_DFL); // report libzmq's abort as such, not through Boost.Test's handler
    // The participant's side: connect, send a message far larger than the socket buffers (the peer
    // never reads it, so it stays unsent) and one more behind it (so close() lingers), then close.
    ChannelOptions options;
    options.endpoint = endpoint;
    options.side = Side::Connect;
    // A ZeroMQ heartbeat timer, if any, first fires 1 s after the handshake: after the hang-up below
    // (0.4 s) and inside the linger (1.5 s); its PING timeout (3 s) never comes into play.
    options.heartbeatSeconds = 1.0;
    options.lingerMilliseconds = 1500;
    Channel channel(options);
    railcosim::com::Timing timing;
    for (int i = 0; i < 200 && !channel.peerSeen(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    channel.send(std::vector<std::uint8_t>(64 << 20, 1), 5.0, timing);
    channel.send(std::vector<std::uint8_t>(100, 2), 5.0, timing); // still queued at close: close lingers
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    (void)::write(closing[1], "c", 1);
    channel.close();
    ::_exit(0);
  }
  const int fd = ::accept(listener, nullptr, nullptr);
  handshake(fd);
  char signal = 0;
  BOOST_REQUIRE(::read(closing[0], &signal, 1) == 1);
  std::this_thread::sleep_for(std::chrono::milliseconds(100)); // the channel is inside close() now
  writeAll(fd, std::string("\x00\x01"
                           "A",
                           3)); // one more message (a window ahead)
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ::close(fd); // unread data pending: the kernel resets the connection (EPOLLHUP on the channel's side)
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  int status = 0;
  BOOST_REQUIRE(::waitpid(child, &status, 0) == child);
  ::close(listener);
  BOOST_TEST_MESSAGE("channel process: " << (WIFSIGNALED(status)
                                                 ? "killed by signal " + std::to_string(WTERMSIG(status))
                                                 : "exit " + std::to_string(WEXITSTATUS(status))));
  BOOST_TEST(WIFEXITED(status));
  BOOST_TEST(WEXITSTATUS(status) == 0);
}
