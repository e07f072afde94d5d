// ZeroMQ PAIR transport with heartbeats, a disconnect monitor, send/receive deadlines and short linger.
#include "com/Channel.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"

#include <zmq.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

namespace railcosim::com {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string zmqError(const char* what, const std::string& endpoint) {
  std::ostringstream text;
  text << what << " '" << endpoint << "' failed: " << zmq_strerror(zmq_errno());
  return text.str();
}

void setIntOption(void* socket, int option, int value, const char* name) {
  if (zmq_setsockopt(socket, option, &value, sizeof(value)) != 0) {
    throw Error(std::string("bridge transport: cannot set ZeroMQ option ") + name + ": " + zmq_strerror(zmq_errno()));
  }
}

/// Buffers handed back by ZeroMQ once sent (from its I/O thread), for the next message to reuse.
struct BufferPool {
  std::mutex mutex;
  std::vector<std::vector<std::uint8_t>> buffers;
  static constexpr std::size_t kept = 4;  // enough for a message in flight each way plus slack
};

struct SentBuffer {
  std::vector<std::uint8_t> bytes;
  std::shared_ptr<BufferPool> pool;  // shared: ZeroMQ may release the message after the Channel is gone
};

void releaseSentBuffer(void* /*data*/, void* hint) {
  std::unique_ptr<SentBuffer> sent(static_cast<SentBuffer*>(hint));
  std::lock_guard<std::mutex> lock(sent->pool->mutex);
  if (sent->pool->buffers.size() < BufferPool::kept) sent->pool->buffers.push_back(std::move(sent->bytes));
}

std::atomic<unsigned long> monitorCounter{0};

/// libzmq leaves the socket file of a bound ipc endpoint behind; the binding side removes it.
void removeIpcFile(const ChannelOptions& options) {
  const std::string prefix = "ipc://";
  if (options.side != Side::Bind || options.endpoint.rfind(prefix, 0) != 0) return;
  const std::string path = options.endpoint.substr(prefix.size());
  struct stat status {};
  if (!path.empty() && path[0] != '@' && ::lstat(path.c_str(), &status) == 0 && S_ISSOCK(status.st_mode)) {
    ::unlink(path.c_str());
  }
}

} // namespace

struct Frame::Impl {
  zmq_msg_t message;
  Impl() { zmq_msg_init(&message); }
  ~Impl() { zmq_msg_close(&message); }
};

Frame::Frame() : impl_(std::make_unique<Impl>()) {}
Frame::~Frame() = default;
Frame::Frame(Frame&&) noexcept = default;
Frame& Frame::operator=(Frame&&) noexcept = default;
const std::uint8_t* Frame::data() const { return static_cast<const std::uint8_t*>(zmq_msg_data(&impl_->message)); }
std::size_t Frame::size() const { return zmq_msg_size(&impl_->message); }

struct Channel::Impl {
  ChannelOptions options;
  void* context = nullptr;
  void* socket = nullptr;
  void* monitor = nullptr;
  std::set<int> peerConnections;  // file descriptors of established transport connections
  bool seen = false;
  bool disconnected = false;
  std::shared_ptr<BufferPool> pool = std::make_shared<BufferPool>();
};

std::vector<std::uint8_t> Channel::takeBuffer() {
  std::lock_guard<std::mutex> lock(impl_->pool->mutex);
  if (impl_->pool->buffers.empty()) return {};
  std::vector<std::uint8_t> buffer = std::move(impl_->pool->buffers.back());
  impl_->pool->buffers.pop_back();
  return buffer;
}

