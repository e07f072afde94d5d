// Geometry of dilated convex polyhedra for host and device: quaternions, GJK core distance, contact patch.
#pragma once

#include <cmath>
#include <cstdint>

#include "railcosim/HostDevice.hpp"
#include "kernels/Quaternion.hpp"
#include "kernels/Vector3.hpp"

// Keeps a large, rarely hot function out of line in device code, where inlining it into the force kernel
// would add its whole stack frame and register demand to every thread.
#if defined(__CUDACC__)
#define RAILCOSIM_POLYHEDRA_NOINLINE __noinline__
#else
#define RAILCOSIM_POLYHEDRA_NOINLINE
#endif

namespace railcosim::polyhedra {

using kernels::Vec3;

// Orientation algebra comes from the shared kernels (kernels/Quaternion.hpp): v_world = q v_body q*.
using Quat = kernels::Quaternion;
using kernels::normalized;
using kernels::rotate;
using kernels::rotateInverse;

// Row-major rotation matrix of q (body -> world); built once per body per contact evaluation.
struct Rotation {
  double m[9];
};

RAILCOSIM_HOST_DEVICE inline Rotation rotationMatrix(const Quat& q) {
  const double xx = q.x * q.x, yy = q.y * q.y, zz = q.z * q.z;
  const double xy = q.x * q.y, xz = q.x * q.z, yz = q.y * q.z;
  const double wx = q.w * q.x, wy = q.w * q.y, wz = q.w * q.z;
  return Rotation{{1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy), 2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz),
                   2.0 * (yz - wx), 2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)}};
}

RAILCOSIM_HOST_DEVICE inline Vec3 apply(const Rotation& r, const Vec3& v) {
  return Vec3{r.m[0] * v.x + r.m[1] * v.y + r.m[2] * v.z, r.m[3] * v.x + r.m[4] * v.y + r.m[5] * v.z,
              r.m[6] * v.x + r.m[7] * v.y + r.m[8] * v.z};
}

RAILCOSIM_HOST_DEVICE inline Vec3 applyTransposed(const Rotation& r, const Vec3& v) {
  return Vec3{r.m[0] * v.x + r.m[3] * v.y + r.m[6] * v.z, r.m[1] * v.x + r.m[4] * v.y + r.m[7] * v.z,
              r.m[2] * v.x + r.m[5] * v.y + r.m[8] * v.z};
}

// ---------------------------------------------------------------------------------------------------
// A convex core seen by GJK: vertices in a local frame, placed by a rotation and a translation.
// A stone uses its template's vertices; a wall triangle passes its 3 world vertices with identity.
// ---------------------------------------------------------------------------------------------------
struct ConvexCore {
  const double* vertices; // 3 per vertex, local frame [m]
  int vertexCount;
  Rotation rotation;           // local -> world
  Vec3 position;               // world position of the local origin [m]
  const std::int32_t* indices; // optional: vertex k is vertices[3 * indices[k]] (a triangle of a mesh)
};

RAILCOSIM_HOST_DEVICE inline const double* vertexData(const ConvexCore& core, int k) {
  return core.vertices + 3 * (core.indices != nullptr ? core.indices[k] : k);
}

RAILCOSIM_HOST_DEVICE inline Vec3 vertexWorld(const ConvexCore& core, int k) {
  const double* v = vertexData(core, k);
  return core.position + apply(core.rotation, Vec3{v[0], v[1], v[2]});
}

// Support vertex: index of the vertex farthest along the world direction d (O(V), the only per-vertex work
// of GJK; the templates are shared, so their vertices come from the cache).
RAILCOSIM_HOST_DEVICE inline int supportIndex(const ConvexCore& core, const Vec3& direction) {
  const Vec3 local = applyTransposed(core.rotation, direction);
  int best = 0;
  double bestValue = -1e300;
  for (int k = 0; k < core.vertexCount; ++k) {
    const double* v = vertexData(core, k);
    const double value = v[0] * local.x + v[1] * local.y + v[2] * local.z;
    if (value > bestValue) {
      bestValue = value;
      best = k;
    }
  }
  return best;
}

RAILCOSIM_HOST_DEVICE inline Vec3 support(const ConvexCore& core, const Vec3& direction) {
  return vertexWorld(core, supportIndex(core, direction));
}

