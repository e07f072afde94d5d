// Stones given in a frame of their own (a shape library's, a YADE body's) handed to a PolyhedraSystem, which keeps
// each stone in the principal frame of its template; and their state read back in that frame.
#pragma once

#include <array>
#include <map>
#include <vector>

#include "polyhedra/PolyhedraSystem.hpp"

namespace railcosim::polyhedra {

/// The stones of a system as a caller's bodies: each registered with its core vertices in its own body frame and
/// that frame's state, read back the same way. Stones with the same core (vertices compared exactly) and dilation
/// share one template. Used by every driver of the library (the YADE engine, the standalone C interface), so that a
/// bed handed to either gives the same system and the same states, bit for bit.
class BodyFrameStones {
public:
  /// Registers a stone with `system` (before its first step): core `vertices` (3 per vertex, body frame; their convex
  /// hull, or a single vertex: a sphere of radius `dilationRadius` about it) [m],
  /// `dilationRadius` [m], `density` [kg/m^3]; the body frame's origin at `position` [m] with orientation
  /// `orientation` (w,x,y,z), the origin's velocity [m/s] and the angular velocity [rad/s] (world frame). Returns the
  /// stone's index in the system.
  int add(PolyhedraSystem& system, const std::vector<double>& vertices, double dilationRadius, double density,
          const std::array<double, 3>& position, const std::array<double, 4>& orientation,
          const std::array<double, 3>& velocity, const std::array<double, 3>& angularVelocity);
  /// Body-frame state of stone `i` from the system's arrays (positions, orientations w,x,y,z, velocities, angular
  /// velocities as PolyhedraSystem returns them): origin, orientation (normalized), origin velocity, angular velocity.
  void bodyState(std::size_t i, const std::vector<double>& positions, const std::vector<double>& orientations,
                 const std::vector<double>& velocities, const std::vector<double>& angularVelocities,
                 std::array<double, 3>& position, std::array<double, 4>& orientation, std::array<double, 3>& velocity,
                 std::array<double, 3>& angularVelocity) const {
    bodyState(i, i, positions, orientations, velocities, angularVelocities, position, orientation, velocity,
              angularVelocity);
  }
  /// The same with stone `i`'s state at entry `k` of the arrays (PolyhedraSystem::stoneStates of a few stones).
  void bodyState(std::size_t i, std::size_t k, const std::vector<double>& positions,
                 const std::vector<double>& orientations, const std::vector<double>& velocities,
                 const std::vector<double>& angularVelocities,
                 std::array<double, 3>& position, std::array<double, 4>& orientation, std::array<double, 3>& velocity,
                 std::array<double, 3>& angularVelocity) const;
  std::size_t size() const { return principalToBody_.size(); }
  int templates() const { return static_cast<int>(templateOf_.size()); }
  /// Mass of stone `i` (its template's dilated body) [kg].
  double mass(std::size_t i) const { return mass_[i]; }
  void clear();

private:
  std::map<std::vector<double>, int> templateOf_;        // core vertices + dilation -> template index
  std::vector<std::array<double, 4>> principalToBody_; // rotation from the principal frame to the body frame
  std::vector<std::array<double, 3>> centroidInBody_;  // the template's centroid in the body frame
  std::vector<double> mass_;
};

} // namespace railcosim::polyhedra