Channel::Channel(ChannelOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  const std::string& endpoint = impl_->options.endpoint;
  impl_->context = zmq_ctx_new();
  if (impl_->context == nullptr) throw Error(zmqError("creating the ZeroMQ context for", endpoint));
  try {
    impl_->socket = zmq_socket(impl_->context, ZMQ_PAIR);
    if (impl_->socket == nullptr) throw Error(zmqError("creating the socket for", endpoint));
    // Heartbeats: a peer that stops answering (frozen, network gone) is dropped after ~3 intervals.
    const int heartbeat = std::max(1, static_cast<int>(impl_->options.heartbeatSeconds * 1000.0));
    setIntOption(impl_->socket, ZMQ_HEARTBEAT_IVL, heartbeat, "ZMQ_HEARTBEAT_IVL");
    setIntOption(impl_->socket, ZMQ_HEARTBEAT_TIMEOUT, 3 * heartbeat, "ZMQ_HEARTBEAT_TIMEOUT");
    setIntOption(impl_->socket, ZMQ_HEARTBEAT_TTL, std::min(3 * heartbeat, 6553500), "ZMQ_HEARTBEAT_TTL");
    setIntOption(impl_->socket, ZMQ_LINGER, impl_->options.lingerMilliseconds, "ZMQ_LINGER");
    // Sends never block inside ZeroMQ: the deadline loop in send() does the waiting.
    setIntOption(impl_->socket, ZMQ_SNDTIMEO, 0, "ZMQ_SNDTIMEO");

    std::ostringstream monitorName;
    monitorName << "inproc://railcosim-monitor-" << monitorCounter.fetch_add(1) << "-" << this;
    const int events = ZMQ_EVENT_CONNECTED | ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_DISCONNECTED |
                       ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                       ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL;
    if (zmq_socket_monitor(impl_->socket, monitorName.str().c_str(), events) != 0) {
      throw Error(zmqError("starting the connection monitor for", endpoint));
    }
    impl_->monitor = zmq_socket(impl_->context, ZMQ_PAIR);
    if (impl_->monitor == nullptr || zmq_connect(impl_->monitor, monitorName.str().c_str()) != 0) {
      throw Error(zmqError("connecting the connection monitor for", endpoint));
    }
    setIntOption(impl_->monitor, ZMQ_LINGER, 0, "ZMQ_LINGER");

    if (impl_->options.side == Side::Bind) {
      if (zmq_bind(impl_->socket, endpoint.c_str()) != 0) {
        const int code = zmq_errno();
        std::ostringstream text;
        text << "binding endpoint '" << endpoint << "' failed: " << zmq_strerror(code);
        if (code == EADDRINUSE) text << "; another process (an FEM participant of another run?) already uses it";
        text << "; choose a free endpoint";
        throw Error(text.str());
      }
    } else {
      if (zmq_connect(impl_->socket, endpoint.c_str()) != 0) {
        throw Error(zmqError("connecting to endpoint", endpoint) + "; check the endpoint syntax");
      }
    }
  } catch (...) {
    close();
    throw;
  }
}

Channel::~Channel() { close(); }

void Channel::close() {
  if (impl_->socket != nullptr) {
    zmq_socket_monitor(impl_->socket, nullptr, 0);
    zmq_close(impl_->socket);
    impl_->socket = nullptr;
  }
  if (impl_->monitor != nullptr) {
    zmq_close(impl_->monitor);
    impl_->monitor = nullptr;
  }
  if (impl_->context != nullptr) {
    // Returns once queued messages are flushed or the linger time passed.
    while (zmq_ctx_term(impl_->context) != 0 && zmq_errno() == EINTR) {
    }
    impl_->context = nullptr;
    removeIpcFile(impl_->options);
  }
}

const std::string& Channel::endpoint() const { return impl_->options.endpoint; }
bool Channel::peerSeen() {
  drainMonitor();
  return impl_->seen;
}

bool Channel::peerDisconnected() {
  drainMonitor();
  return impl_->disconnected;
}

void Channel::drainMonitor() {
  if (impl_->monitor == nullptr) return;
  while (true) {
    zmq_msg_t eventFrame;
    zmq_msg_init(&eventFrame);
    if (zmq_msg_recv(&eventFrame, impl_->monitor, ZMQ_DONTWAIT) < 0) {
      zmq_msg_close(&eventFrame);
      return;
    }
    std::uint16_t event = 0;
    std::uint32_t value = 0;
    if (zmq_msg_size(&eventFrame) >= 6) {
      const auto* bytes = static_cast<const std::uint8_t*>(zmq_msg_data(&eventFrame));
      std::memcpy(&event, bytes, 2);
      std::memcpy(&value, bytes + 2, 4);
    }
    // The second frame (the endpoint address) is read and dropped.
    while (zmq_msg_more(&eventFrame)) {
      zmq_msg_close(&eventFrame);
      zmq_msg_init(&eventFrame);
      if (zmq_msg_recv(&eventFrame, impl_->monitor, ZMQ_DONTWAIT) < 0) break;
    }
    zmq_msg_close(&eventFrame);
    const int connection = static_cast<int>(value);
    switch (event) {
    case ZMQ_EVENT_CONNECTED:
    case ZMQ_EVENT_ACCEPTED:
      impl_->peerConnections.insert(connection);
      break;
    case ZMQ_EVENT_HANDSHAKE_SUCCEEDED:
      impl_->seen = true;
      log(LogLevel::Debug, "bridge transport: peer connected on " + impl_->options.endpoint);
      break;
    case ZMQ_EVENT_DISCONNECTED:
      // Only a connection that completed its handshake counts as the peer; a connect attempt that
      // failed before that (peer not started yet) is retried by ZeroMQ.
      if (impl_->peerConnections.erase(connection) > 0 && impl_->seen) impl_->disconnected = true;
      log(LogLevel::Debug, "bridge transport: connection dropped on " + impl_->options.endpoint);
      break;
    case ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL:
    case ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL:
      log(LogLevel::Warning, "bridge transport: a client on " + impl_->options.endpoint +
                                 " failed the ZeroMQ handshake (not a railcosim participant?)");
      break;
    default:
      break;
    }
  }
}