// ---------------------------------------------------------------------------------------------------
// GJK distance between two convex cores (Gilbert, Johnson & Keerthi 1988) on the Minkowski difference
// A − B, with the closest point of each sub-simplex found through its Voronoi regions (Ericson 2005,
// Real-Time Collision Detection §5.1). Cost O(V) per iteration instead of O(V·F) for vertex–face pairs.
// ---------------------------------------------------------------------------------------------------
struct CoreDistance {
  bool intersecting; // cores overlap (distance 0): only possible when the dilated overlap exceeds r_A + r_B
  bool beyondCutoff; // proven farther apart than the cutoff: distance is then only a lower bound
  double distance;   // Δ between the cores [m]
  Vec3 pointA;       // closest point on core A [m]
  Vec3 pointB;       // closest point on core B [m]
  Vec3 axis;         // beyondCutoff only: unit direction A -> B along which the cores are ≥ cutoff apart
  int iterations;
  std::uint64_t simplex; // final simplex as support vertex pairs (encodeSimplex), the next query's warm start
  bool unfinished;       // stopped at the iteration limit: resume with `simplex` as the warm start
};

namespace detail {

// Simplex vertices are named, not indexed: every access uses a compile-time position, so the simplex stays
// in registers on the GPU (an indexed array went to local memory and dominated the force kernel's time).
// A simplex vertex is the pair of support vertex indices (A's, B's): two integers instead of six doubles
// keep the whole simplex in a few registers; coordinates are recomputed from the shared templates.
struct SimplexVertex {
  int a; // vertex of A
  int b; // vertex of B; the Minkowski-difference point is a − b
};

struct Simplex {
  SimplexVertex p0, p1, p2, p3;
  int count;
};

// Barycentric weights of the closest point, matching p0..p3.
struct Weights {
  double w0, w1, w2, w3;
};

// Bodies of the current query, so that simplex vertices can be turned into coordinates.
struct Pair {
  const ConvexCore& A;
  const ConvexCore& B;
};

RAILCOSIM_HOST_DEVICE inline Vec3 point(const Pair& pair, const SimplexVertex& v) {
  return vertexWorld(pair.A, v.a) - vertexWorld(pair.B, v.b);
}

// Closest point of segment (P, Q) to the origin; reduces to the sub-simplex holding it.
RAILCOSIM_HOST_DEVICE inline void closestOnSegment(const Pair& pair, const SimplexVertex& P, const SimplexVertex& Q,
                                                   Simplex& out, Weights& weights, Vec3& closest) {
  const Vec3 a = point(pair, P), b = point(pair, Q);
  const Vec3 ab = b - a;
  const double denominator = kernels::dot(ab, ab);
  const double t = denominator > 0.0 ? -kernels::dot(a, ab) / denominator : 0.0;
  if (t <= 0.0) {
    out.p0 = P;
    out.count = 1;
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = a;
  } else if (t >= 1.0) {
    out.p0 = Q;
    out.count = 1;
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = b;
  } else {
    out.p0 = P;
    out.p1 = Q;
    out.count = 2;
    weights = Weights{1.0 - t, t, 0.0, 0.0};
    closest = a + t * ab;
  }
}

// Closest point of triangle (P, Q, R) to the origin; Ericson §5.1.5 with p = 0.
RAILCOSIM_HOST_DEVICE inline void closestOnTriangle(const Pair& pair, const SimplexVertex& P, const SimplexVertex& Q,
                                                    const SimplexVertex& R, Simplex& out, Weights& weights,
                                                    Vec3& closest) {
  const Vec3 a = point(pair, P), b = point(pair, Q), c = point(pair, R);
  const Vec3 ab = b - a, ac = c - a;
  const double d1 = kernels::dot(ab, -a), d2 = kernels::dot(ac, -a);
  if (d1 <= 0.0 && d2 <= 0.0) {
    out.p0 = P;
    out.count = 1;
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = a;
    return;
  }
  const double d3 = kernels::dot(ab, -b), d4 = kernels::dot(ac, -b);
  if (d3 >= 0.0 && d4 <= d3) {
    out.p0 = Q;
    out.count = 1;
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = b;
    return;
  }
  const double vc = d1 * d4 - d3 * d2;
  // Each edge region also asks for a positive denominator (d1 − d3 = |ab|², d2 − d6 = |ac|², (d4 − d3) +
  // (d5 − d6) = |bc|²): distinct support pairs can give one point of A − B (aligned identical cubes), and
  // 0/0 there made GJK return NaN. A zero-length edge falls through to the other regions, which then hold
  // the answer (or to the degenerate case below).
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0) {
    const double t = d1 / (d1 - d3);
    out.p0 = P;
    out.p1 = Q;
    out.count = 2;
    weights = Weights{1.0 - t, t, 0.0, 0.0};
    closest = a + t * ab;
    return;
  }
  const double d5 = kernels::dot(ab, -c), d6 = kernels::dot(ac, -c);
  if (d6 >= 0.0 && d5 <= d6) {
    out.p0 = R;
    out.count = 1;
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = c;
    return;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0) {
    const double t = d2 / (d2 - d6);
    out.p0 = P;
    out.p1 = R;
    out.count = 2;
    weights = Weights{1.0 - t, t, 0.0, 0.0};
    closest = a + t * ac;
    return;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    out.p0 = Q;
    out.p1 = R;
    out.count = 2;
    weights = Weights{1.0 - t, t, 0.0, 0.0};
    closest = b + t * (c - b);
    return;
  }
  const double sum = va + vb + vc;
  if (!(sum > 1e-24 * kernels::squaredNorm(kernels::cross(ab, ac)) + 1e-300)) {
    // Collinear or zero-length-edge (degenerate) triangle: the barycentric solve is undefined; keep the closest edge.
    Simplex e1, e2, e3;
    Weights w1, w2, w3;
    Vec3 c1, c2, c3;
    closestOnSegment(pair, P, Q, e1, w1, c1);
    closestOnSegment(pair, P, R, e2, w2, c2);
    closestOnSegment(pair, Q, R, e3, w3, c3);
    const double n1 = kernels::dot(c1, c1), n2 = kernels::dot(c2, c2), n3 = kernels::dot(c3, c3);
    if (n1 <= n2 && n1 <= n3) {
      out = e1, weights = w1, closest = c1;
    } else if (n2 <= n3) {
      out = e2, weights = w2, closest = c2;
    } else {
      out = e3, weights = w3, closest = c3;
    }
    return;
  }
  const double denominator = 1.0 / sum;
  const double v = vb * denominator, w = vc * denominator;
  out.p0 = P;
  out.p1 = Q;
  out.p2 = R;
  out.count = 3;
  weights = Weights{1.0 - v - w, v, w, 0.0};
  closest = a + v * ab + w * ac;
}

