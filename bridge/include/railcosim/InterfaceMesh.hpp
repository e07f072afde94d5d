// The coupled surface: FEM surface nodes + triangles, and the nodal kinematics sent FEM -> DEM.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace railcosim {

/// Surface triangulation of the FEM interface. Node coordinates in metres, 3 per node (x,y,z);
/// triangles as 3 zero-based node indices each, counter-clockwise seen from outside the structure
/// (so the right-hand normal points out of the solid, towards the particles).
struct InterfaceMesh {
  std::vector<double> coordinates;     // size 3 * nodeCount()
  std::vector<std::int32_t> triangles; // size 3 * triangleCount()

  std::size_t nodeCount() const { return coordinates.size() / 3; }
  std::size_t triangleCount() const { return triangles.size() / 3; }
  std::array<double, 3> node(std::size_t i) const {
    return {coordinates[3 * i], coordinates[3 * i + 1], coordinates[3 * i + 2]};
  }
  /// Throws Error naming the first problem: array sizes not multiples of 3, no triangles, an index
  /// out of range, a non-finite coordinate, a degenerate (zero-area) triangle.
  void validate() const;
};

/// Kinematics of the interface nodes at one instant: 3 values per node each, SI units
/// (m, m/s, m/s^2). Velocities/accelerations may be empty when unknown (treated as zero).
struct NodalKinematics {
  double time = 0.0;                 // s
  std::vector<double> positions;     // m
  std::vector<double> velocities;    // m/s
  std::vector<double> accelerations; // m/s^2

  std::size_t nodeCount() const { return positions.size() / 3; }
  /// Throws Error if sizes disagree with `nodes` or a value is not finite.
  void validate(std::size_t nodes) const;
};

} // namespace railcosim
