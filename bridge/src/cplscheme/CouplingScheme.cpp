// What every coupling scheme shares: the surface motion of a window, the force message, acceptance bookkeeping.
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include <istream>
#include <ostream>
#include <utility>

namespace railcosim {

void SchemeSettings::validate() const {
  if (scheme == CouplingScheme::Implicit) implicit.validate();
}

SchemeSettings SchemeSettings::of(CouplingScheme scheme, double tolerance, double absoluteTolerance, int maxIterations,
                                  double relaxation, bool aitken) {
  SchemeSettings settings;
  settings.scheme = scheme;
  settings.implicit.tolerance = tolerance;
  settings.implicit.absoluteTolerance = absoluteTolerance;
  settings.implicit.maxIterations = maxIterations;
  settings.implicit.relaxation = relaxation;
  settings.implicit.aitken = aitken;
  settings.validate();
  return settings;
}

DemCouplingScheme::DemCouplingScheme(CouplingScheme scheme, DemParticipant& participant, const InterfaceSetup& setup)
    : participant_(participant),
      windowLength_(setup.femTimeStep),
      windowStart_(setup.initial),
      lastReceived_(setup.initial),
      scheme_(scheme) {
  if (!(windowLength_ > 0.0))
    throw Error("coupling scheme: the FEM side announced a window of " + std::to_string(windowLength_) + " s");
}

DemCouplingScheme::~DemCouplingScheme() = default;

void DemCouplingScheme::surfaceAt(double tau, std::vector<double>& positions, std::vector<double>& velocities) const {
  extrapolateSurface(windowStart_, tau, positions, velocities);
}

WindowResult DemCouplingScheme::completeWindow(std::vector<double> forces, double time, bool surfaceTouched) {
  ForceMessage message;
  message.window = window_;
  message.iteration = iteration();
  message.time = time;
  message.forces = std::move(forces); // taken by value: a caller done with its vector moves it in, no copy
  const WindowResult result = exchange(message, surfaceTouched);
  if (!result.repeat) {
    ++window_;
    checkpointDue_ = iterates();
  }
  return result;
}

std::vector<CheckpointFile> DemCouplingScheme::orderRestart(const std::string& name, double time) {
  // A window the implicit scheme repeats is not a boundary: the participant's message order refuses it.
  CheckpointOrder order;
  order.window = window_;
  order.time = time;
  order.name = name;
  return participant_.orderCheckpoint(order);
}

// Layout of a scheme's state: the scheme's name first, so that a state is never read into another scheme.
void DemCouplingScheme::writeState(std::ostream& out) const {
  StateWriter state(out);
  state.section("dem coupling scheme");
  state.text(toString(scheme_));
  state.u64(window_);
  state.real(windowLength_);
  state.kinematics(windowStart_);
  state.kinematics(lastReceived_);
  state.flag(checkpointDue_);
  const WindowIterationStatistics& s = iterationStatistics_;
  state.i64(s.passes);
  state.i64(s.lastWindowPasses);
  state.i64(s.maxWindowPasses);
  state.i64(s.unconvergedWindows);
  state.real(s.lastResidual);
  state.real(s.lastLimit);
  state.section("dem " + toString(scheme_));
  writeOwnState(state);
  state.section("end");
}

void DemCouplingScheme::readState(std::istream& in, const InterfaceSetup& setup) {
  StateReader state(in, "of the DEM coupling scheme");
  state.section("dem coupling scheme");
  const std::string saved = state.text();
  if (saved != toString(scheme_))
    throw CheckpointError("the checkpoint's DEM side coupled with the " + saved + " scheme, this run with the " +
                          toString(scheme_) + " scheme; resume with the scheme of the interrupted run");
  window_ = state.u64();
  windowLength_ = state.real();
  if (windowLength_ != setup.femTimeStep)
    throw CheckpointError("the FEM side's window is " + std::to_string(setup.femTimeStep) + " s, the checkpoint's " +
                          std::to_string(windowLength_) + " s; resume with the FEM time step of the interrupted run");
  windowStart_ = state.kinematics();
  lastReceived_ = state.kinematics();
  checkpointDue_ = state.flag();
  WindowIterationStatistics& s = iterationStatistics_;
  s.passes = state.i64();
  s.lastWindowPasses = state.i64();
  s.maxWindowPasses = state.i64();
  s.unconvergedWindows = state.i64();
  s.lastResidual = state.real();
  s.lastLimit = state.real();
  state.section("dem " + toString(scheme_));
  readOwnState(state);
  state.section("end");
  if (windowStart_.positions.size() != setup.mesh.coordinates.size())
    throw CheckpointError("the checkpoint's interface has " + std::to_string(windowStart_.positions.size() / 3) +
                          " nodes, the FEM side's " + std::to_string(setup.mesh.nodeCount()) +
                          "; resume with the structure of the interrupted run");
}

double DemCouplingScheme::work(const std::vector<double>& forces, const NodalKinematics& from,
                               const NodalKinematics& to) {
  double sum = 0.0;
  for (std::size_t k = 0; k < forces.size(); ++k) sum += forces[k] * (to.positions[k] - from.positions[k]);
  return sum;
}

FemCouplingScheme::FemCouplingScheme(CouplingScheme scheme, FemParticipant& participant, std::size_t nodeCount)
    : participant_(participant), nodeCount_(nodeCount), scheme_(scheme) {}

FemCouplingScheme::~FemCouplingScheme() = default;

bool FemCouplingScheme::takeAcceptedStep() {
  const bool accepted = acceptedPending_;
  acceptedPending_ = false;
  return accepted;
}

FemCouplingScheme::Action FemCouplingScheme::receive(std::vector<double>& forces) {
  FemIncoming incoming = participant_.receive();
  if (incoming.kind == FemIncoming::Kind::Finalized) return Action::Stop;
  if (incoming.kind == FemIncoming::Kind::Checkpoint) {
    restartOrder_ = incoming.checkpoint;
    return Action::SaveRestart;
  }
  ForceMessage& message = incoming.forces;
  forces = std::move(message.forces);
  forcesTime_ = message.time;
  forcesIteration_ = message.iteration;
  window_ = message.window;
  windowsReceived_ = message.window + 1;
  return Action::Solve;
}

void FemCouplingScheme::confirmRestart(const std::vector<CheckpointFile>& files) {
  participant_.confirmCheckpoint(restartOrder_.window, files);
}

void FemCouplingScheme::writeState(std::ostream& out) const {
  StateWriter state(out);
  state.section("fem coupling scheme");
  state.text(toString(scheme_));
  state.u64(window_);
  state.u64(windowsReceived_);
  state.real(forcesTime_);
  state.u64(forcesIteration_);
  state.flag(writeCheckpoint_);
  state.flag(readCheckpoint_);
  state.flag(acceptedPending_);
  state.section("fem " + toString(scheme_));
  writeOwnState(state);
  state.section("end");
}

void FemCouplingScheme::readState(std::istream& in) {
  StateReader state(in, "of the FEM coupling scheme");
  state.section("fem coupling scheme");
  const std::string saved = state.text();
  if (saved != toString(scheme_))
    throw CheckpointError("the checkpoint's FEM side coupled with the " + saved + " scheme, this run with the " +
                          toString(scheme_) + " scheme; resume with the scheme of the interrupted run");
  window_ = state.u64();
  windowsReceived_ = state.u64();
  forcesTime_ = state.real();
  forcesIteration_ = static_cast<std::uint32_t>(state.u64());
  writeCheckpoint_ = state.flag();
  readCheckpoint_ = state.flag();
  acceptedPending_ = state.flag();
  state.section("fem " + toString(scheme_));
  readOwnState(state);
  state.section("end");
}

} // namespace railcosim
