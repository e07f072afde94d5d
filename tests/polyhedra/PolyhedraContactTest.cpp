// Unit tests of the dilated-polyhedra DEM CPU reference: analytic contacts, Hertz limit, conservation, history,
// settling.
#define BOOST_TEST_MODULE PolyhedraContact
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <string>
#include <vector>

#include "PolyhedraScenarioRuns.hpp"
#include "polyhedra/PolyhedraBodyFrames.hpp"
#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraStep.hpp"
#include "polyhedra/PolyhedraSystem.hpp"
#include "railcosim/Error.hpp"

using namespace railcosim::polyhedra;
using railcosim::kernels::Vec3;

namespace {

constexpr double pi = 3.14159265358979323846;

// Independent oracle: Hertz force between two spheres of radius r (R* = r/2) or a sphere and a flat
// (R* = r), F = 4/3 E* sqrt(R*) δ^{3/2}, with E* from E and ν of identical materials.
double hertzForce(double youngModulus, double poisson, double effectiveRadius, double overlap, bool rigidFlat = false) {
  const double compliance = (1.0 - poisson * poisson) / youngModulus;
  const double effectiveModulus = rigidFlat ? 1.0 / compliance : 1.0 / (2.0 * compliance);
  return 4.0 / 3.0 * effectiveModulus * std::sqrt(effectiveRadius) * std::pow(overlap, 1.5);
}

struct Body {
  ShapeTemplate shape; // principal-frame template as the system stores it
  ShapeData data;
};

// Builds the core of a template placed at `position` with orientation q (w,x,y,z), as the system would.
ConvexCore place(const ShapeTemplate& shape, const Vec3& position, const Quat& q) {
  return ConvexCore{shape.vertices.data(), static_cast<int>(shape.vertices.size() / 3), rotationMatrix(normalized(q)),
                    position, nullptr};
}

Quat axisAngle(const Vec3& axis, double angle) {
  const Vec3 u = axis / railcosim::kernels::norm(axis);
  return Quat{std::cos(angle / 2), u.x * std::sin(angle / 2), u.y * std::sin(angle / 2), u.z * std::sin(angle / 2)};
}

// The pair law of two like materials without damping (restitution 1), as the system mixes it.
railcosim::kernels::ContactLaw law(double E, double nu, double friction) {
  const railcosim::kernels::ContactMaterial m{E, nu, 1.0, friction};
  return railcosim::kernels::mixContactLaw(m, m);
}

ContactResult staticContact(const ConvexCore& a, const ConvexCore& b, double r,
                            const railcosim::kernels::ContactLaw& constants, double featureTolerance = 0.02) {
  ContactSlot slot{1, 0, 0.0f, {0, 0, 0}, {0, 0, 0}, 0};
  unsigned long long counters[counterCount] = {0, 0, 0, 0, 0};
  const ContactKinematics rest{Vec3{0, 0, 0}, Vec3{0, 0, 0}, Vec3{0, 0, 0}};
  ContactKinematics kinematicsB = rest;
  kinematicsB.centre = b.position;
  ContactKinematics kinematicsA = rest;
  kinematicsA.centre = a.position;
  const ContactResult c = evaluateContact(a, b, r, r, 0.5 * r, 1.0, constants, kinematicsA, kinematicsB, 1e-6,
                                          featureTolerance, slot, counters);
  BOOST_TEST(counters[counterCoreOverlap] == 0u);
  return c;
}

double distance(const Vec3& a, const Vec3& b) { return railcosim::kernels::norm(a - b); }

// Closest distance between segments p1q1 and p2q2 (Ericson 2005, §5.1.9).
double segmentDistance(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2) {
  using railcosim::kernels::dot;
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r), c = dot(d1, r), b = dot(d1, d2);
  const double denominator = a * e - b * b;
  double s = denominator > 1e-30 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return railcosim::kernels::norm((p1 + s * d1) - (p2 + t * d2));
}

// Exhaustive distance between two placed triangulated cores: every vertex against every triangle of the
// other, every edge against every edge. O(V·F + E²): the cost GJK avoids, fine as a test oracle.
double exhaustiveDistance(const ShapeTemplate& sa, const Vec3& xa, const Quat& qa, const ShapeTemplate& sb,
                          const Vec3& xb, const Quat& qb) {
  auto world = [](const ShapeTemplate& s, const Vec3& x, const Quat& q) {
    std::vector<Vec3> out;
    for (std::size_t k = 0; k < s.vertices.size(); k += 3)
      out.push_back(x + rotate(normalized(q), Vec3{s.vertices[k], s.vertices[k + 1], s.vertices[k + 2]}));
    return out;
  };
  const std::vector<Vec3> va = world(sa, xa, qa), vb = world(sb, xb, qb);
  double best = 1e300;
  auto vertexFace = [&](const std::vector<Vec3>& points, const std::vector<Vec3>& corners, const ShapeTemplate& s) {
    for (const Vec3& p : points)
      for (std::size_t t = 0; t < s.triangles.size(); t += 3) {
        const Vec3 c = closestPointOnTriangle(p, corners[s.triangles[t]], corners[s.triangles[t + 1]],
                                              corners[s.triangles[t + 2]]);
        best = std::min(best, railcosim::kernels::norm(c - p));
      }
  };
  vertexFace(va, vb, sb);
  vertexFace(vb, va, sa);
  for (std::size_t t = 0; t < sa.triangles.size(); t += 3)
    for (int e = 0; e < 3; ++e)
      for (std::size_t u = 0; u < sb.triangles.size(); u += 3)
        for (int f = 0; f < 3; ++f)
          best = std::min(best, segmentDistance(va[sa.triangles[t + e]], va[sa.triangles[t + (e + 1) % 3]],
                                                vb[sb.triangles[u + f]], vb[sb.triangles[u + (f + 1) % 3]]));
  return best;
}

} // namespace

// Cube on cube, face on face, B shifted sideways by h/2: gap g between the cores, normal +z, force at the
// centre of the overlapping square region (x ∈ [−h/2, h], so x = h/4), in the mid-plane z = h + g/2.
BOOST_AUTO_TEST_CASE(cube_on_cube_face_face) {
  const double h = 0.01, r = 0.001, g = 0.0015, E = 1e9, nu = 0.25;
  const ShapeTemplate cube = cubeTemplate(h, r, 2600);
  const ConvexCore a = place(cube, Vec3{0, 0, 0}, Quat{1, 0, 0, 0});
  const ConvexCore b = place(cube, Vec3{h / 2, 0, 2 * h + g}, Quat{1, 0, 0, 0});
  const ContactResult c = staticContact(a, b, r, law(E, nu, 0.5));
  BOOST_REQUIRE(c.active);
  // Tolerances: double-precision GJK converges to ~1e-12 relative; 1e-9 m is 1e-6 of the dilation radius.
  BOOST_TEST(std::fabs(c.overlap - (2 * r - g)) < 1e-12);
  BOOST_TEST(distance(c.normal, Vec3{0, 0, 1}) < 1e-9);
  BOOST_TEST(distance(c.point, Vec3{h / 4, 0, h + g / 2}) < 1e-9);
  BOOST_TEST(std::fabs(c.forceOnB.z - hertzForce(E, nu, r / 2, 2 * r - g)) < 1e-9 * c.forceOnB.z);
  BOOST_TEST(std::hypot(c.forceOnB.x, c.forceOnB.y) < 1e-12 * c.forceOnB.z);
  // Without patch centring (the default) the same force acts at a closest point of the parallel faces:
  // anywhere in the overlapping square x ∈ [−h/2, h], y ∈ [−h, h], z = h + g/2.
  const ContactResult plain = staticContact(a, b, r, law(E, nu, 0.5), 0.0);
  BOOST_TEST(std::fabs(plain.forceOnB.z - c.forceOnB.z) < 1e-12 * c.forceOnB.z);
  BOOST_TEST(plain.point.x >= -h / 2 - 1e-12);
  BOOST_TEST(plain.point.x <= h + 1e-12);
  BOOST_TEST(std::fabs(plain.point.y) <= h + 1e-12);
  BOOST_TEST(std::fabs(plain.point.z - (h + g / 2)) < 1e-9);
}

// Nearly parallel faces (B tilted by 1e-5 rad, far inside the 2 % r_d feature band) must still act at the
// centre of the common face, not at the lowest vertex GJK happens to return.
BOOST_AUTO_TEST_CASE(nearly_parallel_faces_act_at_patch_centre) {
  const double h = 0.01, r = 0.001, g = 0.0015;
  const ShapeTemplate cube = cubeTemplate(h, r, 2600);
  const ConvexCore a = place(cube, Vec3{0, 0, 0}, Quat{1, 0, 0, 0});
  const ConvexCore b = place(cube, Vec3{0, 0, 2 * h + g}, axisAngle(Vec3{1, 1, 0}, 1e-5));
  const ContactResult c = staticContact(a, b, r, law(1e9, 0.25, 0.5));
  BOOST_REQUIRE(c.active);
  // The tilt moves B's corners by ≤ h·1e-5·√2 = 1.4e-7 m: the centre may move by that much.
  BOOST_TEST(std::hypot(c.point.x, c.point.y) < 2e-7);
}

