// What every coupling scheme shares: the surface motion of a window, the force message, acceptance bookkeeping.
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include <utility>

namespace railcosim {

void SchemeSettings::validate() const {
  if (scheme == CouplingScheme::Implicit) implicit.validate();
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

bool FemCouplingScheme::receive(std::vector<double>& forces) {
  const auto message = participant_.receiveForces();
  if (!message) return false;
  forces = message->forces;
  forcesTime_ = message->time;
  forcesIteration_ = message->iteration;
  window_ = message->window;
  windowsReceived_ = message->window + 1;
  return true;
}

} // namespace railcosim
