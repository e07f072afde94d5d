// Triangle geometry shared by the FEM force mapping, the sphere–surface contacts and the polyhedra walls (host and
// device): closest point, barycentric weights, lumping of a point force to the three nodes.
#pragma once

#include "railcosim/HostDevice.hpp"
#include "railcosim/Vector3.hpp"

namespace railcosim {

// Barycentric weights (w0, w1, w2) of a point x of the plane of triangle (a, b, c): x = w0 a + w1 b + w2 c with
// w0 + w1 + w2 = 1; all in [0, 1] for a point of the triangle. They are the linear shape functions N_i of the
// triangle at x (Irazábal 2017 eqs. 4.8–4.9, 4.17).
struct BarycentricWeights {
  double w[3];
  RAILCOSIM_HOST_DEVICE double operator[](int k) const { return w[k]; }
  RAILCOSIM_HOST_DEVICE double& operator[](int k) { return w[k]; }
};

RAILCOSIM_HOST_DEVICE inline Vec3 pointAt(const BarycentricWeights& weights, const Vec3& a, const Vec3& b,
                                          const Vec3& c) {
  return weights[0] * a + weights[1] * b + weights[2] * c;
}

// Weights of the point of triangle (a, b, c) closest to p, by the Voronoi regions of the vertices, edges and face
// (Ericson 2005, §5.1.5). When the projection of p onto the plane lies inside the triangle it is that closest point,
// otherwise the closest point is on an edge or a vertex, so the weights always lie in [0, 1]. A degenerate
// (zero-area) triangle gives non-finite weights in the face region: callers that may meet one check the area first.
RAILCOSIM_HOST_DEVICE inline BarycentricWeights closestPointWeights(const Vec3& p, const Vec3& a, const Vec3& b,
                                                                    const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return BarycentricWeights{{1.0, 0.0, 0.0}};
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return BarycentricWeights{{0.0, 1.0, 0.0}};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double t = d1 / (d1 - d3);
    return BarycentricWeights{{1.0 - t, t, 0.0}};
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return BarycentricWeights{{0.0, 0.0, 1.0}};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double t = d2 / (d2 - d6);
    return BarycentricWeights{{1.0 - t, 0.0, t}};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return BarycentricWeights{{0.0, 1.0 - t, t}};
  }
  const double denominator = 1.0 / (va + vb + vc);
  const double v = vb * denominator, w = vc * denominator;
  return BarycentricWeights{{1.0 - v - w, v, w}};
}

// The point of triangle (a, b, c) closest to p.
RAILCOSIM_HOST_DEVICE inline Vec3 closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  return pointAt(closestPointWeights(p, a, b, c), a, b, c);
}

// Signed weights of the projection of p onto the plane of triangle (a, b, c) with unit normal n, from the areas of
// the sub-triangles the projection makes with each edge (Irazábal 2017 eqs. 4.6–4.9): the sub-triangle on edge
// (v_k, v_{k+1}) weights the opposite node v_{k+2}, so weight[(k + 2) % 3] < 0 exactly when the projection lies
// outside edge k. Unlike closestPointWeights they are not clamped: the sphere–surface search reads the signs.
RAILCOSIM_HOST_DEVICE inline BarycentricWeights planeWeights(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                                             const Vec3& unitNormal) {
  const Vec3 vertex[3] = {a, b, c};
  double subArea[3];
  for (int k = 0; k < 3; ++k) {
    const Vec3 edge = vertex[(k + 1) % 3] - vertex[k];        // e^k, eq. 4.6
    subArea[k] = dot(cross(edge, p - vertex[k]), unitNormal); // s^k = 2Δ_k, eq. 4.7
  }
  const double total = subArea[0] + subArea[1] + subArea[2];
  BarycentricWeights weights{};
  for (int k = 0; k < 3; ++k) weights[(k + 2) % 3] = subArea[k] / total; // eqs. 4.8–4.9
  return weights;
}

// Share of a point force F carried by node k of the triangle, f_k = N_k F (Irazábal 2017 eq. 4.20). The third share
// is the remainder F − f_0 − f_1, so the three shares add up to F to the last rounding; Σ x_k × f_k = x × F when the
// weights reproduce the point x (force and moment conserved). Pure, so device code can add each share atomically.
RAILCOSIM_HOST_DEVICE inline Vec3 lumpedShare(const BarycentricWeights& weights, const Vec3& force, int k) {
  if (k < 2) return weights[k] * force;
  return force - weights[0] * force - weights[1] * force;
}

} // namespace railcosim
