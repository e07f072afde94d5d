// ZeroMQ PAIR transport with admission control, heartbeats, a disconnect monitor, deadlines and short linger.
#include "com/Channel.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"

#include <zmq.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <thread>
#include <unistd.h>

namespace railcosim::com {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

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
  static constexpr std::size_t kept = 4; // enough for a message in flight each way plus slack
};

struct SentBuffer {
  std::vector<std::uint8_t> bytes;
  std::shared_ptr<BufferPool> pool; // shared: ZeroMQ may release the message after the Channel is gone
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

/// The PLAIN user name every railcosim participant presents; the token is the password.
constexpr const char* participantUser = "railcosim";

/// PLAIN refuses an empty password, so a run without a token presents this fixed one (and the binding
/// side expects it): without a token the admission still lets only one railcosim participant in.
std::string plainPassword(const std::string& token) { return token.empty() ? "no-token" : token; }

bool sameSecret(const std::string& presented, const std::string& expected) {
  // Compares every byte whatever the first difference, so the time taken does not reveal a prefix.
  unsigned char difference = presented.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < presented.size(); ++i) {
    difference |= static_cast<unsigned char>(presented[i] ^ (i < expected.size() ? expected[i] : 0));
  }
  return difference == 0;
}

/// The user id of an ipc peer from ZeroMQ's peer address, which ends in ":uid:gid:pid" on Linux
/// (SO_PEERCRED, e.g. "localhost:1000:1000:4242"); -1 if the address has no such ending.
long ipcPeerUser(const std::string& address) {
  const std::size_t pidColon = address.rfind(':');
  if (pidColon == std::string::npos || pidColon == 0) return -1;
  const std::size_t gidColon = address.rfind(':', pidColon - 1);
  if (gidColon == std::string::npos || gidColon == 0) return -1;
  const std::size_t uidColon = address.rfind(':', gidColon - 1);
  if (uidColon == std::string::npos) return -1;
  try {
    std::size_t used = 0;
    const std::string field = address.substr(uidColon + 1, gidColon - uidColon - 1);
    const long uid = std::stol(field, &used);
    return used == field.size() ? uid : -1;
  } catch (const std::exception&) {
    return -1;
  }
}

std::vector<std::string> receiveParts(void* socket) {
  std::vector<std::string> parts;
  int more = 1;
  while (more) {
    zmq_msg_t part;
    zmq_msg_init(&part);
    if (zmq_msg_recv(&part, socket, 0) < 0) {
      zmq_msg_close(&part);
      break;
    }
    parts.emplace_back(static_cast<const char*>(zmq_msg_data(&part)), zmq_msg_size(&part));
    more = zmq_msg_more(&part);
    zmq_msg_close(&part);
  }
  return parts;
}

} // namespace

/// ZAP handler of the binding side (RFC 27, run by ZeroMQ during each connection's handshake): admits the
/// first connection presenting the participant user and the run token, refuses every other one. A
/// refused connection never becomes a pipe of the PAIR socket, so it can neither send a message nor
/// reach libzmq 4.3.4's heartbeat assertion on a second PAIR peer (stream_engine_base.cpp:331).
class AdmissionHandler {
public:
  AdmissionHandler(void* context, const std::string& token, std::string endpoint)
      : password_(plainPassword(token)), endpoint_(std::move(endpoint)), ipc_(endpoint_.rfind("ipc://", 0) == 0) {
    socket_ = zmq_socket(context, ZMQ_REP);
    if (socket_ == nullptr) throw Error(zmqError("creating the admission handler for", endpoint_));
    const int linger = 0;
    zmq_setsockopt(socket_, ZMQ_LINGER, &linger, sizeof(linger));
    if (zmq_bind(socket_, "inproc://zeromq.zap.01") != 0) {
      const std::string message = zmqError("binding the admission handler for", endpoint_);
      zmq_close(socket_);
      throw Error(message);
    }
    try {
      thread_ = std::thread([this] { serve(); });
    } catch (...) {
      zmq_close(socket_); // an open socket would keep zmq_ctx_term() waiting forever
      throw;
    }
  }
  ~AdmissionHandler() { stop(); }
  AdmissionHandler(const AdmissionHandler&) = delete;
  AdmissionHandler& operator=(const AdmissionHandler&) = delete;

