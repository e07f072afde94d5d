// Barycentric lumping of a DEM point force onto the three nodes of an FEM surface triangle.
#include "railcosim/ForceLumping.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/TriangleGeometry.hpp"

#include <cmath>
#include <sstream>

namespace railcosim {
namespace {

using Vector = std::array<double, 3>;

Vec3 toVec3(const Vector& v) { return Vec3{v[0], v[1], v[2]}; }

} // namespace

std::array<double, 3> barycentricWeights(const Vector& a, const Vector& b, const Vector& c, const Vector& p) {
  const Vec3 ab = toVec3(b) - toVec3(a);
  const Vec3 ac = toVec3(c) - toVec3(a);
  // Gram determinant |ab|²|ac|² − (ab·ac)² = |ab × ac|², zero for a degenerate triangle. Relative threshold
  // (scale-free): 1e-24 on |ab × ac|² / (|ab|² |ac|²) is sin² of a 1e-12 rad angle.
  const double abab = dot(ab, ab);
  const double acac = dot(ac, ac);
  const double abac = dot(ab, ac);
  const double determinant = abab * acac - abac * abac;
  if (!(determinant > 1e-24 * abab * acac) || !std::isfinite(determinant)) {
    std::ostringstream message;
    message << "barycentricWeights: triangle (" << a[0] << "," << a[1] << "," << a[2] << "), (" << b[0] << "," << b[1]
            << "," << b[2] << "), (" << c[0] << "," << c[1] << "," << c[2]
            << ") is degenerate (zero area); the force cannot be lumped onto it";
    throw Error(message.str());
  }
  // The weights of the triangle's point closest to p: those of p's projection onto the plane when it falls inside.
  const BarycentricWeights weights = closestPointWeights(toVec3(p), toVec3(a), toVec3(b), toVec3(c));
  return {weights[0], weights[1], weights[2]};
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
  const auto w = barycentricWeights(node(corner[0]), node(corner[1]), node(corner[2]), p);
  const BarycentricWeights weights{{w[0], w[1], w[2]}};
  for (int k = 0; k < 3; ++k) {
    const Vec3 share = lumpedShare(weights, toVec3(f), k);
    nodalForces[3 * corner[k]] += share.x;
    nodalForces[3 * corner[k] + 1] += share.y;
    nodalForces[3 * corner[k] + 2] += share.z;
  }
}

} // namespace railcosim
