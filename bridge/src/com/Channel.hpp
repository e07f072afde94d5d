// Transport of whole messages between the two participants over one ZeroMQ PAIR socket (the only ZeroMQ user).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace railcosim::com {

/// One received message; owns the transport buffer, so the bytes are read in place without a copy.
class Frame {
public:
  Frame();
  ~Frame();
  Frame(Frame&&) noexcept;
  Frame& operator=(Frame&&) noexcept;
  const std::uint8_t* data() const;
  std::size_t size() const;

private:
  friend class Channel;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

enum class Side { Bind, Connect };

enum class Status {
  Ok,
  Timeout,          // nothing arrived / could not be queued before the deadline
  PeerDisconnected, // the admitted peer's connection dropped (its process died)
  PeerSilent,       // the peer sent nothing, not even a keepalive, for 3 heartbeat intervals (frozen)
  Refused,          // connecting side: the binding side refused this participant (token, or already taken)
};

/// Where the time of one send or receive went (seconds).
struct Timing {
  double waitSeconds = 0.0;     // before the message was available (receive) or the socket writable (send)
  double transferSeconds = 0.0; // inside the ZeroMQ call that moves the message
};

struct ChannelOptions {
  std::string endpoint;
  Side side = Side::Bind;
  /// Keepalive interval: an empty frame goes out whenever this long passed without a message (from a
  /// background thread while the owner computes); a receive that hears nothing for 3 intervals from a
  /// connected peer returns PeerSilent. Application-level on purpose: ZeroMQ's own heartbeat timer can
  /// fire on a connection that already failed and abort the process in libzmq 4.3.4.
  double heartbeatSeconds = 1.0;
  int lingerMilliseconds = 1000; // longest close() waits to flush queued messages
  double pollSliceSeconds = 0.1; // a blocked call wakes up at least this often
  /// Run secret, sent as the ZeroMQ PLAIN password (at most 255 bytes). The binding side admits the
  /// first connection that presents it and refuses every other one before it can send a message.
  std::string token;
  std::uint64_t maxMessageBytes = 0; // larger incoming messages drop their connection; 0: no limit
};

/// A PAIR socket plus a socket monitor that reports the peer's disconnection as soon as ZeroMQ sees it.
/// Binding side: an admission handler (ZeroMQ's ZAP, RFC 27) lets exactly one connection in, the first
/// with the right user and token (over ipc also the same user id); the peer is the connection its
/// first message came from, and only that connection's loss ends a run. Stray connections (port scans,
/// random bytes, a second participant) are refused during ZeroMQ's handshake and never reach the socket.
/// tcp endpoints with a '*' host bind to 127.0.0.1; another interface must be named and needs a token.
class Channel {
public:
  /// Binds or connects. Throws Error if the endpoint cannot be bound or parsed.
  explicit Channel(ChannelOptions options);
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  /// Queues `bytes` (ownership moves to the transport, no copy). Waits at most `timeoutSeconds`.
  Status send(std::vector<std::uint8_t>&& bytes, double timeoutSeconds, Timing& timing);
  /// An empty buffer that keeps the memory of a message already sent (or a new one): encoding into
  /// it avoids fresh page faults for every large message.
  std::vector<std::uint8_t> takeBuffer();
  /// Waits at most `timeoutSeconds` for one message. Messages already delivered are returned
  /// before a disconnection is reported, so a peer's last words (Finalize, Abort) are never lost.
  Status receive(Frame& frame, double timeoutSeconds, Timing& timing);
  /// True once a transport connection to a peer was established.
  bool peerSeen();
  /// True once that connection dropped.
  bool peerDisconnected();
  /// Connections the admission handler refused so far (binding side).
  int refusedConnections();
  /// The endpoint as bound or connected (a '*' host replaced by 127.0.0.1).
  /// Closes the socket; waits at most the linger time for queued messages. Idempotent.
  void close();
  const std::string& endpoint() const;

  /// The endpoint the binding side really binds: tcp://*:P becomes tcp://127.0.0.1:P. Throws Error for a
  /// non-loopback tcp host without a token (anyone on that network could join the run).
  static std::string bindEndpoint(const std::string& endpoint, bool haveToken);

private:
  void drainMonitor();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace railcosim::com
