// Rigid-body rotation integrators split into predict/correct phases (Irazábal 2017 §5.3.2): ZvW, RK4, direct.
//
// Every scheme is written like velocity Verlet (eqs. 3.44–3.53): `predict` advances the orientation to
// q^{n+1} from the state and torque at step n, the caller then moves the body (e.g. cluster members), and
// evaluates the new torque T^{n+1}; `correct` finishes the angular velocity at n+1. Between the two phases
// RotationState::angularVelocity holds the mid-step velocity, which is what velocity-dependent forces
// (damping) should see, exactly as VV evaluates forces with u̇^{n+1/2}.
//
// Frames: the orientation q maps body (principal-axis) vectors to world vectors; torques and
// angular velocities passed in and out are world-frame; principal inertia is (I'_x, I'_y, I'_z).
//
// Schemes
//  * zhaoVanWachem (recommended; eqs. 5.47–5.55). Orientation update variant: the thesis text, eqs.
//    5.52–5.53, i.e. q^{n+1} = q(ω^{n+1/2}, Δt) q^n with ω^{n+1/2} = q^{n+1/2} ω'^{n+1/2} q^{n+1/2}*, both
//    computed in the predict phase from step-n data. (The Kratos variant, which rotates the corrected
//    ω'^{n+1} with q^{n+1/2}, needs the new torque before the orientation is known, so it cannot give the
//    force evaluation its configuration at n+1.) The torque at the half step, undefined in the thesis
//    (erratum 14), is the average ½(T^n + T^{n+1}) rotated into the body frame with q^{n+1/2}: the
//    midpoint value to second order, and for a sphere (I' = I·1) the scheme is then identical to VV.
//  * rungeKutta4 (Munjiza, eqs. 5.41–5.46): angular momentum H is the state and is held constant while the
//    orientation is advanced with four stages. The momentum kick of eq. 5.41 is split into two half
//    kicks around the force evaluation, H^{n+1/2} = H^n + ½Δt T^n and H^{n+1} = H^{n+1/2} + ½Δt T^{n+1}
//    (eq. 5.41 as printed uses T^n only, which is first order for time-varying torques); the drift uses
//    H^{n+1/2}. For a constant torque both give the same H^{n+1}.
//  * direct (comparison only; the thesis does not define its orientation update, erratum 20): the
//    sphere VV update (eqs. 3.49–3.53) applied to the body-frame components with ω̇' from Euler's
//    equations (5.40) evaluated explicitly, and Δθ = ω^{n+1/2} Δt with ω^{n+1/2} rotated by q^n. Its
//    gyroscopic half kicks amplify a torque-free precession by (1 + (pΔt/2)²) per step, so it drifts
//    (test R1) and converges only as Δt → 0, as the thesis reports.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "railcosim/HostDevice.hpp"
#include "kernels/Quaternion.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::kernels {

enum class RotationScheme { zhaoVanWachem, rungeKutta4, direct };

// State of one rigid body's rotation. The fields after `rotationIncrement` are scratch written by
// `predict` and read by `correct`; they carry no meaning outside one step.
struct RotationState {
  Quaternion orientation; // q: body → world; q^n before predict, q^{n+1} after it
  Vec3 angularVelocity;   // ω, world frame [rad/s]: ω^n; after predict the mid-step value; after correct ω^{n+1}
  Vec3 angularMomentum;   // H = I_world ω, world frame [kg m²/s]; the RK4 state, kept current by all schemes
  Vec3 rotationIncrement; // Δθ of the last predict, world frame [rad] (eq. 5.55 / 5.46c)
  Quaternion startOrientation;      // q^n
  Quaternion halfStepOrientation;   // q^{n+1/2} (ZvW)
  Vec3 startBodyAngularVelocity;    // ω'^n (ZvW)
  Vec3 halfStepBodyAngularVelocity; // ω'^{n+1/2} (ZvW, direct)
  Vec3 startTorque;                 // T^n, world frame (ZvW)
};

RAILCOSIM_HOST_DEVICE inline Vec3 componentProduct(const Vec3& a, const Vec3& b) {
  return Vec3{a.x * b.x, a.y * b.y, a.z * b.z};
}

