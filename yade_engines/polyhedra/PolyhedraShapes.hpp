// Shape-template builders: convex hull of a point cloud, cube, icosphere and a ballast-like 20-vertex stone.
#pragma once

#include <cstdint>
#include <vector>

#include "polyhedra/PolyhedraSystem.hpp"

namespace railcosim::polyhedra {

/// Template whose core is the convex hull of `points` (3 per point, at least 4 not coplanar); hull faces
/// with more than 3 vertices are fan-triangulated. Points inside the hull are dropped. O(n^4): meant for
/// stones of up to ~100 vertices. Throws Error for a flat or degenerate cloud.
ShapeTemplate convexHullTemplate(const std::vector<double>& points, double dilationRadius, double density);

/// Cube of half edge `halfEdge` centred on the origin, edges along the axes.
ShapeTemplate cubeTemplate(double halfEdge, double dilationRadius, double density);

/// Icosahedron refined `subdivisions` times and projected on the sphere of radius `radius`
/// (12, 42, 162, 642 vertices for 0..3 subdivisions).
ShapeTemplate icosphereTemplate(double radius, int subdivisions, double dilationRadius, double density);

/// Regular dodecahedron (20 vertices, circumradius 1) scaled by (a, b, c): an angular, elongated stone.
ShapeTemplate dodecahedronStone(double a, double b, double c, double dilationRadius, double density);

/// Packed bed for benchmarks and comparisons: nx × ny × nz stones on a lattice of pitch `spacing` [m]
/// (first stone centre at (spacing/2, spacing/2, spacing/2)), each with a template drawn from `shapes`, a
/// random orientation and a jitter of ±`jitter` [m] per axis; reproducible from `seed`. With
/// `withBox`, a floor at z = 0 and four side walls enclose the lattice (10 triangles, set with setWalls).
/// Returns the template of each stone added, in the order added.
std::vector<int> addLatticeBed(PolyhedraSystem& system, const std::vector<int>& shapes, int nx, int ny, int nz,
                               double spacing, double jitter, unsigned seed, bool withBox);

/// The box addLatticeBed sets with `withBox` (floor at z = 0 and four side walls up to (nz + 1) × spacing, 8 nodes,
/// 10 triangles counter-clockwise seen from inside), for callers that add walls of their own to it (e.g. a lid).
struct WallMesh {
  std::vector<double> nodes;             ///< 3 coordinates per node [m]
  std::vector<std::int32_t> triangles;   ///< 3 node indices per triangle
};
WallMesh latticeBox(int nx, int ny, int nz, double spacing);

} // namespace railcosim::polyhedra
