// FemParticipant / DemParticipant: handshake, per-window state machine, error reporting and statistics.
#include "railcosim/Participant.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"

#include "com/Channel.hpp"
#include "config/ParticipantConfig.hpp"
#include "cplscheme/MessageOrder.hpp"
#include "io/Recording.hpp"
#include "protocol/Message.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <sstream>

namespace railcosim {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string formatSeconds(double seconds) {
  std::ostringstream text;
  text << seconds << " s";
  return text.str();
}

/// What both participants share: the channel, names, state flags, statistics and error wording.
class Link {
public:
  Link(ParticipantConfig config, protocol::Role role)
      : config_(std::move(config)),
        role_(role),
        peerRole_(role == protocol::Role::Fem ? "DEM" : "FEM"),
        uncaughtAtStart_(std::uncaught_exceptions()) {
    config::validate(config_, role == protocol::Role::Fem ? "fem" : "dem");
  }

  ~Link() { shutDown(); }

  const ParticipantConfig& config() const { return config_; }
  BridgeStatistics& statistics() { return statistics_; }
  bool open() const { return channel_ != nullptr; }
  bool handshakeDone() const { return handshakeDone_; }
  /// Statistics cover the coupled run only: the handshake (and waiting for the peer to start) is left out.
  void setHandshakeDone() {
    makeOrder();
    if (!config_.resumedFrom.empty()) order_->resumeAt(config_.resumedWindow);
    handshakeDone_ = true;
    statistics_ = BridgeStatistics{};
  }
  const std::string& peerName() const { return peerName_; }
  std::size_t nodeCount() const { return nodeCount_; }
  void setNodeCount(std::size_t nodes) { nodeCount_ = nodes; }
  bool peerFinalized() const { return peerFinalized_; }
  void setPeerFinalized() { peerFinalized_ = true; }

  std::string self() const { return config_.name; }
  std::string peerLabel() const {
    return peerName_.empty() ? "the " + peerRole_ + " participant" : "peer '" + peerName_ + "'";
  }

  /// `maxIncomingBytes`: larger messages drop the connection inside ZeroMQ, before they are buffered.
  void openChannel(std::uint64_t maxIncomingBytes) {
    com::ChannelOptions options;
    options.endpoint = config_.endpoint;
    options.side = role_ == protocol::Role::Fem ? com::Side::Bind : com::Side::Connect;
    options.heartbeatSeconds = config_.heartbeatSeconds;
    options.token = config_.token;
    if (options.token.empty()) {
      if (const char* fromEnvironment = std::getenv("RAILCOSIM_BRIDGE_TOKEN")) options.token = fromEnvironment;
    }
    options.maxMessageBytes = maxIncomingBytes;
    std::string recordPath = config_.recordPath;
    if (recordPath.empty()) {
      if (const char* fromEnvironment = std::getenv("RAILCOSIM_BRIDGE_RECORD")) recordPath = fromEnvironment;
    }
    if (!recordPath.empty()) {
      try {
        recorder_ = std::make_unique<io::RecordingWriter>(recordPath, role_ == protocol::Role::Fem ? "fem" : "dem");
      } catch (const Error& error) {
        throw Error(self() + ": " + error.what());
      }
      log(LogLevel::Info, self() + ": recording every interface message to " + recordPath);
    }
    // Long enough to flush a final message to a live peer, short enough that closing never hangs.
    options.lingerMilliseconds = static_cast<int>(std::min(1000.0, config_.timeoutSeconds * 1000.0));
    try {
      channel_ = std::make_unique<com::Channel>(options);
    } catch (const Error& error) {
      throw Error(self() + ": " + error.what());
    }
    if (role_ == protocol::Role::Fem) {
      config_.endpoint = channel_->endpoint(); // as bound: a '*' host or port resolved
      log(LogLevel::Info, self() + ": listening on " + config_.endpoint);
    }
  }

  /// With a recording open: appends a message this side sent or received (before it is decoded).
  void record(bool sent, const std::vector<std::uint8_t>& bytes) {
    if (recorder_) recorder_->write(sent, bytes.data(), bytes.size());
  }
  void record(bool sent, const com::Frame& frame) {
    if (recorder_) recorder_->write(sent, frame.data(), frame.size());
  }
  /// For the closing messages: a recording that fails then is reported, not thrown (called from destructors).
  std::vector<std::uint8_t> recordQuietly(std::vector<std::uint8_t> bytes) {
    try {
      record(true, bytes);
    } catch (const std::exception& error) {
      log(LogLevel::Warning, self() + ": " + error.what());
    }
    return bytes;
  }