// Vertex on face: B turned so that its body diagonal points down; the lowest vertex is h√3 below B's centre.
BOOST_AUTO_TEST_CASE(vertex_on_face) {
  const double h = 0.01, r = 0.001, g = 0.0005, E = 1e9, nu = 0.25;
  const ShapeTemplate cube = cubeTemplate(h, r, 2600);
  // Rotation taking (−1,−1,−1)/√3 to (0,0,−1): axis (1,−1,0)/√2... built from the two unit vectors.
  const Vec3 from = Vec3{-1, -1, -1} / std::sqrt(3.0), to{0, 0, -1};
  const Vec3 axis = railcosim::kernels::cross(from, to);
  const double angle = std::acos(railcosim::kernels::dot(from, to));
  const Quat q = axisAngle(axis, angle);
  const ConvexCore a = place(cube, Vec3{0, 0, 0}, Quat{1, 0, 0, 0});
  const ConvexCore b = place(cube, Vec3{0.002, -0.001, h + g + h * std::sqrt(3.0)}, q);
  const ContactResult c = staticContact(a, b, r, law(E, nu, 0.5));
  BOOST_REQUIRE(c.active);
  BOOST_TEST(std::fabs(c.overlap - (2 * r - g)) < 1e-12);
  BOOST_TEST(distance(c.normal, Vec3{0, 0, 1}) < 1e-9);
  BOOST_TEST(distance(c.point, Vec3{0.002, -0.001, h + g / 2}) < 1e-9);
  BOOST_TEST(std::fabs(railcosim::kernels::norm(c.forceOnB) - hertzForce(E, nu, r / 2, 2 * r - g)) <
             1e-9 * c.forceOnB.z);
}

// Crossed edges: A turned 45° about y (top edge along y at z = h√2), B turned 45° about x (bottom edge
// along x at z_B − h√2); the edges cross above the origin.
BOOST_AUTO_TEST_CASE(crossed_edges) {
  const double h = 0.01, r = 0.001, g = 0.001, E = 1e9, nu = 0.25;
  const ShapeTemplate cube = cubeTemplate(h, r, 2600);
  const ConvexCore a = place(cube, Vec3{0, 0, 0}, axisAngle(Vec3{0, 1, 0}, pi / 4));
  const ConvexCore b = place(cube, Vec3{0, 0, 2 * h * std::sqrt(2.0) + g}, axisAngle(Vec3{1, 0, 0}, pi / 4));
  const ContactResult c = staticContact(a, b, r, law(E, nu, 0.5));
  BOOST_REQUIRE(c.active);
  BOOST_TEST(std::fabs(c.overlap - (2 * r - g)) < 1e-12);
  BOOST_TEST(distance(c.normal, Vec3{0, 0, 1}) < 1e-9);
  BOOST_TEST(distance(c.point, Vec3{0, 0, h * std::sqrt(2.0) + g / 2}) < 1e-9);
  BOOST_TEST(std::fabs(c.forceOnB.z - hertzForce(E, nu, r / 2, 2 * r - g)) < 1e-9 * c.forceOnB.z);
  // Separated by more than 2r: no contact.
  const ConvexCore far =
      place(cube, Vec3{0, 0, 2 * h * std::sqrt(2.0) + 2 * r + 1e-6}, axisAngle(Vec3{1, 0, 0}, pi / 4));
  BOOST_TEST(!staticContact(a, far, r, law(E, nu, 0.5)).active);
}

// A point core dilated by r is a sphere: the law is exactly Hertz. Finely faceted icospheres of core radius
// ρ approach the sphere of radius ρ + r: overlap error ≤ 2ρ(1 − cos θ) with θ the largest vertex–face-centre
// angle, shrinking ~4× per subdivision.
BOOST_AUTO_TEST_CASE(faceted_sphere_approaches_hertz) {
  const double r = 0.002, E = 1e8, nu = 0.3;
  {
    ShapeTemplate point;
    point.vertices = {0, 0, 0};
    point.dilationRadius = r;
    const ConvexCore a = place(point, Vec3{0, 0, 0}, Quat{1, 0, 0, 0});
    const ConvexCore b = place(point, Vec3{0.3 * r, 0.2 * r, 1.8 * r}, Quat{1, 0, 0, 0});
    const double overlap = 2 * r - std::sqrt(0.09 + 0.04 + 3.24) * r;
    const ContactResult c = staticContact(a, b, r, law(E, nu, 0.5));
    BOOST_TEST(std::fabs(railcosim::kernels::norm(c.forceOnB) - hertzForce(E, nu, r / 2, overlap)) <
               1e-12 * railcosim::kernels::norm(c.forceOnB));
  }
  const double rho = 0.01, centreDistance = 2 * (rho + r) - 0.4 * r;
  const double sphereOverlap = 2 * (rho + r) - centreDistance;
  for (int level = 1; level <= 4; ++level) {
    const ShapeTemplate ball = icosphereTemplate(rho, level, r, 2600);
    // Deliberately unaligned orientations so that no vertex sits on the centre line.
    const Quat qa = axisAngle(Vec3{0.3, 1, 0.2}, 0.7), qb = axisAngle(Vec3{1, -0.4, 0.5}, 1.1);
    const ConvexCore a = place(ball, Vec3{0, 0, 0}, qa);
    const ConvexCore b = place(ball, Vec3{0, 0, centreDistance}, qb);
    const ContactResult c = staticContact(a, b, r, law(E, nu, 0.5));
    BOOST_REQUIRE(c.active);
    // Inscribed facets lie at most the sagitta ρ(1 − cos θ) inside the sphere, θ ≤ the edge angle
    // (icosahedron: atan 2, halved per subdivision): the overlap error is bounded by twice that.
    const double edgeAngle = std::atan(2.0) / std::pow(2.0, level);
    const double bound = 2 * rho * (1 - std::cos(edgeAngle));
    const double error = std::fabs(c.overlap - sphereOverlap);
    BOOST_TEST_MESSAGE("level " << level << ": overlap error " << error << " m, bound " << bound << " m");
    BOOST_TEST(error <= bound);
    // Force within the propagated error: dF/F = 1.5 dδ/δ (+1 % for the curvature of δ^{3/2}).
    const double expected = hertzForce(E, nu, r / 2, sphereOverlap);
    BOOST_TEST(std::fabs(railcosim::kernels::norm(c.forceOnB) - expected) <=
               1.5 * bound / sphereOverlap * expected * 1.01);
    if (level <= 2) {
      // Independent oracle for GJK: the exhaustive minimum over vertex–triangle and edge–edge pairs.
      const double exhaustive = exhaustiveDistance(ball, Vec3{0, 0, 0}, qa, ball, Vec3{0, 0, centreDistance}, qb);
      BOOST_TEST(std::fabs((2 * r - c.overlap) - exhaustive) < 1e-10 * rho);
    }
  }
}

namespace {

Parameters quietParameters(double restitution, double friction) {
  Parameters p;
  p.timeStep = 4e-6;
  p.gravity = {0, 0, 0};
  p.stone = Material{1e8, 0.25, restitution, friction};
  p.wall = p.stone;
  p.backend = Backend::Cpu;
  return p;
}

struct Totals {
  Vec3 momentum;
  Vec3 angularMomentum;
  double kineticEnergy;
};

Totals totals(const PolyhedraSystem& system) {
  const auto x = system.positions(), v = system.velocities(), q = system.orientations(), w = system.angularVelocities();
  Totals t{Vec3{0, 0, 0}, Vec3{0, 0, 0}, 0.0};
  for (std::size_t i = 0; i < system.stoneCount(); ++i) {
    const ShapeProperties& p = system.shapeProperties(0);
    const Vec3 xi{x[3 * i], x[3 * i + 1], x[3 * i + 2]}, vi{v[3 * i], v[3 * i + 1], v[3 * i + 2]},
        wi{w[3 * i], w[3 * i + 1], w[3 * i + 2]};
    const Quat qi{q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3]};
    const Vec3 wb = rotateInverse(qi, wi);
    const Vec3 lb{p.principalInertia[0] * wb.x, p.principalInertia[1] * wb.y, p.principalInertia[2] * wb.z};
    t.momentum += p.mass * vi;
    t.angularMomentum += p.mass * railcosim::kernels::cross(xi, vi) + rotate(qi, lb);
    t.kineticEnergy += 0.5 * p.mass * railcosim::kernels::dot(vi, vi) + 0.5 * railcosim::kernels::dot(wb, lb);
  }
  return t;
}

} // namespace

// Off-centre, spinning collision of two angular stones without dissipation (e = 1, μ = 0): linear and
// angular momentum are conserved by construction (equal and opposite forces at one point); kinetic energy
// returns to its initial value after separation up to the O(Δt²) error of velocity Verlet.
BOOST_AUTO_TEST_CASE(dissipation_free_collision_conserves_momentum_and_energy) {
  PolyhedraSystem system(quietParameters(1.0, 0.0));
  const int shape = system.addShape(dodecahedronStone(0.012, 0.01, 0.008, 0.001, 2600));
  system.addStone(shape, {0, 0, 0}, {1, 0, 0, 0}, {0.5, 0, 0}, {0, 20, 5});
  system.addStone(shape, {0.03, 0.006, 0.004}, {0.9, 0.3, -0.2, 0.25}, {-0.5, 0, 0}, {10, 0, -30});
  const Totals before = totals(system);
  system.step(10000); // 0.04 s: approach (~0.01 s), contact (~1 ms), separation
  const Totals after = totals(system);
  BOOST_TEST(system.contacts().empty()); // separated again
  const double pScale = railcosim::kernels::norm(before.momentum) + system.shapeProperties(0).mass * 0.5;
  // Pairwise equal and opposite forces: momentum exact to round-off (1e-12 relative).
  BOOST_TEST(railcosim::kernels::norm(after.momentum - before.momentum) < 1e-12 * pScale);
  // Angular momentum: torques are exactly opposite too, but the rotation update is O(Δt²): 1e-6 relative.
  BOOST_TEST(railcosim::kernels::norm(after.angularMomentum - before.angularMomentum) <
             1e-6 * railcosim::kernels::norm(before.angularMomentum));
  // Energy: second-order integration with Δt ≈ 1/240 of the Hertz contact time returns the energy to
  // ~5e-7 after separation (measured; it scales with Δt²). 1e-5 leaves margin and still catches a
  // first-order scheme (which lost 3e-3 here).
  BOOST_TEST(std::fabs(after.kineticEnergy - before.kineticEnergy) < 1e-5 * before.kineticEnergy);
  BOOST_TEST(system.lastStatistics().coreOverlapFallbacks == 0);
}