// True when the origin and vertex d lie on opposite sides of the plane (a,b,c) (or the origin on it).
RAILCOSIM_HOST_DEVICE inline bool originOutsideFace(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 normal = kernels::cross(b - a, c - a);
  const double signOrigin = kernels::dot(-a, normal);
  const double signOpposite = kernels::dot(d - a, normal);
  return signOrigin * signOpposite < 0.0;
}

// Considers face (P, Q, R) with opposite vertex S and keeps it in `best` if it is nearer to the origin.
RAILCOSIM_HOST_DEVICE inline void tetrahedronFace(const Pair& pair, const SimplexVertex& P, const SimplexVertex& Q,
                                                  const SimplexVertex& R, const Vec3& p, const Vec3& q, const Vec3& r,
                                                  const Vec3& opposite, bool flat, bool& anyOutside,
                                                  double& bestDistance, Simplex& best, Weights& bestWeights,
                                                  Vec3& bestPoint) {
  if (!flat && !originOutsideFace(p, q, r, opposite)) return;
  anyOutside = true;
  Simplex face;
  Weights weights;
  Vec3 closest;
  closestOnTriangle(pair, P, Q, R, face, weights, closest);
  const double distance = kernels::dot(closest, closest);
  if (distance < bestDistance) {
    bestDistance = distance;
    best = face;
    bestWeights = weights;
    bestPoint = closest;
  }
}

// Closest point of the tetrahedron in `s` to the origin, reducing `s`; false if the origin is inside.
RAILCOSIM_HOST_DEVICE inline bool closestOnTetrahedron(const Pair& pair, Simplex& s, Weights& weights, Vec3& closest) {
  const Vec3 x0 = point(pair, s.p0), x1 = point(pair, s.p1), x2 = point(pair, s.p2), x3 = point(pair, s.p3);
  // A flat (degenerate) tetrahedron arises in face–face contacts, where support points of parallel faces
  // are coplanar: its faces cannot separate anything, so all of them are searched instead of reporting
  // a false intersection.
  double longest = kernels::squaredNorm(x1 - x0);
  longest = fmax(longest, kernels::squaredNorm(x2 - x0));
  longest = fmax(longest, kernels::squaredNorm(x3 - x0));
  longest = fmax(longest, kernels::squaredNorm(x2 - x1));
  longest = fmax(longest, kernels::squaredNorm(x3 - x1));
  longest = fmax(longest, kernels::squaredNorm(x3 - x2));
  const double volume6 = std::fabs(kernels::dot(x3 - x0, kernels::cross(x1 - x0, x2 - x0)));
  const bool flat = volume6 <= 1e-9 * longest * std::sqrt(longest);
  bool anyOutside = false;
  double bestDistance = 1e300;
  Simplex best = s;
  Weights bestWeights{1.0, 0.0, 0.0, 0.0};
  Vec3 bestPoint = x0;
  tetrahedronFace(pair, s.p0, s.p1, s.p2, x0, x1, x2, x3, flat, anyOutside, bestDistance, best, bestWeights, bestPoint);
  tetrahedronFace(pair, s.p0, s.p2, s.p3, x0, x2, x3, x1, flat, anyOutside, bestDistance, best, bestWeights, bestPoint);
  tetrahedronFace(pair, s.p0, s.p3, s.p1, x0, x3, x1, x2, flat, anyOutside, bestDistance, best, bestWeights, bestPoint);
  tetrahedronFace(pair, s.p1, s.p3, s.p2, x1, x3, x2, x0, flat, anyOutside, bestDistance, best, bestWeights, bestPoint);
  if (!anyOutside) return false;
  s = best;
  weights = bestWeights;
  closest = bestPoint;
  return true;
}