RAILCOSIM_HOST_DEVICE inline Vec3 componentQuotient(const Vec3& a, const Vec3& b) {
  return Vec3{a.x / b.x, a.y / b.y, a.z / b.z};
}

// State at rest orientation q with world angular velocity ω; H = q I' (q* ω q) q* (eq. 5.42–5.43).
RAILCOSIM_HOST_DEVICE inline RotationState makeRotationState(const Quaternion& orientation,
                                                             const Vec3& worldAngularVelocity,
                                                             const Vec3& principalInertia) {
  RotationState s{};
  s.orientation = normalized(orientation);
  s.angularVelocity = worldAngularVelocity;
  s.angularMomentum = applyRotatedDiagonal(s.orientation, principalInertia, worldAngularVelocity);
  s.startOrientation = s.orientation;
  s.halfStepOrientation = s.orientation;
  return s;
}

// Euler's equations in the body frame: ω̇' = I'⁻¹ (T' − ω' × I' ω') (eqs. 5.22, 5.40, 5.49).
RAILCOSIM_HOST_DEVICE inline Vec3 eulerAngularAcceleration(const Vec3& principalInertia, const Vec3& bodyTorque,
                                                           const Vec3& bodyAngularVelocity) {
  const Vec3 gyroscopic = cross(bodyAngularVelocity, componentProduct(principalInertia, bodyAngularVelocity));
  return componentQuotient(bodyTorque - gyroscopic, principalInertia);
}

// ω = I_world(q)⁻¹ H = R I'⁻¹ Rᵀ H (eq. 5.42 with the note that only the diagonal I' is inverted).
RAILCOSIM_HOST_DEVICE inline Vec3 angularVelocityFromMomentum(const Quaternion& orientation,
                                                              const Vec3& principalInertia,
                                                              const Vec3& angularMomentum) {
  const Vec3 inverseInertia{1.0 / principalInertia.x, 1.0 / principalInertia.y, 1.0 / principalInertia.z};
  return applyRotatedDiagonal(orientation, inverseInertia, angularMomentum);
}

// ½ ω'·I'ω' [J].
RAILCOSIM_HOST_DEVICE inline double rotationalKineticEnergy(const Quaternion& orientation, const Vec3& principalInertia,
                                                            const Vec3& worldAngularVelocity) {
  const Vec3 body = rotateInverse(orientation, worldAngularVelocity);
  return 0.5 * dot(body, componentProduct(principalInertia, body));
}

// ---------------------------------------------------------------------------------------------------
// Zhao–van Wachem predictor–corrector (eqs. 5.47–5.55).
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline void zhaoVanWachemPredict(RotationState& s, const Vec3& principalInertia,
                                                       const Vec3& torque, double timeStep) {
  const Quaternion q = s.orientation;
  const Vec3 bodyOmega = rotateInverse(q, s.angularVelocity);                                      // (5.47)
  const Vec3 bodyTorque = rotateInverse(q, torque);                                                // (5.47)
  const Vec3 bodyAcceleration = eulerAngularAcceleration(principalInertia, bodyTorque, bodyOmega); // (5.49)
  const Vec3 bodyOmegaQuarter = bodyOmega + (0.25 * timeStep) * bodyAcceleration;                  // (5.48)
  const Vec3 bodyOmegaHalf = bodyOmega + (0.5 * timeStep) * bodyAcceleration;                      // (5.48)
  const Vec3 omegaQuarter = rotate(q, bodyOmegaQuarter);                                           // (5.50)
  const Quaternion qHalf = normalized(incrementalRotation(omegaQuarter, 0.5 * timeStep) * q);      // (5.51)
  const Vec3 omegaHalf = rotate(qHalf, bodyOmegaHalf);                                             // (5.52)
  s.orientation = normalized(incrementalRotation(omegaHalf, timeStep) * q);                        // (5.53)
  s.rotationIncrement = timeStep * omegaHalf;                                                      // (5.55)
  s.angularVelocity = omegaHalf;
  s.startOrientation = q;
  s.halfStepOrientation = qHalf;
  s.startBodyAngularVelocity = bodyOmega;
  s.halfStepBodyAngularVelocity = bodyOmegaHalf;
  s.startTorque = torque;
}