namespace {

// Flat square floor at z = 0 made of two triangles (normal +z), half width `half`.
void addFloor(PolyhedraSystem& system, double half) {
  system.setWalls({-half, -half, 0, half, -half, 0, half, half, 0, -half, half, 0}, {0, 1, 2, 0, 2, 3});
}

// A stone on the floor and a second stone on top, pushed sideways; returns the final positions.
std::vector<double> pushedStack(int rebuildInterval, bool adaptive, double& tangentialForce, std::int64_t& rebuilds) {
  Parameters p = quietParameters(0.3, 0.5);
  p.gravity = {0, 0, -9.81};
  p.timeStep = 5e-6;
  p.rebuildInterval = rebuildInterval;
  p.adaptiveRebuild = adaptive;
  p.neighbourSkin = 0.005; // never outgrown in either run, so both see the same candidate set
  PolyhedraSystem system(p);
  const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
  addFloor(system, 0.1);
  // Initial overlaps of 0.1 r_d with the floor and between the cubes; sideways velocities small enough
  // to stick (static friction holds), so the elastic tangential springs carry the motion back.
  system.addStone(cube, {0, 0, 0.0109}, {1, 0, 0, 0}, {0.002, 0, 0});
  system.addStone(cube, {0.003, 0, 0.0109 + 0.0218}, {1, 0, 0, 0}, {-0.003, 0.001, 0});
  system.step(3000);
  rebuilds = system.lastStatistics().neighbourRebuilds;
  tangentialForce = 0.0;
  for (const ContactRecord& c : system.contacts()) {
    const Vec3 f{c.force[0], c.force[1], c.force[2]}, n{c.normal[0], c.normal[1], c.normal[2]};
    tangentialForce = std::max(tangentialForce, railcosim::kernels::norm(railcosim::kernels::tangentialPart(f, n)));
  }
  return system.positions();
}

} // namespace

// History survives list rebuilds: rebuilding every step carries each contact's elastic tangential force by
// partner id, so the trajectory equals that of a run whose single list is never rebuilt (bitwise up to the
// order-independent arithmetic; 1e-12 m allowed). A dropped history would reset the springs each step.
BOOST_AUTO_TEST_CASE(tangential_history_survives_list_rebuild) {
  double forceEveryStep = 0.0, forceNever = 0.0;
  std::int64_t rebuildsEveryStep = 0, rebuildsNever = 0;
  const std::vector<double> everyStep = pushedStack(1, false, forceEveryStep, rebuildsEveryStep);
  const std::vector<double> never = pushedStack(100000, false, forceNever, rebuildsNever);
  BOOST_TEST(rebuildsEveryStep == 3001); // + the rebuild for the initial forces
  BOOST_TEST(rebuildsNever == 2);
  BOOST_TEST(forceNever > 1e-4); // the springs do carry load (N), so the comparison means something
  for (std::size_t k = 0; k < everyStep.size(); ++k) BOOST_TEST(std::fabs(everyStep[k] - never[k]) < 1e-12);
  BOOST_TEST(std::fabs(forceEveryStep - forceNever) < 1e-9 * forceNever);
}

// Adaptive rebuilds: the quiet stack (speeds of mm/s, 3000 steps of 5 µs move a cube ~10 µm against a 5 mm
// skin) never needs new lists, so only the rebuilds for the initial forces and at the start of the call
// happen, and the trajectory equals the never-rebuilt one (1e-12 m as above). A stone thrown at 2 m/s
// through the same skin with the same interval must get a new list before its displacement plus twice the
// travel of the next interval and one step (2 × 2 m/s × 11 × 5 µs = 0.22 mm) reaches skin/2 = 2.5 mm.
BOOST_AUTO_TEST_CASE(adaptive_rebuild_skips_only_what_the_lists_do_not_need) {
  double forceAdaptive = 0.0, forceNever = 0.0;
  std::int64_t rebuildsAdaptive = 0, rebuildsNever = 0;
  const std::vector<double> adaptive = pushedStack(10, true, forceAdaptive, rebuildsAdaptive);
  const std::vector<double> never = pushedStack(100000, false, forceNever, rebuildsNever);
  BOOST_TEST(rebuildsAdaptive == 2); // initial forces and the start of the call
  for (std::size_t k = 0; k < adaptive.size(); ++k) BOOST_TEST(std::fabs(adaptive[k] - never[k]) < 1e-12);

  Parameters p = quietParameters(0.3, 0.5);
  p.gravity = {0, 0, 0};
  p.timeStep = 5e-6;
  p.neighbourSkin = 0.005;
  PolyhedraSystem system(p);
  const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
  system.addStone(cube, {0, 0, 0}, {1, 0, 0, 0}, {2.0, 0, 0});
  system.addStone(cube, {0.2, 0, 0}, {1, 0, 0, 0}, {0, 0, 0});
  system.step(3000);
  const std::int64_t rebuilds = system.lastStatistics().neighbourRebuilds;
  BOOST_TEST_MESSAGE("adaptive rebuilds: quiet stack " << rebuildsAdaptive << ", moving stone " << rebuilds);
  // A list lasts while moved + 0.22 mm ≤ 2.5 mm, i.e. 23 intervals of 0.1 mm: 300 intervals need
  // 300 / 23 ≈ 13 rebuilds, plus the two at the start.
  BOOST_TEST(rebuilds >= 14);
  BOOST_TEST(rebuilds <= 16);
  BOOST_TEST(system.lastStatistics().dangerousRebuilds == 0);
}

namespace {

// A slab (0.16 × 0.16 × 0.03 m core, bounding radius 0.115 m) dropped onto 16 cubes (bounding radius 0.018 m) on a
// floor, with the slab kept out of the grid (largeBodyRatio 2.5: 6.3 times the median) or in it (0): contacts after
// the first step and the state after `steps`.
struct SlabRun {
  std::vector<ContactRecord> contacts;
  std::vector<double> positions;
  StepStatistics statistics;
};

SlabRun slabOnCubes(double largeBodyRatio, int steps) {
  Parameters p = quietParameters(0.3, 0.5);
  p.gravity = {0, 0, -9.81};
  p.timeStep = 5e-6;
  p.largeBodyRatio = largeBodyRatio;
  PolyhedraSystem system(p);
  const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
  std::vector<double> corners;
  for (double x : {-0.08, 0.08})
    for (double y : {-0.08, 0.08})
      for (double z : {-0.015, 0.015}) corners.insert(corners.end(), {x, y, z});
  const int slab = system.addShape(convexHullTemplate(corners, 0.001, 2600));
  addFloor(system, 0.2);
  for (int ix = 0; ix < 4; ++ix)
    for (int iy = 0; iy < 4; ++iy) system.addStone(cube, {-0.06 + 0.04 * ix, -0.06 + 0.04 * iy, 0.0109}, {1, 0, 0, 0});
  // 0.1 mm of overlap with each cube top (0.0219 m), tilted a little so that the contacts differ.
  system.addStone(slab, {0.003, -0.002, 0.0378}, {0.99999983, 0.0005, -0.0003, 0.0});
  SlabRun run;
  system.step(1);
  run.contacts = system.contacts();
  system.step(steps);
  run.positions = system.positions();
  run.statistics = system.lastStatistics();
  return run;
}

} // namespace

// A large body outside the grid (Parameters::largeBodyRatio) is found by every stone within its reach: the slab
// lying on 16 cubes has the same 32 contacts (16 cube–floor, 16 cube–slab) with the same forces as with every body in
// a grid of slab-sized cells. Forces agree to 1e-9 relative: the pair is evaluated from the other side (cube first)
// when the cube lists the slab, which changes the arithmetic's order but nothing else; 2000 steps later (0.01 s of
// the slab rocking on the cubes) the states agree to 1e-9 m for the same reason.
BOOST_AUTO_TEST_CASE(large_body_outside_the_grid_meets_every_stone_in_reach) {
  const SlabRun split = slabOnCubes(2.5, 2000), grid = slabOnCubes(0.0, 2000);
  BOOST_TEST(split.contacts.size() == 32u);
  BOOST_TEST(grid.contacts.size() == 32u);
  auto key = [](const ContactRecord& c) {
    return c.wall ? std::make_pair(c.first, -1 - c.second)
                  : std::make_pair(std::min(c.first, c.second), std::max(c.first, c.second));
  };
  for (const ContactRecord& a : split.contacts) {
    const auto match = std::find_if(grid.contacts.begin(), grid.contacts.end(),
                                    [&](const ContactRecord& b) { return key(a) == key(b); });
    BOOST_TEST_REQUIRE((match != grid.contacts.end()));
    // The force on `second`: a pair listed the other way round reports the opposite force.
    const double sign = !a.wall && a.first != match->first ? -1.0 : 1.0;
    const Vec3 fa{a.force[0], a.force[1], a.force[2]}, fb{match->force[0], match->force[1], match->force[2]};
    BOOST_TEST(railcosim::kernels::norm(fa - sign * fb) <= 1e-9 * railcosim::kernels::norm(fb));
  }
  for (std::size_t k = 0; k < split.positions.size(); ++k)
    BOOST_TEST(std::fabs(split.positions[k] - grid.positions[k]) < 1e-9);
  BOOST_TEST(split.statistics.dangerousRebuilds == 0);
}

