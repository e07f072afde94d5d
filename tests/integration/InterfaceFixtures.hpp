// Interface data the participant-level integration tests share: a fresh ipc endpoint, a unit square, a surface at rest.
#pragma once

#include "railcosim/BridgeTypes.hpp"

#include <unistd.h>

#include <atomic>
#include <string>

namespace railcosim::test {

/// An ipc endpoint no other test of this process uses.
inline std::string uniqueEndpoint() {
  static std::atomic<int> counter{0};
  return "ipc:///tmp/railcosim-test-" + std::to_string(getpid()) + "-" + std::to_string(counter++) + ".sock";
}

/// The unit square in z = 0 as two triangles.
inline InterfaceMesh square() {
  InterfaceMesh mesh;
  mesh.coordinates = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  mesh.triangles = {0, 1, 2, 0, 2, 3};
  return mesh;
}

/// The mesh's nodes at rest at `time` (zero velocities and accelerations).
inline NodalKinematics restingAt(const InterfaceMesh& mesh, double time) {
  NodalKinematics kinematics;
  kinematics.time = time;
  kinematics.positions = mesh.coordinates;
  kinematics.velocities.assign(mesh.coordinates.size(), 0.0);
  kinematics.accelerations.assign(mesh.coordinates.size(), 0.0);
  return kinematics;
}

} // namespace railcosim::test
