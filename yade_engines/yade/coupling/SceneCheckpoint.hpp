// Snapshots of a YADE scene's dynamic state: in memory to simulate a window again, on disk to resume a run.
#pragma once

#include <core/Scene.hpp>

#include <iosfwd>
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
  /// The snapshot itself, for a restart checkpoint (an implicit run resumed between two windows may have to
  /// repeat the next one from the snapshot taken at its start).
  void write(std::ostream& out) const;
  void read(std::istream& in, const std::string& source);

  /// The scene's whole dynamic state between two steps, written by the last engine of a step, for a restart
  /// checkpoint: every body's state, shape and bound, the interactions in their container order with every contact
  /// law's history, permanent forces, energies, the clock. readBetweenSteps() puts it into a scene rebuilt with the
  /// same bodies (same count, ids and shape classes, else CheckpointError) as it would be at the start of the next
  /// step: Omega.iter and Omega.time advanced as YADE does after its last engine.
  static void writeBetweenSteps(Scene& scene, std::ostream& out);
  static void readBetweenSteps(Scene& scene, std::istream& in, const std::string& source);

private:
  std::string archive;
  std::vector<Vector3r> force, torque;
  Real time = 0;
  long iter = 0;
  mutable double elapsed = 0;
};

} // namespace yade