  void requireUsable(const char* call) const {
    if (closed_) throw Error(self() + ": " + call + " called after the run ended (" + closedBecause_ + ")");
    if (!handshakeDone_) throw Error(self() + ": " + call + " called before initialize() completed");
  }

  void fail(const std::string& message) const { throw Error(self() + ": " + message); }

  /// Sends one encoded message; `what` describes it for errors ("kinematics of window 3").
  void send(std::vector<std::uint8_t>&& bytes, const std::string& what, bool countAsExchange) {
    const std::size_t size = bytes.size();
    com::Timing timing;
    record(true, bytes);
    const com::Status status = channel_->send(std::move(bytes), config_.timeoutSeconds, timing);
    statistics_.transferSeconds += timing.transferSeconds;
    statistics_.waitSeconds += timing.waitSeconds;
    if (status == com::Status::Ok) {
      if (countAsExchange) {
        ++statistics_.exchanges;
        statistics_.bytes += size;
      }
      return;
    }
    if (status == com::Status::Refused) {
      markClosed("the peer refused this participant");
      throw PeerLostError(refusedMessage());
    }
    if (status == com::Status::PeerDisconnected) {
      // A peer that finalized and closed before reading this message is a normal end, not a loss
      // (e.g. predictive order: the FEM side always sends one window ahead).
      if (finalizeIsPending()) {
        log(LogLevel::Debug, self() + ": " + peerLabel() + " finalized before reading " + what + "; dropped");
        return;
      }
      markClosed("the connection to the peer ended with an error");
      throw PeerLostError(disconnectedMessage("sending " + what));
    }
    markClosed("the connection to the peer ended with an error");
    std::ostringstream text;
    text << self() << ": could not hand " << what << " to " << peerLabel() << " on " << config_.endpoint << " within "
         << formatSeconds(config_.timeoutSeconds) << " (the peer does not read its messages); "
         << "raise timeoutSeconds if the " << peerRole_ << " side is just slow";
    throw PeerLostError(text.str());
  }

  /// After a disconnection: is the peer's Finalize (or Abort) already delivered but unread?
  bool finalizeIsPending() {
    com::Frame frame;
    com::Timing timing;
    if (channel_->receive(frame, 0.0, timing) != com::Status::Ok) return false;
    record(false, frame);
    protocol::Header header;
    try {
      header = protocol::decodeHeader(frame.data(), frame.size());
    } catch (const ProtocolError&) {
      return false;
    }
    if (header.type == protocol::MessageType::Abort) {
      markClosed("the connection to the peer ended with an error");
      std::string reason;
      try {
        reason = protocol::decodeAbort(header, frame.data());
      } catch (const ProtocolError& error) {
        reason = std::string("(unreadable reason: ") + error.what() + ")";
      }
      throw PeerLostError(self() + ": " + peerLabel() + " aborted the run: " + reason);
    }
    if (header.type != protocol::MessageType::Finalize) return false;
    peerFinalized_ = true;
    return true;
  }

