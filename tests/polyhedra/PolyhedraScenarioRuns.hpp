// The contact law's path scenarios (tests/kernels/ContactLawScenarios.hpp) run through a PolyhedraSystem on a chosen
// backend: shared by the CPU test (PolyhedraContactTest.cpp) and the GPU comparison (PolyhedraGpuComparison.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "../kernels/ContactLawScenarios.hpp"
#include "polyhedra/PolyhedraShapes.hpp"
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

// Bounded rolling friction on a sphere (Irazábal 2017 §5.3, Table 5.2 material; R = 0.05 m, Δt 5e-5 s) on a rigid
// 2 m square floor, the path kept over one triangle's interior. Rigid-body oracles (Ai et al. 2011 test cases 1 and 2,
// closed forms for a rolling sphere with the resistance e_c |F_n| = η_r R m g cos β): on the flat, from v0 = 1 m/s
// without spin, slip then roll with a = −(5/7) η_r g, stopping at t = 0.5097 s, x = 0.18836 m (η_r 0.2, μ 0.8); up a
// 10° slope from pure rolling at 1 m/s, a sphere with η_r > tan 10° stops at v0² / (2 (5/7) g (sin β + η_r cos β))
// and stays, one with η_r < tan 10° rolls back.
struct RollingRun {
  double stopTime = -1.0; // first step at which the velocity along the path is <= 0 [s]
  double stopX = 0.0;     // travel then [m]
  double top = 0.0;       // largest travel [m]
  double finalX = 0.0;    // travel at the end [m]
  double finalSpin = 0.0; // |ω| at the end [rad/s]
};
constexpr double rollingRadius = 0.05, rollingGravity = 9.81, rollingPi = 3.14159265358979323846;
// The flat roll-out's closed form (η_r 0.2, μ 0.8, v0 = 1 m/s without spin): the stop [s] and the travel then [m].
constexpr double rollOutStopTime = 0.5097, rollOutStopX = 0.18836;
// |measured / closed form − 1| allowed: the Hertz contact's compliance (the arm R − δ, with δ/R up to 2e-3 in these
// scenarios; the tangential spring's stretch F_t / k_t ≈ 7e-6 m) and the 5e-5 s step; measured up to 7.4e-4 on a wall
// on either backend, 1.7e-3 on the soft cube's face (runRollingOnPolyhedronScenario).
constexpr double rollingTolerance = 2e-3;

inline double radians(double degrees) { return degrees * rollingPi / 180.0; }
// Whether a sphere that climbed the slope stays at its top: the resistance η_r m g R cos β outweighs m g R sin β.
inline bool rollingStays(double rollingFriction, double slopeDegrees) {
  return rollingFriction > std::tan(radians(slopeDegrees));
}

// Runs `system` (step `timeStep`) for 1.2 s, one step at a time, recording the roll of stone `stone` along x from x0.
inline RollingRun recordRolling(polyhedra::PolyhedraSystem& system, int stone, double x0, double timeStep) {
  RollingRun run;
  for (int step = 0; step < 24000; ++step) {
    system.step(1);
    const double x = system.positions()[3 * stone] - x0;
    run.top = std::max(run.top, x);
    if (run.stopTime < 0.0 && system.velocities()[3 * stone] <= 0.0) {
      run.stopTime = (step + 1) * timeStep;
      run.stopX = x;
    }
  }
  run.finalX = system.positions()[3 * stone] - x0;
  const std::vector<double> w = system.angularVelocities();
  run.finalSpin = std::sqrt(w[3 * stone] * w[3 * stone] + w[3 * stone + 1] * w[3 * stone + 1] +
                            w[3 * stone + 2] * w[3 * stone + 2]);
  return run;
}

// The benchmarks' material (Irazábal 2017 Table 5.2: E 4e7 Pa, ν 0.49, e 0.2, μ 0.8, ρ 1056 kg/m³), 5e-5 s, the
// walls a million times stiffer (rigid: E* of a sphere–wall pair is the sphere's E/(1 − ν²)).
constexpr double rollingDensity = 1056.0, rollingEStar = 4e7 / (1.0 - 0.49 * 0.49);
constexpr double rollingMass = rollingDensity * 4.0 / 3.0 * rollingPi * rollingRadius * rollingRadius * rollingRadius;

