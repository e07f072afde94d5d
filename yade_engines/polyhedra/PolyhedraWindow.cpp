// One coupling window of a polyhedra system under a FEM surface (PolyhedraWindow.hpp).
#include "polyhedra/PolyhedraWindow.hpp"

#include <algorithm>
#include <array>

#include "railcosim/CouplingScheme.hpp"
#include "railcosim/ForceLumping.hpp"

namespace railcosim::polyhedra {

void beginSurfaceWindow(const DemCouplingScheme& scheme, double windowLength, std::vector<double>& start,
                        std::vector<double>& velocity) {
  std::vector<double> end, unused;
  scheme.surfaceAt(0.0, start, unused);
  scheme.surfaceAt(windowLength, end, unused);
  velocity.resize(end.size());
  for (std::size_t k = 0; k < end.size(); ++k) velocity[k] = (end[k] - start[k]) / windowLength;
}

long lumpWindowForces(const std::vector<double>& start, const std::vector<double>& velocity, double windowLength,
                      const std::vector<std::int32_t>& triangles, const std::vector<double>& triangleForces,
                      const std::vector<double>& contactPoints, std::vector<double>& nodalForces) {
  std::vector<double> middle(start.size());
  for (std::size_t k = 0; k < middle.size(); ++k) middle[k] = start[k] + 0.5 * windowLength * velocity[k];
  nodalForces.assign(start.size(), 0.0);
  long loaded = 0;
  for (std::size_t t = 0; t < triangleForces.size() / 3; ++t) {
    const std::array<double, 3> force{triangleForces[3 * t], triangleForces[3 * t + 1], triangleForces[3 * t + 2]};
    if (force[0] == 0 && force[1] == 0 && force[2] == 0) continue;
    lumpPointForce(middle, triangles, t, {contactPoints[3 * t], contactPoints[3 * t + 1], contactPoints[3 * t + 2]},
                   force, nodalForces);
    ++loaded;
  }
  return loaded;
}

double windowWork(const std::vector<double>& nodalForces, const std::vector<double>& velocity, double windowLength) {
  double work = 0;
  for (std::size_t k = 0; k < nodalForces.size(); ++k) work += nodalForces[k] * velocity[k];
  return work * windowLength;
}

} // namespace railcosim::polyhedra