  void stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    if (socket_ != nullptr) {
      zmq_close(socket_);
      socket_ = nullptr;
    }
  }
  int refused() const { return refused_.load(); }

private:
  /// The log sink runs on this thread: whatever it throws must not end the process (std::terminate).
  static void report(LogLevel level, const std::string& text) {
    try {
      log(level, text);
    } catch (...) {
    }
  }

  void serve() {
    while (!stopping_) {
      zmq_pollitem_t item{socket_, 0, ZMQ_POLLIN, 0};
      if (zmq_poll(&item, 1, 50) <= 0 || !(item.revents & ZMQ_POLLIN)) continue;
      const std::vector<std::string> request = receiveParts(socket_);
      // version, request id, domain, address, routing id, mechanism, credentials (PLAIN: user, password)
      // A REP socket must answer every request, or it never reads the next one: malformed ones get 400.
      const std::string requestId = request.size() > 1 ? request[1] : "";
      const std::string address = request.size() > 3 ? request[3] : "";
      std::string reason;
      if (request.size() != 8 || request[0] != "1.0" || request[5] != "PLAIN" || request[6] != participantUser) {
        reason = "not a railcosim participant";
      } else if (!sameSecret(request[7], password_)) {
        reason = "wrong run token";
      } else if (ipc_ && ipcPeerUser(address) != static_cast<long>(::geteuid())) {
        // A process of another user that can reach the socket file (permissive directory) is refused.
        reason = "process of another user (" + address + ")";
      } else if (admitted_) {
        reason = "a participant already joined this run";
      }
      report(LogLevel::Debug, "bridge transport: admission request on " + endpoint_ + " from '" + address + "'");
      const bool admit = reason.empty();
      if (admit) {
        admitted_ = true;
      } else {
        // A refused ZeroMQ peer retries every 100 ms: the first refusals are logged, then one in a thousand.
        const int count = ++refused_;
        if (count <= 10 || count % 1000 == 0) {
          report(LogLevel::Warning, "bridge transport: refused a connection on " + endpoint_ + " (" + reason + ")" +
                                        (count >= 10 ? "; " + std::to_string(count) + " refused so far" : ""));
        }
      }
      const std::string reply[6] = {"1.0", requestId, admit ? "200" : "400", admit ? "OK" : reason, "", ""};
      for (int i = 0; i < 6; ++i) zmq_send(socket_, reply[i].data(), reply[i].size(), i < 5 ? ZMQ_SNDMORE : 0);
    }
  }

  std::string password_;
  std::string endpoint_;
  bool ipc_ = false;
  void* socket_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> refused_{0};
  bool admitted_ = false; // touched by the handler thread only
};

