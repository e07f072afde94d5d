// Motion of the DEM copy of the FEM surface inside one coupling window, from the window-start state.
#pragma once

#include "railcosim/InterfaceMesh.hpp"

#include <string>
#include <vector>

namespace railcosim {

/// How the DEM side moves the surface within a window and in which order the solvers run.
enum class CouplingScheme {
  JustInTime,  // DEM first; surface P + V*tau + A*tau^2/2 from the kinematics received at t_i (seed 002, Alg. 3)
  Predictive,  // FEM first; surface moves linearly from P(t_i) to P(t_i+1): V = (P1-P0)/dt_F, A = 0 (eq. 3.4-3.7)
  Implicit,    // DEM first, window repeated until the FEM end state agrees with the DEM's (ImplicitCoupling.hpp)
};

/// "justInTime" | "predictive" | "implicit" (case-insensitive, also "just-in-time"); throws Error otherwise.
CouplingScheme parseCouplingScheme(const std::string& name);
std::string toString(CouplingScheme scheme);

/// Positions and velocities of the surface nodes at time `tau` [s] after the window start, from the
/// window-start kinematics `start`: P + V tau + A tau^2 / 2 and V + A tau (missing V or A count as 0).
/// Writes 3 values per node into `positions` and `velocities` (resized).
void extrapolateSurface(const NodalKinematics& start, double tau, std::vector<double>& positions,
                        std::vector<double>& velocities);

/// Predictive window start state from the FEM positions at t_i and t_i+1: P = P0, V = (P1-P0)/dt, A = 0.
NodalKinematics predictiveStart(const NodalKinematics& atStart, const NodalKinematics& atEnd, double femTimeStep);

} // namespace railcosim