inline polyhedra::Parameters rollingParameters(polyhedra::Backend backend, double rollingFriction,
                                               const std::array<double, 3>& gravity) {
  polyhedra::Parameters p;
  p.timeStep = 5e-5;
  p.gravity = gravity;
  p.stone = polyhedra::Material{4e7, 0.49, 0.2, 0.8};
  p.stone.rollingFriction = rollingFriction;
  p.wall = polyhedra::Material{4e7 * 1e6, 0.49, 0.2, 0.8};
  p.backend = backend;
  return p;
}

// The rolling sphere: a one-point core dilated by its radius.
inline polyhedra::ShapeTemplate rollingSphere() {
  polyhedra::ShapeTemplate sphere;
  sphere.vertices = {0.0, 0.0, 0.0};
  sphere.dilationRadius = rollingRadius;
  sphere.density = rollingDensity;
  return sphere;
}

// Static Hertz overlap under `force` for the effective modulus and radius of a pair [m].
inline double hertzOverlap(double force, double effectiveModulus, double radius) {
  return std::pow(3.0 * force / (4.0 * effectiveModulus * std::sqrt(radius)), 2.0 / 3.0);
}

inline RollingRun runRollingScenario(polyhedra::Backend backend, double rollingFriction, double slopeDegrees,
                                     bool rollingStart) {
  using namespace polyhedra;
  const double beta = radians(slopeDegrees);
  const Parameters p = rollingParameters(backend, rollingFriction,
                                         {-rollingGravity * std::sin(beta), 0.0, -rollingGravity * std::cos(beta)});
  PolyhedraSystem system(p);
  const int shape = system.addShape(rollingSphere());
  system.setWalls({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
  // Start at the static Hertz overlap under the normal weight.
  const double overlap = hertzOverlap(rollingMass * rollingGravity * std::cos(beta), rollingEStar, rollingRadius);
  const double x0 = -0.8, y0 = 0.5; // the diagonal x = y is 1.3 m away
  system.addStone(shape, {x0, y0, rollingRadius - overlap}, {1, 0, 0, 0}, {1.0, 0.0, 0.0},
                  {0.0, rollingStart ? 1.0 / rollingRadius : 0.0, 0.0});
  return recordRolling(system, 0, x0, p.timeStep);
}

// The flat roll-out on top of a sphere of 10 km resting on the floor: the pair's arm is η_r R* with
// R* = R r / (R + r) = r (1 − 5e-6), and along the 0.19 m of travel gravity tilts by 2e-5 rad against the surface, so
// the flat's closed form holds to 1e-5. The big sphere (4.2 kg) is held by its own rolling friction on the floor (η_r R
// F_n ≈ 9e4 N m against A's friction torque of about 800 N m) and the floor's Coulomb friction.
inline RollingRun runRollingOnSphereScenario(polyhedra::Backend backend) {
  using namespace polyhedra;
  const Parameters p = rollingParameters(backend, 0.2, {0.0, 0.0, -rollingGravity});
  PolyhedraSystem system(p);
  const double bigRadius = 1e4;
  polyhedra::ShapeTemplate big;
  big.vertices = {0.0, 0.0, 0.0};
  big.dilationRadius = bigRadius;
  big.density = 1e-12;
  const int smallShape = system.addShape(rollingSphere()), bigShape = system.addShape(big);
  system.setWalls({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
  const double bigMass = 1e-12 * 4.0 / 3.0 * rollingPi * std::pow(bigRadius, 3);
  // Both start at their static overlaps: the big sphere on the rigid floor (E*), the small one on it (E*/2).
  const double floorOverlap = hertzOverlap((bigMass + rollingMass) * rollingGravity, rollingEStar, bigRadius);
  const double pairOverlap = hertzOverlap(rollingMass * rollingGravity, 0.5 * rollingEStar,
                                          rollingRadius * bigRadius / (rollingRadius + bigRadius));
  const double x0 = -0.8, y0 = 0.5;
  const double bigZ = bigRadius - floorOverlap;
  system.addStone(bigShape, {x0 + 0.1, y0, bigZ}, {1, 0, 0, 0});
  system.addStone(smallShape, {x0, y0, bigZ + bigRadius + rollingRadius - pairOverlap}, {1, 0, 0, 0}, {1.0, 0.0, 0.0});
  return recordRolling(system, 1, x0, p.timeStep);
}

// The flat roll-out on the top face of a cube of 100 m half edge resting on the floor (the sphere–polyhedron path:
// the arm is the sphere's η_r R, as on a wall, and only the sphere's budget counts). With the cube's dilation equal to
// the sphere's radius, an arm taken from the pair's Hertz radius R r_d / (R + r_d) = R / 2 would double the travel.
// The cube (4 kg) carries no rolling friction (polyhedra ignore η_r); tipping it over an edge takes 3.9e3 N m, and
// the sphere's friction at its top gives at most 9e2 N m. The pair's Hertz contact, both of the soft stone material,
// overlaps by 1e-4 m = 2e-3 R (on the rigid wall 1e-3 R): the arm R − δ shortens the travel by about that.
inline RollingRun runRollingOnPolyhedronScenario(polyhedra::Backend backend) {
  using namespace polyhedra;
  const Parameters p = rollingParameters(backend, 0.2, {0.0, 0.0, -rollingGravity});
  PolyhedraSystem system(p);
  const double halfEdge = 100.0, cubeDilation = 0.05, cubeMass = 4.0;
  std::vector<double> corners;
  for (int k = 0; k < 8; ++k)
    corners.insert(corners.end(), {(k & 1 ? 1.0 : -1.0) * halfEdge, (k & 2 ? 1.0 : -1.0) * halfEdge,
                                   (k & 4 ? 1.0 : -1.0) * halfEdge});
  // the density that gives the dilated cube cubeMass (Steiner: a³ + 6a² r + 3πa r² + 4/3 π r³, edge a)
  const double a = 2.0 * halfEdge, r = cubeDilation;
  const double cubeVolume =
      a * a * a + 6.0 * a * a * r + 3.0 * rollingPi * a * r * r + 4.0 / 3.0 * rollingPi * r * r * r;
  const int smallShape = system.addShape(rollingSphere());
  const int cubeShape = system.addShape(convexHullTemplate(corners, cubeDilation, cubeMass / cubeVolume));
  const double floorHalf = 2.0 * halfEdge;
  system.setWalls({-floorHalf, -floorHalf, 0, floorHalf, -floorHalf, 0, floorHalf, floorHalf, 0, -floorHalf,
                   floorHalf, 0},
                  {0, 1, 2, 0, 2, 3});
  // Both start near their static overlaps: the cube's face on the rigid floor as one Hertz contact of its dilation
  // (E*), the sphere on the cube's face (E*/2, the pair's radius R r_d / (R + r_d)).
  const double floorOverlap = hertzOverlap((cubeMass + rollingMass) * rollingGravity, rollingEStar, cubeDilation);
  const double pairOverlap = hertzOverlap(rollingMass * rollingGravity, 0.5 * rollingEStar,
                                          rollingRadius * cubeDilation / (rollingRadius + cubeDilation));
  const double x0 = 0.1, y0 = 0.05, cubeZ = halfEdge + cubeDilation - floorOverlap;
  system.addStone(cubeShape, {0.0, 0.0, cubeZ}, {1, 0, 0, 0});
  system.addStone(smallShape, {x0, y0, cubeZ + halfEdge + cubeDilation + rollingRadius - pairOverlap}, {1, 0, 0, 0},
                  {1.0, 0.0, 0.0});
  return recordRolling(system, 1, x0, p.timeStep);
}

// The top of the climb up the slope for a sphere that stays there [m].
inline double rollingSlopeTop(double rollingFriction, double slopeDegrees) {
  const double beta = radians(slopeDegrees);
  return 1.0 / (2.0 * 5.0 / 7.0 * rollingGravity * (std::sin(beta) + rollingFriction * std::cos(beta)));
}

} // namespace railcosim::testing