  /// Receives and header-checks one message; Abort from the peer becomes PeerLostError.
  /// `waitingFor` is said in errors, e.g. "forces of window 42".
  std::pair<com::Frame, protocol::Header> receive(const std::string& waitingFor, bool countAsExchange) {
    com::Frame frame;
    com::Timing timing;
    com::Status status = com::Status::Ok;
    try {
      status = channel_->receive(frame, config_.timeoutSeconds, timing);
    } catch (const ProtocolError& error) { // a multi-part message: told to the peer like any bad message
      rejectPeer(error.what(), waitingFor);
    }
    statistics_.transferSeconds += timing.transferSeconds;
    statistics_.waitSeconds += timing.waitSeconds;
    if (status == com::Status::PeerDisconnected) {
      markClosed("the connection to the peer ended with an error");
      throw PeerLostError(disconnectedMessage("waiting for " + waitingFor));
    }
    if (status == com::Status::Refused) {
      markClosed("the peer refused this participant");
      throw PeerLostError(refusedMessage());
    }
    if (status == com::Status::PeerSilent) {
      markClosed("the peer fell silent");
      std::ostringstream text;
      text << self() << ": " << peerLabel() << " on " << config_.endpoint
           << " sent nothing, not even its keepalive, for " << formatSeconds(3 * config_.heartbeatSeconds)
           << " while this side waited for " << waitingFor << "; the " << peerRole_
           << " process is frozen (stopped, swapped out or stuck in a system call) or the network is gone";
      throw PeerLostError(text.str());
    }
    if (status == com::Status::Timeout) {
      markClosed("the connection to the peer ended with an error");
      std::ostringstream text;
      text << self() << ": no message from " << peerLabel() << " on " << config_.endpoint << " within "
           << formatSeconds(config_.timeoutSeconds) << " while waiting for " << waitingFor << "; ";
      if (!channel_->peerSeen()) {
        text << "no " << peerRole_ << " participant ever connected (start it with the same endpoint)";
      } else {
        text << "the " << peerRole_ << " side is connected but silent (stuck, or slower than the timeout)";
      }
      text << "; raise timeoutSeconds (now " << config_.timeoutSeconds << ") if it is just slow";
      throw PeerLostError(text.str());
    }
    record(false, frame);
    const auto decodeStart = Clock::now();
    protocol::Header header;
    try {
      header = protocol::decodeHeader(frame.data(), frame.size());
    } catch (const ProtocolError& error) {
      rejectPeer(error.what(), waitingFor);
    }
    statistics_.encodeSeconds += secondsSince(decodeStart);
    if (header.type == protocol::MessageType::Abort) {
      std::string reason;
      try {
        reason = protocol::decodeAbort(header, frame.data());
      } catch (const ProtocolError& error) {
        reason = std::string("(unreadable reason: ") + error.what() + ")";
      }
      markClosed("the connection to the peer ended with an error");
      throw PeerLostError(self() + ": " + peerLabel() + " aborted the run while this side was waiting for " +
                          waitingFor + ": " + reason);
    }
    // Finalize and Checkpoint are bookkeeping, not exchanges of interface data.
    if (countAsExchange && header.type != protocol::MessageType::Finalize &&
        header.type != protocol::MessageType::Checkpoint) {
      ++statistics_.exchanges;
      statistics_.bytes += frame.size();
    }
    return {std::move(frame), header};
  }

  /// A message broke the protocol: tell the peer (best effort), close, and throw ProtocolError.
  [[noreturn]] void rejectPeer(const std::string& problem, const std::string& waitingFor) {
    const std::string message =
        self() + ": rejected a message from " + peerLabel() + " while waiting for " + waitingFor + ": " + problem;
    abortQuietly(message);
    throw ProtocolError(message);
  }

  /// Runs a body decoder; its ProtocolError is reported to the peer and rethrown with context.
  template <class Decode>
  auto decodeBody(Decode decode, const std::string& waitingFor) -> decltype(decode()) {
    const auto start = Clock::now();
    try {
      auto result = decode();
      statistics_.encodeSeconds += secondsSince(start);
      return result;
    } catch (const ProtocolError& error) {
      rejectPeer(error.what(), waitingFor);
    }
  }

  [[noreturn]] void unexpected(const protocol::Header& header, const std::string& expected) {
    rejectPeer("expected " + expected + ", got " + protocol::describe(header), expected);
  }

  /// Runs an encoder with a recycled buffer; a value it refuses (NaN, infinity) becomes an Error
  /// naming this participant, and nothing is sent.
  template <class Encode>
  std::vector<std::uint8_t> encode(Encode encode) {
    const auto start = Clock::now();
    std::vector<std::uint8_t> bytes;
    try {
      bytes = encode(channel_ ? channel_->takeBuffer() : std::vector<std::uint8_t>{});
    } catch (const ProtocolError& error) {
      throw Error(self() + ": " + error.what());
    }
    statistics_.encodeSeconds += secondsSince(start);
    return bytes;
  }

  std::string refusedMessage() const {
    return self() + ": the " + peerRole_ + " participant on " + config_.endpoint +
           " refused this participant: the run tokens differ (RAILCOSIM_BRIDGE_TOKEN or ParticipantConfig::token), "
           "or another participant already joined that run";
  }

  std::string disconnectedMessage(const std::string& doing) const {
    std::ostringstream text;
    text << self() << ": " << peerLabel() << " disconnected from " << config_.endpoint << " while " << doing << "; the "
         << peerRole_
         << " process probably died - check its log (a message larger than the protocol "
            "allows also ends the connection)";
    return text.str();
  }

  /// Sends Abort if the peer may still listen; never throws.
  void abortQuietly(const std::string& reason) {
    if (channel_ && !closed_ && channel_->peerSeen() && !channel_->peerDisconnected()) {
      try {
        com::Timing timing;
        std::vector<std::uint8_t> abortBytes = recordQuietly(protocol::encodeAbort(0, reason));
        channel_->send(std::move(abortBytes), std::min(config_.timeoutSeconds, 2.0), timing);
      } catch (const std::exception& error) {
        log(LogLevel::Warning, self() + ": could not send Abort to " + peerLabel() + ": " + error.what());
      }
    }
    markClosed("abort() or a rejected message");
    if (channel_) channel_->close();
  }

