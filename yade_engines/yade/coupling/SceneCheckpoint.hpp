// A snapshot of a YADE scene's dynamic state in memory, to simulate a stretch of time again from it.
#pragma once

#include <core/Scene.hpp>

#include <string>
#include <vector>

namespace yade {

/// Body states and interactions (serialized with YADE's own archives, so every contact law's history comes
/// back), the summed forces and torques of the step the snapshot was taken in, Omega.time and Omega.iter.
/// Engines' private state is not part of it: an engine that needs its own snapshot keeps it beside this one.
class SceneCheckpoint {
public:
  /// Replaces the snapshot with the scene's present state.
  void save(Scene& scene);
  /// Puts the snapshot back; throws if bodies were added or erased since save() (the scene then
  /// cannot be restored body by body).
  void restore(Scene& scene) const;
  bool empty() const { return archive.empty(); }
  double seconds() const { return elapsed; } // wall time spent saving and restoring [s]

private:
  std::string archive;
  std::vector<Vector3r> force, torque;
  Real time = 0;
  long iter = 0;
  mutable double elapsed = 0;
};

} // namespace yade
