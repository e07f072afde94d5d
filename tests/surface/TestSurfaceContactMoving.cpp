// Sphere on a moving and on a deforming FEM surface: the contact-point velocity interpolated from the nodes drives
// friction.
#define BOOST_TEST_MODULE surface_contact_moving
#include <boost/test/unit_test.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

#include "SphereOnSurface.hpp"
#include "kernels/SurfaceContact.hpp"
#include "kernels/SurfaceContactMesh.hpp"

using namespace railcosim::kernels;
using namespace railcosim::kernels::testing;

namespace {

constexpr double gravityMagnitude = 9.81; // [m/s²]

// Table 4.7 sphere softened to E = 1e9 Pa so that Δt = 1e-5 s resolves the contact (period ≈ 9e-3 s).
SphereProperties softenedTableFourSeven() { return SphereProperties{0.3, 100.0, 1.0e9, 0.2, 0.3, 0.4}; }

double restOverlap(const SphereOnSurface& simulation, const SphereProperties& sphere) {
  const HertzMindlinParams& p = simulation.params();
  return std::pow(
      3.0 * sphere.mass() * gravityMagnitude / (4.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius)),
      2.0 / 3.0);
}

} // namespace

BOOST_AUTO_TEST_CASE(a_sphere_at_rest_on_a_translating_surface_is_dragged_into_rolling) {
  // The 80-triangle plane moves at u = 2 m/s along x under a sphere released at rest. In the surface
  // frame this is H2-06 with v0 = −u (Galilean invariance), so: sliding until t_c = 2u/(7μg), then
  // rolling at v = u − 5u/7 = 2u/7, ω_z = +5u/(7R), x = x0 + u t − [12u²/(49μg) + (5/7)u(t − t_c)].
  const SphereProperties sphere = softenedTableFourSeven();
  const double speed = 2.0, mu = sphere.friction, duration = 0.4;
  const PlaneMesh plane = planeMesh(10, 4, -1.0, -1.0, 0.7, 0.5);
  const SurfaceTopology topology(plane.triangles, static_cast<std::int32_t>(plane.positions.size() / 3));
  SphereOnSurface simulation(sphere, topology, plane.positions, Vec3{0.0, -gravityMagnitude, 0.0}, 1.0e-5, 0.5);
  const std::vector<double> reference = plane.positions;
  simulation.setSurfaceMotion([&](double t, std::vector<double>& positions, std::vector<double>& velocities) {
    for (std::size_t i = 0; i < positions.size(); i += 3) {
      positions[i] = reference[i] + speed * t;
      velocities[i] = speed;
    }
  });
  const double x0 = 1.0;
  simulation.position = Vec3{x0, sphere.radius - restOverlap(simulation, sphere), 0.1};
  simulation.start();
  while (simulation.time < duration - 0.5e-5) simulation.step();
  const double rollingStart = 2.0 * speed / (7.0 * mu * gravityMagnitude);
  const double xOracle =
      x0 + speed * duration -
      (12.0 * speed * speed / (49.0 * mu * gravityMagnitude) + 5.0 / 7.0 * speed * (duration - rollingStart));
  BOOST_TEST_MESSAGE("moving plane: x = " << simulation.position.x << " (oracle " << xOracle
                                          << "), v = " << simulation.velocity.x << " (oracle " << 2.0 / 7.0 * speed
                                          << "), ω_z = " << simulation.angularVelocity.z << " (oracle "
                                          << 5.0 / 7.0 * speed / sphere.radius << ")");
  // Model error against the rigid analytic solution ~ δ/R ≈ 1e-4 (rolling radius R − δ and the short
  // tangential-spring transient at t_c); 1e-3 relative.
  BOOST_TEST(simulation.position.x == xOracle, boost::test_tools::tolerance(1e-3));
  BOOST_TEST(simulation.velocity.x == 2.0 / 7.0 * speed, boost::test_tools::tolerance(1e-3));
  BOOST_TEST(simulation.angularVelocity.z == 5.0 / 7.0 * speed / sphere.radius, boost::test_tools::tolerance(1e-3));
  BOOST_TEST(simulation.contacts().size() == 1u);
}

BOOST_AUTO_TEST_CASE(a_sphere_on_a_stretching_surface_stays_where_the_surface_does_not_move) {
  // The plane is stretched uniformly along x about x_s: node velocity ε̇ (x − x_s). The surface point under
  // a sphere resting at x_s does not move, so the sphere must stay at rest although every triangle
  // around it moves. A facet-body representation (one rigid velocity per triangle, the mean of its
  // nodes) would see ε̇ (centroid − x_s) ≠ 0 at the contact and drag the sphere: checked below.
  const SphereProperties sphere = softenedTableFourSeven();
  const double strainRate = 0.5, centre = 0.5; // [1/s], x_s [m]: inside a triangle, off its centroid
  const PlaneMesh plane = planeMesh(10, 4, -1.0, -1.0, 0.7, 0.5);
  const SurfaceTopology topology(plane.triangles, static_cast<std::int32_t>(plane.positions.size() / 3));
  SphereOnSurface simulation(sphere, topology, plane.positions, Vec3{0.0, -gravityMagnitude, 0.0}, 1.0e-5, 0.5);
  const std::vector<double> reference = plane.positions;
  simulation.setSurfaceMotion([&](double t, std::vector<double>& positions, std::vector<double>& velocities) {
    const double stretch = std::exp(strainRate * t); // x(t) − x_s = (x0 − x_s) e^{ε̇t}
    for (std::size_t i = 0; i < positions.size(); i += 3) {
      positions[i] = centre + (reference[i] - centre) * stretch;
      velocities[i] = strainRate * (positions[i] - centre);
    }
  });
  simulation.position = Vec3{centre, sphere.radius - restOverlap(simulation, sphere), 0.1};
  simulation.start();
  const std::vector<SurfaceContact> first = simulation.contacts();
  BOOST_REQUIRE_EQUAL(first.size(), 1u);
  // What the per-triangle rigid velocity would have been at the contact (the discriminating power of this test).
  const SurfaceContact& c = first[0];
  double facetMeanVelocity = 0.0;
  for (int k = 0; k < 3; ++k) facetMeanVelocity += strainRate * (reference[3 * c.nodes[k]] - centre) / 3.0;
  BOOST_TEST(std::fabs(facetMeanVelocity) > 0.05);
  BOOST_TEST(std::fabs(c.velocity.x) < 1e-14); // interpolation: ε̇ (x_c − x_s) = 0 to round-off
  while (simulation.time < 0.2 - 0.5e-5) simulation.step();
  BOOST_TEST_MESSAGE("stretching plane: |v| = " << norm(simulation.velocity) << " m/s, drift "
                                                << simulation.position.x - centre << " m after 0.2 s; a per-triangle "
                                                << "rigid velocity would have been " << facetMeanVelocity << " m/s");
  // Round-off only (positions ~1 m, 2e4 steps): a drag by the facet mean velocity would reach
  // ~μ g t ≈ 0.6 m/s or the 0.06 m/s surface speed.
  BOOST_TEST(norm(simulation.velocity) < 1e-9);
  BOOST_TEST(std::fabs(simulation.position.x - centre) < 1e-9);
}
