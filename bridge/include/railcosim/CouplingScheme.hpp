// Coupling schemes: the order of the messages and the window logic, behind one scheme-agnostic API per side.
#pragma once

#include "railcosim/BridgeTypes.hpp"
#include "railcosim/Checkpoint.hpp"

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace railcosim {

class DemParticipant;
class FemParticipant;
class StateReader;
class StateWriter;

/// The schemes of Ullrich 2022 (Sec. 3.4) and the implicit window iteration (docs/coupling-schemes.md).
enum class CouplingScheme {
  JustInTime, // DEM first; surface P + V*tau + A*tau^2/2 from the kinematics received at t_i (Ullrich 2022, Alg. 3)
  Predictive, // FEM first; surface moves linearly from P(t_i) to P(t_i+1): V = (P1-P0)/dt_F, A = 0 (eq. 3.4-3.7)
  Implicit,   // DEM first, window repeated until the FEM end state agrees with the DEM's (ImplicitCoupling.hpp)
};

/// "justInTime" | "predictive" | "implicit" (case-insensitive, also "just-in-time"); throws Error otherwise.
CouplingScheme parseCouplingScheme(const std::string& name);
/// Canonical spelling, as announced at the handshake.
std::string toString(CouplingScheme scheme);
/// The canonical names, comma-separated (for messages).
std::string knownCouplingSchemes();

/// Settings of the window iteration (serial, DEM first; Aitken relaxation of the interface positions).
struct ImplicitSettings {
  double tolerance = 1e-3; // relative: converged when rms|r| <= tolerance * rms|P_end - P_0| + absoluteTolerance
  double absoluteTolerance = 1e-14; // m, rms over the interface values; floor for a surface that has hardly moved
  int maxIterations = 30;           // passes per window; the last one is accepted and counted as not converged
  double relaxation = 0.5;          // ω of the first window's first correction (of every pass without Aitken; with
                           // Aitken, later windows start from the previous window's last ω if it lies in (0, 1])
  bool aitken = true;    // dynamic Aitken ω (Irons & Tuck; Küttler & Wall 2008)
  void validate() const; // throws Error naming the bad setting
};

/// A scheme and the settings of those schemes that have any.
struct SchemeSettings {
  CouplingScheme scheme = CouplingScheme::JustInTime;
  ImplicitSettings implicit; // read by the implicit scheme only
  void validate() const;     // throws Error naming the bad setting
  /// The settings a DEM driver exposes as six values (the scheme and ImplicitSettings' five), validated.
  static SchemeSettings of(CouplingScheme scheme, double tolerance, double absoluteTolerance, int maxIterations,
                           double relaxation, bool aitken);
};

/// How one window ended on the DEM side.
struct WindowResult {
  bool repeat = false;   // restore the checkpoint written at the window start and simulate the window again
  bool converged = true; // false: accepted after the scheme's last allowed pass without meeting its tolerance
  double femWork = 0.0;  // accepted window: sum of F_sent . (P_end - P_start) over the FEM step those forces drove [J]
};

/// Window iteration figures (zero for schemes that never repeat a window).
struct WindowIterationStatistics {
  long passes = 0;             // DEM passes over all windows (a window accepted at once counts 1)
  long lastWindowPasses = 0;   // passes of the last accepted window
  long maxWindowPasses = 0;    // most passes any window needed
  long unconvergedWindows = 0; // windows accepted without meeting the tolerance
  double lastResidual = 0.0;   // rms position residual of the last judged pass [m]
  double lastLimit = 0.0;      // the rms residual that pass had to reach [m]
};

/// DEM side of a coupling scheme. The DEM solver simulates one window at a time and asks the scheme
/// where the surface is; the scheme sends the forces, receives the FEM's answer in the scheme's order and
/// decides whether the window stands. Use:
///   scheme = DemCouplingScheme::create(settings, participant, setup);   // after participant.initialize()
///   loop: if (scheme->requiresWritingCheckpoint()) { save state; scheme->markCheckpointWritten(); }
///         each DEM step: scheme->surfaceAt(tau, P, V); ... gather forces
///         at the window end: r = scheme->completeWindow(forces, t, touched); if (r.repeat) restore state
/// Restart checkpoints (between two windows): files = scheme->orderRestart(name, t) has the FEM side save its part;
/// scheme->writeState(out) is the scheme's; a resumed run makes its scheme with resume() from that state.
class DemCouplingScheme {
public:
  /// The scheme `settings` names (the handshake already refused a FEM side configured for another one).
  /// May exchange messages (predictive: receives the FEM's first step).
  static std::unique_ptr<DemCouplingScheme> create(const SchemeSettings& settings, DemParticipant& participant,
                                                   const InterfaceSetup& setup);
  /// The scheme of a run resumed from a restart checkpoint: `state` is what writeState() wrote in the interrupted
  /// run; `participant` was initialized with ParticipantConfig::resumedFrom, and nothing is exchanged here. Throws
  /// CheckpointError if the state is of another scheme or the FEM side's window length differs from the saved one.
  static std::unique_ptr<DemCouplingScheme> resume(const SchemeSettings& settings, DemParticipant& participant,
                                                   const InterfaceSetup& setup, std::istream& state);
  virtual ~DemCouplingScheme();

  CouplingScheme scheme() const { return scheme_; }
  /// Surface positions [m] and velocities [m/s] `tau` seconds after the current window's start (3 per node).
  void surfaceAt(double tau, std::vector<double>& positions, std::vector<double>& velocities) const;
  /// The window about to be simulated may have to be repeated: save the DEM state now.
  bool requiresWritingCheckpoint() const { return checkpointDue_; }
  void markCheckpointWritten() { checkpointDue_ = false; }
  /// Sends the window's nodal forces [N] (force on the structure, 3 per node) stamped with `time` [s],
  /// receives the FEM's answer and judges it. `surfaceTouched`: whether any particle touched the surface
  /// during the window (a window without contact cannot depend on where the surface was assumed).
  WindowResult completeWindow(std::vector<double> forces, double time, bool surfaceTouched);
  std::uint64_t window() const { return window_; }      // index of the window being simulated
  virtual std::uint32_t iteration() const { return 0; } // pass over it (0 = first)
  /// FEM steps between the forces of window i and the step they drive (predictive: 1; the FEM's first
  /// step runs before any DEM force is known).
  virtual std::uint64_t forcesLag() const { return 0; }
  /// Whether a window can be repeated (then requiresWritingCheckpoint() comes true once per window).
  virtual bool iterates() const { return false; }
  const WindowIterationStatistics& iterationStatistics() const { return iterationStatistics_; }
  /// FEM state received last (the end of the window just completed, or of the first FEM step).
  const NodalKinematics& lastReceived() const { return lastReceived_; }
  /// Between two windows: orders the FEM side's part of restart checkpoint `name` (t_window = `time` [s]) and
  /// returns its files once they are written. The scheme's own part is writeState().
  std::vector<CheckpointFile> orderRestart(const std::string& name, double time);
  /// Everything the scheme needs to go on from this window boundary: the window, the surface motion, the FEM state
  /// received last, the statistics, and the scheme's own (implicit: the accepted state, Aitken's factor).
  void writeState(std::ostream& out) const;

protected:
  DemCouplingScheme(CouplingScheme scheme, DemParticipant& participant, const InterfaceSetup& setup);
  /// Scheme-specific half of completeWindow: exchange, judge, set the next window's surface motion.
  virtual WindowResult exchange(const ForceMessage& message, bool surfaceTouched) = 0;
  /// The scheme's own state beyond the base class's, in writeState() and resume().
  virtual void writeOwnState(StateWriter&) const {}
  virtual void readOwnState(StateReader&) {}
  /// Sum of F . (P_end - P_start) over the values of `forces`.
  static double work(const std::vector<double>& forces, const NodalKinematics& from, const NodalKinematics& to);

  DemParticipant& participant_;
  double windowLength_;         // s, the FEM time step
  NodalKinematics windowStart_; // surface motion of the current window: P + V tau + A tau^2/2
  NodalKinematics lastReceived_;
  bool checkpointDue_ = false;
  WindowIterationStatistics iterationStatistics_;

private:
  void readState(std::istream& in, const InterfaceSetup& setup);
  CouplingScheme scheme_;
  std::uint64_t window_ = 0;
};

/// FEM side of a coupling scheme. The FEM solver steps once per window; the scheme says which forces load
/// the step, whether to save or restore the solver state first, and when a solved step is final. Use:
///   scheme = FemCouplingScheme::create(participant);                    // after participant.initialize()
///   while ((action = scheme->beginStep(forces)) != Action::Stop) {
///     if (scheme->takeAcceptedStep()) record the previous step;
///     if (action == Action::SaveRestart) { save the solver state, scheme->writeState(); scheme->confirmRestart(files);
///                                          continue; }
///     if (scheme->requiresWritingCheckpoint()) save u, v, a, t;  if (scheme->requiresReadingCheckpoint()) restore;
///     solve with forces; scheme->endStep(kinematics at the step end);
///     if (scheme->takeAcceptedStep()) record this step;
///   }
///   if (scheme->takeAcceptedStep()) record the last step;
/// (requiresWritingCheckpoint: the implicit scheme's in-memory checkpoint for repeating a window; a restart
/// checkpoint, SaveRestart, is one on disk from which a new process goes on.)
class FemCouplingScheme {
public:
  /// What beginStep() asks of the FEM solver.
  enum class Action {
    Solve,       // solve the next step with the forces returned
    SaveRestart, // the DEM side ordered restart checkpoint restartOrder(): save the state, confirmRestart()
    Stop,        // the DEM side ended the run
  };

  /// The scheme agreed at the handshake (this side's, else the DEM side's, else just-in-time).
  static std::unique_ptr<FemCouplingScheme> create(FemParticipant& participant, std::size_t nodeCount);
  /// The scheme of a run resumed from a restart checkpoint (`state`: what writeState() wrote); `participant` was
  /// initialized with ParticipantConfig::resumedFrom. Throws CheckpointError for the state of another scheme.
  static std::unique_ptr<FemCouplingScheme> resume(FemParticipant& participant, std::size_t nodeCount,
                                                   std::istream& state);
  virtual ~FemCouplingScheme();

  CouplingScheme scheme() const { return scheme_; }
  /// Waits, if the scheme orders it, for the DEM side's next message: nodal forces [N] that load the next step
  /// (3 per node; Solve), a restart checkpoint to save (SaveRestart; forces untouched) or the end (Stop).
  virtual Action beginStep(std::vector<double>& forces) = 0;
  /// SaveRestart: the checkpoint to save (window, time, folder name).
  const CheckpointOrder& restartOrder() const { return restartOrder_; }
  /// SaveRestart: this side's files of the checkpoint are written; tells the DEM side which they are.
  void confirmRestart(const std::vector<CheckpointFile>& files);
  /// The scheme's state at this window boundary, for the restart checkpoint.
  void writeState(std::ostream& out) const;
  bool requiresWritingCheckpoint() const { return writeCheckpoint_; } // save the solver state before solving
  bool requiresReadingCheckpoint() const { return readCheckpoint_; }  // restore it before solving
  /// Sends the interface kinematics at the end of the step just solved.
  virtual void endStep(const NodalKinematics& end) = 0;
  /// Whether a solved step became final since the last call (then record it once).
  bool takeAcceptedStep();
  std::uint64_t window() const { return window_; }                   // window of the step being solved
  std::uint64_t windowsReceived() const { return windowsReceived_; } // windows the DEM side sent forces for
  double forcesTime() const { return forcesTime_; }                  // time stamp of the forces received last [s]
  std::uint32_t forcesIteration() const { return forcesIteration_; } // pass of the forces received last

protected:
  FemCouplingScheme(CouplingScheme scheme, FemParticipant& participant, std::size_t nodeCount);
  /// Receives the DEM side's next message: forces into `forces` (Solve), a restart order (SaveRestart) or the end.
  Action receive(std::vector<double>& forces);
  virtual void writeOwnState(StateWriter&) const {}
  virtual void readOwnState(StateReader&) {}

  FemParticipant& participant_;
  std::size_t nodeCount_;
  std::uint64_t window_ = 0;
  bool writeCheckpoint_ = false;
  bool readCheckpoint_ = false;
  bool acceptedPending_ = false;

private:
  void readState(std::istream& in);
  CouplingScheme scheme_;
  std::uint64_t windowsReceived_ = 0;
  double forcesTime_ = 0.0;
  std::uint32_t forcesIteration_ = 0;
  CheckpointOrder restartOrder_;
};

} // namespace railcosim