  /// Normal end: Finalize to a live peer, then close. Never throws (called from destructors).
  void finalizeQuietly(std::uint64_t window) {
    if (closed_) {
      if (channel_) channel_->close();
      return;
    }
    if (std::uncaught_exceptions() > uncaughtAtStart_) {
      // Destroyed while an exception propagates: the run did not end normally, so say so.
      abortQuietly(self() + " was shut down by an error (see its log)");
      return;
    }
    if (channel_ && handshakeDone_ && !peerFinalized_ && !channel_->peerDisconnected()) {
      try {
        com::Timing timing;
        const auto status = channel_->send(recordQuietly(protocol::encodeFinalize(window)),
                                           std::min(config_.timeoutSeconds, 2.0), timing);
        if (status != com::Status::Ok) {
          log(LogLevel::Info, self() + ": " + peerLabel() + " was gone before Finalize could be sent");
        }
      } catch (const std::exception& error) {
        log(LogLevel::Warning, self() + ": could not send Finalize: " + error.what());
      }
    }
    markClosed("finalize()");
    if (channel_) channel_->close();
  }

  void shutDown() {
    try {
      if (channel_) channel_->close();
    } catch (...) {
      // Closing must not throw from a destructor; nothing useful is left to report.
    }
  }

  void setPeerName(const std::string& name) { peerName_ = name; }

  /// Hello checks shared by both sides: role and names.
  void checkHello(const protocol::Hello& hello, protocol::Role expectedRole, const std::string& waitingFor) {
    if (hello.role != expectedRole) {
      rejectPeer("participant '" + hello.participantName + "' announced role " + protocol::toString(hello.role) +
                     " but this side is " + protocol::toString(role_) + "; two " +
                     (role_ == protocol::Role::Fem ? std::string("FEM") : std::string("DEM")) +
                     " participants cannot couple - start one FEM (binds) and one DEM (connects) participant",
                 waitingFor);
    }
    if (hello.participantName == config_.name) {
      rejectPeer("both participants are named '" + config_.name +
                     "'; give them distinct names so errors and logs "
                     "say which side is meant",
                 waitingFor);
    }
    if (!hello.couplingScheme.empty() && !config_.couplingScheme.empty() &&
        hello.couplingScheme != toString(parseCouplingScheme(config_.couplingScheme))) {
      rejectPeer("participant '" + hello.participantName + "' couples with the " + hello.couplingScheme +
                     " scheme but this side is configured for " + config_.couplingScheme +
                     "; both sides must use the same couplingScheme (the message order differs)",
                 waitingFor);
    }
    if (hello.resumedFrom != config_.resumedFrom || hello.resumedWindow != config_.resumedWindow) {
      auto start = [](const std::string& name, std::uint64_t window) {
        return name.empty() ? std::string("a fresh start")
                            : "restart checkpoint " + name + " (window " + std::to_string(window) + ")";
      };
      rejectPeer("participant '" + hello.participantName + "' resumed from " +
                     start(hello.resumedFrom, hello.resumedWindow) + " but this side from " +
                     start(config_.resumedFrom, config_.resumedWindow) +
                     "; both sides must start from the same checkpoint (./railcosim run --resume gives it to both)",
                 waitingFor);
    }
    setPeerName(hello.participantName);
    peerScheme_ = hello.couplingScheme;
  }

  const std::string& peerScheme() const { return peerScheme_; }
  /// The scheme both sides follow: this side's, else the peer's (the handshake refused two different
  /// names), else none named ("").
  std::string agreedScheme() const {
    if (!config_.couplingScheme.empty()) return toString(parseCouplingScheme(config_.couplingScheme));
    return peerScheme_;
  }
  /// The message order of the agreed scheme (just-in-time's when none was named); made at the handshake.
  cplscheme::MessageOrder& order() { return *order_; }
  const cplscheme::MessageOrder* orderIfAny() const { return order_.get(); }
  std::string agreedSchemeLabel() const {
    const std::string scheme = agreedScheme();
    return scheme.empty() ? std::string("justInTime (none named)") : scheme;
  }
  void makeOrder() {
    const std::string scheme = agreedScheme();
    order_ = cplscheme::makeMessageOrder(scheme.empty() ? CouplingScheme::JustInTime : parseCouplingScheme(scheme));
  }

