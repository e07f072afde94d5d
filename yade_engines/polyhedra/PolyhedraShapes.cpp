// Shape-template builders (convex hull by exhaustive plane search, regular solids) for stones and tests.
#include "polyhedra/PolyhedraShapes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>

#include "polyhedra/PolyhedraGeometry.hpp"
#include "railcosim/Error.hpp"

namespace railcosim::polyhedra {

namespace {

Vec3 pointAt(const std::vector<double>& p, std::size_t k) { return Vec3{p[3 * k], p[3 * k + 1], p[3 * k + 2]}; }

} // namespace

ShapeTemplate convexHullTemplate(const std::vector<double>& points, double dilationRadius, double density) {
  const std::size_t n = points.size() / 3;
  if (points.size() % 3 != 0 || n < 4)
    throw Error("convexHullTemplate: need at least 4 points with 3 coordinates each");
  Vec3 centre{0, 0, 0};
  for (std::size_t k = 0; k < n; ++k) centre += pointAt(points, k);
  centre = centre / static_cast<double>(n);
  double size = 0.0;
  for (std::size_t k = 0; k < n; ++k) size = std::max(size, kernels::norm(pointAt(points, k) - centre));
  const double tolerance = 1e-9 * size;
  // Supporting planes through point triples with every point behind them; one entry per distinct plane.
  struct Plane {
    Vec3 normal;
    double offset;
  };
  std::vector<Plane> planes;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      for (std::size_t k = j + 1; k < n; ++k) {
        const Vec3 a = pointAt(points, i), b = pointAt(points, j), c = pointAt(points, k);
        Vec3 normal = kernels::cross(b - a, c - a);
        const double length = kernels::norm(normal);
        if (length <= 1e-12 * size * size) continue;
        normal = normal / length;
        if (kernels::dot(normal, a - centre) < 0.0) normal = -normal;
        const double offset = kernels::dot(normal, a);
        bool supporting = true;
        for (std::size_t m = 0; m < n && supporting; ++m)
          supporting = kernels::dot(normal, pointAt(points, m)) <= offset + tolerance;
        if (!supporting) continue;
        bool known = false;
        for (const Plane& p : planes)
          known = known || (kernels::dot(p.normal, normal) > 1.0 - 1e-9 && std::fabs(p.offset - offset) <= tolerance);
        if (!known) planes.push_back(Plane{normal, offset});
      }
  if (planes.size() < 4) throw Error("convexHullTemplate: the points are coplanar or collinear; a stone needs volume");
  // Keep only hull vertices, then fan-triangulate each face polygon ordered around its centroid.
  std::vector<int> index(n, -1);
  ShapeTemplate shape;
  shape.dilationRadius = dilationRadius;
  shape.density = density;
  for (const Plane& plane : planes) {
    std::vector<std::size_t> face;
    for (std::size_t m = 0; m < n; ++m)
      if (std::fabs(kernels::dot(plane.normal, pointAt(points, m)) - plane.offset) <= tolerance) face.push_back(m);
    // Duplicate points would produce zero-area triangles: keep the first of coincident points.
    std::vector<std::size_t> unique;
    for (std::size_t m : face) {
      bool duplicate = false;
      for (std::size_t u : unique)
        duplicate = duplicate || kernels::norm(pointAt(points, m) - pointAt(points, u)) <= tolerance;
      if (!duplicate) unique.push_back(m);
    }
    Vec3 faceCentre{0, 0, 0};
    for (std::size_t m : unique) faceCentre += pointAt(points, m);
    faceCentre = faceCentre / static_cast<double>(unique.size());
    Vec3 t1, t2;
    tangentBasis(plane.normal, t1, t2);
    std::sort(unique.begin(), unique.end(), [&](std::size_t a, std::size_t b) {
      const Vec3 da = pointAt(points, a) - faceCentre, db = pointAt(points, b) - faceCentre;
      return std::atan2(kernels::dot(da, t2), kernels::dot(da, t1)) <
             std::atan2(kernels::dot(db, t2), kernels::dot(db, t1));
    });
    for (std::size_t m : unique) {
      if (index[m] < 0) {
        index[m] = static_cast<int>(shape.vertices.size() / 3);
        const Vec3 p = pointAt(points, m);
        shape.vertices.insert(shape.vertices.end(), {p.x, p.y, p.z});
      }
    }
    // t1 × t2 = n, so increasing angle is counter-clockwise seen from outside.
    for (std::size_t m = 1; m + 1 < unique.size(); ++m)
      shape.triangles.insert(shape.triangles.end(), {index[unique[0]], index[unique[m]], index[unique[m + 1]]});
  }
  return shape;
}

ShapeTemplate cubeTemplate(double halfEdge, double dilationRadius, double density) {
  std::vector<double> points;
  for (int k = 0; k < 8; ++k)
    points.insert(points.end(),
                  {(k & 1 ? 1.0 : -1.0) * halfEdge, (k & 2 ? 1.0 : -1.0) * halfEdge, (k & 4 ? 1.0 : -1.0) * halfEdge});
  return convexHullTemplate(points, dilationRadius, density);
}

ShapeTemplate icosphereTemplate(double radius, int subdivisions, double dilationRadius, double density) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> vertices = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::int32_t> triangles = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                                         4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                                         6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
  for (Vec3& v : vertices) v = v / kernels::norm(v);
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto middle = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      const auto found = midpoint.find(key);
      if (found != midpoint.end()) return found->second;
      Vec3 m = vertices[a] + vertices[b];
      vertices.push_back(m / kernels::norm(m));
      midpoint[key] = static_cast<int>(vertices.size() - 1);
      return static_cast<int>(vertices.size() - 1);
    };
    std::vector<std::int32_t> refined;
    for (std::size_t k = 0; k < triangles.size(); k += 3) {
      const int a = triangles[k], b = triangles[k + 1], c = triangles[k + 2];
      const int ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
      refined.insert(refined.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    triangles = refined;
  }
  ShapeTemplate shape;
  shape.dilationRadius = dilationRadius;
  shape.density = density;
  for (const Vec3& v : vertices)
    shape.vertices.insert(shape.vertices.end(), {radius * v.x, radius * v.y, radius * v.z});
  shape.triangles = triangles;
  return shape;
}

