// Just-in-time (Ullrich 2022, Alg. 3): the DEM simulates window i first, on the surface extrapolated from the FEM
// state at t_i; the FEM then steps with the window's end forces and answers with its state at t_i+1.
#include "cplscheme/SchemeRegistry.hpp"
#include "railcosim/Participant.hpp"

namespace railcosim::cplscheme {
namespace {

class JustInTimeDem : public DemCouplingScheme {
public:
  JustInTimeDem(DemParticipant& participant, const InterfaceSetup& setup)
      : DemCouplingScheme(CouplingScheme::JustInTime, participant, setup) {}

private:
  WindowResult exchange(const ForceMessage& message, bool) override {
    participant_.sendForces(message);
    NodalKinematics received = participant_.receiveKinematics(message.window);
    WindowResult result;
    result.femWork = work(message.forces, windowStart_, received);
    windowStart_ = received; // P + V tau + A tau^2/2 from the state at t_i+1
    lastReceived_ = std::move(received);
    return result;
  }
};

class JustInTimeFem : public FemCouplingScheme {
public:
  JustInTimeFem(FemParticipant& participant, std::size_t nodeCount)
      : FemCouplingScheme(CouplingScheme::JustInTime, participant, nodeCount) {}

  Action beginStep(std::vector<double>& forces) override { return receive(forces); }

  void endStep(const NodalKinematics& end) override {
    participant_.sendKinematics(window_, end);
    acceptedPending_ = true;
  }
};

std::unique_ptr<DemCouplingScheme> makeDem(const SchemeSettings&, DemParticipant& participant,
                                           const InterfaceSetup& setup, bool) {
  return std::make_unique<JustInTimeDem>(participant, setup);
}

std::unique_ptr<FemCouplingScheme> makeFem(FemParticipant& participant, std::size_t nodeCount) {
  return std::make_unique<JustInTimeFem>(participant, nodeCount);
}

std::unique_ptr<MessageOrder> makeOrder() { return std::make_unique<SequentialOrder>(); }

} // namespace

extern const SchemeEntry justInTimeEntry;
const SchemeEntry justInTimeEntry{CouplingScheme::JustInTime, makeDem, makeFem, makeOrder};

} // namespace railcosim::cplscheme