  protocol::Hello ownHello() const {
    protocol::Hello hello;
    hello.role = role_;
    hello.participantName = config_.name;
    hello.unitSystem = "SI";
    // Sent in its canonical spelling, so the peer compares names, not spellings.
    hello.couplingScheme = config_.couplingScheme.empty() ? "" : toString(parseCouplingScheme(config_.couplingScheme));
    hello.resumedFrom = config_.resumedFrom;
    hello.resumedWindow = config_.resumedWindow;
    return hello;
  }

  void markClosed(const std::string& because) {
    if (!closed_) closedBecause_ = because;
    closed_ = true;
  }
  bool closed() const { return closed_; }

private:
  ParticipantConfig config_;
  protocol::Role role_;
  std::string peerRole_;
  std::string peerName_;
  std::string peerScheme_;
  std::unique_ptr<com::Channel> channel_;
  std::unique_ptr<cplscheme::MessageOrder> order_;
  std::unique_ptr<io::RecordingWriter> recorder_; // RAILCOSIM_BRIDGE_RECORD or ParticipantConfig::recordPath
  BridgeStatistics statistics_;
  std::size_t nodeCount_ = 0;
  bool handshakeDone_ = false;
  bool peerFinalized_ = false;
  bool closed_ = false;
  std::string closedBecause_;
  int uncaughtAtStart_ = 0;
};

std::string windowText(const char* what, std::uint64_t window) {
  return std::string(what) + " of window " + std::to_string(window);
}

} // namespace

// ---------------------------------------------------------------------------------------------- FEM side

struct FemParticipant::Impl {
  explicit Impl(ParticipantConfig config) : link(std::move(config), protocol::Role::Fem) {}
  Link link;
  std::optional<CheckpointOrder> pendingCheckpoint; // ordered, its files not yet confirmed
  /// Windows with kinematics sent so far (the Finalize message's window).
  std::uint64_t kinematicsWindows() const { return link.orderIfAny() ? link.orderIfAny()->kinematicsWindows() : 0; }
};