namespace {

// Two cubes stacked on the floor under a plate (two triangles facing down, 29.8 mm above the upper cube) that moves
// down at `speed` [m/s] for 3000 steps of 5 µs; returns the final positions, the rebuild count and the number of
// contacts with the plate at the end.
std::vector<double> stackUnderPlate(double speed, int rebuildInterval, bool adaptive, std::int64_t& rebuilds,
                                    std::int64_t& dangerous, int& plateContacts) {
  Parameters p = quietParameters(0.3, 0.5);
  p.gravity = {0, 0, -9.81};
  p.timeStep = 5e-6;
  p.rebuildInterval = rebuildInterval;
  p.adaptiveRebuild = adaptive;
  p.neighbourSkin = 0.005;
  PolyhedraSystem system(p);
  const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
  const double h = 0.0109 + 0.0218 + 0.011 + 0.0298, half = 0.1;
  const std::vector<double> nodes = {-half, -half, 0, half, -half, 0, half, half, 0, -half, half, 0,
                                     -half, -half, h, half, -half, h, half, half, h, -half, half, h};
  system.setWalls(nodes, {0, 1, 2, 0, 2, 3, 4, 6, 5, 4, 7, 6});
  std::vector<double> velocities(nodes.size(), 0.0);
  for (int k = 4; k < 8; ++k) velocities[3 * k + 2] = -speed;
  system.setSurfaceKinematics(nodes, velocities);
  system.addStone(cube, {0, 0, 0.0109}, {1, 0, 0, 0});
  system.addStone(cube, {0.003, 0, 0.0109 + 0.0218}, {1, 0, 0, 0});
  system.step(3000);
  rebuilds = system.lastStatistics().neighbourRebuilds;
  dangerous = system.lastStatistics().dangerousRebuilds;
  plateContacts = 0;
  for (const ContactRecord& c : system.contacts()) plateContacts += c.wall && c.second >= 2 ? 1 : 0;
  return system.positions();
}

} // namespace

// Moving walls in the stale test: a plate coming down at 1 mm/s travels 15 µm in 3000 steps, far inside half the
// 5 mm skin, so the adaptive run keeps its first lists (2 rebuilds: initial forces, the call's start) where a moving
// surface used to rebuild every 10 steps, and its trajectory equals a run rebuilding every step (1e-12 m, as above).
// At 2 m/s the plate reaches the upper cube after 14.9 ms and presses on it: the lists must be renewed before the
// plate's travel plus twice its way over the next interval and a step (2 × 2 m/s × 11 × 5 µs = 0.22 mm) reaches 2.5 mm,
// i.e. every 23 intervals: 300 / 23 ≈ 13 rebuilds plus the two, and the trajectory equals the every-step run's.
BOOST_AUTO_TEST_CASE(moving_plate_counts_in_the_rebuild_test) {
  std::int64_t rebuilds = 0, reference = 0, dangerous = 0, ignored = 0;
  int plateContacts = 0, referenceContacts = 0;
  const std::vector<double> slow = stackUnderPlate(0.001, 10, true, rebuilds, dangerous, plateContacts);
  const std::vector<double> slowEveryStep = stackUnderPlate(0.001, 1, false, reference, ignored, referenceContacts);
  BOOST_TEST(rebuilds == 2);
  for (std::size_t k = 0; k < slow.size(); ++k) BOOST_TEST(std::fabs(slow[k] - slowEveryStep[k]) < 1e-12);
  BOOST_TEST(plateContacts == 0);
  const std::vector<double> fast = stackUnderPlate(2.0, 10, true, rebuilds, dangerous, plateContacts);
  const std::vector<double> fastEveryStep = stackUnderPlate(2.0, 1, false, reference, ignored, referenceContacts);
  BOOST_TEST_MESSAGE("moving plate: rebuilds " << rebuilds << " at 2 m/s, plate contacts " << plateContacts);
  BOOST_TEST(plateContacts >= 1); // the plate does press on the upper cube at the end
  BOOST_TEST(referenceContacts == plateContacts);
  BOOST_TEST(rebuilds >= 14);
  BOOST_TEST(rebuilds <= 16);
  BOOST_TEST(dangerous == 0);
  for (std::size_t k = 0; k < fast.size(); ++k) BOOST_TEST(std::fabs(fast[k] - fastEveryStep[k]) < 1e-12);
}

// Stones are stored in spatial (Morton) order from the first step on; every accessor, setState and
// contacts() must still speak the order of addStone. Four cubes added far corner first: two free ones
// (user 0 and 3) must move by exactly v Δt (no force: velocity Verlet is exact, 1e-15 m roundoff), the
// touching pair (users 1 and 2, 1 mm of overlap along x) must be the one contact, with equal and opposite
// x forces on users 1 and 2 only; setState must round-trip the state.
BOOST_AUTO_TEST_CASE(stone_indices_stay_the_users_after_spatial_ordering) {
  PolyhedraSystem system(quietParameters(0.5, 0.5));
  const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
  const std::array<std::array<double, 3>, 4> x = {
      {{1.0, 1.0, 1.0}, {0.0, 0.0, 0.0}, {0.021, 0.0, 0.0}, {0.5, 0.0, 0.0}}};
  const std::array<std::array<double, 3>, 4> v = {
      {{0.1, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, -0.2, 0.0}}};
  for (int k = 0; k < 4; ++k) BOOST_TEST(system.addStone(cube, x[k], {1, 0, 0, 0}, v[k]) == k);
  system.step(1);
  const double dt = 4e-6;
  const auto position = system.positions(), velocity = system.velocities(), force = system.forces();
  for (const int k : {0, 3})
    for (int c = 0; c < 3; ++c) {
      BOOST_TEST(std::fabs(position[3 * k + c] - (x[k][c] + v[k][c] * dt)) < 1e-15);
      BOOST_TEST(velocity[3 * k + c] == v[k][c]);
      BOOST_TEST(force[3 * k + c] == 0.0);
    }
  BOOST_TEST(force[3] < 0.0); // user 1, pushed towards −x by user 2
  BOOST_TEST(force[6] > 0.0);
  BOOST_TEST(std::fabs(force[3] + force[6]) < 1e-12 * force[6]);
  const auto contacts = system.contacts();
  BOOST_TEST_REQUIRE(contacts.size() == 1u);
  BOOST_TEST(std::min(contacts[0].first, contacts[0].second) == 1);
  BOOST_TEST(std::max(contacts[0].first, contacts[0].second) == 2);
  // Force on `second`, normal from first to second: the one on user 2 points to +x.
  const double onUser2 = contacts[0].second == 2 ? contacts[0].force[0] : -contacts[0].force[0];
  BOOST_TEST(std::fabs(onUser2 - force[6]) < 1e-12 * force[6]);
  // Input that would poison the storage order (and everything else) is refused with the stone's index.
  PolyhedraSystem other(quietParameters(0.5, 0.5));
  const int shape = other.addShape(cubeTemplate(0.01, 0.001, 2600));
  BOOST_CHECK_THROW(other.addStone(shape, {std::nan(""), 0.0, 0.0}, {1, 0, 0, 0}), railcosim::Error);
  BOOST_CHECK_THROW(other.addStone(shape, {0.0, 0.0, 0.0}, {0, 0, 0, 0}), railcosim::Error);
  BOOST_TEST(other.stoneCount() == 0u);
  // setState takes the user's order: moving user 0 only moves user 0.
  std::vector<double> moved = position;
  moved[0] += 0.25;
  system.setState(moved, system.orientations(), velocity, system.angularVelocities());
  const auto back = system.positions();
  for (std::size_t k = 0; k < back.size(); ++k) BOOST_TEST(back[k] == moved[k]);
  // A state with a NaN is refused and changes nothing.
  std::vector<double> poisoned = back;
  poisoned[7] = std::nan("");
  BOOST_CHECK_THROW(system.setState(poisoned, system.orientations(), velocity, system.angularVelocities()),
                    railcosim::Error);
  BOOST_TEST(system.positions() == back);
}

// The slot keeps the last tangential stiffness in single precision; the one-sided unloading correction of the
// tangential spring must not mistake the rounding for unloading. A static contact (fixed overlap, no
// relative motion) holding a 1 N tangential spring far below the Coulomb limit (μ F_n ≈ 200 N) must keep it
// exactly over 1e6 evaluations; with the rounded value as the previous one a rounded-up copy loses 0.35 %.
BOOST_AUTO_TEST_CASE(static_tangential_spring_keeps_its_force) {
  const railcosim::kernels::ContactLaw constants = law(1e10, 0.25, 0.6);
  const double r = 0.003;
  ContactGeometry g{true, 1.234568e-4, Vec3{0, 0, 1}, Vec3{0, 0, 0}, false};
  ContactSlot slot{1, 1, 0.0f, {0, 0, 1}, {1.0, 0, 0}, 0};
  const ContactKinematics rest{Vec3{0, 0, 0}, Vec3{0, 0, 0}, Vec3{0, 0, -0.01}};
  ContactKinematics other = rest;
  other.centre = Vec3{0, 0, 0.01};
  Vec3 force{0, 0, 0};
  for (int k = 0; k < 1000000; ++k) force = contactForce(g, 0.5 * r, 0.01, constants, rest, other, 1e-6, slot, nullptr);
  // The stored k_t rounds up here, so the test exercises the comparison (a value that rounds down would pass
  // without it).
  const double stiffness = railcosim::kernels::mindlinTangentialStiffness(
      railcosim::kernels::HertzMindlinParams{constants.params.hertzMindlin.effectiveYoungModulus,
                                             constants.params.hertzMindlin.effectiveShearModulus, 0.5 * r, 0.01, 0.0},
      g.overlap);
  BOOST_TEST(static_cast<double>(static_cast<float>(stiffness)) > stiffness);
  BOOST_TEST(force.z > 100.0); // the Hertz force, so that Coulomb does not cap the 1 N spring
  BOOST_TEST(std::fabs(slot.elasticShear[0] - 1.0) < 1e-12);
  BOOST_TEST(std::fabs(force.x - 1.0) < 1e-12);
}

