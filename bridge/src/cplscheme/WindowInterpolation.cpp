// Surface motion inside a coupling window (Taylor extrapolation of a window-start state, predictive linear motion).
#include "railcosim/WindowInterpolation.hpp"
#include "railcosim/Error.hpp"

#include <cmath>
#include <sstream>

namespace railcosim {

void extrapolateSurface(const NodalKinematics& start, double tau, std::vector<double>& positions,
                        std::vector<double>& velocities) {
  const std::size_t size = start.positions.size();
  const bool hasVelocity = !start.velocities.empty();
  const bool hasAcceleration = !start.accelerations.empty();
  if ((hasVelocity && start.velocities.size() != size) || (hasAcceleration && start.accelerations.size() != size)) {
    std::ostringstream message;
    message << "extrapolateSurface: positions has " << size << " values, velocities " << start.velocities.size()
            << ", accelerations " << start.accelerations.size() << "; each must match positions or be empty";
    throw Error(message.str());
  }
  positions.resize(size);
  velocities.resize(size);
  const double halfTauSquared = 0.5 * tau * tau;
  for (std::size_t i = 0; i < size; ++i) {
    const double velocity = hasVelocity ? start.velocities[i] : 0.0;
    const double acceleration = hasAcceleration ? start.accelerations[i] : 0.0;
    positions[i] = start.positions[i] + velocity * tau + acceleration * halfTauSquared;
    velocities[i] = velocity + acceleration * tau;
  }
}

NodalKinematics predictiveStart(const NodalKinematics& atStart, const NodalKinematics& atEnd, double femTimeStep) {
  if (!(femTimeStep > 0.0) || !std::isfinite(femTimeStep)) {
    std::ostringstream message;
    message << "predictiveStart: femTimeStep = " << femTimeStep << " s; it must be positive and finite";
    throw Error(message.str());
  }
  if (atStart.positions.size() != atEnd.positions.size()) {
    std::ostringstream message;
    message << "predictiveStart: window-start positions have " << atStart.positions.size()
            << " values, window-end positions " << atEnd.positions.size() << "; they must describe the same nodes";
    throw Error(message.str());
  }
  NodalKinematics start;
  start.time = atStart.time;
  start.positions = atStart.positions;
  start.velocities.resize(atStart.positions.size());
  for (std::size_t i = 0; i < atStart.positions.size(); ++i) {
    start.velocities[i] = (atEnd.positions[i] - atStart.positions[i]) / femTimeStep;
  }
  start.accelerations.assign(atStart.positions.size(), 0.0);
  return start;
}

} // namespace railcosim
