// Message order of the schemes that never repeat a window.
#include "cplscheme/MessageOrder.hpp"

namespace railcosim::cplscheme {

bool SequentialOrder::forcesAllowed(std::uint64_t window, std::uint32_t iteration) const {
  return iteration == 0 && window == nextForces_ && window <= nextKinematics_;
}

std::string SequentialOrder::expectedForces() const {
  std::string text = "window " + std::to_string(nextForces_);
  if (nextForces_ > nextKinematics_) {
    text += " once the kinematics of window " + std::to_string(nextKinematics_) +
            " are exchanged (a side may be one window ahead, not more)";
  }
  return text;
}

void SequentialOrder::forcesExchanged(std::uint64_t window, std::uint32_t) { nextForces_ = window + 1; }

bool SequentialOrder::kinematicsAllowed(std::uint64_t window) const {
  return window == nextKinematics_ && window <= nextForces_;
}

std::string SequentialOrder::expectedKinematics() const {
  std::string text = "window " + std::to_string(nextKinematics_);
  if (nextKinematics_ > nextForces_) {
    text += " once the forces of window " + std::to_string(nextForces_) +
            " are exchanged (a side may be one window ahead, not more)";
  }
  return text;
}

void SequentialOrder::kinematicsExchanged(std::uint64_t window) { nextKinematics_ = window + 1; }

bool SequentialOrder::checkpointAllowed(std::uint64_t window) const {
  return window == nextForces_ && nextKinematics_ == nextForces_ + lead_;
}

void SequentialOrder::resumeAt(std::uint64_t window) {
  nextForces_ = window;
  nextKinematics_ = window + lead_;
}

std::string MessageOrder::expectedCheckpoint() const {
  return "window " + std::to_string(nextForces_) +
         " (a checkpoint is taken at a window boundary: every Forces answered, the next Forces not yet sent)";
}

} // namespace railcosim::cplscheme
