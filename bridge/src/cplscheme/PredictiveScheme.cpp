// Predictive (Ullrich 2022, Sec. 3.4): the FEM steps first with the previous window's forces (none for its first
// step); the DEM then moves the surface linearly between the FEM positions at the window ends (eq. 3.4-3.7).
#include "cplscheme/SchemeRegistry.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"
#include "railcosim/WindowInterpolation.hpp"

namespace railcosim::cplscheme {
namespace {

class PredictiveDem : public DemCouplingScheme {
public:
  PredictiveDem(DemParticipant& participant, const InterfaceSetup& setup, bool fresh)
      : DemCouplingScheme(CouplingScheme::Predictive, participant, setup) {
    if (!fresh) return; // resumed: the state comes from the checkpoint
    // The FEM has already stepped to t_1 with zero interface force and sent that state.
    lastReceived_ = participant_.receiveKinematics(0);
    windowStart_ = predictiveStart(setup.initial, lastReceived_, windowLength_);
  }

  std::uint64_t forcesLag() const override { return 1; }

private:
  WindowResult exchange(const ForceMessage& message, bool) override {
    participant_.sendForces(message);
    NodalKinematics received = participant_.receiveKinematics(message.window + 1);
    WindowResult result;
    // The forces drive the FEM step from t_i+1 (received last) to t_i+2.
    result.femWork = work(message.forces, lastReceived_, received);
    windowStart_ = predictiveStart(lastReceived_, received, windowLength_);
    lastReceived_ = std::move(received);
    return result;
  }
};

class PredictiveFem : public FemCouplingScheme {
public:
  PredictiveFem(FemParticipant& participant, std::size_t nodeCount)
      : FemCouplingScheme(CouplingScheme::Predictive, participant, nodeCount) {}

  Action beginStep(std::vector<double>& forces) override {
    if (!started_) {
      started_ = true;
      forces.assign(3 * nodeCount_, 0.0); // the first step runs before any DEM force exists
      return Action::Solve;
    }
    const Action action = receive(forces); // Stop: the last solved step stays, it ran on valid forces
    if (action == Action::Solve) window_ = windowsReceived(); // the forces of window i load the step of window i+1
    return action;
  }

  void endStep(const NodalKinematics& end) override {
    participant_.sendKinematics(window_, end);
    acceptedPending_ = true;
  }

private:
  void writeOwnState(StateWriter& state) const override { state.flag(started_); }
  void readOwnState(StateReader& state) override { started_ = state.flag(); }

  bool started_ = false;
};

std::unique_ptr<DemCouplingScheme> makeDem(const SchemeSettings&, DemParticipant& participant,
                                           const InterfaceSetup& setup, bool fresh) {
  return std::make_unique<PredictiveDem>(participant, setup, fresh);
}

std::unique_ptr<FemCouplingScheme> makeFem(FemParticipant& participant, std::size_t nodeCount) {
  return std::make_unique<PredictiveFem>(participant, nodeCount);
}

std::unique_ptr<MessageOrder> makeOrder() { return std::make_unique<SequentialOrder>(1); }

} // namespace

extern const SchemeEntry predictiveEntry;
const SchemeEntry predictiveEntry{CouplingScheme::Predictive, makeDem, makeFem, makeOrder};

} // namespace railcosim::cplscheme
