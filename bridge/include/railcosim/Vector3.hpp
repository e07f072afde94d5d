// Minimal 3-vector of doubles shared by the kernels, the polyhedra DEM and the bridge (host and device; no allocation).
#pragma once

#include <cmath>

#include "railcosim/HostDevice.hpp"

namespace railcosim {

// Plain aggregate so that it can live in CUDA device memory and be brace-initialised: Vec3{x, y, z}.
struct Vec3 {
  double x;
  double y;
  double z;
};

RAILCOSIM_HOST_DEVICE inline Vec3 operator+(const Vec3& a, const Vec3& b) {
  return Vec3{a.x + b.x, a.y + b.y, a.z + b.z};
}
RAILCOSIM_HOST_DEVICE inline Vec3 operator-(const Vec3& a, const Vec3& b) {
  return Vec3{a.x - b.x, a.y - b.y, a.z - b.z};
}
RAILCOSIM_HOST_DEVICE inline Vec3 operator-(const Vec3& a) { return Vec3{-a.x, -a.y, -a.z}; }
RAILCOSIM_HOST_DEVICE inline Vec3 operator*(double s, const Vec3& a) { return Vec3{s * a.x, s * a.y, s * a.z}; }
RAILCOSIM_HOST_DEVICE inline Vec3 operator*(const Vec3& a, double s) { return Vec3{s * a.x, s * a.y, s * a.z}; }
RAILCOSIM_HOST_DEVICE inline Vec3 operator/(const Vec3& a, double s) { return Vec3{a.x / s, a.y / s, a.z / s}; }
RAILCOSIM_HOST_DEVICE inline Vec3& operator+=(Vec3& a, const Vec3& b) {
  a.x += b.x;
  a.y += b.y;
  a.z += b.z;
  return a;
}
RAILCOSIM_HOST_DEVICE inline Vec3& operator-=(Vec3& a, const Vec3& b) {
  a.x -= b.x;
  a.y -= b.y;
  a.z -= b.z;
  return a;
}

RAILCOSIM_HOST_DEVICE inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RAILCOSIM_HOST_DEVICE inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return Vec3{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
RAILCOSIM_HOST_DEVICE inline double squaredNorm(const Vec3& a) { return dot(a, a); }
RAILCOSIM_HOST_DEVICE inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

// Component of a perpendicular to the unit vector n (projection onto the tangent plane of a contact).
RAILCOSIM_HOST_DEVICE inline Vec3 tangentialPart(const Vec3& a, const Vec3& unitNormal) {
  return a - dot(a, unitNormal) * unitNormal;
}

} // namespace railcosim