Status Channel::send(std::vector<std::uint8_t>&& bytes, double timeoutSeconds, Timing& timing) {
  if (impl_->socket == nullptr) throw Error("bridge transport: send on a closed channel to " + impl_->options.endpoint);
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeoutSeconds));
  auto* owned = new SentBuffer{std::move(bytes), impl_->pool};
  zmq_msg_t message;
  if (zmq_msg_init_data(&message, owned->bytes.data(), owned->bytes.size(), releaseSentBuffer, owned) != 0) {
    delete owned;
    throw Error(zmqError("allocating a message for", impl_->options.endpoint));
  }
  while (true) {
    drainMonitor();
    if (impl_->disconnected) {
      zmq_msg_close(&message);
      timing.waitSeconds += secondsSince(start);
      return Status::PeerDisconnected;
    }
    const auto attempt = Clock::now();
    if (zmq_msg_send(&message, impl_->socket, ZMQ_DONTWAIT) >= 0) {
      timing.transferSeconds += secondsSince(attempt);
      timing.waitSeconds += std::chrono::duration<double>(attempt - start).count();
      return Status::Ok;  // ZeroMQ owns and frees the message now
    }
    if (zmq_errno() != EAGAIN && zmq_errno() != EINTR) {
      zmq_msg_close(&message);
      throw Error(zmqError("sending on", impl_->options.endpoint));
    }
    const auto now = Clock::now();
    if (now >= deadline) {
      zmq_msg_close(&message);
      timing.waitSeconds += secondsSince(start);
      return Status::Timeout;
    }
    const double slice = std::min(impl_->options.pollSliceSeconds, std::chrono::duration<double>(deadline - now).count());
    zmq_pollitem_t items[2] = {{impl_->socket, 0, ZMQ_POLLOUT, 0}, {impl_->monitor, 0, ZMQ_POLLIN, 0}};
    zmq_poll(items, 2, std::max(1L, static_cast<long>(slice * 1000.0)));
  }
}

Status Channel::receive(Frame& frame, double timeoutSeconds, Timing& timing) {
  if (impl_->socket == nullptr) {
    throw Error("bridge transport: receive on a closed channel to " + impl_->options.endpoint);
  }
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeoutSeconds));
  auto tryReceive = [&]() {
    const auto attempt = Clock::now();
    if (zmq_msg_recv(&frame.impl_->message, impl_->socket, ZMQ_DONTWAIT) < 0) {
      if (zmq_errno() == EAGAIN || zmq_errno() == EINTR) return false;
      throw Error(zmqError("receiving on", impl_->options.endpoint));
    }
    timing.transferSeconds += secondsSince(attempt);
    timing.waitSeconds += std::chrono::duration<double>(attempt - start).count();
    impl_->seen = true;  // a message proves the peer, even before the monitor event is read
    if (zmq_msg_more(&frame.impl_->message)) {
      // Drop the rest so the socket stays usable, then report: the protocol sends single-part messages.
      zmq_msg_t rest;
      zmq_msg_init(&rest);
      while (zmq_msg_more(&frame.impl_->message) && zmq_msg_recv(&rest, impl_->socket, ZMQ_DONTWAIT) >= 0 &&
             zmq_msg_more(&rest)) {
      }
      zmq_msg_close(&rest);
      throw ProtocolError("received a multi-part message on " + impl_->options.endpoint +
                          "; railcosim messages are single-part (another program on this endpoint?)");
    }
    return true;
  };
  while (true) {
    if (tryReceive()) return Status::Ok;
    drainMonitor();
    if (impl_->disconnected) {
      // Messages that arrived before the connection dropped are delivered first.
      if (tryReceive()) return Status::Ok;
      timing.waitSeconds += secondsSince(start);
      return Status::PeerDisconnected;
    }
    const auto now = Clock::now();
    if (now >= deadline) {
      timing.waitSeconds += secondsSince(start);
      return Status::Timeout;
    }
    const double slice = std::min(impl_->options.pollSliceSeconds, std::chrono::duration<double>(deadline - now).count());
    zmq_pollitem_t items[2] = {{impl_->socket, 0, ZMQ_POLLIN, 0}, {impl_->monitor, 0, ZMQ_POLLIN, 0}};
    zmq_poll(items, 2, std::max(1L, static_cast<long>(slice * 1000.0)));
  }
}

} // namespace railcosim::com
