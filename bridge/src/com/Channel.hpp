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
  Timeout,           // nothing arrived / could not be queued before the deadline
  PeerDisconnected,  // the transport connection to the peer dropped (process died or heartbeat lost)
};

/// Where the time of one send or receive went (seconds).
struct Timing {
  double waitSeconds = 0.0;      // before the message was available (receive) or the socket writable (send)
  double transferSeconds = 0.0;  // inside the ZeroMQ call that moves the message
};

struct ChannelOptions {
  std::string endpoint;
  Side side = Side::Bind;
  double heartbeatSeconds = 1.0;
  int lingerMilliseconds = 1000;   // longest close() waits to flush queued messages
  double pollSliceSeconds = 0.1;   // a blocked call wakes up at least this often
};

/// A PAIR socket plus a socket monitor that reports the peer's disconnection as soon as ZeroMQ sees it.
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
  /// Closes the socket; waits at most the linger time for queued messages. Idempotent.
  void close();
  const std::string& endpoint() const;

private:
  void drainMonitor();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace railcosim::com
