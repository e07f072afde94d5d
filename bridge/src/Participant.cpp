// FemParticipant / DemParticipant: handshake, per-window state machine, error reporting and statistics.
#include "railcosim/Participant.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"

#include "com/Channel.hpp"
#include "config/ParticipantConfig.hpp"
#include "protocol/Message.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <sstream>

namespace railcosim {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string formatSeconds(double seconds) {
  std::ostringstream text;
  text << seconds << " s";
  return text.str();
}

/// What both participants share: the channel, names, state flags, statistics and error wording.
class Link {
public:
  Link(ParticipantConfig config, protocol::Role role)
      : config_(std::move(config)), role_(role), peerRole_(role == protocol::Role::Fem ? "DEM" : "FEM"),
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
    // Long enough to flush a final message to a live peer, short enough that closing never hangs.
    options.lingerMilliseconds = static_cast<int>(std::min(1000.0, config_.timeoutSeconds * 1000.0));
    try {
      channel_ = std::make_unique<com::Channel>(options);
    } catch (const Error& error) {
      throw Error(self() + ": " + error.what());
    }
    if (role_ == protocol::Role::Fem) {
      config_.endpoint = channel_->endpoint();  // as bound: a '*' host or port resolved
      log(LogLevel::Info, self() + ": listening on " + config_.endpoint);
    }
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
    text << self() << ": could not hand " << what << " to " << peerLabel() << " on " << config_.endpoint
         << " within " << formatSeconds(config_.timeoutSeconds) << " (the peer does not read its messages); "
         << "raise timeoutSeconds if the " << peerRole_ << " side is just slow";
    throw PeerLostError(text.str());
  }