// Reduces the simplex to the sub-simplex whose affine hull holds the point closest to the origin and
// returns that point with barycentric weights. False when the origin lies inside a tetrahedron.
// closestOnSimplex for 1–3 vertices (always succeeds). A warm start calls it directly, so that the GPU's first
// narrow-phase pass, which never grows the simplex, does not carry the tetrahedron code (its registers
// 236 → 174, measured with ptxas, sm_90).
RAILCOSIM_HOST_DEVICE inline void closestOnSimplexUpToTriangle(const Pair& pair, Simplex& s, Weights& weights,
                                                               Vec3& closest) {
  if (s.count == 1) {
    weights = Weights{1.0, 0.0, 0.0, 0.0};
    closest = point(pair, s.p0);
  } else if (s.count == 2) {
    const SimplexVertex P = s.p0, Q = s.p1;
    closestOnSegment(pair, P, Q, s, weights, closest);
  } else {
    const SimplexVertex P = s.p0, Q = s.p1, R = s.p2;
    closestOnTriangle(pair, P, Q, R, s, weights, closest);
  }
}

RAILCOSIM_HOST_DEVICE inline bool closestOnSimplex(const Pair& pair, Simplex& s, Weights& weights, Vec3& closest) {
  if (s.count > 3) return closestOnTetrahedron(pair, s, weights, closest);
  closestOnSimplexUpToTriangle(pair, s, weights, closest);
  return true;
}

RAILCOSIM_HOST_DEVICE inline bool sameSupport(const SimplexVertex& v, int a, int b) { return v.a == a && v.b == b; }

// A simplex of 1–3 vertices packed in 64 bits: the count in bits 0–1, then per vertex 10 bits of A's and
// 10 bits of B's vertex index. 0 means none (also for cores of more than 1024 vertices, or a tetrahedron).
constexpr int simplexIndexBits = 10;
constexpr int simplexIndexLimit = 1 << simplexIndexBits;

RAILCOSIM_HOST_DEVICE inline std::uint64_t encodeSimplex(const Simplex& s) {
  if (s.count < 1 || s.count > 3) return 0;
  const SimplexVertex vertices[3] = {s.p0, s.p1, s.p2};
  std::uint64_t code = static_cast<std::uint64_t>(s.count);
  for (int k = 0; k < s.count; ++k) {
    if (vertices[k].a >= simplexIndexLimit || vertices[k].b >= simplexIndexLimit) return 0;
    code |= static_cast<std::uint64_t>(vertices[k].a) << (2 + 2 * simplexIndexBits * k);
    code |= static_cast<std::uint64_t>(vertices[k].b) << (2 + 2 * simplexIndexBits * k + simplexIndexBits);
  }
  return code;
}

RAILCOSIM_HOST_DEVICE inline SimplexVertex decodeSimplexVertex(std::uint64_t code, int k) {
  const int shift = 2 + 2 * simplexIndexBits * k;
  return SimplexVertex{static_cast<int>((code >> shift) & (simplexIndexLimit - 1)),
                       static_cast<int>((code >> (shift + simplexIndexBits)) & (simplexIndexLimit - 1))};
}

} // namespace detail

