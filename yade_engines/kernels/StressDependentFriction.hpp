// Stress-dependent friction coefficient for cluster–cluster contacts (Irazábal 2017 §6.3.4, eqs. 6.3–6.9).
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "railcosim/HostDevice.hpp"
#include "kernels/MathConstants.hpp"

namespace railcosim::kernels {

// Parameters of the friction-coefficient sub-model. The reduction is active only when both
// maxContactStress > 0 and frictionExponent < 0; otherwise μ = μ0 (plain Coulomb).
struct StressDependentFrictionParams {
  double baseFrictionCoefficient; // μ0 [-], unconfined friction (thesis: 0.6 from the angle of repose)
  double frictionExponent;        // γ ≤ 0 [-] (thesis calibration: −0.15)
  double maxContactStress;        // σ_c,max [Pa], peak Hertz pressure above which μ drops (thesis: 5.17 MPa)
};

// Critical normal force of one contact, F_n,c = (2/3) π R* δ σ_c,max (eq. 6.4): the force at which the
// Hertz peak pressure σ0 = 3F/(2π R* δ) (eq. 6.3) equals σ_c,max. [N]
RAILCOSIM_HOST_DEVICE inline double criticalNormalForce(const StressDependentFrictionParams& p, double effectiveRadius,
                                                        double overlap) {
  return (2.0 / 3.0) * pi * effectiveRadius * overlap * p.maxContactStress;
}

// μ = μ0 for F_n ≤ F_n,c and μ = μ0 (F_n/F_n,c)^γ above (eq. 6.6). F_n is the total normal force
// (elastic + viscous, ≥ 0), as in the thesis author's own implementation.
// Scope: the caller applies it between members of DIFFERENT clusters only; cluster–wall and sphere
// contacts keep μ0 (thesis §6.3.4, Fig. 6.15).
RAILCOSIM_HOST_DEVICE inline double stressDependentFrictionCoefficient(const StressDependentFrictionParams& p,
                                                                       double effectiveRadius, double overlap,
                                                                       double normalForce) {
  if (!(p.maxContactStress > 0.0) || !(p.frictionExponent < 0.0) || overlap <= 0.0) return p.baseFrictionCoefficient;
  const double critical = criticalNormalForce(p, effectiveRadius, overlap);
  if (normalForce <= critical) return p.baseFrictionCoefficient;
  return p.baseFrictionCoefficient * std::pow(normalForce / critical, p.frictionExponent);
}

// σ_c,max from the weight of one mean particle resting on one contact (eqs. 6.7–6.9):
// F = g ρ V, δ = [3F/(4E*√R*)]^{2/3}, σ_c,max = 3F/(2π R* δ). Inputs: mean cluster volume [m³],
// density [kg/m³], gravity magnitude [m/s²], E* [Pa] and R* [m] of the mean sub-sphere pair. [Pa]
RAILCOSIM_HOST_DEVICE inline double maxContactStressFromParticleWeight(double meanParticleVolume, double density,
                                                                       double gravity, double effectiveYoungModulus,
                                                                       double effectiveRadius) {
  const double weight = gravity * density * meanParticleVolume;
  const double overlap = std::pow(3.0 * weight / (4.0 * effectiveYoungModulus * std::sqrt(effectiveRadius)), 2.0 / 3.0);
  return 3.0 * weight / (2.0 * pi * effectiveRadius * overlap);
}

// Host-only validation (throws std::invalid_argument with the offending value).
inline void validate(const StressDependentFrictionParams& p, const char* where = "StressDependentFrictionParams") {
  std::ostringstream message;
  if (!(p.baseFrictionCoefficient >= 0.0) || std::isinf(p.baseFrictionCoefficient))
    message << "baseFrictionCoefficient must be finite and >= 0, got " << p.baseFrictionCoefficient;
  else if (!(p.frictionExponent <= 0.0))
    message << "frictionExponent must be <= 0 (friction falls with stress), got " << p.frictionExponent;
  else if (!(p.maxContactStress >= 0.0))
    message << "maxContactStress must be >= 0 Pa (0 disables the model), got " << p.maxContactStress;
  else
    return;
  throw std::invalid_argument(std::string(where) + ": " + message.str());
}

} // namespace railcosim::kernels
