// Conservative DEM -> FEM force mapping: a point force on a surface triangle lumped to its 3 nodes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace railcosim {

/// Barycentric weights (w0,w1,w2), summing to 1, of the projection of p onto the plane of the
/// triangle (a,b,c). Points outside the triangle are first moved to the closest point of the
/// triangle, so all weights are in [0,1]. Throws Error for a degenerate triangle.
std::array<double, 3> barycentricWeights(const std::array<double, 3>& a, const std::array<double, 3>& b,
                                         const std::array<double, 3>& c, const std::array<double, 3>& p);

/// Adds force f [N] acting at point p [m] on triangle `triangle` of a surface whose current node
/// positions are `positions` (3 per node) and connectivity `triangles` (3 per triangle) into
/// `nodalForces` (3 per node), with the barycentric weights of p. The total force is conserved
/// exactly; the total moment about any point is conserved when p lies in the triangle.
/// Throws Error for an out-of-range triangle or a size mismatch.
void lumpPointForce(const std::vector<double>& positions, const std::vector<std::int32_t>& triangles,
                    std::size_t triangle, const std::array<double, 3>& p, const std::array<double, 3>& f,
                    std::vector<double>& nodalForces);

} // namespace railcosim