RAILCOSIM_HOST_DEVICE inline void zhaoVanWachemCorrect(RotationState& s, const Vec3& principalInertia,
                                                       const Vec3& torque, double timeStep) {
  const Vec3 midTorque = 0.5 * (s.startTorque + torque);
  const Vec3 bodyTorqueHalf = rotateInverse(s.halfStepOrientation, midTorque);
  const Vec3 bodyAccelerationHalf =
      eulerAngularAcceleration(principalInertia, bodyTorqueHalf, s.halfStepBodyAngularVelocity);
  const Vec3 bodyOmegaNew = s.startBodyAngularVelocity + timeStep * bodyAccelerationHalf; // (5.54a, erratum 14)
  s.angularVelocity = rotate(s.orientation, bodyOmegaNew);                                // (5.54b)
  s.angularMomentum = rotate(s.orientation, componentProduct(principalInertia, bodyOmegaNew));
}

// ---------------------------------------------------------------------------------------------------
// Quaternion RK4 with angular momentum as state (Munjiza, eqs. 5.41–5.46).
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline void rungeKutta4Predict(RotationState& s, const Vec3& principalInertia, const Vec3& torque,
                                                     double timeStep) {
  const Quaternion q = s.orientation;
  const Vec3 momentum = s.angularMomentum + (0.5 * timeStep) * torque; // half kick of eq. 5.41
  const Vec3 omega1 = angularVelocityFromMomentum(q, principalInertia, momentum);
  const Quaternion q2 = incrementalRotation(omega1, 0.5 * timeStep) * q; // (5.44b)
  const Vec3 omega2 = angularVelocityFromMomentum(q2, principalInertia, momentum);
  const Quaternion q3 = incrementalRotation(omega2, 0.5 * timeStep) * q;
  const Vec3 omega3 = angularVelocityFromMomentum(q3, principalInertia, momentum);
  const Quaternion q4 = incrementalRotation(omega3, timeStep) * q;
  const Vec3 omega4 = angularVelocityFromMomentum(q4, principalInertia, momentum);
  const Vec3 omegaMean = (omega1 + 2.0 * omega2 + 2.0 * omega3 + omega4) / 6.0; // (5.44c)
  s.orientation = normalized(incrementalRotation(omegaMean, timeStep) * q);     // (5.46a)
  s.rotationIncrement = timeStep * omegaMean;                                   // (5.46c)
  s.angularMomentum = momentum;
  s.angularVelocity = angularVelocityFromMomentum(s.orientation, principalInertia, momentum);
  s.startOrientation = q;
}

RAILCOSIM_HOST_DEVICE inline void rungeKutta4Correct(RotationState& s, const Vec3& principalInertia, const Vec3& torque,
                                                     double timeStep) {
  s.angularMomentum += (0.5 * timeStep) * torque; // second half kick of eq. 5.41
  s.angularVelocity = angularVelocityFromMomentum(s.orientation, principalInertia, s.angularMomentum); // (5.46b)
}

// ---------------------------------------------------------------------------------------------------
// Direct explicit scheme (comparison only; see the header comment).
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline void directPredict(RotationState& s, const Vec3& principalInertia, const Vec3& torque,
                                                double timeStep) {
  const Quaternion q = s.orientation;
  const Vec3 bodyOmega = rotateInverse(q, s.angularVelocity);
  const Vec3 bodyAcceleration =
      eulerAngularAcceleration(principalInertia, rotateInverse(q, torque), bodyOmega); // (5.40)
  const Vec3 bodyOmegaHalf = bodyOmega + (0.5 * timeStep) * bodyAcceleration;          // (3.49)
  const Vec3 omegaHalf = rotate(q, bodyOmegaHalf);
  s.rotationIncrement = timeStep * omegaHalf; // (3.50)
  s.orientation = normalized(rotationQuaternion(s.rotationIncrement) * q);
  s.angularVelocity = omegaHalf;
  s.startOrientation = q;
  s.halfStepBodyAngularVelocity = bodyOmegaHalf;
}