// A moving floor: the triangles report the stone's weight and the contact point under it; a floor that
// rises at constant speed carries the resting stone with it.
BOOST_AUTO_TEST_CASE(surface_reports_triangle_forces_and_carries_stone) {
  Parameters p = quietParameters(0.2, 0.5);
  p.gravity = {0, 0, -9.81};
  p.timeStep = 1e-5;
  PolyhedraSystem system(p);
  const int stone = system.addShape(dodecahedronStone(0.012, 0.01, 0.008, 0.001, 2600));
  addFloor(system, 0.1);
  system.addStone(stone, {0.02, 0.01, 0.0095}, {1, 0, 0, 0});
  system.step(20000); // 0.2 s: the stone comes to rest on the floor
  system.step(2000);  // window whose mean triangle forces are checked
  const double weight = system.shapeProperties(stone).mass * 9.81;
  const auto forces = system.triangleForces();
  const auto points = system.triangleContactPoints();
  double total = 0.0;
  for (std::size_t t = 0; t < system.triangleCount(); ++t) total += forces[3 * t + 2];
  // At rest the floor carries the weight: residual vibration averages out over the 0.02 s window (1 %).
  BOOST_TEST(std::fabs(-total - weight) < 0.01 * weight);
  const auto x = system.positions();
  // The loaded triangle's point lies under the stone (within the stone's half size, 0.012 m), on the floor.
  for (std::size_t t = 0; t < system.triangleCount(); ++t) {
    if (std::fabs(forces[3 * t + 2]) < 0.5 * weight) continue;
    BOOST_TEST(std::hypot(points[3 * t] - x[0], points[3 * t + 1] - x[1]) < 0.012);
    // Mid-plane of the overlap between floor (z = 0) and dilated surface (z = −δ): z = −δ/2, δ ≪ r_d.
    BOOST_TEST(points[3 * t + 2] <= 0.0);
    BOOST_TEST(points[3 * t + 2] > -0.05 * 0.001);
  }
  // Raise the floor at 0.05 m/s for 0.05 s: the stone follows (its velocity within 5 % of the floor's).
  std::vector<double> nodes = {-0.1, -0.1, 0, 0.1, -0.1, 0, 0.1, 0.1, 0, -0.1, 0.1, 0};
  std::vector<double> speeds(12, 0.0);
  for (int k = 0; k < 4; ++k) speeds[3 * k + 2] = 0.05;
  system.setSurfaceKinematics(nodes, speeds);
  system.step(5000);
  const auto v = system.velocities();
  BOOST_TEST(std::fabs(v[2] - 0.05) < 0.05 * 0.05);
  BOOST_TEST(system.positions()[2] > x[2] + 0.0024); // lifted by ≈ 0.0025 m
}

// A GJK run stopped at the iteration limit 0 (the GPU's first narrow-phase pass) and resumed from the
// simplex it returned must end exactly where one undivided run ends: same distance, points, simplex and
// iteration count, bit for bit, over random stone pairs from touching to well apart (and identical aligned
// cubes, whose coplanar supports are the hardest case), with and without a warm start. After the limits 1
// and 3 the resumed run recomputes its direction from the saved simplex: equal to roundoff (1e-15 m at
// distances of mm), which is all that is claimed there.
BOOST_AUTO_TEST_CASE(gjk_resumed_after_iteration_limit_equals_undivided_run) {
  const ShapeTemplate a = dodecahedronStone(0.03, 0.025, 0.02, 0.003, 2600);
  const ShapeTemplate b = dodecahedronStone(0.024, 0.027, 0.026, 0.003, 2600);
  unsigned seed = 777u;
  auto uniform = [&seed](double lo, double hi) {
    seed = seed * 1664525u + 1013904223u;
    return lo + (hi - lo) * (seed >> 8) / 16777216.0;
  };
  int resumed = 0;
  const ShapeTemplate cube = cubeTemplate(0.02, 0.003, 2600);
  for (int k = 0; k < 20000; ++k) {
    const bool cubes = k % 4 == 3; // aligned identical cubes, offset mostly along one axis
    const ShapeTemplate& shapeA = cubes ? cube : a;
    const ShapeTemplate& shapeB = cubes ? cube : b;
    const Quat turn =
        cubes ? Quat{1, 0, 0, 0} : normalized(Quat{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)});
    const ConvexCore coreA = place(shapeA, Vec3{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)}, turn);
    const Vec3 direction = cubes ? Vec3{uniform(-0.1, 0.1), uniform(-0.1, 0.1), 1.0}
                                 : Vec3{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)};
    const Vec3 offset =
        ((cubes ? uniform(0.041, 0.05) : uniform(0.035, 0.07)) / railcosim::kernels::norm(direction)) * direction;
    const ConvexCore coreB =
        place(shapeB, coreA.position + offset,
              cubes ? turn : normalized(Quat{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)}));
    // A warm simplex from a nearby earlier pose half of the time (as a persistent candidate has).
    std::uint64_t warm = 0;
    if (k % 2 == 1) {
      const ConvexCore earlier = place(shapeB, coreB.position + Vec3{0.002, -0.001, 0.0015},
                                       cubes ? turn : normalized(Quat{1.0, 0.05, -0.03, 0.02}));
      warm = coreDistance(coreA, earlier, offset, 0.006).simplex;
    }
    const CoreDistance whole = coreDistance(coreA, coreB, offset, 0.006, warm);
    for (const int limit : {0, 1, 3}) {
      CoreDistance part = coreDistance(coreA, coreB, offset, 0.006, warm, limit);
      int iterations = 0;
      if (part.unfinished) {
        ++resumed;
        iterations = part.iterations;
        BOOST_TEST(part.simplex != 0u);
        part = coreDistance(coreA, coreB, offset, 0.006, part.simplex);
      }
      BOOST_TEST(!part.unfinished);
      BOOST_TEST(part.intersecting == whole.intersecting);
      BOOST_TEST(std::isfinite(whole.distance)); // coincident support points of the aligned cubes once gave NaN
      if (limit == 0) {
        BOOST_TEST(part.beyondCutoff == whole.beyondCutoff);
        BOOST_TEST(part.distance == whole.distance); // exact: the same arithmetic in the same order
        BOOST_TEST(part.pointA.x == whole.pointA.x);
        BOOST_TEST(part.pointB.z == whole.pointB.z);
        BOOST_TEST(part.simplex == whole.simplex);
        BOOST_TEST(iterations + part.iterations == whole.iterations);
      } else if (!part.beyondCutoff && !whole.beyondCutoff) {
        BOOST_TEST(std::fabs(part.distance - whole.distance) < 1e-15);
      }
    }
  }
  BOOST_TEST_MESSAGE("GJK runs resumed after the limit: " << resumed);
  BOOST_TEST(resumed > 100); // the limits actually interrupt runs
}

// GJK's triangle step over every triple of support pairs of two aligned identical cubes, whose Minkowski
// difference has many coincident points (a_i − b_j = a_k − b_l): zero-length edges once gave 0/0 = NaN.
// Oracle: the result must be finite, a convex combination of the triangle's points (weights ≥ 0 summing to 1,
// reproducing the point to 1e-15 m: roundoff at coordinates of 0.1 m), and no farther from the origin than
// the nearest point of any of the three edges (closed-form point–segment distance with clamping, exact for
// coincident ends), to the same roundoff.
BOOST_AUTO_TEST_CASE(gjk_triangle_step_handles_coincident_support_points) {
  using namespace railcosim::polyhedra::detail;
  const ShapeTemplate cube = cubeTemplate(0.02, 0.003, 2600);
  const ConvexCore a = place(cube, Vec3{0.01, -0.02, 0.05}, Quat{1, 0, 0, 0});
  const ConvexCore b = place(cube, Vec3{0.01, -0.02, 0.05 + 0.041}, Quat{1, 0, 0, 0});
  const Pair pair{a, b};
  auto segmentToOrigin = [](const Vec3& p, const Vec3& q) {
    const Vec3 d = q - p;
    const double length2 = railcosim::kernels::dot(d, d);
    const double t = length2 > 0.0 ? std::clamp(-railcosim::kernels::dot(p, d) / length2, 0.0, 1.0) : 0.0;
    return railcosim::kernels::norm(p + t * d);
  };
  int coincident = 0, checked = 0;
  std::vector<SimplexVertex> supports;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) supports.push_back(SimplexVertex{i, j});
  for (const SimplexVertex& P : supports)
    for (const SimplexVertex& Q : supports)
      for (const SimplexVertex& R : supports) {
        if (sameSupport(P, Q.a, Q.b) || sameSupport(P, R.a, R.b) || sameSupport(Q, R.a, R.b)) continue;
        const Vec3 p = point(pair, P), q = point(pair, Q), r = point(pair, R);
        if (railcosim::kernels::squaredNorm(p - q) == 0.0 || railcosim::kernels::squaredNorm(p - r) == 0.0 ||
            railcosim::kernels::squaredNorm(q - r) == 0.0)
          ++coincident;
        Simplex out;
        Weights w;
        Vec3 closest;
        closestOnTriangle(pair, P, Q, R, out, w, closest);
        ++checked;
        const double distance = railcosim::kernels::norm(closest);
        const double edges = std::min({segmentToOrigin(p, q), segmentToOrigin(p, r), segmentToOrigin(q, r)});
        const bool finite =
            std::isfinite(distance) && std::isfinite(w.w0) && std::isfinite(w.w1) && std::isfinite(w.w2);
        BOOST_TEST_REQUIRE(finite);
        const SimplexVertex kept[3] = {out.p0, out.p1, out.p2};
        const double weights[3] = {w.w0, w.w1, w.w2};
        Vec3 combination{0, 0, 0};
        double sum = 0.0;
        for (int k = 0; k < out.count; ++k) {
          BOOST_TEST(weights[k] >= -1e-12);
          BOOST_TEST(
              (sameSupport(kept[k], P.a, P.b) || sameSupport(kept[k], Q.a, Q.b) || sameSupport(kept[k], R.a, R.b)));
          combination += weights[k] * point(pair, kept[k]);
          sum += weights[k];
        }
        BOOST_TEST(std::fabs(sum - 1.0) < 1e-12);
        BOOST_TEST(railcosim::kernels::norm(combination - closest) < 1e-15);
        BOOST_TEST(distance <= edges + 1e-15);
      }
  BOOST_TEST_MESSAGE("triangles checked: " << checked << ", with coincident points: " << coincident);
  BOOST_TEST(coincident > 1000); // the degenerate case is really exercised
}

