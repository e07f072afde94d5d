// Implicit (serial, DEM first): a window is repeated from its start until the FEM end state agrees with the
// one the DEM moved the surface to (ImplicitWindowIteration: predictor, residual, Aitken relaxation).
#include "cplscheme/SchemeRegistry.hpp"
#include "railcosim/ImplicitCoupling.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"

#include <algorithm>

namespace railcosim::cplscheme {
namespace {

class ImplicitDem : public DemCouplingScheme {
public:
  ImplicitDem(const ImplicitSettings& settings, DemParticipant& participant, const InterfaceSetup& setup)
      : DemCouplingScheme(CouplingScheme::Implicit, participant, setup),
        iteration_(settings, setup.mesh.coordinates, setup.femTimeStep),
        accepted_(setup.initial) {
    iteration_.startWindow(accepted_);
    windowStart_ = iteration_.surfaceStart();
    checkpointDue_ = true;
  }

  std::uint32_t iteration() const override { return iteration_.iteration(); }
  bool iterates() const override { return true; }

private:
  void writeOwnState(StateWriter& state) const override {
    state.kinematics(accepted_);
    iteration_.writeState(state);
  }
  void readOwnState(StateReader& state) override {
    accepted_ = state.kinematics();
    iteration_.readState(state);
  }

  WindowResult exchange(const ForceMessage& message, bool surfaceTouched) override {
    participant_.sendForces(message);
    lastReceived_ = participant_.receiveKinematics(message.window);
    const auto outcome = iteration_.judge(lastReceived_, surfaceTouched);
    WindowIterationStatistics& s = iterationStatistics_;
    ++s.passes;
    s.lastResidual = iteration_.residualNorm();
    s.lastLimit = iteration_.convergenceLimit();
    WindowResult result;
    if (outcome == ImplicitWindowIteration::Outcome::Repeat) {
      windowStart_ = iteration_.surfaceStart();
      result.repeat = true;
      return result;
    }
    s.lastWindowPasses = static_cast<long>(iteration_.iteration()) + 1;
    s.maxWindowPasses = std::max(s.maxWindowPasses, s.lastWindowPasses);
    if (outcome == ImplicitWindowIteration::Outcome::GaveUp) {
      result.converged = false;
      ++s.unconvergedWindows;
    }
    // Every pass restarts the FEM from the accepted state at t_i.
    result.femWork = work(message.forces, accepted_, lastReceived_);
    accepted_ = lastReceived_;
    iteration_.startWindow(accepted_);
    windowStart_ = iteration_.surfaceStart();
    return result;
  }

  ImplicitWindowIteration iteration_;
  NodalKinematics accepted_; // FEM state at the start of the current window
};

class ImplicitFem : public FemCouplingScheme {
public:
  ImplicitFem(FemParticipant& participant, std::size_t nodeCount)
      : FemCouplingScheme(CouplingScheme::Implicit, participant, nodeCount) {}

  Action beginStep(std::vector<double>& forces) override {
    writeCheckpoint_ = readCheckpoint_ = false;
    // The DEM side finalizes after an accepted window or inside a later one; the last solved pass stands
    // (when it stopped during a repeated window, that pass was not judged converged). A restart checkpoint is
    // ordered only at a window boundary: the DEM side accepted the last pass.
    const Action action = receive(forces);
    if (action != Action::Solve) {
      acceptSolved();
      return action;
    }
    // Pass 0 of a window accepts the previous pass and starts from its state; a later pass solves the same
    // window again from that state with the DEM's new forces.
    if (forcesIteration() == 0) {
      acceptSolved();
      writeCheckpoint_ = true;
    } else {
      readCheckpoint_ = true;
    }
    return Action::Solve;
  }

  void endStep(const NodalKinematics& end) override {
    participant_.sendKinematics(window_, end);
    solved_ = true; // final once the DEM side accepts it
  }

private:
  void writeOwnState(StateWriter& state) const override { state.flag(solved_); }
  void readOwnState(StateReader& state) override { solved_ = state.flag(); }

  void acceptSolved() {
    if (solved_) acceptedPending_ = true;
    solved_ = false;
  }

  bool solved_ = false;
};

/// Forces and Kinematics alternate; Forces either repeat the window answered last (iteration k+1) or open
/// the next one (iteration 0).
class ImplicitOrder : public MessageOrder {
public:
  std::string forcesBlockedBecause() const override {
    if (!owed_) return {};
    return "the kinematics of window " + std::to_string(nextForces_ - 1) + " (iteration " + std::to_string(iteration_) +
           ") were not exchanged yet; the implicit scheme alternates forces and kinematics";
  }
  bool forcesAllowed(std::uint64_t window, std::uint32_t iteration) const override {
    const bool next = window == nextForces_ && iteration == 0;
    const bool repeat = !closed_ && nextForces_ > 0 && window == nextForces_ - 1 && iteration == iteration_ + 1;
    return !owed_ && (next || repeat);
  }
  std::string expectedForces() const override {
    std::string text = "window " + std::to_string(nextForces_);
    if (nextForces_ > 0 && !closed_) {
      text +=
          " or for window " + std::to_string(nextForces_ - 1) + " (iteration " + std::to_string(iteration_ + 1) + ")";
    }
    return text;
  }
  void forcesExchanged(std::uint64_t window, std::uint32_t iteration) override {
    if (iteration == 0) nextForces_ = window + 1;
    iteration_ = iteration;
    owed_ = true;
    closed_ = false;
  }
  bool kinematicsAllowed(std::uint64_t window) const override { return owed_ && window + 1 == nextForces_; }
  std::string expectedKinematics() const override {
    if (!owed_) return "none: no forces wait for an answer";
    return "window " + std::to_string(nextForces_ - 1) + " (iteration " + std::to_string(iteration_) + ")";
  }
  std::uint32_t kinematicsIteration() const override { return iteration_; }
  void kinematicsExchanged(std::uint64_t window) override {
    nextKinematics_ = window + 1;
    owed_ = false;
  }
  bool checkpointAllowed(std::uint64_t window) const override { return !owed_ && window == nextForces_; }
  void checkpointExchanged(std::uint64_t) override { closed_ = true; }
  void resumeAt(std::uint64_t window) override {
    nextForces_ = nextKinematics_ = window;
    iteration_ = 0;
    owed_ = false;
    closed_ = true;
  }

private:
  std::uint32_t iteration_ = 0; // pass of the forces exchanged last
  bool owed_ = false;           // forces exchanged, their kinematics not yet
  bool closed_ = false;         // a checkpoint accepted the last window: only the next one may follow
};

std::unique_ptr<DemCouplingScheme> makeDem(const SchemeSettings& settings, DemParticipant& participant,
                                           const InterfaceSetup& setup, bool) {
  return std::make_unique<ImplicitDem>(settings.implicit, participant, setup);
}

std::unique_ptr<FemCouplingScheme> makeFem(FemParticipant& participant, std::size_t nodeCount) {
  return std::make_unique<ImplicitFem>(participant, nodeCount);
}

std::unique_ptr<MessageOrder> makeOrder() { return std::make_unique<ImplicitOrder>(); }

} // namespace

extern const SchemeEntry implicitEntry;
const SchemeEntry implicitEntry{CouplingScheme::Implicit, makeDem, makeFem, makeOrder};

} // namespace railcosim::cplscheme