ShapeTemplate dodecahedronStone(double a, double b, double c, double dilationRadius, double density) {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0, inverse = 1.0 / phi, scale = 1.0 / std::sqrt(3.0);
  std::vector<double> points;
  for (int k = 0; k < 8; ++k)
    points.insert(points.end(), {(k & 1 ? 1.0 : -1.0), (k & 2 ? 1.0 : -1.0), (k & 4 ? 1.0 : -1.0)});
  for (int k = 0; k < 4; ++k) {
    const double s1 = k & 1 ? 1.0 : -1.0, s2 = k & 2 ? 1.0 : -1.0;
    points.insert(points.end(), {0.0, s1 * inverse, s2 * phi});
    points.insert(points.end(), {s1 * inverse, s2 * phi, 0.0});
    points.insert(points.end(), {s1 * phi, 0.0, s2 * inverse});
  }
  for (std::size_t k = 0; k < points.size(); k += 3) {
    points[k] *= scale * a;
    points[k + 1] *= scale * b;
    points[k + 2] *= scale * c;
  }
  return convexHullTemplate(points, dilationRadius, density);
}

std::vector<int> addLatticeBed(PolyhedraSystem& system, const std::vector<int>& shapes, int nx, int ny, int nz,
                               double spacing, double jitter, unsigned seed, bool withBox) {
  if (shapes.empty() || nx < 1 || ny < 1 || nz < 1 || !(spacing > 0.0))
    throw Error("addLatticeBed: need at least one shape, positive counts and a positive spacing");
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<int> shapeOfStone;
  shapeOfStone.reserve(static_cast<std::size_t>(nx) * ny * nz);
  for (int iz = 0; iz < nz; ++iz)
    for (int iy = 0; iy < ny; ++iy)
      for (int ix = 0; ix < nx; ++ix) {
        // Uniform random rotation: a normalised 4-D Gaussian vector.
        std::array<double, 4> q{gauss(random), gauss(random), gauss(random), gauss(random)};
        const double length = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (double& c : q) c /= length;
        const int shape = shapes[random() % shapes.size()];
        shapeOfStone.push_back(shape);
        system.addStone(shape,
                        {(ix + 0.5) * spacing + jitter * unit(random), (iy + 0.5) * spacing + jitter * unit(random),
                         (iz + 0.5) * spacing + jitter * unit(random)},
                        q);
      }
  if (withBox) {
    const WallMesh box = latticeBox(nx, ny, nz, spacing);
    system.setWalls(box.nodes, box.triangles);
  }
  return shapeOfStone;
}

WallMesh latticeBox(int nx, int ny, int nz, double spacing) {
  const double x = nx * spacing, y = ny * spacing, z = (nz + 1) * spacing;
  // Counter-clockwise seen from inside: floor, y = 0, x = max, y = max, x = 0.
  return {{0, 0, 0, x, 0, 0, x, y, 0, 0, y, 0, 0, 0, z, x, 0, z, x, y, z, 0, y, z},
          {0, 1, 2, 0, 2, 3, 0, 4, 5, 0, 5, 1, 1, 5, 6, 1, 6, 2, 2, 6, 7, 2, 7, 3, 3, 7, 4, 3, 4, 0}};
}

} // namespace railcosim::polyhedra