// A touching wall contact decided by GJK (a tilted cube whose lowest vertex hangs 1 mm beside a floor
// triangle's edge and 1 mm above its plane: vertex against edge, 1.41 mm < r_d = 3 mm) must keep the final
// simplex in its slot, so that the next step's GJK starts from the same features and converges at once
// (0 iterations); the narrow phase once kept the simplex only for contacts that had come apart.
BOOST_AUTO_TEST_CASE(wall_narrow_phase_keeps_warm_simplex_of_touching_contact) {
  const double h = 0.02, r = 0.003, tilt = 0.05;
  ShapeTemplate cube = cubeTemplate(h, r, 2600);
  const Quat q = axisAngle(Vec3{0, 1, 0}, tilt);
  // The lowest vertices (+h, ±h, −h) after the turn about y, placed at x = −1 mm (beside the edge x = 0), z = +1 mm.
  const Vec3 lowest = rotate(q, Vec3{h, h, -h});
  const Vec3 centre = Vec3{-0.001, 0.2, 0.001} - lowest;
  std::vector<double> nodes = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::vector<std::int32_t> triangle = {0, 1, 2};
  ShapeData shape{0, 8, r, 0.05, 1.0, {1.0, 1.0, 1.0}};
  std::int32_t shapeIndex = 0;
  double position[3] = {centre.x, centre.y, centre.z};
  railcosim::kernels::RotationState rotation{};
  rotation.orientation = q;
  ContactSlot slot{0, 0, 0.0f, {0, 0, 0}, {0, 0, 0}, 0};
  ContactGeometry geometry{};
  unsigned long long counters[counterCount] = {};
  SystemView view{};
  view.stoneCount = 1;
  view.position = position;
  view.rotation = &rotation;
  view.shape = &shapeIndex;
  view.shapes = &shape;
  view.shapeVertices = cube.vertices.data();
  view.nodePosition = nodes.data();
  view.triangles = triangle.data();
  view.maxWalls = 1;
  view.wallSlots = &slot;
  view.wallGeometry = &geometry;
  view.counters = counters;
  const ConvexCore core = stoneCore(view, 0);
  CoreDistance shortcut;
  BOOST_TEST(!coreOverTriangleInterior(core, triangleCore(view, 0), shortcut)); // GJK decides this one
  wallNarrowPhase(view, 0, 0);
  BOOST_TEST(geometry.touching);
  BOOST_TEST(std::fabs(geometry.overlap - (r - std::sqrt(2.0) * 0.001)) < 1e-12); // δ = r_d − |(−1, 1) mm|
  BOOST_TEST(slot.simplex != 0u);
  const CoreDistance warm = coreDistance(core, triangleCore(view, 0), Vec3{0, 0, -1}, r, slot.simplex);
  BOOST_TEST(warm.iterations == 0);
  BOOST_TEST(std::fabs(warm.distance - std::sqrt(2.0) * 0.001) < 1e-12);
  BOOST_TEST(counters[counterCoreOverlap] == 0u);
}

// The wall narrow phase's plane shortcut (coreOverTriangleInterior) against an exhaustive oracle: random
// stones over a large floor triangle (20 m sides, the benchmark's scale) and a small tilted one. Where it
// applies, distance and closest points must equal the oracle's (every stone vertex against the triangle,
// every triangle corner against the stone's faces, every edge pair); where the nearest vertex projects
// outside the triangle or the stone crosses its plane it must decline, and GJK must then agree with the
// oracle for the stones wholly on one side. Tolerance 1e-12 m: both are closed-form in double precision at coordinates
// ≤ 20 m (roundoff ~20 m × 2e-16 ≈ 4e-15 m; GJK's stop leaves ~1e-13 m relative to 3 mm distances).
BOOST_AUTO_TEST_CASE(stone_over_triangle_plane_shortcut_matches_exhaustive_distance) {
  using railcosim::kernels::dot;
  const ShapeTemplate stone = dodecahedronStone(0.03, 0.025, 0.02, 0.003, 2600);
  struct Case {
    std::vector<double> corners; // 3 nodes
  };
  const std::vector<Case> triangles = {{{-3.0, -3.0, 0.0, 17.0, -3.0, 0.0, -3.0, 17.0, 0.0}},
                                       {{0.0, 0.0, 0.01, 0.12, 0.0, 0.03, 0.02, 0.1, -0.01}}};
  const std::int32_t connectivity[3] = {0, 1, 2};
  unsigned seed = 12345u;
  auto uniform = [&seed](double lo, double hi) {
    seed = seed * 1664525u + 1013904223u;
    return lo + (hi - lo) * (seed >> 8) / 16777216.0;
  };
  int applied = 0, declined = 0;
  for (const Case& t : triangles) {
    const Vec3 a{t.corners[0], t.corners[1], t.corners[2]}, b{t.corners[3], t.corners[4], t.corners[5]},
        c{t.corners[6], t.corners[7], t.corners[8]};
    Vec3 normal = railcosim::kernels::cross(b - a, c - a);
    normal = normal / railcosim::kernels::norm(normal);
    const ConvexCore triangle{t.corners.data(), 3, Rotation{{1, 0, 0, 0, 1, 0, 0, 0, 1}}, Vec3{0, 0, 0}, connectivity};
    for (int k = 0; k < 200; ++k) {
      // A point of the triangle's plane near (or just outside) it, lifted by 0–0.04 m (some cross the plane).
      const double u = uniform(-0.05, 1.05), v = uniform(-0.05, 1.05) * (1.0 - std::min(u, 1.0));
      const Vec3 onPlane = a + u * (b - a) + v * (c - a);
      const Quat q = normalized(Quat{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)});
      const Vec3 position = onPlane + uniform(0.005, 0.04) * normal;
      const ConvexCore core = place(stone, position, q);
      // Oracle: vertices of the stone against the triangle, triangle corners against the stone's faces, edges.
      std::vector<Vec3> world;
      for (std::size_t m = 0; m < stone.vertices.size(); m += 3)
        world.push_back(position + rotate(q, Vec3{stone.vertices[m], stone.vertices[m + 1], stone.vertices[m + 2]}));
      double oracle = 1e300;
      for (const Vec3& x : world) oracle = std::min(oracle, distance(closestPointOnTriangle(x, a, b, c), x));
      const Vec3 corner[3] = {a, b, c};
      for (std::size_t f = 0; f < stone.triangles.size(); f += 3) {
        const Vec3 p0 = world[stone.triangles[f]], p1 = world[stone.triangles[f + 1]],
                   p2 = world[stone.triangles[f + 2]];
        for (const Vec3& y : corner) oracle = std::min(oracle, distance(closestPointOnTriangle(y, p0, p1, p2), y));
        for (int e = 0; e < 3; ++e)
          for (int g = 0; g < 3; ++g)
            oracle =
                std::min(oracle, segmentDistance(world[stone.triangles[f + e]], world[stone.triangles[f + (e + 1) % 3]],
                                                 corner[g], corner[(g + 1) % 3]));
      }
      const bool crosses =
          std::any_of(world.begin(), world.end(), [&](const Vec3& x) { return dot(normal, x - a) <= 0.0; });
      CoreDistance shortcut;
      if (coreOverTriangleInterior(core, triangle, shortcut)) {
        ++applied;
        BOOST_TEST(!crosses);
        BOOST_TEST(std::fabs(shortcut.distance - oracle) < 1e-12);
        BOOST_TEST(std::fabs(distance(shortcut.pointA, shortcut.pointB) - oracle) < 1e-12);
        BOOST_TEST(std::fabs(dot(normal, shortcut.pointB - a)) < 1e-12); // on the triangle's plane
      } else {
        ++declined;
        if (!crosses) { // the oracle omits stone edges piercing the triangle, which only a crossing stone has
          const CoreDistance gjk = coreDistance(core, triangle, a - position);
          BOOST_TEST(std::fabs(gjk.distance - oracle) < 1e-12 * std::max(1.0, 1e3 * oracle));
        }
      }
    }
  }
  BOOST_TEST_MESSAGE("plane shortcut applied " << applied << ", declined " << declined);
  BOOST_TEST(applied > 100); // both branches exercised
  BOOST_TEST(declined > 20);
}

// A pile of 27 angular stones dropped into a box settles: kinetic energy decays to rest, no stone falls
// through the floor, no core–core overlap (the dilated contact model stays valid).
BOOST_AUTO_TEST_CASE(settling_pile_reaches_rest) {
  Parameters p = quietParameters(0.2, 0.6);
  p.gravity = {0, 0, -9.81};
  p.timeStep = 1e-5;
  // Impacts at up to 1.3 m/s move a stone 1.3e-4 m per 10-step list interval: the skin must exceed twice that.
  p.neighbourSkin = 0.001;
  PolyhedraSystem system(p);
  const int stone = system.addShape(dodecahedronStone(0.012, 0.01, 0.008, 0.001, 2600));
  // Box 0.1 × 0.1, open top: floor and four walls, normals pointing inside.
  const double w = 0.05, height = 0.15;
  std::vector<double> nodes = {-w, -w, 0,      w, -w, 0,      w, w, 0,      -w, w, 0,
                               -w, -w, height, w, -w, height, w, w, height, -w, w, height};
  std::vector<std::int32_t> triangles = {0, 1, 2, 0, 2, 3,  // floor
                                         0, 4, 5, 0, 5, 1,  // y = −w
                                         1, 5, 6, 1, 6, 2,  // x = +w
                                         2, 6, 7, 2, 7, 3,  // y = +w
                                         3, 7, 4, 3, 4, 0}; // x = −w
  system.setWalls(nodes, triangles);
  int k = 0;
  for (int ix = 0; ix < 3; ++ix)
    for (int iy = 0; iy < 3; ++iy)
      for (int iz = 0; iz < 3; ++iz, ++k) {
        const double angle = 0.7 * k;
        // 0.03 m apart: more than the bounding diameter (0.026 m), so no initial overlaps.
        system.addStone(stone, {-0.03 + 0.03 * ix, -0.03 + 0.03 * iy, 0.02 + 0.03 * iz},
                        {std::cos(angle), std::sin(angle) * 0.6, std::sin(angle) * 0.48, std::sin(angle) * 0.64});
      }
  double maxSpeed = 0.0;
  double energy = 0.0;
  std::int64_t fallbacks = 0, dangerous = 0;
  for (int window = 0; window < 16; ++window) { // 0.8 s
    system.step(5000);
    fallbacks += system.lastStatistics().coreOverlapFallbacks;
    dangerous += system.lastStatistics().dangerousRebuilds;
  }
  const auto v = system.velocities();
  const auto x = system.positions();
  const double mass = system.shapeProperties(stone).mass;
  for (std::size_t i = 0; i < system.stoneCount(); ++i) {
    const double speed = std::sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
    maxSpeed = std::max(maxSpeed, speed);
    energy += 0.5 * mass * speed * speed;
    BOOST_TEST(x[3 * i + 2] > 0.0); // centre above the floor
    BOOST_TEST(std::fabs(x[3 * i]) < w);
  }
  // Rest: stones dropped from up to 0.08 m hit at 1.25 m/s; after 0.8 s the largest speed must be below
  // 0.4 % of that (5 mm/s; measured 2.4 mm/s, while at 0.4–0.5 s stones still move at 0.01–0.07 m/s;
  // the settling time varies by ~0.1 s with round-off, which is why 0.8 s is simulated).
  BOOST_TEST_MESSAGE("settled pile: max speed " << maxSpeed << " m/s, kinetic energy " << energy << " J");
  BOOST_TEST(maxSpeed < 0.005);
  BOOST_TEST(fallbacks == 0);
  BOOST_TEST(dangerous == 0);
}

