// Device only: warp-aggregated atomic sums (cooperative groups), kept behind the CUDA folder's boundary.
#pragma once

#include <cooperative_groups.h>
#include <cooperative_groups/reduce.h>

#include "kernels/Vector3.hpp"

namespace railcosim::polyhedra {

// Adds a wall contact's force, |F| x_c and |F| to the sums of triangle t. The active lanes of a warp that hit
// the same triangle sum among themselves first, so that one atomic per triangle and warp reaches each address.
// The group is formed before the values are gathered: in that order ptxas spills less in the wall kernel
// (24 instead of 32 bytes of spill stores for sm_90).
__device__ inline void addTriangleSumsWarpAggregated(int t, const kernels::Vec3& force, const kernels::Vec3& weighted,
                                                     double magnitude, double* triangleForceSum,
                                                     double* trianglePointSum, double* triangleWeightSum) {
  namespace cg = cooperative_groups;
  const cg::coalesced_group same = cg::labeled_partition(cg::coalesced_threads(), t);
  const double values[7] = {force.x, force.y, force.z, weighted.x, weighted.y, weighted.z, magnitude};
  double* const targets[7] = {triangleForceSum + 3 * t, triangleForceSum + 3 * t + 1, triangleForceSum + 3 * t + 2,
                              trianglePointSum + 3 * t, trianglePointSum + 3 * t + 1, trianglePointSum + 3 * t + 2,
                              triangleWeightSum + t};
#pragma unroll
  for (int c = 0; c < 7; ++c) {
    const double sum = cg::reduce(same, values[c], cg::plus<double>());
    if (same.thread_rank() == 0) atomicAdd(targets[c], sum);
  }
}

} // namespace railcosim::polyhedra