FemParticipant::FemParticipant(ParticipantConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

FemParticipant::~FemParticipant() { impl_->link.finalizeQuietly(impl_->kinematicsWindows()); }

void FemParticipant::initialize(const InterfaceMesh& mesh, double femTimeStep, const NodalKinematics& initial) {
  Link& link = impl_->link;
  if (link.open()) link.fail("initialize() called twice");
  try {
    mesh.validate();
    initial.validate(mesh.nodeCount());
  } catch (const Error& error) {
    link.fail(std::string("initialize: ") + error.what());
  }
  if (!(femTimeStep > 0.0) || !std::isfinite(femTimeStep)) {
    link.fail("initialize: femTimeStep = " + std::to_string(femTimeStep) + " s; it must be positive and finite");
  }
  // The mesh is known before binding, so the FEM side accepts nothing larger than its own Forces.
  link.openChannel(protocol::maxMessageBytesTowardsFem(mesh.nodeCount()));
  const std::string waitingFor = "the Hello of a DEM participant";
  auto [frame, header] = link.receive(waitingFor, false);
  if (header.type != protocol::MessageType::Hello) link.unexpected(header, "Hello");
  const protocol::Hello hello =
      link.decodeBody([&] { return protocol::decodeHello(header, frame.data()); }, waitingFor);
  link.checkHello(hello, protocol::Role::Dem, waitingFor);
  link.send(link.encode([&](auto buffer) {
    return protocol::encodeHello(link.ownHello(), protocol::protocolVersion, std::move(buffer));
  }),
            "the Hello", false);
  link.send(
      link.encode([&](auto buffer) { return protocol::encodeMesh(mesh, femTimeStep, initial, std::move(buffer)); }),
      "the interface mesh", false);
  link.setNodeCount(mesh.nodeCount());
  link.setHandshakeDone();
  log(LogLevel::Info, link.self() + ": coupled with DEM participant '" + hello.participantName + "' on " +
                          link.config().endpoint + " (" + std::to_string(mesh.nodeCount()) + " interface nodes)");
}

std::optional<ForceMessage> FemParticipant::receiveForces() {
  FemIncoming incoming = receive();
  if (incoming.kind == FemIncoming::Kind::Checkpoint) {
    impl_->link.abortQuietly(impl_->link.self() + ": the DEM side ordered restart checkpoint " +
                             incoming.checkpoint.name +
                             ", which this FEM side cannot save (it reads with receiveForces())");
    impl_->link.fail("receiveForces: the DEM side ordered restart checkpoint " + incoming.checkpoint.name +
                     " (window " + std::to_string(incoming.checkpoint.window) +
                     "); a FEM side that saves checkpoints reads with receive() or FemCouplingScheme::beginStep()");
  }
  if (incoming.kind == FemIncoming::Kind::Finalized) return std::nullopt;
  return std::move(incoming.forces);
}

FemIncoming FemParticipant::receive() {
  Link& link = impl_->link;
  FemIncoming incoming;
  if (link.peerFinalized()) return incoming;
  link.requireUsable("receive()");
  if (impl_->pendingCheckpoint) {
    link.fail("receive: checkpoint " + impl_->pendingCheckpoint->name +
              " was ordered and not confirmed; call confirmCheckpoint() once this side's files are written");
  }
  cplscheme::MessageOrder& order = link.order();
  const std::string blocked = order.forcesBlockedBecause();
  if (!blocked.empty()) link.fail("receive: " + blocked);
  const std::string waitingFor = windowText("forces", order.forcesWindows());
  auto [frame, header] = link.receive(waitingFor, true);
  if (header.type == protocol::MessageType::Finalize) {
    link.decodeBody(
        [&] {
          protocol::decodeFinalize(header);
          return 0;
        },
        waitingFor);
    link.setPeerFinalized();
    log(LogLevel::Info, link.self() + ": " + link.peerLabel() + " finalized the run after " +
                            std::to_string(order.forcesWindows()) + " windows");
    return incoming;
  }
  if (header.type == protocol::MessageType::Checkpoint) {
    if (!order.checkpointAllowed(header.window))
      link.unexpected(header, "a Checkpoint for " + order.expectedCheckpoint());
    incoming.kind = FemIncoming::Kind::Checkpoint;
    incoming.checkpoint = link.decodeBody([&] { return protocol::decodeCheckpoint(header, frame.data()); }, waitingFor);
    order.checkpointExchanged(header.window);
    impl_->pendingCheckpoint = incoming.checkpoint;
    log(LogLevel::Info,
        link.self() + ": " + link.peerLabel() + " ordered restart checkpoint " + incoming.checkpoint.name);
    return incoming;
  }
  if (header.type != protocol::MessageType::Forces || !order.forcesAllowed(header.window, header.iteration)) {
    link.unexpected(header, "Forces for " + order.expectedForces());
  }
  incoming.kind = FemIncoming::Kind::Forces;
  incoming.forces =
      link.decodeBody([&] { return protocol::decodeForces(header, frame.data(), link.nodeCount()); }, waitingFor);
  order.forcesExchanged(incoming.forces.window, incoming.forces.iteration);
  return incoming;
}

void FemParticipant::confirmCheckpoint(std::uint64_t window, const std::vector<CheckpointFile>& files) {
  Link& link = impl_->link;
  link.requireUsable("confirmCheckpoint()");
  if (!impl_->pendingCheckpoint || impl_->pendingCheckpoint->window != window) {
    link.fail("confirmCheckpoint(window " + std::to_string(window) + "): " +
              (impl_->pendingCheckpoint
                   ? "the checkpoint ordered is that of window " + std::to_string(impl_->pendingCheckpoint->window)
                   : std::string("no checkpoint was ordered")));
  }
  std::string list;
  try {
    list = encodeCheckpointFiles(files);
  } catch (const Error& error) {
    link.fail(std::string("confirmCheckpoint: ") + error.what());
  }
  link.send(
      link.encode([&](auto buffer) { return protocol::encodeCheckpointWritten(window, list, std::move(buffer)); }),
      windowText("the files of the checkpoint", window), false);
  impl_->pendingCheckpoint.reset();
}

void FemParticipant::sendKinematics(std::uint64_t window, const NodalKinematics& kinematics) {
  Link& link = impl_->link;
  if (link.peerFinalized()) {
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " already finalized the run; kinematics of window " +
                        std::to_string(window) + " have no receiver");
  }
  link.requireUsable("sendKinematics()");
  if (impl_->pendingCheckpoint)
    link.fail("sendKinematics: checkpoint " + impl_->pendingCheckpoint->name + " was ordered and not confirmed");
  cplscheme::MessageOrder& order = link.order();
  if (!order.kinematicsAllowed(window)) {
    link.fail("sendKinematics: window " + std::to_string(window) + " but the " + link.agreedSchemeLabel() +
              " scheme expects the kinematics of " + order.expectedKinematics());
  }
  // Sizes here; finiteness is checked by the encoder in the same pass as the copy.
  const std::size_t values = 3 * link.nodeCount();
  if (kinematics.positions.size() != values ||
      (!kinematics.velocities.empty() && kinematics.velocities.size() != values) ||
      (!kinematics.accelerations.empty() && kinematics.accelerations.size() != values)) {
    link.fail("sendKinematics(window " + std::to_string(window) + "): positions/velocities/accelerations have " +
              std::to_string(kinematics.positions.size()) + "/" + std::to_string(kinematics.velocities.size()) + "/" +
              std::to_string(kinematics.accelerations.size()) + " values; the interface needs " +
              std::to_string(values) + " each (velocities and accelerations may be empty)");
  }
  if (!std::isfinite(kinematics.time)) link.fail("sendKinematics: time is not finite");
  const std::uint32_t iteration = order.kinematicsIteration();
  link.send(link.encode([&](auto buffer) {
    return protocol::encodeKinematics(window, kinematics, std::move(buffer), iteration);
  }),
            windowText("kinematics", window), true);
  order.kinematicsExchanged(window);
}