// Asking for the CUDA backend where none is usable fails loudly with the reason and the way out; on a
// machine with a GPU it must actually run on it. Automatic falls back to the CPU reference (logged once).
BOOST_AUTO_TEST_CASE(cuda_request_without_gpu_is_a_clear_error) {
  Parameters p = quietParameters(0.5, 0.5);
  p.backend = Backend::Cuda;
  try {
    PolyhedraSystem system(p);
    BOOST_TEST((system.activeBackend() == Backend::Cuda));
  } catch (const railcosim::Error& error) {
    const std::string message = error.what();
    BOOST_TEST(message.find("CUDA backend was requested") != std::string::npos);
    BOOST_TEST(message.find("Backend::Cpu") != std::string::npos);
  }
  p.backend = Backend::Automatic;
  PolyhedraSystem automatic(p);
  BOOST_TEST(!automatic.backendReason().empty());
}

// Principal frame convention of addShape (principalAxes in PolyhedraSystem.cpp): a template already in principal
// axes keeps its frame and the order of its moments; otherwise the frame is the eigenvector frame closest to the
// given one (largest Σ_k |v_k·e_k|, v_k·e_k ≥ 0 but for one axis reversed to make it right-handed); an isotropic
// tensor keeps the given axes; for two equal moments the odd axis is the eigenvector.
BOOST_AUTO_TEST_CASE(principal_frame_is_the_eigenvector_frame_closest_to_the_given_one) {
  PolyhedraSystem system(quietParameters(0.5, 0.5));
  const auto rotated = [](ShapeTemplate shape, const Quat& q) {
    const Rotation r = rotationMatrix(normalized(q));
    for (std::size_t k = 0; k < shape.vertices.size(); k += 3) {
      const Vec3 v = apply(r, Vec3{shape.vertices[k], shape.vertices[k + 1], shape.vertices[k + 2]});
      shape.vertices[k] = v.x;
      shape.vertices[k + 1] = v.y;
      shape.vertices[k + 2] = v.z;
    }
    return shape;
  };
  const auto frameOf = [&](int shape) { // m[3 r + c]: component r of principal axis c in the given frame
    const std::array<double, 4> q = system.shapeProperties(shape).principalToGiven;
    return rotationMatrix(Quat{q[0], q[1], q[2], q[3]});
  };
  const std::array<double, 4> identity{1.0, 0.0, 0.0, 0.0};
  const Quat q0{0.9, 0.3, -0.2, 0.25}, q1{0.2, 0.7, 0.1, -0.5};
  const ShapeTemplate stone = dodecahedronStone(0.026, 0.028, 0.022, 0.003, 2600); // moments I_y < I_x < I_z

  const ShapeProperties given = system.shapeProperties(system.addShape(stone));
  BOOST_TEST((given.principalToGiven == identity));
  BOOST_TEST(given.principalInertia[0] > given.principalInertia[1]);

  for (const Quat& q : {q0, q1}) {
    const int shape = system.addShape(rotated(stone, q));
    std::array<double, 3> moments = system.shapeProperties(shape).principalInertia, expected = given.principalInertia;
    std::sort(moments.begin(), moments.end());
    std::sort(expected.begin(), expected.end());
    // Ratios: the dilated volume, hence the scale of the moments, carries the rotated edge angles' round-off.
    for (int k = 0; k < 2; ++k)
      BOOST_TEST(moments[k] / moments[2] == expected[k] / expected[2], boost::test_tools::tolerance(1e-12));
    const Rotation r = frameOf(shape);
    const double alignment = std::fabs(r.m[0]) + std::fabs(r.m[4]) + std::fabs(r.m[8]);
    for (const auto& p : {std::array<int, 3>{0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}})
      BOOST_TEST(alignment >= std::fabs(r.m[p[0]]) + std::fabs(r.m[3 + p[1]]) + std::fabs(r.m[6 + p[2]]));
    BOOST_TEST((r.m[0] < 0.0) + (r.m[4] < 0.0) + (r.m[8] < 0.0) <= 1);
  }

  BOOST_TEST((system.shapeProperties(system.addShape(rotated(cubeTemplate(0.01, 0.001, 2600), q0))).principalToGiven ==
              identity));

  const int axisymmetric = system.addShape(rotated(dodecahedronStone(0.02, 0.02, 0.03, 0.002, 2600), q0));
  const std::array<double, 3> moments = system.shapeProperties(axisymmetric).principalInertia;
  const double sum = moments[0] + moments[1] + moments[2];
  int odd = 0; // the moment farthest from the mean of the two others
  for (int k = 1; k < 3; ++k)
    if (std::fabs(1.5 * moments[k] - 0.5 * sum) > std::fabs(1.5 * moments[odd] - 0.5 * sum)) odd = k;
  const Rotation r = frameOf(axisymmetric);
  const Vec3 longAxis = apply(rotationMatrix(normalized(q0)), Vec3{0.0, 0.0, 1.0});
  BOOST_TEST(std::fabs(r.m[odd] * longAxis.x + r.m[3 + odd] * longAxis.y + r.m[6 + odd] * longAxis.z) == 1.0,
             boost::test_tools::tolerance(1e-12));
}

// The contact law's path scenarios (tests/kernels/ContactLawScenarios.hpp) on the CPU reference: the elasto-plastic
// Pohrt–Popov cycle of a point core dilated by R (a sphere) on the floor gives the closed-form peak force, plastic
// overlap and unloading branch, and the impact the restitution, within the tolerances every path shares. The GPU
// comparison runs the same two on the CUDA backend.
BOOST_AUTO_TEST_CASE(contact_law_scenarios_give_the_closed_forms) {
  namespace scenario = railcosim::testing::scenario;
  const scenario::CycleRecorder cycle = railcosim::testing::runCycleScenario(Backend::Cpu);
  BOOST_TEST_REQUIRE(cycle.done);
  BOOST_TEST_MESSAGE(std::setprecision(9)
                     << "polyhedra CPU cycle: F_max " << cycle.peakForce << " N at " << cycle.peakOverlap
                     << " m, force vanishes in [" << cycle.zeroOverlap << ", " << cycle.releaseOverlap
                     << "] m, closed-form δ_p " << scenario::plasticOverlap(cycle.peakOverlap, cycle.peakForce)
                     << " m; errors: peak " << cycle.peakForceError() << ", unloading " << cycle.unloadingForceError());
  BOOST_TEST(cycle.peakForceError() < scenario::peakForceTolerance);
  BOOST_TEST(cycle.plasticOverlapStepsOutside() <= scenario::plasticOverlapStepTolerance);
  BOOST_TEST(cycle.unloadingForceError() < scenario::unloadingForceTolerance);
  const double restitution = railcosim::testing::runImpactScenario(Backend::Cpu);
  BOOST_TEST_MESSAGE(std::setprecision(9) << "polyhedra CPU impact: e = " << restitution);
  BOOST_TEST(std::fabs(restitution / scenario::impactRestitution - 1.0) < scenario::restitutionTolerance);
}

