// Facade of the bridge: one FEM and one DEM participant exchanging interface data over ZeroMQ.
#pragma once

#include "railcosim/InterfaceMesh.hpp"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace railcosim {

/// How a participant reaches its peer. The FEM side binds, the DEM side connects; either may start
/// first (the connecting side retries until the peer appears or `timeoutSeconds` passes). A tcp endpoint
/// written with host '*' binds to 127.0.0.1 only.
struct ParticipantConfig {
  std::string name;                 // this participant, e.g. "fem" (printed in every error)
  std::string endpoint;             // ZeroMQ endpoint, e.g. "ipc:///tmp/railcosim-1234.sock" or "tcp://127.0.0.1:5555"
  double timeoutSeconds = 60.0;     // longest wait for any expected message before PeerLostError
  double heartbeatSeconds = 1.0;    // transport heartbeat: a frozen or dead peer is detected in ~3x this
  std::string couplingScheme;       // optional "justInTime" | "predictive" | "implicit": announced at the handshake;
                                    // when both sides name one, a mismatch is refused there
  std::string token;                // run secret shared by both sides (empty: the environment variable
                                    // RAILCOSIM_BRIDGE_TOKEN, else none); the FEM side admits only the first
                                    // participant presenting it, and binding a non-loopback tcp host needs one
};

/// What the DEM side learns at the handshake.
struct InterfaceSetup {
  std::string peerName;             // the FEM participant's name
  InterfaceMesh mesh;               // surface nodes + triangles at t = 0
  double femTimeStep = 0.0;         // s; the coupling window length
  NodalKinematics initial;          // kinematics at t = 0
  std::string couplingScheme;       // the FEM side's ParticipantConfig::couplingScheme ("" if it named none)
};

/// Nodal forces of one coupling window (DEM -> FEM).
struct ForceMessage {
  std::uint64_t window = 0;         // window index i: forces for the step t_i -> t_i+1
  std::uint32_t iteration = 0;      // implicit scheme: pass k over window i (0 = first); other schemes: 0
  double time = 0.0;                // s, the time the forces refer to
  std::vector<double> forces;       // N, 3 per interface node
};

/// Time spent inside the bridge, for the cost report. Waiting for the peer is counted separately.
struct BridgeStatistics {
  std::uint64_t exchanges = 0;      // messages sent + received after the handshake
  std::uint64_t bytes = 0;          // payload bytes sent + received
  double encodeSeconds = 0.0;       // packing and unpacking messages
  double transferSeconds = 0.0;     // inside ZeroMQ send/receive calls once the message is available
  double waitSeconds = 0.0;         // waiting for the peer's message to arrive (peer computing)
  double bridgeSeconds() const { return encodeSeconds + transferSeconds; }
};

/// FEM side: sends the mesh, then per window receives forces and returns kinematics.
class FemParticipant {
public:
  explicit FemParticipant(ParticipantConfig config);
  ~FemParticipant();
  FemParticipant(const FemParticipant&) = delete;
  FemParticipant& operator=(const FemParticipant&) = delete;

  /// Handshake: exchanges hello messages (protocol version, names, units), sends mesh, window
  /// length and initial kinematics. Throws PeerLostError if no DEM participant answers in time.
  void initialize(const InterfaceMesh& mesh, double femTimeStep, const NodalKinematics& initial);
  /// Next window's forces, or std::nullopt once the DEM side has finalized (run over).
  /// Implicit scheme: the forces of the next pass over the same window (iteration k+1) or of the
  /// next window (iteration 0, meaning the last pass converged: keep its state, step on).
  std::optional<ForceMessage> receiveForces();
  /// Kinematics at the end of window `window` (time t_i+1). Implicit scheme: answers the pass
  /// whose forces were received last (same window, same iteration).
  void sendKinematics(std::uint64_t window, const NodalKinematics& kinematics);
  /// Tells the peer the run ended normally. Idempotent; also called by the destructor.
  void finalize();
  /// Tells the peer this side failed, with the reason (the peer throws PeerLostError quoting it).
  void abort(const std::string& reason);
  const BridgeStatistics& statistics() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// DEM side: receives the mesh, then per window sends forces and receives kinematics.
class DemParticipant {
public:
  explicit DemParticipant(ParticipantConfig config);
  ~DemParticipant();
  DemParticipant(const DemParticipant&) = delete;
  DemParticipant& operator=(const DemParticipant&) = delete;

  InterfaceSetup initialize();
  /// Implicit scheme: after the kinematics of (window i, iteration k) came back, either send
  /// (i, k+1) to repeat the window or (i+1, 0) to accept it. Other schemes: iteration 0 only.
  void sendForces(const ForceMessage& message);
  /// Kinematics for window `window` (implicit: of the pass just sent); throws PeerLostError if the
  /// FEM side finalized or vanished.
  NodalKinematics receiveKinematics(std::uint64_t window);
  void finalize();
  void abort(const std::string& reason);
  const BridgeStatistics& statistics() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace railcosim
