// Stray and hostile connections any local program could make to a participant's endpoint (tests only).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>
#include <zmq.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace railcosim::test::intrusion {

/// A raw stream socket connected to the endpoint's address (tcp or ipc). Throws if nothing listens.
inline int rawConnect(const std::string& endpoint) {
  int fd = -1;
  int status = -1;
  if (endpoint.rfind("ipc://", 0) == 0) {
    fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, endpoint.c_str() + 6, sizeof(address.sun_path) - 1);
    status = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  } else {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons(static_cast<std::uint16_t>(std::stoi(endpoint.substr(endpoint.rfind(':') + 1))));
    status = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  }
  if (status != 0) {
    ::close(fd);
    throw std::runtime_error("cannot connect to " + endpoint + ": " + std::strerror(errno));
  }
  return fd;
}

/// Writes as much of `bytes` as the peer takes (it may hang up early); returns the bytes written.
inline std::size_t writeAll(int fd, const std::vector<unsigned char>& bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + written, bytes.size() - written, MSG_NOSIGNAL);
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  return written;
}

/// `count` bytes of noise: a random block of at most 64 KiB repeated (cheap even for 200 MB).
inline std::vector<unsigned char> randomBytes(std::size_t count, unsigned seed) {
  std::mt19937 generator(seed);
  std::vector<unsigned char> bytes(count);
  const std::size_t block = std::min<std::size_t>(count, 65536);
  for (std::size_t i = 0; i < block; ++i) bytes[i] = static_cast<unsigned char>(generator());
  for (std::size_t i = block; i < count; ++i) bytes[i] = bytes[i % block];
  return bytes;
}

/// The opening a ZeroMQ 3.0 peer sends (signature, version, mechanism NULL), then one long frame header
/// announcing a 1 TB message.
inline std::vector<unsigned char> terabyteAnnouncement() {
  std::vector<unsigned char> bytes(64, 0);
  bytes[0] = 0xFF;
  bytes[9] = 0x7F;
  bytes[10] = 3;
  std::memcpy(&bytes[12], "NULL", 4);
  bytes.push_back(0x02); // long message frame
  const std::uint64_t size = 1'000'000'000'000ULL;
  for (int shift = 56; shift >= 0; shift -= 8) bytes.push_back(static_cast<unsigned char>(size >> shift));
  return bytes;
}

/// Sends `bytes` on a fresh raw connection, waits a little, closes; returns the bytes the peer took.
inline std::size_t sendRaw(const std::string& endpoint, const std::vector<unsigned char>& bytes) {
  const int fd = rawConnect(endpoint);
  const std::size_t taken = writeAll(fd, bytes);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ::close(fd);
  return taken;
}

/// A ZeroMQ PAIR peer that connects, sends one message and closes: the second-peer case that aborted
/// libzmq 4.3.4 (stream_engine_base.cpp:331) with heartbeats on. `password` empty: NULL mechanism.
inline std::size_t zeromqPeerSendsAndCloses(const std::string& endpoint, const std::string& password) {
  void* context = zmq_ctx_new();
  void* socket = zmq_socket(context, ZMQ_PAIR);
  if (!password.empty()) {
    zmq_setsockopt(socket, ZMQ_PLAIN_USERNAME, "railcosim", 9);
    zmq_setsockopt(socket, ZMQ_PLAIN_PASSWORD, password.data(), password.size());
  }
  const int linger = 200;
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof(linger));
  if (zmq_connect(socket, endpoint.c_str()) != 0) throw std::runtime_error("zmq_connect " + endpoint + " failed");
  const std::vector<unsigned char> message = randomBytes(100, 7);
  zmq_send(socket, message.data(), message.size(), ZMQ_DONTWAIT);
  std::this_thread::sleep_for(std::chrono::milliseconds(300)); // the handshake and its refusal
  zmq_close(socket);
  zmq_ctx_term(context);
  return message.size();
}

struct Attack {
  std::string name;
  std::function<std::size_t(const std::string&)> run; // returns the bytes the target took
};

/// Every intrusion, in the order the tests make them.
inline std::vector<Attack> all() {
  return {
      {"connect-and-close", [](const std::string& e) { return sendRaw(e, {}); }},
      {"random bytes", [](const std::string& e) { return sendRaw(e, randomBytes(4096, 1)); }},
      {"1 TB frame announcement", [](const std::string& e) { return sendRaw(e, terabyteAnnouncement()); }},
      {"junk", [](const std::string& e) { return sendRaw(e, randomBytes(200'000'000, 2)); }},
      {"ZeroMQ peer without a token", [](const std::string& e) { return zeromqPeerSendsAndCloses(e, ""); }},
      {"ZeroMQ peer with a wrong token",
       [](const std::string& e) { return zeromqPeerSendsAndCloses(e, "not-the-run-token"); }},
  };
}

} // namespace railcosim::test::intrusion