// A sphere as a one-point core (the steel sheet's wheat grains): registered through BodyFrameStones like every driver's
// stone, it has the sphere's mass, and resting on a steel floor under gravity it sinks by Hertz's static overlap,
// δ = (3 m g / (4 E* √r))^(2/3) with E* = 1 / ((1 − ν1²)/E1 + (1 − ν2²)/E2) (Johnson 1985, eq. 4.22): the law of the
// dilation's curvature is a sphere's law.
BOOST_AUTO_TEST_CASE(point_core_sphere_rests_at_hertz_overlap) {
  const double r = 0.002, density = 1242.0, g = 9.81;
  Parameters p;
  p.timeStep = 1e-6;
  p.gravity = {0, 0, -g};
  p.stone = Material{1e8, 0.3, 0.4, 1.0};
  p.wall = Material{185e9, 0.3, 0.4, 0.22};
  p.backend = Backend::Cpu;
  PolyhedraSystem system(p);
  BodyFrameStones stones;
  stones.add(system, {0.0, 0.0, 0.0}, r, density, {0.0, 0.0, r}, {1, 0, 0, 0}, {0, 0, 0}, {0, 0, 0});
  system.setWalls({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
  const double mass = density * 4.0 / 3.0 * pi * r * r * r;
  BOOST_TEST(std::fabs(stones.mass(0) - mass) < 1e-12 * mass);
  system.step(100000); // 0.1 s: the viscous damping of e = 0.4 stops the bounce (period 0.65 ms) within a few ms
  const double compliance = (1 - 0.3 * 0.3) / 1e8 + (1 - 0.3 * 0.3) / 185e9;
  const double overlap = std::pow(3.0 * mass * g * compliance / (4.0 * std::sqrt(r)), 2.0 / 3.0);
  const double sunk = r - system.positions()[2];
  BOOST_TEST_MESSAGE("overlap " << sunk << " m, Hertz " << overlap << " m");
  // At rest, Verlet's equilibrium is exactly F(δ) = mg; 1e-4 relative covers what is left of the decaying bounce
  // after more than 100 damping times.
  BOOST_TEST(std::fabs(sunk - overlap) < 1e-4 * overlap);
  BOOST_TEST(std::fabs(system.velocities()[2]) < 1e-6);
}

// Non-viscous damping (Parameters::damping, YADE's NewtonIntegrator.damping) on a stone in free fall, no contact:
// gravity accelerates a falling stone, so it acts at (1 - λ) g, and brakes a rising one, so it acts at (1 + λ) g.
// Constant accelerations, which velocity Verlet integrates exactly: v = v0 + a t and x = x0 + v0 t + a t²/2 up to
// rounding. Each run starts away from v = 0 and ends before the velocity would cross it.
// Damping 0 (the default) leaves the fall at g; damping outside [0, 1) is refused.
BOOST_AUTO_TEST_CASE(non_viscous_damping_scales_gravity_as_the_closed_form) {
  const double g = 9.81, lambda = 0.3, dt = 1e-5, r = 0.01;
  for (const double v0 : {-1.0, 1.0}) { // falling, rising
    Parameters p;
    p.timeStep = dt;
    p.gravity = {0, 0, -g};
    p.damping = lambda;
    p.stone = Material{1e8, 0.3, 0.4, 0.5};
    p.backend = Backend::Cpu;
    PolyhedraSystem system(p);
    BodyFrameStones stones;
    stones.add(system, {0.0, 0.0, 0.0}, r, 2700.0, {0.0, 0.0, 1.0}, {1, 0, 0, 0}, {0.0, 0.0, v0}, {0, 0, 0});
    const int steps = 5000; // 0.05 s: a rising stone at 1 m/s slows by 0.64 m/s, still rising
    system.step(steps);
    const double t = steps * dt, a = -g * (v0 < 0 ? 1.0 - lambda : 1.0 + lambda);
    BOOST_TEST_MESSAGE("v0 " << v0 << " m/s: v " << system.velocities()[2] << " m/s, closed form " << v0 + a * t);
    BOOST_TEST(std::fabs(system.velocities()[2] - (v0 + a * t)) < 1e-9); // rounding over 5000 steps
    BOOST_TEST(std::fabs(system.positions()[2] - (1.0 + v0 * t + 0.5 * a * t * t)) < 1e-9);
    system.setDamping(0.0);
    const double v1 = system.velocities()[2];
    system.step(1000);
    BOOST_TEST(std::fabs(system.velocities()[2] - (v1 - g * 1000 * dt)) < 1e-9); // undamped: g again
  }
  const auto namesDamping = [](const std::exception& e) {
    return std::string(e.what()).find("damping") != std::string::npos;
  };
  Parameters bad;
  bad.damping = 1.0;
  BOOST_CHECK_EXCEPTION(PolyhedraSystem{bad}, std::exception, namesDamping);
  Parameters good;
  good.backend = Backend::Cpu;
  PolyhedraSystem system(good);
  BOOST_CHECK_EXCEPTION(system.setDamping(-0.1), std::exception, namesDamping);
}

// Bounded rolling friction on a sphere stone (a one-vertex core): Irazábal 2017's BROF benchmarks against the
// rigid-body closed forms of PolyhedraScenarioRuns.hpp, within rollingTolerance (0.2 %, justified there). A stopped
// spin must stay exactly stopped (the bound never pushes it past zero): 1e-9 rad/s.
BOOST_AUTO_TEST_CASE(bounded_rolling_friction_stops_a_sphere_as_the_closed_forms) {
  using namespace railcosim::testing;
  const RollingRun flat = runRollingScenario(Backend::Cpu, 0.2, 0.0, false);
  BOOST_TEST_MESSAGE("flat: stops at t = " << flat.stopTime << " s, x = " << flat.stopX << " m; final x " << flat.finalX
                                           << " m, |ω| " << flat.finalSpin << " rad/s");
  BOOST_TEST(std::fabs(flat.stopTime / rollOutStopTime - 1.0) < rollingTolerance);
  BOOST_TEST(std::fabs(flat.stopX / rollOutStopX - 1.0) < rollingTolerance);
  // No roll back: only the tangential spring's elastic stretch relaxes, F_t / k_t = (5/7) η_r m g / (8 G* a) ≈ 7e-6 m.
  BOOST_TEST(std::fabs(flat.finalX - flat.top) < 1e-4);
  BOOST_TEST(flat.finalSpin < 1e-9);
  for (double eta : {0.1, 0.2, 0.4}) {
    const RollingRun slope = runRollingScenario(Backend::Cpu, eta, 10.0, true);
    BOOST_TEST_MESSAGE("10° slope, η_r " << eta << ": top " << slope.top << " m (rigid body "
                                         << rollingSlopeTop(eta, 10.0) << "), final " << slope.finalX << " m");
    // Staying: within 1e-4 m of the top (the Hertz contact's settling); rolling back: 0.12 m below by 1.2 s.
    BOOST_TEST((std::fabs(slope.finalX - slope.top) < 1e-4) == rollingStays(eta, 10.0));
    BOOST_TEST(std::fabs(slope.top / rollingSlopeTop(eta, 10.0) - 1.0) < rollingTolerance);
    if (rollingStays(eta, 10.0)) BOOST_TEST(slope.finalSpin < 1e-9);
  }
  // Without rolling friction the sphere rolls on at 5/7 of v0 (no resistance): it never stops in 1.2 s.
  const RollingRun free = runRollingScenario(Backend::Cpu, 0.0, 0.0, false);
  BOOST_TEST(free.stopTime < 0.0);
}

// The same roll-out on a sphere (the pair path: arm η_r R*, the budget summed for both spheres) as on the flat, where
// the other sphere is so large that its top is flat (PolyhedraScenarioRuns.hpp), within the same band.
BOOST_AUTO_TEST_CASE(bounded_rolling_friction_between_spheres_as_the_closed_form) {
  using namespace railcosim::testing;
  const RollingRun onSphere = runRollingOnSphereScenario(Backend::Cpu);
  BOOST_TEST_MESSAGE("on a 10 km sphere: stops at t = " << onSphere.stopTime << " s, x = " << onSphere.stopX
                                                        << " m; |ω| " << onSphere.finalSpin << " rad/s");
  BOOST_TEST(std::fabs(onSphere.stopTime / rollOutStopTime - 1.0) < rollingTolerance);
  BOOST_TEST(std::fabs(onSphere.stopX / rollOutStopX - 1.0) < rollingTolerance);
  BOOST_TEST(onSphere.finalSpin < 1e-9);
}

// The same roll-out on the top face of a large cube (the sphere–polyhedron path: the arm η_r R of the sphere, its
// budget alone), within the same band (PolyhedraScenarioRuns.hpp).
BOOST_AUTO_TEST_CASE(bounded_rolling_friction_on_a_polyhedron_as_the_closed_form) {
  using namespace railcosim::testing;
  const RollingRun onCube = runRollingOnPolyhedronScenario(Backend::Cpu);
  BOOST_TEST_MESSAGE("on a 200 m cube: stops at t = " << onCube.stopTime << " s, x = " << onCube.stopX << " m; |ω| "
                                                       << onCube.finalSpin << " rad/s");
  BOOST_TEST(std::fabs(onCube.stopTime / rollOutStopTime - 1.0) < rollingTolerance);
  BOOST_TEST(std::fabs(onCube.stopX / rollOutStopX - 1.0) < rollingTolerance);
  BOOST_TEST(onCube.finalSpin < 1e-9);
}

// The rolling torque acts on spheres only: a cube with the same η_r slides and tumbles as one without it.
BOOST_AUTO_TEST_CASE(rolling_friction_leaves_polyhedra_alone) {
  auto run = [](double eta) {
    Parameters p = quietParameters(0.3, 0.5);
    p.gravity = {0, 0, -9.81};
    p.stone.rollingFriction = eta;
    PolyhedraSystem system(p);
    const int cube = system.addShape(cubeTemplate(0.01, 0.001, 2600));
    addFloor(system, 0.5);
    system.addStone(cube, {0, 0, 0.0109}, {0.95, 0.2, 0.1, 0.0}, {0.3, 0.1, 0}, {5, -3, 8});
    system.step(5000);
    return system.positions();
  };
  const std::vector<double> with = run(0.5), without = run(0.0);
  for (std::size_t k = 0; k < with.size(); ++k) BOOST_TEST(with[k] == without[k]);
}

// setState with the state the system already holds changes nothing: the forces of the replaced state are not added to
// the re-evaluated ones (a rolling, bouncing sphere on the floor; same trajectory to round-off, 1e-12 m).
BOOST_AUTO_TEST_CASE(set_state_to_the_same_state_leaves_the_run_unchanged) {
  auto run = [](bool reset) {
    Parameters p = quietParameters(0.3, 0.5);
    p.gravity = {0, 0, -9.81};
    p.stone.rollingFriction = 0.3;
    PolyhedraSystem system(p);
    railcosim::polyhedra::ShapeTemplate sphere;
    sphere.vertices = {0.0, 0.0, 0.0};
    sphere.dilationRadius = 0.01;
    sphere.density = 2600.0;
    const int shape = system.addShape(sphere);
    addFloor(system, 0.5);
    system.addStone(shape, {0, 0, 0.00999}, {1, 0, 0, 0}, {0.2, 0.05, -0.01}, {0, 3, 0});
    system.step(2000);
    if (reset)
      system.setState(system.positions(), system.orientations(), system.velocities(), system.angularVelocities());
    system.step(2000);
    return system.positions();
  };
  const std::vector<double> with = run(true), without = run(false);
  for (std::size_t k = 0; k < with.size(); ++k) BOOST_TEST(std::fabs(with[k] - without[k]) < 1e-12);
}