RAILCOSIM_HOST_DEVICE inline void directCorrect(RotationState& s, const Vec3& principalInertia, const Vec3& torque,
                                                double timeStep) {
  const Vec3 bodyAcceleration = eulerAngularAcceleration(principalInertia, rotateInverse(s.orientation, torque),
                                                         s.halfStepBodyAngularVelocity);         // (3.52 with 5.40)
  const Vec3 bodyOmegaNew = s.halfStepBodyAngularVelocity + (0.5 * timeStep) * bodyAcceleration; // (3.53)
  s.angularVelocity = rotate(s.orientation, bodyOmegaNew);
  s.angularMomentum = rotate(s.orientation, componentProduct(principalInertia, bodyOmegaNew));
}

// ---------------------------------------------------------------------------------------------------
// Dispatch by scheme (what an engine calls per body).
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline void predictRotation(RotationScheme scheme, RotationState& s, const Vec3& principalInertia,
                                                  const Vec3& torque, double timeStep) {
  switch (scheme) {
    case RotationScheme::zhaoVanWachem:
      zhaoVanWachemPredict(s, principalInertia, torque, timeStep);
      break;
    case RotationScheme::rungeKutta4:
      rungeKutta4Predict(s, principalInertia, torque, timeStep);
      break;
    case RotationScheme::direct:
      directPredict(s, principalInertia, torque, timeStep);
      break;
  }
}

RAILCOSIM_HOST_DEVICE inline void correctRotation(RotationScheme scheme, RotationState& s, const Vec3& principalInertia,
                                                  const Vec3& torque, double timeStep) {
  switch (scheme) {
    case RotationScheme::zhaoVanWachem:
      zhaoVanWachemCorrect(s, principalInertia, torque, timeStep);
      break;
    case RotationScheme::rungeKutta4:
      rungeKutta4Correct(s, principalInertia, torque, timeStep);
      break;
    case RotationScheme::direct:
      directCorrect(s, principalInertia, torque, timeStep);
      break;
  }
}

// ---------------------------------------------------------------------------------------------------
// Translation: velocity Verlet (eqs. 3.44–3.48), the partner of every rotation scheme above.
// ---------------------------------------------------------------------------------------------------
// u̇ += ½ (F/m) Δt: used for both half kicks (eqs. 3.44 and 3.48).
RAILCOSIM_HOST_DEVICE inline void velocityVerletHalfKick(Vec3& velocity, const Vec3& force, double mass,
                                                         double timeStep) {
  velocity += (0.5 * timeStep / mass) * force;
}

// u^{n+1} = u^n + u̇^{n+1/2} Δt (eq. 3.45).
RAILCOSIM_HOST_DEVICE inline void velocityVerletDrift(Vec3& position, const Vec3& halfStepVelocity, double timeStep) {
  position += timeStep * halfStepVelocity;
}

// ---------------------------------------------------------------------------------------------------
// Host-side parsing and validation (not for device code: they throw).
// ---------------------------------------------------------------------------------------------------
inline RotationScheme rotationSchemeFromName(const std::string& name) {
  if (name == "zhaoVanWachem") return RotationScheme::zhaoVanWachem;
  if (name == "rk4") return RotationScheme::rungeKutta4;
  if (name == "direct") return RotationScheme::direct;
  throw std::invalid_argument("rotationSchemeFromName: unknown rotation scheme '" + name +
                              "'; use \"zhaoVanWachem\" (recommended), \"rk4\" or \"direct\"");
}

inline const char* rotationSchemeName(RotationScheme scheme) {
  switch (scheme) {
    case RotationScheme::zhaoVanWachem:
      return "zhaoVanWachem";
    case RotationScheme::rungeKutta4:
      return "rk4";
    case RotationScheme::direct:
      return "direct";
  }
  return "unknown";
}

// Principal moments must be positive and finite: the schemes divide by each of them.
inline void validatePrincipalInertia(const Vec3& principalInertia, const char* where) {
  const double values[3] = {principalInertia.x, principalInertia.y, principalInertia.z};
  for (int i = 0; i < 3; ++i) {
    if (!(values[i] > 0.0) || !std::isfinite(values[i])) {
      std::ostringstream message;
      message << where << ": principal inertia component " << i << " is " << values[i]
              << " kg m^2; every component must be positive and finite (set the body's inertia, or block "
                 "its rotation instead)";
      throw std::invalid_argument(message.str());
    }
  }
}

} // namespace railcosim::kernels
