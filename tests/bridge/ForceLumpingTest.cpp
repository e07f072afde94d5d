// Barycentric lumping: weights at known points, closest-point behaviour, and force/moment conservation.
#define BOOST_TEST_MODULE bridge_force_lumping
#include <boost/test/unit_test.hpp>

#include "railcosim/Error.hpp"
#include "railcosim/ForceLumping.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

using namespace railcosim;
using Vector = std::array<double, 3>;

namespace {

Vector cross(const Vector& u, const Vector& v) {
  return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
}
Vector combine(const Vector& a, const Vector& b, const Vector& c, const std::array<double, 3>& w) {
  return {w[0] * a[0] + w[1] * b[0] + w[2] * c[0], w[0] * a[1] + w[1] * b[1] + w[2] * c[1],
          w[0] * a[2] + w[1] * b[2] + w[2] * c[2]};
}
double distance(const Vector& u, const Vector& v) {
  return std::sqrt((u[0] - v[0]) * (u[0] - v[0]) + (u[1] - v[1]) * (u[1] - v[1]) + (u[2] - v[2]) * (u[2] - v[2]));
}

struct RandomTriangle {
  Vector a, b, c;
};

RandomTriangle randomTriangle(std::mt19937_64& random) {
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  while (true) {
    RandomTriangle t;
    for (int i = 0; i < 3; ++i) {
      t.a[i] = coordinate(random);
      t.b[i] = coordinate(random);
      t.c[i] = coordinate(random);
    }
    const Vector n =
        cross({t.b[0] - t.a[0], t.b[1] - t.a[1], t.b[2] - t.a[2]}, {t.c[0] - t.a[0], t.c[1] - t.a[1], t.c[2] - t.a[2]});
    // Keep reasonably shaped triangles so the tolerances below stay meaningful.
    if (std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) > 0.1) return t;
  }
}

} // namespace

