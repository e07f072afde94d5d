// The contact law's path scenarios (tests/kernels/ContactLawScenarios.hpp) run through a PolyhedraSystem on a chosen
// backend: shared by the CPU test (PolyhedraContactTest.cpp) and the GPU comparison (PolyhedraGpuComparison.cpp).
#pragma once

#include <cmath>
#include <vector>

#include "../kernels/ContactLawScenarios.hpp"
#include "polyhedra/PolyhedraSystem.hpp"

namespace railcosim::testing {

// A point core dilated by R is a sphere of radius R: against a flat wall the polyhedra law sees R* = R, and its mass
// is that of the sphere (Steiner's formula reduces to (4/3)πR³).
inline polyhedra::ShapeTemplate scenarioSphere(double density) {
  polyhedra::ShapeTemplate sphere;
  sphere.vertices = {0.0, 0.0, 0.0};
  sphere.dilationRadius = scenario::radius;
  sphere.density = density;
  return sphere;
}

// The granite flat: a 0.2 m square at z = 0 of two triangles (diagonal x = y), the sphere over the interior of one.
inline void addScenarioFloor(polyhedra::PolyhedraSystem& system) {
  system.setWalls({-0.1, -0.1, 0, 0.1, -0.1, 0, 0.1, 0.1, 0, -0.1, 0.1, 0}, {0, 1, 2, 0, 2, 3});
}
constexpr double scenarioX = 0.03, scenarioY = -0.03; // 42 mm from the diagonal: one face contact

inline polyhedra::Parameters scenarioParameters(const kernels::ContactMaterial& material, double timeStep,
                                                polyhedra::Backend backend) {
  polyhedra::Parameters p;
  p.timeStep = timeStep;
  p.gravity = {0.0, 0.0, 0.0};
  p.stone = polyhedra::materialOf(material);
  p.wall = p.stone;
  p.backend = backend;
  return p;
}

// Overlap and normal force of the sphere's wall contact after the last step; false when there is none.
inline bool wallContact(const polyhedra::PolyhedraSystem& system, double& overlap, double& force) {
  for (const polyhedra::ContactRecord& c : system.contacts()) {
    if (!c.wall) continue;
    overlap = c.overlap;
    // `force` acts on the wall and `normal` points from the stone to the wall: their product is F_n ≥ 0.
    force = c.force[0] * c.normal[0] + c.force[1] * c.normal[1] + c.force[2] * c.normal[2];
    return true;
  }
  return false;
}

// Scenario 1. The prescribed motion is the motion of a sphere 1e9 times denser than granite: 500 N then change its
// speed of 0.01 m/s by 4e-6 m/s over the whole cycle and its position by 2e-16 m per step, so the overlap still
// grows by 1e-8 m per step (the recorder reads the overlaps the law saw, whatever they are). e = 1: no dashpot, so
// the mass does not enter the law.
inline scenario::CycleRecorder runCycleScenario(polyhedra::Backend backend) {
  using namespace polyhedra;
  PolyhedraSystem system(scenarioParameters(scenario::roughPlasticGranite(), scenario::cycleTimeStep, backend));
  const int shape = system.addShape(scenarioSphere(1e9 * scenario::density));
  addScenarioFloor(system);
  system.addStone(shape, {scenarioX, scenarioY, scenario::radius + 0.5 * scenario::cycleStep}, {1, 0, 0, 0},
                  {0.0, 0.0, -scenario::cycleSpeed});
  scenario::CycleRecorder recorder;
  bool unloading = false;
  for (int step = 0; step < 100000 && !recorder.done; ++step) {
    system.step(1);
    double overlap = 0.0, force = 0.0;
    if (!wallContact(system, overlap, force)) continue;
    recorder.sample(overlap, force, unloading);
    if (!unloading && force >= scenario::cyclePeakForce) {
      unloading = true;
      std::vector<double> velocity = system.velocities();
      velocity[2] = scenario::cycleSpeed;
      system.setState(system.positions(), system.orientations(), velocity, system.angularVelocities());
    }
  }
  return recorder;
}

// Scenario 2: rebound speed / approach speed of the smooth sphere dropped on the flat.
inline double runImpactScenario(polyhedra::Backend backend) {
  using namespace polyhedra;
  PolyhedraSystem system(scenarioParameters(scenario::smoothGranite(), scenario::impactTimeStep, backend));
  const int shape = system.addShape(scenarioSphere(scenario::density));
  addScenarioFloor(system);
  system.addStone(shape, {scenarioX, scenarioY, scenario::radius + 1e-7}, {1, 0, 0, 0},
                  {0.0, 0.0, -scenario::impactSpeed});
  bool touched = false;
  for (int chunk = 0; chunk < 1000; ++chunk) {
    system.step(10);
    double overlap = 0.0, force = 0.0;
    touched = touched || wallContact(system, overlap, force);
    if (touched && system.positions()[2] > scenario::radius + 1e-7) break;
  }
  return system.velocities()[2] / scenario::impactSpeed;
}

} // namespace railcosim::testing
