// One coupling window of a polyhedra system under a FEM surface: the surface's straight-line motion through the
// window and the window's triangle forces lumped to the surface nodes. Shared by every DEM driver of the library
// (YADE's FemCouplingEngine with contactModel 'polyhedra', the standalone C interface in driver/).
#pragma once

#include <cstdint>
#include <vector>

namespace railcosim {
class DemCouplingScheme;
}

namespace railcosim::polyhedra {

/// The straight line the surface follows in the window the scheme is at: `start` = its position at the window's
/// start, `velocity` = (position at the end - start) / windowLength (3 per node). Exact for the predictive and
/// implicit schemes, whose surface moves linearly; for just-in-time the chord of its parabola.
void beginSurfaceWindow(const DemCouplingScheme& scheme, double windowLength, std::vector<double>& start,
                        std::vector<double>& velocity);

/// Nodal forces [N] (3 per node, into `nodalForces`, overwritten) of the window's mean force on each surface
/// triangle (`triangleForces`, 3 each) acting at its force-weighted mean contact point (`contactPoints`), lumped with
/// the barycentric weights of that point on the surface at mid-window (the mean position of a linearly moving
/// triangle): the total force and impulse over the window are exact. Returns the number of loaded triangles.
long lumpWindowForces(const std::vector<double>& start, const std::vector<double>& velocity, double windowLength,
                      const std::vector<std::int32_t>& triangles, const std::vector<double>& triangleForces,
                      const std::vector<double>& contactPoints, std::vector<double>& nodalForces);

/// Work of the window's nodal forces on the surface as the DEM side sees it [J]: sum over DEM steps of F . V dt with
/// V constant over the window is the mean force times V times the window, exactly.
double windowWork(const std::vector<double>& nodalForces, const std::vector<double>& velocity, double windowLength);

} // namespace railcosim::polyhedra