BOOST_AUTO_TEST_CASE(weights_at_vertices_and_centroid) {
  const Vector a{0.3, -1.0, 2.0}, b{1.7, 0.4, 2.5}, c{-0.2, 1.1, 1.0};
  // Tolerance: the weights come from a 2x2 solve with O(1) coefficients, accurate to ~1e-15.
  const double tolerance = 1e-13;
  const auto wa = barycentricWeights(a, b, c, a);
  const auto wb = barycentricWeights(a, b, c, b);
  const auto wc = barycentricWeights(a, b, c, c);
  for (int i = 0; i < 3; ++i) {
    BOOST_TEST(std::abs(wa[i] - (i == 0 ? 1.0 : 0.0)) < tolerance);
    BOOST_TEST(std::abs(wb[i] - (i == 1 ? 1.0 : 0.0)) < tolerance);
    BOOST_TEST(std::abs(wc[i] - (i == 2 ? 1.0 : 0.0)) < tolerance);
  }
  const Vector centroid{(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3};
  const auto wg = barycentricWeights(a, b, c, centroid);
  for (int i = 0; i < 3; ++i) BOOST_TEST(std::abs(wg[i] - 1.0 / 3.0) < tolerance);
}

BOOST_AUTO_TEST_CASE(points_off_the_plane_use_their_projection) {
  // Triangle in z = 0: a point above an interior point has that point's weights.
  const Vector a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  const auto w = barycentricWeights(a, b, c, {0.2, 0.3, 5.0});
  BOOST_TEST(std::abs(w[0] - 0.5) < 1e-15);
  BOOST_TEST(std::abs(w[1] - 0.2) < 1e-15);
  BOOST_TEST(std::abs(w[2] - 0.3) < 1e-15);
}

BOOST_AUTO_TEST_CASE(outside_points_map_to_the_closest_point_of_the_triangle) {
  const Vector a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  // Beyond vertex b: the closest point is b itself.
  auto w = barycentricWeights(a, b, c, {2.0, -1.0, 0.3});
  BOOST_TEST(std::abs(w[1] - 1.0) < 1e-15);
  // Beyond edge ab (below the x axis): the foot of the perpendicular, x = 0.4.
  w = barycentricWeights(a, b, c, {0.4, -3.0, 0.0});
  BOOST_TEST(std::abs(w[0] - 0.6) < 1e-15);
  BOOST_TEST(std::abs(w[1] - 0.4) < 1e-15);
  BOOST_TEST(w[2] == 0.0);
  // Beyond the hypotenuse bc: (1,1) projects onto its midpoint.
  w = barycentricWeights(a, b, c, {1.0, 1.0, 0.0});
  BOOST_TEST(std::abs(w[1] - 0.5) < 1e-15);
  BOOST_TEST(std::abs(w[2] - 0.5) < 1e-15);

  // Random triangles and far points: weights are a convex combination and no point of the triangle
  // (dense sample, the independent oracle) is closer to p than the point the weights give.
  std::mt19937_64 random(20261122);
  std::uniform_real_distribution<double> far(-6.0, 6.0);
  for (int trial = 0; trial < 200; ++trial) {
    const RandomTriangle t = randomTriangle(random);
    const Vector p{far(random), far(random), far(random)};
    const auto weights = barycentricWeights(t.a, t.b, t.c, p);
    BOOST_TEST(std::abs(weights[0] + weights[1] + weights[2] - 1.0) < 1e-14);
    for (double weight : weights) BOOST_TEST((weight >= 0.0 && weight <= 1.0));
    const double found = distance(combine(t.a, t.b, t.c, weights), p);
    const int samples = 60;
    double closestSample = std::numeric_limits<double>::max();
    for (int i = 0; i <= samples; ++i) {
      for (int j = 0; i + j <= samples; ++j) {
        const std::array<double, 3> sample{1.0 - double(i + j) / samples, double(i) / samples, double(j) / samples};
        closestSample = std::min(closestSample, distance(combine(t.a, t.b, t.c, sample), p));
      }
    }
    // 1e-12: round-off of distances of O(10); no sample may beat the exact closest point. And the
    // sample grid (spacing <= 4/60 m along edges) must come within that spacing of it.
    BOOST_TEST(found <= closestSample + 1e-12);
    BOOST_TEST(closestSample - found <= 4.0 * std::sqrt(3.0) / samples);
  }
}

BOOST_AUTO_TEST_CASE(degenerate_triangle_is_an_error) {
  BOOST_CHECK_THROW(barycentricWeights({0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {0, 0, 0}), Error);
  BOOST_CHECK_THROW(barycentricWeights({1, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}), Error);
}

BOOST_AUTO_TEST_CASE(lumping_conserves_total_force_and_moment) {
  // A random surface patch: random nodes, random triangles over them, many point forces at random
  // interior points. Oracle: the direct sums of the point forces and of their moments p x f.
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> force(-500.0, 500.0);
  const std::size_t nodes = 40;
  std::vector<double> positions(3 * nodes);
  for (double& value : positions) value = coordinate(random);
  std::vector<std::int32_t> triangles;
  std::uniform_int_distribution<int> pick(0, static_cast<int>(nodes) - 1);
  while (triangles.size() < 3 * 60) {
    const int i = pick(random), j = pick(random), k = pick(random);
    if (i != j && j != k && i != k) triangles.insert(triangles.end(), {i, j, k});
  }
  std::vector<double> nodalForces(3 * nodes, 0.0);
  Vector totalForce{0, 0, 0}, totalMoment{0, 0, 0};
  const Vector origin{0.37, -0.21, 0.9}; // moments about an arbitrary point
  for (int n = 0; n < 2000; ++n) {
    const std::size_t triangle = static_cast<std::size_t>(n) % (triangles.size() / 3);
    auto node = [&](int corner) {
      const std::size_t index = static_cast<std::size_t>(triangles[3 * triangle + corner]);
      return Vector{positions[3 * index], positions[3 * index + 1], positions[3 * index + 2]};
    };
    double s = unit(random), t = unit(random);
    if (s + t > 1.0) {
      s = 1.0 - s;
      t = 1.0 - t;
    }
    const Vector p = combine(node(0), node(1), node(2), {1.0 - s - t, s, t});
    const Vector f{force(random), force(random), force(random)};
    lumpPointForce(positions, triangles, triangle, p, f, nodalForces);
    const Vector arm{p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]};
    const Vector moment = cross(arm, f);
    for (int i = 0; i < 3; ++i) {
      totalForce[i] += f[i];
      totalMoment[i] += moment[i];
    }
  }
  Vector lumpedForce{0, 0, 0}, lumpedMoment{0, 0, 0};
  for (std::size_t n = 0; n < nodes; ++n) {
    const Vector f{nodalForces[3 * n], nodalForces[3 * n + 1], nodalForces[3 * n + 2]};
    const Vector arm{positions[3 * n] - origin[0], positions[3 * n + 1] - origin[1], positions[3 * n + 2] - origin[2]};
    const Vector moment = cross(arm, f);
    for (int i = 0; i < 3; ++i) {
      lumpedForce[i] += f[i];
      lumpedMoment[i] += moment[i];
    }
  }
  // Scale: 2000 forces of up to 500 N, arms up to ~3 m. The per-force split is exact up to one
  // rounding, so the sums agree to accumulated round-off, ~1e-16 x 2000 x 500 N; 1e-9 N leaves room.
  for (int i = 0; i < 3; ++i) {
    BOOST_TEST(std::abs(lumpedForce[i] - totalForce[i]) < 1e-9);
    // Moments also carry the round-off of the barycentric weights (~1e-15 relative): 1e-8 N m.
    BOOST_TEST(std::abs(lumpedMoment[i] - totalMoment[i]) < 1e-8);
  }
}

BOOST_AUTO_TEST_CASE(single_force_split_adds_up_exactly_per_component) {
  const std::vector<double> positions{0, 0, 0, 3, 0, 0, 0, 7, 0};
  const std::vector<std::int32_t> triangles{0, 1, 2};
  std::vector<double> nodalForces(9, 0.0);
  const Vector f{0.1, -123.456, 1e-3};
  lumpPointForce(positions, triangles, 0, {0.71, 1.93, 0.0}, f, nodalForces);
  for (int i = 0; i < 3; ++i) {
    // The third share is the remainder, so the sum reproduces f up to the final additions' rounding.
    const double sum = nodalForces[i] + nodalForces[3 + i] + nodalForces[6 + i];
    BOOST_TEST(std::abs(sum - f[i]) <= 2 * std::numeric_limits<double>::epsilon() * std::abs(f[i]));
  }
}

BOOST_AUTO_TEST_CASE(lumping_rejects_bad_input) {
  const std::vector<double> positions{0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::vector<double> nodalForces(9, 0.0);
  std::vector<double> wrongSize(6, 0.0);
  BOOST_CHECK_THROW(lumpPointForce(positions, {0, 1, 2}, 1, {0, 0, 0}, {1, 0, 0}, nodalForces), Error);
  BOOST_CHECK_THROW(lumpPointForce(positions, {0, 1, 3}, 0, {0, 0, 0}, {1, 0, 0}, nodalForces), Error);
  BOOST_CHECK_THROW(lumpPointForce(positions, {0, 1, 2}, 0, {0, 0, 0}, {1, 0, 0}, wrongSize), Error);
}
