// Window iteration of the implicit scheme: predictor, residual, convergence test, Aitken relaxation.
#include "railcosim/ImplicitCoupling.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

#include <cmath>
#include <sstream>

namespace railcosim {
namespace {

double rms(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v * v;
  return values.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(values.size()));
}

} // namespace

void ImplicitSettings::validate() const {
  std::ostringstream problem;
  if (!(tolerance > 0.0) || !std::isfinite(tolerance))
    problem << "tolerance " << tolerance << " must be positive";
  else if (!(absoluteTolerance >= 0.0) || !std::isfinite(absoluteTolerance))
    problem << "absoluteTolerance " << absoluteTolerance << " m must be >= 0";
  else if (maxIterations < 1)
    problem << "maxIterations " << maxIterations << " must be at least 1";
  else if (!(relaxation > 0.0 && relaxation <= 1.0))
    problem << "relaxation " << relaxation << " must lie in (0, 1]";
  if (!problem.str().empty()) throw Error("implicit coupling: " + problem.str());
}

ImplicitWindowIteration::ImplicitWindowIteration(ImplicitSettings settings, std::vector<double> referencePositions,
                                                 double windowLength)
    : settings_(settings), reference_(std::move(referencePositions)), windowLength_(windowLength) {
  settings_.validate();
  if (!(windowLength_ > 0.0)) throw Error("implicit coupling: the window length must be positive");
  if (reference_.empty() || reference_.size() % 3 != 0)
    throw Error("implicit coupling: reference positions need 3 values per node");
}

void ImplicitWindowIteration::startWindow(const NodalKinematics& accepted) {
  if (accepted.positions.size() != reference_.size()) {
    throw Error("implicit coupling: window start has " + std::to_string(accepted.positions.size()) +
                " position values, the interface " + std::to_string(reference_.size()));
  }
  accepted_ = accepted;
  // Predictor: the accepted state's own Taylor extrapolation over the window (exact for uniform acceleration).
  const double dt = windowLength_;
  assumed_ = accepted.positions;
  for (std::size_t k = 0; k < assumed_.size(); ++k) {
    if (!accepted.velocities.empty()) assumed_[k] += dt * accepted.velocities[k];
    if (!accepted.accelerations.empty()) assumed_[k] += 0.5 * dt * dt * accepted.accelerations[k];
  }
  iteration_ = 0;
  // Aitken: a window starts from the last factor of the previous one when that is a plain under-relaxation
  // (bed_under_block: 3.7 instead of 4.2 passes per window); otherwise from implicitRelaxation.
  omega_ = (settings_.aitken && omega_ > 0.0 && omega_ <= 1.0) ? omega_ : settings_.relaxation;
  residualNorm_ = 0.0;
  limit_ = 0.0;
  previousResidual_.clear();
  setSurface();
}

void ImplicitWindowIteration::setSurface() {
  surfaceStart_.time = accepted_.time;
  surfaceStart_.positions = accepted_.positions;
  surfaceStart_.velocities.resize(assumed_.size());
  for (std::size_t k = 0; k < assumed_.size(); ++k)
    surfaceStart_.velocities[k] = (assumed_[k] - accepted_.positions[k]) / windowLength_;
  surfaceStart_.accelerations.clear();
}

ImplicitWindowIteration::Outcome ImplicitWindowIteration::judge(const NodalKinematics& femEnd, bool surfaceTouched) {
  if (femEnd.positions.size() != assumed_.size()) throw Error("implicit coupling: FEM end state has the wrong size");
  residual_.resize(assumed_.size());
  double displacementSquares = 0.0;
  for (std::size_t k = 0; k < assumed_.size(); ++k) {
    residual_[k] = femEnd.positions[k] - assumed_[k];
    const double displacement = femEnd.positions[k] - reference_[k];
    displacementSquares += displacement * displacement;
  }
  residualNorm_ = rms(residual_);
  limit_ = settings_.tolerance * std::sqrt(displacementSquares / static_cast<double>(assumed_.size())) +
           settings_.absoluteTolerance;
  if (!surfaceTouched || residualNorm_ <= limit_) return Outcome::Converged;
  if (static_cast<int>(iteration_) + 1 >= settings_.maxIterations) return Outcome::GaveUp;
  if (settings_.aitken && !previousResidual_.empty()) {
    double numerator = 0.0, denominator = 0.0;
    for (std::size_t k = 0; k < residual_.size(); ++k) {
      const double change = residual_[k] - previousResidual_[k];
      numerator += previousResidual_[k] * change;
      denominator += change * change;
    }
    if (denominator > 0.0) omega_ = -omega_ * numerator / denominator;
  }
  for (std::size_t k = 0; k < assumed_.size(); ++k) assumed_[k] += omega_ * residual_[k];
  previousResidual_ = residual_;
  ++iteration_;
  setSurface();
  return Outcome::Repeat;
}

void ImplicitWindowIteration::writeState(StateWriter& state) const {
  state.section("implicit window iteration");
  state.reals(reference_);
  state.real(windowLength_);
  state.kinematics(accepted_);
  state.reals(assumed_);
  state.reals(residual_);
  state.reals(previousResidual_);
  state.kinematics(surfaceStart_);
  state.u64(iteration_);
  state.real(omega_);
  state.real(residualNorm_);
  state.real(limit_);
}

void ImplicitWindowIteration::readState(StateReader& state) {
  state.section("implicit window iteration");
  if (state.reals() != reference_) state.fail("the interface's reference positions differ from the saved ones");
  if (state.real() != windowLength_) state.fail("the window length differs from the saved one");
  accepted_ = state.kinematics();
  assumed_ = state.reals();
  residual_ = state.reals();
  previousResidual_ = state.reals();
  surfaceStart_ = state.kinematics();
  iteration_ = static_cast<std::uint32_t>(state.u64());
  omega_ = state.real();
  residualNorm_ = state.real();
  limit_ = state.real();
}

std::string toString(ImplicitWindowIteration::Outcome outcome) {
  switch (outcome) {
    case ImplicitWindowIteration::Outcome::Converged:
      return "Converged";
    case ImplicitWindowIteration::Outcome::Repeat:
      return "Repeat";
    case ImplicitWindowIteration::Outcome::GaveUp:
      return "GaveUp";
  }
  return "unknown";
}

} // namespace railcosim