  /// After a disconnection: is the peer's Finalize (or Abort) already delivered but unread?
  bool finalizeIsPending() {
    com::Frame frame;
    com::Timing timing;
    if (channel_->receive(frame, 0.0, timing) != com::Status::Ok) return false;
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
    } catch (const ProtocolError& error) {  // a multi-part message: told to the peer like any bad message
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
      text << self() << ": " << peerLabel() << " on " << config_.endpoint << " sent nothing, not even its keepalive, for "
           << formatSeconds(3 * config_.heartbeatSeconds) << " while this side waited for " << waitingFor << "; the "
           << peerRole_ << " process is frozen (stopped, swapped out or stuck in a system call) or the network is gone";
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
    // Finalize is bookkeeping, not an exchange of interface data.
    if (countAsExchange && header.type != protocol::MessageType::Finalize) {
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
    text << self() << ": " << peerLabel() << " disconnected from " << config_.endpoint << " while " << doing
         << "; the " << peerRole_ << " process probably died - check its log (a message larger than the protocol "
            "allows also ends the connection)";
    return text.str();
  }

  /// Sends Abort if the peer may still listen; never throws.
  void abortQuietly(const std::string& reason) {
    if (channel_ && !closed_ && channel_->peerSeen() && !channel_->peerDisconnected()) {
      try {
        com::Timing timing;
        channel_->send(protocol::encodeAbort(0, reason), std::min(config_.timeoutSeconds, 2.0), timing);
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
        const auto status =
            channel_->send(protocol::encodeFinalize(window), std::min(config_.timeoutSeconds, 2.0), timing);
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
      rejectPeer("both participants are named '" + config_.name + "'; give them distinct names so errors and logs "
                 "say which side is meant", waitingFor);
    }
    if (!hello.couplingScheme.empty() && !config_.couplingScheme.empty() &&
        hello.couplingScheme != toString(parseCouplingScheme(config_.couplingScheme))) {
      rejectPeer("participant '" + hello.participantName + "' couples with the " + hello.couplingScheme +
                     " scheme but this side is configured for " + config_.couplingScheme +
                     "; both sides must use the same couplingScheme (the message order differs)",
                 waitingFor);
    }
    setPeerName(hello.participantName);
    peerScheme_ = hello.couplingScheme;
  }

  const std::string& peerScheme() const { return peerScheme_; }
  /// Whether either side named the implicit scheme (the handshake refused two different names).
  bool implicitScheme() const {
    return peerScheme_ == "implicit" ||
           (!config_.couplingScheme.empty() && parseCouplingScheme(config_.couplingScheme) == CouplingScheme::Implicit);
  }

  protocol::Hello ownHello() const {
    protocol::Hello hello;
    hello.role = role_;
    hello.participantName = config_.name;
    hello.unitSystem = "SI";
    // Sent in its canonical spelling, so the peer compares names, not spellings.
    hello.couplingScheme = config_.couplingScheme.empty() ? "" : toString(parseCouplingScheme(config_.couplingScheme));
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
  std::uint64_t nextForcesWindow = 0;      // window of the next Forces message expected
  std::uint64_t nextKinematicsWindow = 0;  // window of the next Kinematics message to send
  std::uint32_t forcesIteration = 0;       // implicit: pass of the forces received last
  bool kinematicsOwed = false;             // implicit: forces received, their kinematics not sent yet
};

FemParticipant::FemParticipant(ParticipantConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

FemParticipant::~FemParticipant() { impl_->link.finalizeQuietly(impl_->nextKinematicsWindow); }

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
  const protocol::Hello hello = link.decodeBody([&] { return protocol::decodeHello(header, frame.data()); }, waitingFor);
  link.checkHello(hello, protocol::Role::Dem, waitingFor);
  link.send(link.encode([&](auto buffer) { return protocol::encodeHello(link.ownHello(), protocol::protocolVersion, std::move(buffer)); }), "the Hello", false);
  link.send(link.encode([&](auto buffer) { return protocol::encodeMesh(mesh, femTimeStep, initial, std::move(buffer)); }), "the interface mesh", false);
  link.setNodeCount(mesh.nodeCount());
  link.setHandshakeDone();
  log(LogLevel::Info, link.self() + ": coupled with DEM participant '" + hello.participantName + "' on " +
                          link.config().endpoint + " (" + std::to_string(mesh.nodeCount()) + " interface nodes)");
}

std::optional<ForceMessage> FemParticipant::receiveForces() {
  Link& link = impl_->link;
  if (link.peerFinalized()) return std::nullopt;
  link.requireUsable("receiveForces()");
  if (impl_->kinematicsOwed) {
    link.fail("receiveForces: the kinematics of window " + std::to_string(impl_->nextForcesWindow - 1) + " (iteration " +
              std::to_string(impl_->forcesIteration) + ") were not sent yet; the implicit scheme answers every pass");
  }
  const std::string waitingFor = windowText("forces", impl_->nextForcesWindow);
  auto [frame, header] = link.receive(waitingFor, true);
  if (header.type == protocol::MessageType::Finalize) {
    link.decodeBody([&] { protocol::decodeFinalize(header); return 0; }, waitingFor);
    link.setPeerFinalized();
    log(LogLevel::Info, link.self() + ": " + link.peerLabel() + " finalized the run after " +
                            std::to_string(impl_->nextForcesWindow) + " windows");
    return std::nullopt;
  }
  if (link.implicitScheme()) {
    // Implicit: the next pass over the window just answered, or the first pass of the next window.
    const std::uint64_t next = impl_->nextForcesWindow;
    const bool nextWindow = header.window == next && header.iteration == 0;
    const bool repeat = next > 0 && header.window == next - 1 && header.iteration == impl_->forcesIteration + 1;
    if (header.type != protocol::MessageType::Forces || !(nextWindow || repeat)) {
      link.unexpected(header, "Forces for window " + std::to_string(next) + (next > 0 ? " or for window " +
                                  std::to_string(next - 1) + " (iteration " + std::to_string(impl_->forcesIteration + 1) + ")" : std::string()));
    }
  } else if (header.type != protocol::MessageType::Forces || header.window != impl_->nextForcesWindow || header.iteration != 0) {
    link.unexpected(header, "Forces for window " + std::to_string(impl_->nextForcesWindow));
  }
  ForceMessage message = link.decodeBody(
      [&] { return protocol::decodeForces(header, frame.data(), link.nodeCount()); }, waitingFor);
  if (message.iteration == 0) ++impl_->nextForcesWindow;
  impl_->forcesIteration = message.iteration;
  impl_->kinematicsOwed = link.implicitScheme();
  return message;
}

void FemParticipant::sendKinematics(std::uint64_t window, const NodalKinematics& kinematics) {
  Link& link = impl_->link;
  if (link.peerFinalized()) {
    throw PeerLostError(link.self() + ": " + link.peerLabel() + " already finalized the run; kinematics of window " +
                        std::to_string(window) + " have no receiver");
  }
  link.requireUsable("sendKinematics()");
  std::uint32_t iteration = 0;
  if (link.implicitScheme()) {
    // Implicit: kinematics answer the pass whose forces arrived last.
    if (!impl_->kinematicsOwed || window + 1 != impl_->nextForcesWindow) {
      link.fail("sendKinematics: window " + std::to_string(window) + " but the implicit scheme answers the forces received last (" +
                (impl_->nextForcesWindow > 0 && impl_->kinematicsOwed ? "window " + std::to_string(impl_->nextForcesWindow - 1)
                                                                       : std::string("none pending")) + ")");
    }
    iteration = impl_->forcesIteration;
  } else if (window != impl_->nextKinematicsWindow) {
    link.fail("sendKinematics: window " + std::to_string(window) + " but window " +
              std::to_string(impl_->nextKinematicsWindow) + " is next; windows go 0, 1, 2, ... without gaps");
  }
  // Just-in-time sends kinematics of window i after its forces, predictive one window before them.
  if (!link.implicitScheme() && window > impl_->nextForcesWindow) {
    link.fail("sendKinematics: window " + std::to_string(window) + " is more than one window ahead of the forces "
              "received so far (" + std::to_string(impl_->nextForcesWindow) + " windows)");
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
  link.send(link.encode([&](auto buffer) { return protocol::encodeKinematics(window, kinematics, std::move(buffer), iteration); }),
            windowText("kinematics", window), true);
  impl_->nextKinematicsWindow = window + 1;
  impl_->kinematicsOwed = false;
}

void FemParticipant::finalize() { impl_->link.finalizeQuietly(impl_->nextKinematicsWindow); }

void FemParticipant::abort(const std::string& reason) { impl_->link.abortQuietly(impl_->link.self() + ": " + reason); }

const BridgeStatistics& FemParticipant::statistics() const { return impl_->link.statistics(); }

// ---------------------------------------------------------------------------------------------- DEM side

struct DemParticipant::Impl {
  explicit Impl(ParticipantConfig config) : link(std::move(config), protocol::Role::Dem) {}
  Link link;
  std::uint64_t nextForcesWindow = 0;      // window of the next Forces message to send
  std::uint64_t nextKinematicsWindow = 0;  // window of the next Kinematics message expected
  std::uint32_t forcesIteration = 0;       // implicit: pass of the forces sent last
  bool kinematicsAwaited = false;          // implicit: forces sent, their kinematics not received yet
};

DemParticipant::DemParticipant(ParticipantConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

DemParticipant::~DemParticipant() { impl_->link.finalizeQuietly(impl_->nextForcesWindow); }

InterfaceSetup DemParticipant::initialize() {
  Link& link = impl_->link;
  if (link.open()) link.fail("initialize() called twice");
  link.openChannel(protocol::maxMessageBytes);  // the interface mesh is not known yet
  // Queued by ZeroMQ until the FEM side binds; the wait below obeys the timeout.
  link.send(link.encode([&](auto buffer) { return protocol::encodeHello(link.ownHello(), protocol::protocolVersion, std::move(buffer)); }), "the Hello", false);
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
    ++impl_->nextForcesWindow;
    return;
  }
  link.requireUsable("sendForces()");
  const bool implicit = link.implicitScheme();
  if (implicit) {
    const std::uint64_t next = impl_->nextForcesWindow;
    const bool nextWindow = message.window == next && message.iteration == 0;
    const bool repeat = next > 0 && message.window == next - 1 && message.iteration == impl_->forcesIteration + 1;
    if (impl_->kinematicsAwaited) {
      link.fail("sendForces: the kinematics of window " + std::to_string(next - 1) + " (iteration " +
                std::to_string(impl_->forcesIteration) + ") were not received yet; the implicit scheme alternates");
    }
    if (!nextWindow && !repeat) {
      link.fail("sendForces: window " + std::to_string(message.window) + " iteration " + std::to_string(message.iteration) +
                "; the implicit scheme continues with window " + std::to_string(next) + " iteration 0" +
                (next > 0 ? " or repeats window " + std::to_string(next - 1) + " as iteration " +
                                std::to_string(impl_->forcesIteration + 1) : std::string()));
    }
  } else if (message.iteration != 0) {
    link.fail("sendForces: iteration " + std::to_string(message.iteration) + " but only the implicit scheme repeats windows");
  } else if (message.window != impl_->nextForcesWindow) {
    link.fail("sendForces: window " + std::to_string(message.window) + " but window " +
              std::to_string(impl_->nextForcesWindow) + " is next; windows go 0, 1, 2, ... without gaps");
  }
  // Just-in-time sends forces of window i before its kinematics, predictive after them.
  if (!implicit && message.window > impl_->nextKinematicsWindow) {
    link.fail("sendForces: window " + std::to_string(message.window) + " is more than one window ahead of the "
              "kinematics received so far (" + std::to_string(impl_->nextKinematicsWindow) + " windows)");
  }
  if (message.forces.size() != 3 * link.nodeCount()) {
    link.fail("sendForces(window " + std::to_string(message.window) + "): forces has " +
              std::to_string(message.forces.size()) + " values, the interface needs 3 per node = " +
              std::to_string(3 * link.nodeCount()));
  }
  if (!std::isfinite(message.time)) link.fail("sendForces: time is not finite");
  link.send(link.encode([&](auto buffer) { return protocol::encodeForces(message, std::move(buffer)); }), windowText("forces", message.window), true);
  impl_->nextForcesWindow = message.window + 1;
  impl_->forcesIteration = message.iteration;
  impl_->kinematicsAwaited = implicit;
}

NodalKinematics DemParticipant::receiveKinematics(std::uint64_t window) {
  Link& link = impl_->link;
  link.requireUsable("receiveKinematics()");
  const bool implicit = link.implicitScheme();
  if (implicit) {
    if (!impl_->kinematicsAwaited || window + 1 != impl_->nextForcesWindow) {
      link.fail("receiveKinematics: window " + std::to_string(window) + " asked but the implicit scheme answers the forces sent last (" +
                (impl_->kinematicsAwaited ? "window " + std::to_string(impl_->nextForcesWindow - 1) : std::string("none sent")) + ")");
    }
  } else if (window != impl_->nextKinematicsWindow) {
    link.fail("receiveKinematics: window " + std::to_string(window) + " asked but window " +
              std::to_string(impl_->nextKinematicsWindow) + " is next");
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
  const std::uint32_t iteration = implicit ? impl_->forcesIteration : 0;
  if (header.type != protocol::MessageType::Kinematics || header.window != window || header.iteration != iteration) {
    link.unexpected(header, "Kinematics for window " + std::to_string(window) +
                                (iteration > 0 ? " (iteration " + std::to_string(iteration) + ")" : std::string()));
  }
  NodalKinematics kinematics = link.decodeBody(
      [&] { return protocol::decodeKinematics(header, frame.data(), link.nodeCount()); }, waitingFor);
  impl_->nextKinematicsWindow = window + 1;
  impl_->kinematicsAwaited = false;
  return kinematics;
}

void DemParticipant::finalize() { impl_->link.finalizeQuietly(impl_->nextForcesWindow); }

void DemParticipant::abort(const std::string& reason) { impl_->link.abortQuietly(impl_->link.self() + ": " + reason); }

const BridgeStatistics& DemParticipant::statistics() const { return impl_->link.statistics(); }

} // namespace railcosim