// initialDirection: any guess of the direction from A to B (a cached contact normal makes GJK converge
// in one or two iterations for persistent contacts, the "warm start"). cutoff: GJK stops as soon as a
// separating direction proves the distance ≥ cutoff (most neighbour-list candidates are not in contact,
// and the exact distance of those is never needed); pass a huge value for the exact distance.
// warmSimplex: the `simplex` of an earlier query of the same two cores (0: none). Any support vertex pairs
// are points of A − B, so GJK may start from them; for a persistent contact the closest features rarely
// change between steps, and the first iteration then only confirms them.
// iterationLimit: how many support points GJK may add before it stops with `unfinished` set and its current
// simplex in `simplex`; a second call warm-started from that simplex resumes the search (the GPU defers
// the few long searches this way). 0: only test the starting simplex; the resumed run is then exactly the
// undivided one. After a larger limit it agrees to roundoff (the direction is recomputed from the simplex).
RAILCOSIM_HOST_DEVICE inline CoreDistance coreDistance(const ConvexCore& A, const ConvexCore& B,
                                                       const Vec3& initialDirection, double cutoff = 1e300,
                                                       std::uint64_t warmSimplex = 0, int iterationLimit = 64) {
  // Relative tolerance on the squared distance (double precision: ~1e-12 of the distance itself is
  // far below any overlap that matters, 1e-3 r_d in the tests).
  constexpr double relativeTolerance = 1e-12;
  constexpr int maxIterations = 64;
  const detail::Pair pair{A, B};
  detail::Simplex s;
  detail::Weights weights{1.0, 0.0, 0.0, 0.0};
  Vec3 v;
  const int warmCount = static_cast<int>(warmSimplex & 3u);
  if (warmCount > 0) {
    s.p0 = detail::decodeSimplexVertex(warmSimplex, 0);
    s.p1 = warmCount > 1 ? detail::decodeSimplexVertex(warmSimplex, 1) : s.p0;
    s.p2 = warmCount > 2 ? detail::decodeSimplexVertex(warmSimplex, 2) : s.p0;
    s.p3 = s.p0;
    s.count = warmCount;
    detail::closestOnSimplexUpToTriangle(pair, s, weights, v);
  } else {
    Vec3 direction = initialDirection;
    if (kernels::squaredNorm(direction) < 1e-300) direction = Vec3{1.0, 0.0, 0.0};
    // First vertex of A − B: support of A along −(B−A) and of B along +(B−A), i.e. the facing features.
    s.p0 = detail::SimplexVertex{supportIndex(A, direction), supportIndex(B, -direction)};
    s.p1 = s.p2 = s.p3 = s.p0;
    s.count = 1;
    v = detail::point(pair, s.p0);
  }
  CoreDistance result{false, false, 0.0, Vec3{0.0, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}, 0, 0, false};
  int iteration = 0;
  for (; iteration < maxIterations; ++iteration) {
    const double vv = kernels::dot(v, v);
    if (!(vv >= 1e-30)) { // the origin is (numerically) in A − B; a non-finite v ends the same way
      result.intersecting = true;
      break;
    }
    const int a = supportIndex(A, -v);
    const int b = supportIndex(B, v);
    const Vec3 w = vertexWorld(A, a) - vertexWorld(B, b);
    // v̂·w is the separation of A and B along v̂, a lower bound of the distance.
    const double separation = kernels::dot(v, w);
    if (separation > 0.0 && separation * separation >= cutoff * cutoff * vv) {
      result.beyondCutoff = true;
      const double length = std::sqrt(vv);
      result.distance = separation / length;
      result.axis = (-1.0 / length) * v; // v points from B to A
      result.iterations = iteration;
      result.simplex = detail::encodeSimplex(s);
      return result;
    }
    // Convergence: no support point gets closer than v by more than the tolerance (GJK's lower bound).
    if (vv - separation <= relativeTolerance * vv) break;
    // A support pair already in the simplex means no progress is possible (numerical termination).
    bool duplicate = detail::sameSupport(s.p0, a, b);
    if (s.count > 1) duplicate = duplicate || detail::sameSupport(s.p1, a, b);
    if (s.count > 2) duplicate = duplicate || detail::sameSupport(s.p2, a, b);
    if (duplicate) break;
    if (iteration >= iterationLimit) {
      // A core of more than 1024 vertices cannot be encoded (0): the resumed run then starts afresh.
      result.unfinished = true;
      result.iterations = iteration;
      // Stopped before adding anything: hand back the caller's own start (the reduced copy would make
      // the resumed run recompute its direction by another formula, different in the last bits).
      result.simplex = iteration == 0 && warmCount > 0 ? warmSimplex : detail::encodeSimplex(s);
      return result;
    }
    const detail::SimplexVertex added{a, b};
    if (s.count == 1) {
      s.p1 = added;
    } else if (s.count == 2) {
      s.p2 = added;
    } else {
      s.p3 = added;
    }
    ++s.count;
    if (!detail::closestOnSimplex(pair, s, weights, v)) {
      result.intersecting = true;
      break;
    }
    // No progress: in exact arithmetic every step brings v strictly closer to the origin. Far from the
    // origin of the coordinates (a stone on a large floor triangle) roundoff can keep the relative test
    // above from ever passing while GJK cycles through coplanar supports; stop then, at roundoff level.
    if (kernels::dot(v, v) >= vv) break;
  }
  result.iterations = iteration;
  result.simplex = result.intersecting ? 0 : detail::encodeSimplex(s);
  Vec3 pa = weights.w0 * vertexWorld(A, s.p0.a), pb = weights.w0 * vertexWorld(B, s.p0.b);
  if (s.count > 1) {
    pa += weights.w1 * vertexWorld(A, s.p1.a);
    pb += weights.w1 * vertexWorld(B, s.p1.b);
  }
  if (s.count > 2) {
    pa += weights.w2 * vertexWorld(A, s.p2.a);
    pb += weights.w2 * vertexWorld(B, s.p2.b);
  }
  if (s.count > 3) {
    pa += weights.w3 * vertexWorld(A, s.p3.a);
    pb += weights.w3 * vertexWorld(B, s.p3.b);
  }
  result.pointA = pa;
  result.pointB = pb;
  result.distance = result.intersecting ? 0.0 : kernels::norm(v);
  return result;
}