std::string Channel::bindEndpoint(const std::string& endpoint, bool haveToken) {
  const std::string prefix = "tcp://";
  if (endpoint.rfind(prefix, 0) != 0) return endpoint;
  const std::size_t colon = endpoint.rfind(':');
  const std::string host = colon > prefix.size() ? endpoint.substr(prefix.size(), colon - prefix.size()) : "";
  if (host == "*" || host.empty()) return prefix + "127.0.0.1" + endpoint.substr(colon);
  const bool loopback =
      host == "localhost" || host == "[::1]" || host == "::1" || host.rfind("127.", 0) == 0 || host == "lo";
  if (!loopback && !haveToken) {
    throw Error("binding '" + endpoint +
                "' would accept participants from the network without a run token; "
                "set RAILCOSIM_BRIDGE_TOKEN (the same secret on both sides) or bind tcp://127.0.0.1:PORT");
  }
  return endpoint;
}

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
  std::unique_ptr<AdmissionHandler> admission; // binding side only
  std::set<int> openConnections;               // file descriptors of transport connections not yet dropped
  int peerConnection = -1;                     // binding side: the connection the peer's first message came from
  bool seen = false;
  bool disconnected = false;
  bool refused = false; // connecting side: the binding side refused our credentials
  // One thread at a time uses the socket: the owner for a whole send/receive call, the keepalive thread
  // only in between (try_lock), so ZeroMQ's single-thread rule holds and the owner never waits for it.
  std::mutex socketMutex;
  Clock::time_point lastSent = Clock::now();  // guarded by socketMutex
  Clock::time_point lastHeard = Clock::now(); // guarded by socketMutex (the owner's calls, drainMonitor)
  std::thread keepalive;
  std::mutex keepaliveMutex;
  std::condition_variable keepaliveWake;
  bool keepaliveStop = false; // guarded by keepaliveMutex

  void drainMonitor();
  /// tcp: whether the peer's connection received bytes within `window` (a large message still arriving
  /// holds its keepalives back in the same stream); false for ipc or an unknown connection.
  bool bytesArrivedWithin(Clock::duration window) const;

  Clock::duration interval() const {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.heartbeatSeconds));
  }
  /// An empty frame (no protocol message is empty) when an interval passed without sending anything.
  void sendKeepaliveIfDue() {
    const auto now = Clock::now();
    if (now - lastSent < interval()) return;
    zmq_send(socket, nullptr, 0, ZMQ_DONTWAIT); // best effort: a full queue already keeps the peer informed
    lastSent = now;
  }
  void runKeepalive() {
    std::unique_lock<std::mutex> wait(keepaliveMutex);
    while (!keepaliveWake.wait_for(wait, interval() / 4, [this] { return keepaliveStop; })) {
      std::unique_lock<std::mutex> use(socketMutex, std::try_to_lock);
      if (!use.owns_lock() || socket == nullptr) continue;
      sendKeepaliveIfDue();
      // Also while the owner computes: libzmq's I/O thread blocks on a full monitor queue (stray
      // connections make three events each), and close() would wait for it forever.
      drainMonitor();
    }
  }
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
    // No ZMQ_HEARTBEAT_*: in libzmq 4.3.4 the heartbeat timer calls out_event() on a connection whose
    // input already failed (a peer that sent while this socket closed, then hung up) and aborts the
    // process (stream_engine_base.cpp:331). The keepalive below does the same job without that path.
    setIntOption(impl_->socket, ZMQ_LINGER, impl_->options.lingerMilliseconds, "ZMQ_LINGER");
    if (impl_->options.token.size() > 255) {
      throw Error("bridge transport: the run token has " + std::to_string(impl_->options.token.size()) +
                  " bytes; at most 255 are allowed (ZeroMQ PLAIN password)");
    }
    if (impl_->options.maxMessageBytes > 0) {
      const std::int64_t limit = static_cast<std::int64_t>(impl_->options.maxMessageBytes);
      if (zmq_setsockopt(impl_->socket, ZMQ_MAXMSGSIZE, &limit, sizeof(limit)) != 0) {
        throw Error(zmqError("limiting the message size on", endpoint));
      }
    }
    // Every connection authenticates (PLAIN, user railcosim, the run token as password): the binding
    // side's admission handler decides before the connection can deliver anything.
    if (impl_->options.side == Side::Bind) {
      impl_->admission = std::make_unique<AdmissionHandler>(impl_->context, impl_->options.token, endpoint);
      setIntOption(impl_->socket, ZMQ_PLAIN_SERVER, 1, "ZMQ_PLAIN_SERVER");
      const std::string domain = "railcosim";
      zmq_setsockopt(impl_->socket, ZMQ_ZAP_DOMAIN, domain.data(), domain.size());
    } else {
      zmq_setsockopt(impl_->socket, ZMQ_PLAIN_USERNAME, participantUser, std::strlen(participantUser));
      const std::string password = plainPassword(impl_->options.token);
      zmq_setsockopt(impl_->socket, ZMQ_PLAIN_PASSWORD, password.data(), password.size());
    }
    // Sends never block inside ZeroMQ: the deadline loop in send() does the waiting.
    setIntOption(impl_->socket, ZMQ_SNDTIMEO, 0, "ZMQ_SNDTIMEO");

    std::ostringstream monitorName;
    monitorName << "inproc://railcosim-monitor-" << monitorCounter.fetch_add(1) << "-" << this;
    const int events = ZMQ_EVENT_CONNECTED | ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_DISCONNECTED |
                       ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                       ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_HANDSHAKE_FAILED_AUTH;
    if (zmq_socket_monitor(impl_->socket, monitorName.str().c_str(), events) != 0) {
      throw Error(zmqError("starting the connection monitor for", endpoint));
    }
    impl_->monitor = zmq_socket(impl_->context, ZMQ_PAIR);
    if (impl_->monitor == nullptr || zmq_connect(impl_->monitor, monitorName.str().c_str()) != 0) {
      throw Error(zmqError("connecting the connection monitor for", endpoint));
    }
    setIntOption(impl_->monitor, ZMQ_LINGER, 0, "ZMQ_LINGER");

    if (impl_->options.side == Side::Bind) {
      impl_->options.endpoint = bindEndpoint(endpoint, !impl_->options.token.empty());
      if (zmq_bind(impl_->socket, impl_->options.endpoint.c_str()) != 0) {
        const int code = zmq_errno();
        std::ostringstream text;
        text << "binding endpoint '" << endpoint << "' failed: " << zmq_strerror(code);
        if (code == EADDRINUSE) text << "; another process (an FEM participant of another run?) already uses it";
        text << "; choose a free endpoint";
        throw Error(text.str());
      }
      // A wildcard port (tcp://127.0.0.1:*) is chosen by the kernel: keep the endpoint really bound, so it
      // can be announced to the peer and two runs can never race for one port number.
      char bound[1024] = {};
      std::size_t boundSize = sizeof(bound);
      if (endpoint.rfind("tcp://", 0) == 0 &&
          zmq_getsockopt(impl_->socket, ZMQ_LAST_ENDPOINT, bound, &boundSize) == 0) {
        impl_->options.endpoint = bound;
      }
    } else {
      if (zmq_connect(impl_->socket, endpoint.c_str()) != 0) {
        throw Error(zmqError("connecting to endpoint", endpoint) + "; check the endpoint syntax");
      }
    }
    if (!(impl_->options.heartbeatSeconds > 0.0)) throw Error("bridge transport: heartbeatSeconds must be positive");
    impl_->keepalive = std::thread([impl = impl_.get()] { impl->runKeepalive(); });
  } catch (...) {
    close();
    throw;
  }
}

