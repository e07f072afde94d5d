// Barycentric lumping of a DEM point force onto the three nodes of an FEM surface triangle.
#include "railcosim/ForceLumping.hpp"
#include "railcosim/Error.hpp"

#include <cmath>
#include <sstream>

namespace railcosim {
namespace {

using Vector = std::array<double, 3>;

Vector subtract(const Vector& u, const Vector& v) { return {u[0] - v[0], u[1] - v[1], u[2] - v[2]}; }
double dot(const Vector& u, const Vector& v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }

} // namespace

std::array<double, 3> barycentricWeights(const Vector& a, const Vector& b, const Vector& c, const Vector& p) {
  const Vector ab = subtract(b, a);
  const Vector ac = subtract(c, a);
  const Vector ap = subtract(p, a);
  // Gram matrix of the edge vectors: its determinant is |ab x ac|^2, zero for a degenerate triangle.
  const double abab = dot(ab, ab);
  const double abac = dot(ab, ac);
  const double acac = dot(ac, ac);
  const double determinant = abab * acac - abac * abac;
  // Relative threshold (scale-free): 1e-24 on |ab x ac|^2 / (|ab|^2 |ac|^2) is sin^2 of a 1e-12 rad angle.
  if (!(determinant > 1e-24 * abab * acac) || !std::isfinite(determinant)) {
    std::ostringstream message;
    message << "barycentricWeights: triangle (" << a[0] << "," << a[1] << "," << a[2] << "), (" << b[0] << "," << b[1]
            << "," << b[2] << "), (" << c[0] << "," << c[1] << "," << c[2]
            << ") is degenerate (zero area); the force cannot be lumped onto it";
    throw Error(message.str());
  }
  const double apab = dot(ap, ab);
  const double apac = dot(ap, ac);
  // Weights of b and c of the projection of p onto the triangle's plane (normal equations).
  double v = (acac * apab - abac * apac) / determinant;
  double w = (abab * apac - abac * apab) / determinant;
  if (v >= 0.0 && w >= 0.0 && v + w <= 1.0) return {1.0 - v - w, v, w};

  // Outside: the closest point of the triangle lies on one of its edges (possibly at a vertex).
  // Project onto each edge segment and keep the nearest, measured in the plane metric.
  auto clamp01 = [](double t) { return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t); };
  const Vector bc = subtract(c, b);
  const Vector bp = subtract(p, b);
  const double tAB = clamp01(apab / abab);
  const double tAC = clamp01(apac / acac);
  const double tBC = clamp01(dot(bp, bc) / dot(bc, bc));
  const std::array<std::array<double, 3>, 3> candidates = {{
      {1.0 - tAB, tAB, 0.0},
      {1.0 - tAC, 0.0, tAC},
      {0.0, 1.0 - tBC, tBC},
  }};
  double bestDistance = 0.0;
  std::array<double, 3> best{};
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    const auto& weights = candidates[k];
    Vector point;
    for (int i = 0; i < 3; ++i) point[i] = weights[0] * a[i] + weights[1] * b[i] + weights[2] * c[i];
    const Vector difference = subtract(p, point);
    const double distance = dot(difference, difference);
    if (k == 0 || distance < bestDistance) {
      bestDistance = distance;
      best = weights;
    }
  }
  return best;
}

void lumpPointForce(const std::vector<double>& positions, const std::vector<std::int32_t>& triangles,
                    std::size_t triangle, const Vector& p, const Vector& f, std::vector<double>& nodalForces) {
  const std::size_t nodes = positions.size() / 3;
  if (positions.size() % 3 != 0 || nodalForces.size() != positions.size()) {
    std::ostringstream message;
    message << "lumpPointForce: positions has " << positions.size() << " values and nodalForces " << nodalForces.size()
            << "; both must hold 3 values per node";
    throw Error(message.str());
  }
  if (triangle >= triangles.size() / 3) {
    std::ostringstream message;
    message << "lumpPointForce: triangle " << triangle << " is out of range (the surface has " << triangles.size() / 3
            << " triangles)";
    throw Error(message.str());
  }
  std::size_t corner[3];
  for (int j = 0; j < 3; ++j) {
    const std::int32_t index = triangles[3 * triangle + j];
    if (index < 0 || static_cast<std::size_t>(index) >= nodes) {
      std::ostringstream message;
      message << "lumpPointForce: triangle " << triangle << " corner " << j << " refers to node " << index
              << ", out of range [0, " << nodes << ")";
      throw Error(message.str());
    }
    corner[j] = static_cast<std::size_t>(index);
  }
  auto node = [&](std::size_t n) { return Vector{positions[3 * n], positions[3 * n + 1], positions[3 * n + 2]}; };
  const auto weights = barycentricWeights(node(corner[0]), node(corner[1]), node(corner[2]), p);
  for (int i = 0; i < 3; ++i) {
    // The third share is the remainder, so the three shares add up to f to the last rounding.
    const double share0 = weights[0] * f[i];
    const double share1 = weights[1] * f[i];
    const double share2 = f[i] - share0 - share1;
    nodalForces[3 * corner[0] + i] += share0;
    nodalForces[3 * corner[1] + i] += share1;
    nodalForces[3 * corner[2] + i] += share2;
  }
}

} // namespace railcosim
