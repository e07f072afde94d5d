// Motion of the DEM copy of the FEM surface inside one coupling window, from the window-start state.
#pragma once

#include "railcosim/InterfaceMesh.hpp"

#include <vector>

namespace railcosim {

/// Positions and velocities of the surface nodes at time `tau` [s] after the window start, from the
/// window-start kinematics `start`: P + V tau + A tau^2 / 2 and V + A tau (missing V or A count as 0).
/// Writes 3 values per node into `positions` and `velocities` (resized).
void extrapolateSurface(const NodalKinematics& start, double tau, std::vector<double>& positions,
                        std::vector<double>& velocities);

/// Predictive window start state from the FEM positions at t_i and t_i+1: P = P0, V = (P1-P0)/dt, A = 0.
NodalKinematics predictiveStart(const NodalKinematics& atStart, const NodalKinematics& atEnd, double femTimeStep);

} // namespace railcosim