// Exact distance of core A from triangle T (a 3-vertex core) when A lies wholly on one side of T's plane
// and its vertex nearest to that plane projects into T: for any y in A and z in T, |y − z| ≥ N·(y − z) ≥
// h_min, and that vertex with its projection attains it. Fills `out` like coreDistance (the simplex is the
// vertex against T's three corners, GJK's own vertex–face simplex) and returns true; false when the test
// does not apply and GJK must decide.
RAILCOSIM_HOST_DEVICE inline bool coreOverTriangleInterior(const ConvexCore& A, const ConvexCore& T,
                                                           CoreDistance& out) {
  const Vec3 a = vertexWorld(T, 0), b = vertexWorld(T, 1), c = vertexWorld(T, 2);
  const Vec3 e0 = b - a, e1 = c - a;
  Vec3 normal = kernels::cross(e0, e1);
  const double length = kernels::norm(normal);
  if (!(length > 0.0)) return false; // degenerate triangle
  normal = (1.0 / length) * normal;
  if (kernels::dot(normal, A.position - a) < 0.0) normal = -normal; // towards A's reference point
  const int lowest = supportIndex(A, -normal);
  const Vec3 x = vertexWorld(A, lowest);
  const double height = kernels::dot(normal, x - a);
  if (!(height > 0.0)) return false; // A reaches the plane or beyond
  const Vec3 p = x - height * normal;
  // Barycentric coordinates of p in (a, b, c).
  const Vec3 e2 = p - a;
  const double d00 = kernels::dot(e0, e0), d01 = kernels::dot(e0, e1), d11 = kernels::dot(e1, e1);
  const double d20 = kernels::dot(e2, e0), d21 = kernels::dot(e2, e1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0.0)) return false;
  const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
  if (v < 0.0 || w < 0.0 || v + w > 1.0) return false; // projects outside T: an edge or corner of T is nearest
  detail::Simplex simplex;
  simplex.p0 = detail::SimplexVertex{lowest, 0};
  simplex.p1 = detail::SimplexVertex{lowest, 1};
  simplex.p2 = detail::SimplexVertex{lowest, 2};
  simplex.p3 = simplex.p0;
  simplex.count = 3;
  out = CoreDistance{false, false, height, x, p, Vec3{0.0, 0.0, 0.0}, 0, detail::encodeSimplex(simplex), false};
  return true;
}

// Separating-axis depth of overlapping cores along the unit normal n (A -> B): how far A's support along n
// reaches past B's support along −n. Used only in the fallback when the cores themselves intersect.
RAILCOSIM_HOST_DEVICE inline double coreOverlapAlong(const ConvexCore& A, const ConvexCore& B, const Vec3& unitNormal) {
  const Vec3 a = support(A, unitNormal);
  const Vec3 b = support(B, -unitNormal);
  return kernels::dot(a - b, unitNormal);
}

// ---------------------------------------------------------------------------------------------------
// Contact patch of nearly parallel features. GJK returns one closest pair, which is arbitrary inside a
// face–face or parallel edge–face contact; the force must act at the centre of the touching region,
// otherwise a stone resting on a face feels a spurious torque. The features of A facing n and of B facing
// −n (vertices within `tolerance` of the support height) are projected onto the contact plane and
// intersected; the centroid of the intersection is the contact point. Vertex–face and crossed-edge
// contacts keep the GJK point.
// ---------------------------------------------------------------------------------------------------
namespace detail {

constexpr int maxFeatureVertices = 8;

struct Point2 {
  double u;
  double v;
};

RAILCOSIM_HOST_DEVICE inline double cross2(const Point2& o, const Point2& a, const Point2& b) {
  return (a.u - o.u) * (b.v - o.v) - (a.v - o.v) * (b.u - o.u);
}

// Convex hull (Andrew's monotone chain) of at most maxFeatureVertices points, counter-clockwise,
// collinear points dropped. Returns the hull size (1, 2 or more). Sorting by insertion: n ≤ 8.
RAILCOSIM_HOST_DEVICE inline int convexHull(Point2* p, int n, Point2* hull, double areaTolerance) {
  for (int i = 1; i < n; ++i) {
    const Point2 key = p[i];
    int j = i - 1;
    while (j >= 0 && (p[j].u > key.u || (p[j].u == key.u && p[j].v > key.v))) {
      p[j + 1] = p[j];
      --j;
    }
    p[j + 1] = key;
  }
  if (n == 1) {
    hull[0] = p[0];
    return 1;
  }
  int k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross2(hull[k - 2], hull[k - 1], p[i]) <= areaTolerance) --k;
    hull[k++] = p[i];
  }
  for (int i = n - 2, lower = k + 1; i >= 0; --i) {
    while (k >= lower && cross2(hull[k - 2], hull[k - 1], p[i]) <= areaTolerance) --k;
    hull[k++] = p[i];
  }
  return k - 1 > 0 ? k - 1 : 1;
}

