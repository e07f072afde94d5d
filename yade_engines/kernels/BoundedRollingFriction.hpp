// Bounded rolling friction (BROF), Irazábal 2017 §5.2.1, with eq. 5.4 corrected as docs/contact-models.md explains.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "railcosim/HostDevice.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::kernels {

// One parameter per contact pair: η_r (particle–particle and particle–wall use separate values; the
// thesis uses η_r = 1.0 against walls so that stones resting on a face cannot roll).
struct BoundedRollingFrictionParams {
  double rollingFrictionCoefficient; // η_r [-]
};

// Rolling-resistance arm e_c = η_r R_r with R_r = R1 R2/(R1 + R2) the pair's effective radius (eqs. 5.2–5.3). [m]
RAILCOSIM_HOST_DEVICE inline double rollingResistanceArm(const BoundedRollingFrictionParams& p,
                                                         double effectiveRadius) {
  return p.rollingFrictionCoefficient * effectiveRadius;
}

// The same from the two radii. A wall is radius2 = INFINITY, giving e_c = η_r R1. Note: other codes use
// min(R1, R2), a factor 2 larger for equal spheres; η_r must be calibrated with the definition used here. [m]
RAILCOSIM_HOST_DEVICE inline double rollingResistanceArm(const BoundedRollingFrictionParams& p, double radius1,
                                                         double radius2) {
  return rollingResistanceArm(p, 1.0 / (1.0 / radius1 + 1.0 / radius2));
}

// Contribution of one contact to the particle's rolling-resistance budget M_r = Σ e_c |F_n|. [N m]
RAILCOSIM_HOST_DEVICE inline double rollingResistanceMoment(double rollingArm, double normalForce) {
  return rollingArm * std::fabs(normalForce);
}

// Per-particle BROF torque, applied once after all contact moments are summed (eqs. 5.4–5.5 corrected).
// The integrator's update is ω_new = ω + h (T_applied + T_r)/I, where h is the time increment the
// integrator actually applies to ω with this torque (YADE's leapfrog NewtonIntegrator: h = Δt and ω is
// the stored mid-step spin; a velocity-Verlet half-kick: h = Δt/2). With T_stop = I ω/h + T_applied, the
// torque −T_stop would give ω_new = 0 exactly, so:
//    |T_stop| > M_r :  T_r = −M_r T_stop/|T_stop|   (full resistance; ω_new keeps the direction of T_stop)
//    |T_stop| ≤ M_r :  T_r = −T_stop                 (spin stopped in this step, never reversed)
// In both cases ω_new = (h/I)(1 − min(1, M_r/|T_stop|)) T_stop: the resistance can bring the spin to zero
// but never past it. The torque follows T_stop, not the relative rotation, which makes it frame-
// independent (Fig. 5.9). Valid for isotropic inertia (spheres; the thesis uses no rolling friction on
// clusters). The bound assumes the integrator applies the torque unmodified: YADE's Cundall damping
// amplifies a torque that opposes the spin by (1 + damping) and would push a stopped spin past zero, so
// bodies with rolling friction need damping = 0 (the thesis uses contact damping only). [N m]
RAILCOSIM_HOST_DEVICE inline Vec3 boundedRollingTorque(const Vec3& angularVelocity, double momentOfInertia,
                                                       double rotationTimeIncrement, const Vec3& appliedTorque,
                                                       double rollingResistanceBudget) {
  const Vec3 stopTorque = (momentOfInertia / rotationTimeIncrement) * angularVelocity + appliedTorque;
  const double stopMagnitude = norm(stopTorque);
  if (stopMagnitude <= rollingResistanceBudget) return -stopTorque;
  return (-rollingResistanceBudget / stopMagnitude) * stopTorque;
}

// Host-only validation (throws std::invalid_argument with the offending value).
inline void validate(const BoundedRollingFrictionParams& p, const char* where = "BoundedRollingFrictionParams") {
  if (!(p.rollingFrictionCoefficient >= 0.0) || std::isinf(p.rollingFrictionCoefficient)) {
    std::ostringstream message;
    message << where << ": rollingFrictionCoefficient must be finite and >= 0, got " << p.rollingFrictionCoefficient;
    throw std::invalid_argument(message.str());
  }
}

inline void validateRollingStep(double momentOfInertia, double rotationTimeIncrement,
                                const char* where = "boundedRollingTorque") {
  if (!(momentOfInertia > 0.0) || !(rotationTimeIncrement > 0.0)) {
    std::ostringstream message;
    message << where << ": momentOfInertia (" << momentOfInertia << " kg m²) and rotationTimeIncrement ("
            << rotationTimeIncrement << " s) must both be > 0";
    throw std::invalid_argument(message.str());
  }
}

} // namespace railcosim::kernels