void FemParticipant::finalize() { impl_->link.finalizeQuietly(impl_->kinematicsWindows()); }

std::string FemParticipant::couplingScheme() const { return impl_->link.agreedScheme(); }

void FemParticipant::abort(const std::string& reason) { impl_->link.abortQuietly(impl_->link.self() + ": " + reason); }

const BridgeStatistics& FemParticipant::statistics() const { return impl_->link.statistics(); }

// ---------------------------------------------------------------------------------------------- DEM side

struct DemParticipant::Impl {
  explicit Impl(ParticipantConfig config) : link(std::move(config), protocol::Role::Dem) {}
  Link link;
  std::uint64_t forcesAfterFinalize = 0; // forces not sent because the FEM side had finalized
  /// Windows with forces sent so far (the Finalize message's window).
  std::uint64_t forcesWindows() const {
    return (link.orderIfAny() ? link.orderIfAny()->forcesWindows() : 0) + forcesAfterFinalize;
  }
};

DemParticipant::DemParticipant(ParticipantConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

DemParticipant::~DemParticipant() { impl_->link.finalizeQuietly(impl_->forcesWindows()); }

InterfaceSetup DemParticipant::initialize() {
  Link& link = impl_->link;
  if (link.open()) link.fail("initialize() called twice");
  link.openChannel(protocol::maxMessageBytes); // the interface mesh is not known yet
  // Queued by ZeroMQ until the FEM side binds; the wait below obeys the timeout.
  link.send(link.encode([&](auto buffer) {
    return protocol::encodeHello(link.ownHello(), protocol::protocolVersion, std::move(buffer));
  }),
            "the Hello", false);
  const std::string waitingFor = "the Hello of the FEM participant";
  auto [helloFrame, helloHeader] = link.receive(waitingFor, false);
  if (helloHeader.type != protocol::MessageType::Hello) link.unexpected(helloHeader, "Hello");
  const protocol::Hello hello =
      link.decodeBody([&] { return protocol::decodeHello(helloHeader, helloFrame.data()); }, waitingFor);
  link.checkHello(hello, protocol::Role::Fem, waitingFor);
  const std::string waitingForMesh = "the interface mesh";
  auto [meshFrame, meshHeader] = link.receive(waitingForMesh, false);
  if (meshHeader.type != protocol::MessageType::InterfaceMesh) link.unexpected(meshHeader, "InterfaceMesh");
  protocol::MeshSetup setup =
      link.decodeBody([&] { return protocol::decodeMesh(meshHeader, meshFrame.data()); }, waitingForMesh);
  link.setNodeCount(setup.mesh.nodeCount());
  link.setHandshakeDone();
  log(LogLevel::Info, link.self() + ": coupled with FEM participant '" + hello.participantName + "' on " +
                          link.config().endpoint + " (" + std::to_string(setup.mesh.nodeCount()) +
                          " interface nodes, window " + std::to_string(setup.femTimeStep) + " s)");
  InterfaceSetup result;
  result.peerName = hello.participantName;
  result.mesh = std::move(setup.mesh);
  result.femTimeStep = setup.femTimeStep;
  result.initial = std::move(setup.initial);
  result.couplingScheme = link.peerScheme();
  return result;
}

void DemParticipant::sendForces(const ForceMessage& message) {
  Link& link = impl_->link;
  if (link.peerFinalized()) {
    // Nothing to deliver to; the following receiveKinematics() reports the early end.
    ++impl_->forcesAfterFinalize;
    return;
  }
  link.requireUsable("sendForces()");
  cplscheme::MessageOrder& order = link.order();
  const std::string blocked = order.forcesBlockedBecause();
  if (!blocked.empty()) link.fail("sendForces: " + blocked);
  if (!order.forcesAllowed(message.window, message.iteration)) {
    link.fail("sendForces: window " + std::to_string(message.window) + " iteration " +
              std::to_string(message.iteration) + " but the " + link.agreedSchemeLabel() + " scheme continues with " +
              order.expectedForces());
  }
  if (message.forces.size() != 3 * link.nodeCount()) {
    link.fail("sendForces(window " + std::to_string(message.window) + "): forces has " +
              std::to_string(message.forces.size()) +
              " values, the interface needs 3 per node = " + std::to_string(3 * link.nodeCount()));
  }
  if (!std::isfinite(message.time)) link.fail("sendForces: time is not finite");
  link.send(link.encode([&](auto buffer) { return protocol::encodeForces(message, std::move(buffer)); }),
            windowText("forces", message.window), true);
  order.forcesExchanged(message.window, message.iteration);
}

NodalKinematics DemParticipant::receiveKinematics(std::uint64_t window) {
  Link& link = impl_->link;
  link.requireUsable("receiveKinematics()");
  cplscheme::MessageOrder& order = link.order();
  if (!order.kinematicsAllowed(window)) {
    link.fail("receiveKinematics: window " + std::to_string(window) + " asked but the " + link.agreedSchemeLabel() +
              " scheme expects the kinematics of " + order.expectedKinematics());
  }
  const std::string waitingFor = windowText("kinematics", window);
  if (link.peerFinalized()) {
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " finalized the run while this side was waiting for " +
                        waitingFor + "; the FEM side ended early (end time reached or stopped) - check its log");
  }
  auto [frame, header] = link.receive(waitingFor, true);
  if (header.type == protocol::MessageType::Finalize) {
    link.setPeerFinalized();
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " finalized the run while this side was waiting for " +
                        waitingFor + "; the FEM side ended early (end time reached or stopped) - check its log");
  }
  const std::uint32_t iteration = order.kinematicsIteration();
  if (header.type != protocol::MessageType::Kinematics || header.window != window || header.iteration != iteration) {
    link.unexpected(header, "Kinematics for window " + std::to_string(window) +
                                (iteration > 0 ? " (iteration " + std::to_string(iteration) + ")" : std::string()));
  }
  NodalKinematics kinematics =
      link.decodeBody([&] { return protocol::decodeKinematics(header, frame.data(), link.nodeCount()); }, waitingFor);
  order.kinematicsExchanged(window);
  return kinematics;
}