// Clips the convex polygon `subject` (n points) by the convex counter-clockwise polygon `clip` (m ≥ 3)
// (Sutherland–Hodgman). Output holds at most n + m points; returns its size.
RAILCOSIM_HOST_DEVICE inline int clipPolygon(const Point2* subject, int n, const Point2* clip, int m, Point2* out) {
  Point2 buffer[2][2 * maxFeatureVertices + 2];
  int count = n;
  for (int i = 0; i < n; ++i) buffer[0][i] = subject[i];
  int current = 0;
  for (int e = 0; e < m && count > 0; ++e) {
    const Point2 c0 = clip[e], c1 = clip[(e + 1) % m];
    const Point2* input = buffer[current];
    Point2* output = buffer[1 - current];
    int outCount = 0;
    for (int i = 0; i < count; ++i) {
      const Point2 p = input[i], q = input[(i + 1) % count];
      const double sp = cross2(c0, c1, p), sq = cross2(c0, c1, q);
      if (sp >= 0.0 && outCount < 2 * maxFeatureVertices + 2) output[outCount++] = p;
      if ((sp >= 0.0) != (sq >= 0.0) && outCount < 2 * maxFeatureVertices + 2) {
        const double t = sp / (sp - sq);
        output[outCount++] = Point2{p.u + t * (q.u - p.u), p.v + t * (q.v - p.v)};
      }
    }
    count = outCount;
    current = 1 - current;
  }
  for (int i = 0; i < count; ++i) out[i] = buffer[current][i];
  return count;
}

// Centroid of a polygon (area-weighted); falls back to the vertex mean when the area vanishes.
RAILCOSIM_HOST_DEVICE inline Point2 polygonCentroid(const Point2* p, int n) {
  double area = 0.0, cu = 0.0, cv = 0.0;
  for (int i = 0; i < n; ++i) {
    const Point2 a = p[i], b = p[(i + 1) % n];
    const double c = a.u * b.v - b.u * a.v;
    area += c;
    cu += (a.u + b.u) * c;
    cv += (a.v + b.v) * c;
  }
  if (std::fabs(area) > 1e-300) return Point2{cu / (3.0 * area), cv / (3.0 * area)};
  double su = 0.0, sv = 0.0;
  for (int i = 0; i < n; ++i) {
    su += p[i].u;
    sv += p[i].v;
  }
  return Point2{su / n, sv / n};
}

// Part of segment (p0,p1) inside the convex counter-clockwise polygon (Cyrus–Beck); false if none.
RAILCOSIM_HOST_DEVICE inline bool clipSegment(Point2& p0, Point2& p1, const Point2* polygon, int m) {
  double tEnter = 0.0, tExit = 1.0;
  for (int e = 0; e < m; ++e) {
    const Point2 c0 = polygon[e], c1 = polygon[(e + 1) % m];
    const double s0 = cross2(c0, c1, p0), s1 = cross2(c0, c1, p1);
    if (s0 < 0.0 && s1 < 0.0) return false;
    if (s0 < 0.0 || s1 < 0.0) {
      const double t = s0 / (s0 - s1);
      if (s0 < 0.0) {
        if (t > tEnter) tEnter = t;
      } else if (t < tExit) {
        tExit = t;
      }
    }
  }
  if (tEnter > tExit) return false;
  const Point2 a = p0;
  p0 = Point2{a.u + tEnter * (p1.u - a.u), a.v + tEnter * (p1.v - a.v)};
  p1 = Point2{a.u + tExit * (p1.u - a.u), a.v + tExit * (p1.v - a.v)};
  return true;
}

// Vertices of `core` whose height along `direction` is within `tolerance` of the maximum, projected.
RAILCOSIM_HOST_DEVICE inline int supportFeature(const ConvexCore& core, const Vec3& direction, double tolerance,
                                                const Vec3& t1, const Vec3& t2, Point2* out) {
  const Vec3 local = applyTransposed(core.rotation, direction);
  double best = -1e300;
  for (int k = 0; k < core.vertexCount; ++k) {
    const double* v = vertexData(core, k);
    const double h = v[0] * local.x + v[1] * local.y + v[2] * local.z;
    if (h > best) best = h;
  }
  int count = 0;
  for (int k = 0; k < core.vertexCount && count < maxFeatureVertices; ++k) {
    const double* v = vertexData(core, k);
    const double h = v[0] * local.x + v[1] * local.y + v[2] * local.z;
    if (h >= best - tolerance) {
      const Vec3 world = vertexWorld(core, k);
      out[count++] = Point2{kernels::dot(world, t1), kernels::dot(world, t2)};
    }
  }
  return count;
}

} // namespace detail