Channel::~Channel() { close(); }

void Channel::close() {
  if (impl_->keepalive.joinable()) {
    {
      std::lock_guard<std::mutex> lock(impl_->keepaliveMutex);
      impl_->keepaliveStop = true;
    }
    impl_->keepaliveWake.notify_all();
    impl_->keepalive.join();
  }
  if (impl_->admission) impl_->admission->stop();
  if (impl_->socket != nullptr) {
    impl_->drainMonitor(); // a full monitor queue would keep zmq_socket_monitor() below waiting
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
    impl_->admission.reset();
    removeIpcFile(impl_->options);
  }
}

const std::string& Channel::endpoint() const { return impl_->options.endpoint; }
bool Channel::peerSeen() {
  std::lock_guard<std::mutex> lock(impl_->socketMutex);
  drainMonitor();
  return impl_->seen;
}

bool Channel::peerDisconnected() {
  std::lock_guard<std::mutex> lock(impl_->socketMutex);
  drainMonitor();
  return impl_->disconnected;
}

int Channel::refusedConnections() { return impl_->admission ? impl_->admission->refused() : 0; }

void Channel::drainMonitor() { impl_->drainMonitor(); }

bool Channel::Impl::bytesArrivedWithin(Clock::duration window) const {
  if (options.endpoint.rfind("tcp://", 0) != 0) return false;
  const int connection =
      options.side == Side::Bind ? peerConnection : (openConnections.size() == 1 ? *openConnections.begin() : -1);
  if (connection < 0 || openConnections.count(connection) == 0) return false;
  tcp_info info{};
  socklen_t length = sizeof(info);
  if (::getsockopt(connection, IPPROTO_TCP, TCP_INFO, &info, &length) != 0) return false;
  return std::chrono::milliseconds(info.tcpi_last_data_recv) < window;
}