std::vector<CheckpointFile> DemParticipant::orderCheckpoint(const CheckpointOrder& checkpoint) {
  Link& link = impl_->link;
  link.requireUsable("orderCheckpoint()");
  if (link.peerFinalized()) {
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " finalized the run before checkpoint " +
                        checkpoint.name + " could be taken");
  }
  cplscheme::MessageOrder& order = link.order();
  if (!order.checkpointAllowed(checkpoint.window)) {
    link.fail("orderCheckpoint: window " + std::to_string(checkpoint.window) + " but the " + link.agreedSchemeLabel() +
              " scheme is at " + order.expectedCheckpoint());
  }
  if (!std::isfinite(checkpoint.time)) link.fail("orderCheckpoint: time is not finite");
  link.send(link.encode([&](auto buffer) { return protocol::encodeCheckpoint(checkpoint, std::move(buffer)); }),
            "checkpoint " + checkpoint.name, false);
  order.checkpointExchanged(checkpoint.window);
  const std::string waitingFor = "the FEM side's files of checkpoint " + checkpoint.name;
  auto [frame, header] = link.receive(waitingFor, false);
  if (header.type == protocol::MessageType::Finalize) {
    link.setPeerFinalized();
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " finalized the run while this side was waiting for " +
                        waitingFor + " - check its log");
  }
  if (header.type != protocol::MessageType::CheckpointWritten || header.window != checkpoint.window)
    link.unexpected(header, "CheckpointWritten for window " + std::to_string(checkpoint.window));
  const std::string list =
      link.decodeBody([&] { return protocol::decodeCheckpointWritten(header, frame.data()); }, waitingFor);
  try {
    return decodeCheckpointFiles(list);
  } catch (const Error& error) {
    link.rejectPeer(error.what(), waitingFor);
  }
}

void DemParticipant::finalize() { impl_->link.finalizeQuietly(impl_->forcesWindows()); }

std::string DemParticipant::couplingScheme() const { return impl_->link.agreedScheme(); }

void DemParticipant::abort(const std::string& reason) { impl_->link.abortQuietly(impl_->link.self() + ": " + reason); }

const BridgeStatistics& DemParticipant::statistics() const { return impl_->link.statistics(); }

} // namespace railcosim