// Orthonormal tangent basis (t1, t2) of the plane normal to the unit vector n.
RAILCOSIM_HOST_DEVICE inline void tangentBasis(const Vec3& n, Vec3& t1, Vec3& t2) {
  const Vec3 helper = std::fabs(n.x) < 0.6 ? Vec3{1.0, 0.0, 0.0} : Vec3{0.0, 1.0, 0.0};
  t1 = kernels::tangentialPart(helper, n);
  t1 = t1 / kernels::norm(t1);
  t2 = kernels::cross(n, t1);
}

// Contact point in the mid-plane of the dilated overlap. `planeHeight` is that plane's position along n,
// `fallback` the GJK mid-point; `tolerance` the support-height band that counts as one feature [m].
RAILCOSIM_HOST_DEVICE RAILCOSIM_POLYHEDRA_NOINLINE inline Vec3 contactPatchCentre(const ConvexCore& A,
                                                                                  const ConvexCore& B, const Vec3& n,
                                                                                  double planeHeight,
                                                                                  const Vec3& fallback,
                                                                                  double tolerance) {
  using namespace detail;
  Vec3 t1, t2;
  tangentBasis(n, t1, t2);
  Point2 rawA[maxFeatureVertices], rawB[maxFeatureVertices];
  const int countA = supportFeature(A, n, tolerance, t1, t2, rawA);
  const int countB = supportFeature(B, -n, tolerance, t1, t2, rawB);
  if (countA < 2 || countB < 2) return fallback; // vertex against anything: GJK point is exact
  // Hulls; tiny area tolerance (relative to the feature size squared) merges collinear points.
  Point2 hullA[2 * maxFeatureVertices + 1], hullB[2 * maxFeatureVertices + 1];
  const double scale = tolerance * tolerance * 1e-6;
  const int hullSizeA = convexHull(rawA, countA, hullA, scale);
  const int hullSizeB = convexHull(rawB, countB, hullB, scale);
  if (hullSizeA < 2 || hullSizeB < 2) return fallback; // feature collapsed to a point
  Point2 centre;
  if (hullSizeA >= 3 && hullSizeB >= 3) { // face–face
    Point2 clipped[2 * maxFeatureVertices + 2];
    const int clippedSize = clipPolygon(hullA, hullSizeA, hullB, hullSizeB, clipped);
    if (clippedSize == 0) return fallback;
    centre = polygonCentroid(clipped, clippedSize);
  } else if (hullSizeA >= 3 || hullSizeB >= 3) { // edge–face: clip the edge by the face
    const Point2* face = hullSizeA >= 3 ? hullA : hullB;
    const int faceSize = hullSizeA >= 3 ? hullSizeA : hullSizeB;
    const Point2* edge = hullSizeA >= 3 ? hullB : hullA;
    Point2 p0 = edge[0], p1 = edge[1];
    if (!clipSegment(p0, p1, face, faceSize)) return fallback;
    centre = Point2{0.5 * (p0.u + p1.u), 0.5 * (p0.v + p1.v)};
  } else { // edge–edge: parallel edges share an interval, crossed edges meet at the GJK point
    const Point2 a0 = hullA[0], a1 = hullA[1], b0 = hullB[0], b1 = hullB[1];
    const double du = a1.u - a0.u, dv = a1.v - a0.v;
    const double lengthSquared = du * du + dv * dv;
    const double crossing = du * (b1.v - b0.v) - dv * (b1.u - b0.u);
    const double lengthB = std::sqrt((b1.u - b0.u) * (b1.u - b0.u) + (b1.v - b0.v) * (b1.v - b0.v));
    if (lengthSquared <= 0.0 || std::fabs(crossing) > 1e-3 * std::sqrt(lengthSquared) * lengthB) return fallback;
    double s0 = ((b0.u - a0.u) * du + (b0.v - a0.v) * dv) / lengthSquared;
    double s1 = ((b1.u - a0.u) * du + (b1.v - a0.v) * dv) / lengthSquared;
    if (s0 > s1) {
      const double t = s0;
      s0 = s1;
      s1 = t;
    }
    const double lo = s0 > 0.0 ? s0 : 0.0, hi = s1 < 1.0 ? s1 : 1.0;
    if (lo > hi) return fallback;
    const double mid = 0.5 * (lo + hi);
    centre = Point2{a0.u + mid * du, a0.v + mid * dv};
  }
  return centre.u * t1 + centre.v * t2 + planeHeight * n;
}

} // namespace railcosim::polyhedra