void Channel::Impl::drainMonitor() {
  if (monitor == nullptr) return;
  while (true) {
    zmq_msg_t eventFrame;
    zmq_msg_init(&eventFrame);
    if (zmq_msg_recv(&eventFrame, monitor, ZMQ_DONTWAIT) < 0) {
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
      if (zmq_msg_recv(&eventFrame, monitor, ZMQ_DONTWAIT) < 0) break;
    }
    zmq_msg_close(&eventFrame);
    const int connection = static_cast<int>(value);
    switch (event) {
      case ZMQ_EVENT_CONNECTED:
      case ZMQ_EVENT_ACCEPTED:
        openConnections.insert(connection);
        break;
      case ZMQ_EVENT_HANDSHAKE_SUCCEEDED:
        // Binding side: only the admitted connection gets here (the admission handler lets one in).
        seen = true;
        // The peer's silence counts from its connection: a peer that bound late (a solver still assembling
        // its matrices) has been silent only since now, however long this side waited for it.
        lastHeard = Clock::now();
        log(LogLevel::Debug, "bridge transport: peer connected on " + options.endpoint);
        break;
      case ZMQ_EVENT_DISCONNECTED:
        openConnections.erase(connection);
        // Binding side: only the connection the peer's messages came from counts, so refused or stray
        // connections that close never end a run. Connecting side: its one connection is the peer's.
        if (options.side == Side::Bind ? connection == peerConnection : seen) {
          disconnected = true;
        }
        // Binding side, the admitted peer gone before its first frame named its connection: no connection
        // is left open after its handshake succeeded (strays never reach HANDSHAKE_SUCCEEDED).
        if (options.side == Side::Bind && peerConnection < 0 && seen && openConnections.empty()) disconnected = true;
        log(LogLevel::Debug, "bridge transport: connection dropped on " + options.endpoint);
        break;
      case ZMQ_EVENT_HANDSHAKE_FAILED_AUTH:
        if (options.side == Side::Connect) refused = true;
        break;
      case ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL:
      case ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL:
        log(LogLevel::Debug, "bridge transport: a connection on " + options.endpoint +
                                 " failed the ZeroMQ handshake (not a railcosim participant?)");
        break;
      default:
        break;
    }
  }
}

Status Channel::send(std::vector<std::uint8_t>&& bytes, double timeoutSeconds, Timing& timing) {
  if (impl_->socket == nullptr) throw Error("bridge transport: send on a closed channel to " + impl_->options.endpoint);
  std::lock_guard<std::mutex> lock(impl_->socketMutex);
  const auto start = Clock::now();
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeoutSeconds));
  auto* owned = new SentBuffer{std::move(bytes), impl_->pool};
  zmq_msg_t message;
  if (zmq_msg_init_data(&message, owned->bytes.data(), owned->bytes.size(), releaseSentBuffer, owned) != 0) {
    delete owned;
    throw Error(zmqError("allocating a message for", impl_->options.endpoint));
  }
  while (true) {
    drainMonitor();
    if (impl_->disconnected || impl_->refused) {
      zmq_msg_close(&message);
      timing.waitSeconds += secondsSince(start);
      return impl_->disconnected ? Status::PeerDisconnected : Status::Refused;
    }
    const auto attempt = Clock::now();
    if (zmq_msg_send(&message, impl_->socket, ZMQ_DONTWAIT) >= 0) {
      impl_->lastSent = Clock::now();
      timing.transferSeconds += secondsSince(attempt);
      timing.waitSeconds += std::chrono::duration<double>(attempt - start).count();
      return Status::Ok; // ZeroMQ owns and frees the message now
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
    const double slice =
        std::min(impl_->options.pollSliceSeconds, std::chrono::duration<double>(deadline - now).count());
    zmq_pollitem_t items[2] = {{impl_->socket, 0, ZMQ_POLLOUT, 0}, {impl_->monitor, 0, ZMQ_POLLIN, 0}};
    zmq_poll(items, 2, std::max(1L, static_cast<long>(slice * 1000.0)));
  }
}

