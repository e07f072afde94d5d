// Facade of the bridge: one FEM and one DEM participant exchanging interface data over ZeroMQ.
#pragma once

#include "railcosim/BridgeTypes.hpp"
#include "railcosim/Checkpoint.hpp"

#include <memory>
#include <optional>
#include <string>

namespace railcosim {

/// What the DEM side sent the FEM side next (FemParticipant::receive).
struct FemIncoming {
  enum class Kind { Forces, Checkpoint, Finalized };
  Kind kind = Kind::Finalized;
  ForceMessage forces;        // Kind::Forces
  CheckpointOrder checkpoint; // Kind::Checkpoint: save the state now, then confirmCheckpoint()
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
  /// A restart checkpoint ordered by the DEM side is refused here (this call has no way to report it): a FEM
  /// side that can save its state reads with receive().
  std::optional<ForceMessage> receiveForces();
  /// The DEM side's next message: forces as receiveForces() returns them, the end of the run, or a restart
  /// checkpoint to save (at a window boundary; the state to save is the one after the last kinematics sent).
  FemIncoming receive();
  /// Tells the DEM side that this side's files of checkpoint `window` are written (and which they are).
  void confirmCheckpoint(std::uint64_t window, const std::vector<CheckpointFile>& files);
  /// Kinematics at the end of window `window` (time t_i+1). Implicit scheme: answers the pass
  /// whose forces were received last (same window, same iteration).
  void sendKinematics(std::uint64_t window, const NodalKinematics& kinematics);
  /// Tells the peer the run ended normally. Idempotent; also called by the destructor.
  void finalize();
  /// Tells the peer this side failed, with the reason (the peer throws PeerLostError quoting it).
  void abort(const std::string& reason);
  const BridgeStatistics& statistics() const;
  /// The coupling scheme agreed at the handshake: this side's ParticipantConfig::couplingScheme, else the
  /// DEM side's, else "" (none named: just-in-time's message order applies).
  std::string couplingScheme() const;

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
  /// Restart checkpoint at the boundary of window `order.window` (every Forces sent so far answered, the next not
  /// sent yet): orders the FEM side to save its state into checkpoint `order.name` and returns its files once it has.
  std::vector<CheckpointFile> orderCheckpoint(const CheckpointOrder& order);
  void finalize();
  void abort(const std::string& reason);
  const BridgeStatistics& statistics() const;
  /// The coupling scheme agreed at the handshake (this side's, else the FEM side's, else "").
  std::string couplingScheme() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace railcosim
