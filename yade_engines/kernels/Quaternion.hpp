// Unit-quaternion algebra for rigid-body orientation (Irazábal 2017 §5.3.1, eqs. 5.25–5.39), host and device.
#pragma once

#include <cmath>

#include "railcosim/HostDevice.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::kernels {

// q = w + x i + y j + z k = [q0, q] (eqs. 5.29–5.30). An orientation maps body-frame vectors to the world
// frame: v_world = q v_body q*, v_body = q* v_world q (the convention of eqs. 5.47 and 5.50).
struct Quaternion {
  double w;
  double x;
  double y;
  double z;
};

RAILCOSIM_HOST_DEVICE inline Quaternion identityQuaternion() { return Quaternion{1.0, 0.0, 0.0, 0.0}; }

RAILCOSIM_HOST_DEVICE inline Vec3 vectorPart(const Quaternion& q) { return Vec3{q.x, q.y, q.z}; }

// q* = [q0, −q] (eq. 5.31); equals q⁻¹ for a unit quaternion (eq. 5.32 with the erratum ||q||² applied).
RAILCOSIM_HOST_DEVICE inline Quaternion conjugate(const Quaternion& q) { return Quaternion{q.w, -q.x, -q.y, -q.z}; }

RAILCOSIM_HOST_DEVICE inline double squaredNorm(const Quaternion& q) {
  return q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
}

RAILCOSIM_HOST_DEVICE inline double norm(const Quaternion& q) { return std::sqrt(squaredNorm(q)); }

// Re-projects onto the unit sphere: products of unit quaternions drift from |q| = 1 only by round-off,
// and this keeps that drift from accumulating over millions of steps.
RAILCOSIM_HOST_DEVICE inline Quaternion normalized(const Quaternion& q) {
  const double inverseNorm = 1.0 / norm(q);
  return Quaternion{q.w * inverseNorm, q.x * inverseNorm, q.y * inverseNorm, q.z * inverseNorm};
}

// Hamilton product p q = [p0 q0 − p·q, p0 q + q0 p + p × q] (eq. 5.34); not commutative.
RAILCOSIM_HOST_DEVICE inline Quaternion operator*(const Quaternion& p, const Quaternion& q) {
  return Quaternion{p.w * q.w - p.x * q.x - p.y * q.y - p.z * q.z, p.w * q.x + q.w * p.x + p.y * q.z - p.z * q.y,
                    p.w * q.y + q.w * p.y + p.z * q.x - p.x * q.z, p.w * q.z + q.w * p.z + p.x * q.y - p.y * q.x};
}

// v' = q v q* for a unit quaternion, in the fast form t = 2 (q × v), v' = v + q0 t + q × t (eqs. 5.35–5.36).
RAILCOSIM_HOST_DEVICE inline Vec3 rotate(const Quaternion& q, const Vec3& v) {
  const Vec3 axis = vectorPart(q);
  const Vec3 t = 2.0 * cross(axis, v);
  return v + q.w * t + cross(axis, t);
}

// v' = q* v q: world frame → body frame.
RAILCOSIM_HOST_DEVICE inline Vec3 rotateInverse(const Quaternion& q, const Vec3& v) { return rotate(conjugate(q), v); }

// Rotation by the angle |θ| about θ/|θ|: [cos(|θ|/2), sin(|θ|/2) θ/|θ|] (eqs. 5.25 and 5.39 with the erratum
// that the argument is the norm). sin(a/2)/a is evaluated by its Taylor series near a = 0, so a zero
// rotation vector gives the identity instead of 0/0.
RAILCOSIM_HOST_DEVICE inline Quaternion rotationQuaternion(const Vec3& rotationVector) {
  const double angle = norm(rotationVector);
  double halfSinOverAngle; // sin(angle/2)/angle
  if (angle < 1e-4) {
    // Series 1/2 − a²/48 + a⁴/3840: truncation below 1e-21 for a < 1e-4, far under double round-off.
    const double angleSquared = angle * angle;
    halfSinOverAngle = 0.5 - angleSquared / 48.0 + angleSquared * angleSquared / 3840.0;
  } else {
    halfSinOverAngle = std::sin(0.5 * angle) / angle;
  }
  return Quaternion{std::cos(0.5 * angle), halfSinOverAngle * rotationVector.x, halfSinOverAngle * rotationVector.y,
                    halfSinOverAngle * rotationVector.z};
}

// Rotation by `angle` [rad] about a unit axis (eq. 5.25).
RAILCOSIM_HOST_DEVICE inline Quaternion quaternionFromAxisAngle(const Vec3& unitAxis, double angle) {
  return rotationQuaternion(angle * unitAxis);
}

// Increment for a constant world-frame angular velocity over Δt, q(ω, Δt) (eq. 5.39); the orientation is
// advanced by left multiplication, q^{n+1} = q(ω, Δt) q^n, because ω is expressed in the world frame.
RAILCOSIM_HOST_DEVICE inline Quaternion incrementalRotation(const Vec3& worldAngularVelocity, double timeStep) {
  return rotationQuaternion(timeStep * worldAngularVelocity);
}

// Rotation vector θ u of a unit quaternion with the angle in [0, π] (q and −q are the same rotation).
RAILCOSIM_HOST_DEVICE inline Vec3 rotationVector(const Quaternion& q) {
  const Quaternion h = q.w < 0.0 ? Quaternion{-q.w, -q.x, -q.y, -q.z} : q;
  const double sinHalf = norm(vectorPart(h));
  if (sinHalf < 1e-12) {
    return 2.0 * vectorPart(h); // angle ≈ 2 sin(angle/2) to round-off for such small angles
  }
  const double angle = 2.0 * std::atan2(sinHalf, h.w);
  return (angle / sinHalf) * vectorPart(h);
}

// A' = R A Rᵀ for a diagonal body tensor A = diag(d) applied to a world vector: R diag(d) Rᵀ v. This is the
// action of the tensor rotation of eq. 5.38 (and eq. 5.43) without forming a matrix.
RAILCOSIM_HOST_DEVICE inline Vec3 applyRotatedDiagonal(const Quaternion& q, const Vec3& diagonal,
                                                       const Vec3& worldVector) {
  const Vec3 body = rotateInverse(q, worldVector);
  return rotate(q, Vec3{diagonal.x * body.x, diagonal.y * body.y, diagonal.z * body.z});
}

} // namespace railcosim::kernels