Status Channel::receive(Frame& frame, double timeoutSeconds, Timing& timing) {
  if (impl_->socket == nullptr) {
    throw Error("bridge transport: receive on a closed channel to " + impl_->options.endpoint);
  }
  std::lock_guard<std::mutex> lock(impl_->socketMutex);
  const auto start = Clock::now();
  const auto deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeoutSeconds));
  auto tryReceive = [&]() {
    const auto attempt = Clock::now();
    while (true) {
      if (zmq_msg_recv(&frame.impl_->message, impl_->socket, ZMQ_DONTWAIT) < 0) {
        if (zmq_errno() == EAGAIN || zmq_errno() == EINTR) return false;
        throw Error(zmqError("receiving on", impl_->options.endpoint));
      }
      impl_->lastHeard = Clock::now();
      if (impl_->options.side == Side::Bind && impl_->peerConnection < 0) {
        // Only the admitted connection has a pipe, so the first frame names the peer's connection. Events
        // of connections closed before it opened are queued ahead of its own: reading them first means a
        // reused file descriptor number is never mistaken for the peer's.
        drainMonitor();
        impl_->peerConnection = zmq_msg_get(&frame.impl_->message, ZMQ_SRCFD);
        // Its DISCONNECTED, if already read above, came before the number was known.
        if (impl_->openConnections.count(impl_->peerConnection) == 0) impl_->disconnected = true;
      }
      if (zmq_msg_size(&frame.impl_->message) != 0 || zmq_msg_more(&frame.impl_->message)) break;
      // A keepalive: the peer is alive; not a message for the caller.
    }
    timing.transferSeconds += secondsSince(attempt);
    timing.waitSeconds += std::chrono::duration<double>(attempt - start).count();
    impl_->seen = true; // a message proves the peer, even before the monitor event is read
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
    if (impl_->refused) {
      timing.waitSeconds += secondsSince(start);
      return Status::Refused;
    }
    impl_->sendKeepaliveIfDue(); // this side waits: its keepalive thread is locked out, so it speaks here
    const auto now = Clock::now();
    // Silence counts from this call's start at the earliest: frames queued while the caller computed were
    // read above, so a live peer has always been heard within the last interval or so.
    const bool peerKnown = impl_->options.side == Side::Bind ? impl_->peerConnection >= 0 : impl_->seen;
    if (peerKnown && now - std::max(impl_->lastHeard, start) > 3 * impl_->interval() &&
        !impl_->bytesArrivedWithin(3 * impl_->interval())) {
      timing.waitSeconds += secondsSince(start);
      return Status::PeerSilent;
    }
    if (now >= deadline) {
      timing.waitSeconds += secondsSince(start);
      return Status::Timeout;
    }
    // Bounded by a quarter interval too, so the waiting side's keepalives keep their pace.
    const double slice = std::min({impl_->options.pollSliceSeconds, impl_->options.heartbeatSeconds / 4,
                                   std::chrono::duration<double>(deadline - now).count()});
    zmq_pollitem_t items[2] = {{impl_->socket, 0, ZMQ_POLLIN, 0}, {impl_->monitor, 0, ZMQ_POLLIN, 0}};
    zmq_poll(items, 2, std::max(1L, static_cast<long>(slice * 1000.0)));
  }
}

} // namespace railcosim::com
