// Sphere contact with a moving triangulated FEM surface by the Double Hierarchy (H²) method (Irazábal 2017 §4.3–4.4).
#pragma once

#include <cmath>
#include <cstdint>

#include "railcosim/HostDevice.hpp"
#include "kernels/Vector3.hpp"
#include "railcosim/TriangleGeometry.hpp"

namespace railcosim::kernels {

// ---------------------------------------------------------------------------------------------------
// Surface data. The engine refreshes positions and velocities every DEM step; the topology arrays are
// built once from the connectivity (SurfaceContactMesh.hpp, SurfaceTopology) and never change.
// All pointers are non-owning, so the view can be copied into device memory as it is.
// ---------------------------------------------------------------------------------------------------
struct SurfaceMeshView {
  std::int32_t nodeCount;
  std::int32_t triangleCount;
  std::int32_t edgeCount;
  const double* positions;       // 3 per node [m]
  const double* velocities;      // 3 per node [m/s]; nullptr means the surface is at rest
  const std::int32_t* triangles; // 3 node indices per triangle
  // Global edge of local edge a of triangle t, the edge from node a to node (a + 1) % 3: triangleEdges[3t + a].
  const std::int32_t* triangleEdges;
  // The two nodes of each edge, lower node index first: that fixed orientation makes an edge's closest
  // point bitwise identical whichever adjacent triangle computes it, so shared edges deduplicate exactly.
  const std::int32_t* edgeNodes;
  // Triangles around edge e: edgeTriangleList[edgeTriangleStart[e] .. edgeTriangleStart[e + 1]).
  const std::int32_t* edgeTriangleStart;
  const std::int32_t* edgeTriangleList;
  // Triangles around node v: nodeTriangleList[nodeTriangleStart[v] .. nodeTriangleStart[v + 1]).
  const std::int32_t* nodeTriangleStart;
  const std::int32_t* nodeTriangleList;
};

// Contact type of the H² hierarchy (facet > edge > vertex, Irazábal 2017 §4.3); the value is the rank.
enum class SurfaceFeature : std::int32_t { Face = 0, Edge = 1, Vertex = 2 };

struct SurfaceContactSettings {
  // Relative tolerance of the distance hierarchy: contact i is shadowed by a kept contact j when
  // Vc_i·Vc_j ≥ (1 − tol)|Vc_j|² (eq. 4.19, Table 4.3). The thesis uses "a tolerance to detect coplanar
  // cases" without a value. Round-off between coplanar neighbours is ~1e-15 relative, so 1e-6 removes
  // it with a wide margin, while two faces meeting in a concave kink of angle α still give two
  // contacts when α > √(2 tol) (0.081° here). Raise it to merge shallow kinks of a deformed surface
  // (tol 1e-3 merges up to 2.6°) and so avoid the doubled force of thesis §4.5.1.
  double coplanarTolerance = 1.0e-6;
  // The thesis treats walls as contactable from both sides (normal flipped towards the sphere). With
  // false, a triangle whose plane has the sphere centre behind it (opposite its right-hand normal,
  // i.e. inside the structure for an outward-oriented FEM surface) gives no contact.
  bool twoSided = true;
};

// One sphere–surface contact, ready for the contact law and for lumping the force to the FEM nodes.
struct SurfaceContact {
  std::int32_t triangle;      // triangle the contact is assigned to; nodes/weights refer to it
  SurfaceFeature feature;     // face interior, edge or vertex
  std::int32_t featureIndex;  // triangle index (face), global edge index (edge) or node index (vertex)
  std::int32_t nodes[3];      // the assigned triangle's nodes
  BarycentricWeights weights; // shape-function values N_i of the contact point on those nodes (eq. 4.8, 4.17)
  Vec3 point;                 // contact point Pc on the surface [m]
  Vec3 normal;                // unit normal from the surface towards the sphere centre
  double distance;            // |C − Pc| [m]
  double overlap;             // δ = R − |C − Pc| > 0 [m]
  Vec3 velocity;              // surface velocity at Pc, Σ N_i v_i [m/s]
};

// Number of contacts written by findSurfaceContacts.
struct SurfaceContactCount {
  std::int32_t count;
  // True when more elements touched the sphere than `capacity`: the farthest ones were dropped before
  // the distance hierarchy. Shadowing only ever goes from a nearer contact to a farther one, so the
  // contacts returned are still correct; only farther genuine contacts may be missing.
  bool truncated;
};

// ---------------------------------------------------------------------------------------------------
// Small helpers
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline Vec3 surfaceNodePosition(const SurfaceMeshView& surface, std::int32_t node) {
  const double* p = surface.positions + 3 * static_cast<std::int64_t>(node);
  return Vec3{p[0], p[1], p[2]};
}

RAILCOSIM_HOST_DEVICE inline Vec3 surfaceNodeVelocity(const SurfaceMeshView& surface, std::int32_t node) {
  if (surface.velocities == nullptr) return Vec3{0.0, 0.0, 0.0};
  const double* v = surface.velocities + 3 * static_cast<std::int64_t>(node);
  return Vec3{v[0], v[1], v[2]};
}

// Right-hand unit normal of triangle t, (v2 − v1) × (v3 − v2) normalised (eqs. 4.2–4.3); zero vector
// for a degenerate triangle.
RAILCOSIM_HOST_DEVICE inline Vec3 surfaceTriangleNormal(const SurfaceMeshView& surface, std::int32_t triangle) {
  const std::int32_t* n = surface.triangles + 3 * static_cast<std::int64_t>(triangle);
  const Vec3 a = surfaceNodePosition(surface, n[0]);
  const Vec3 b = surfaceNodePosition(surface, n[1]);
  const Vec3 c = surfaceNodePosition(surface, n[2]);
  const Vec3 t = cross(b - a, c - b);
  const double length = norm(t);
  return length > 0.0 ? t / length : Vec3{0.0, 0.0, 0.0};
}

// Surface velocity at the contact point, interpolated with the contact's shape-function weights. Exact
// for any affine nodal velocity field (rigid motion, uniform stretch), since the weights reproduce Pc.
RAILCOSIM_HOST_DEVICE inline Vec3 interpolateSurfaceVelocity(const SurfaceMeshView& surface,
                                                             const SurfaceContact& contact) {
  Vec3 velocity{0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) velocity += contact.weights[k] * surfaceNodeVelocity(surface, contact.nodes[k]);
  return velocity;
}

// Share of the contact force F carried by local node k of the contact's triangle, f_k = N_k F (eq. 4.20;
// railcosim/TriangleGeometry.hpp). Σ f_k = F, and Σ x_k × f_k = Pc × F because Σ N_k x_k = Pc (force and moment
// conserved). Pass the force the sphere exerts on the surface (the reaction of the force on the sphere).
RAILCOSIM_HOST_DEVICE inline Vec3 contactNodalForce(const SurfaceContact& contact, const Vec3& force, int k) {
  return lumpedShare(contact.weights, force, k);
}

// Adds the three nodal shares of `force` into `nodalForces` (3 per node). Not atomic: device code that
// lumps many contacts in parallel should use contactNodalForce with atomic adds instead.
RAILCOSIM_HOST_DEVICE inline void lumpContactForce(const SurfaceContact& contact, const Vec3& force,
                                                   double* nodalForces) {
  for (int k = 0; k < 3; ++k) {
    const Vec3 share = contactNodalForce(contact, force, k);
    double* f = nodalForces + 3 * static_cast<std::int64_t>(contact.nodes[k]);
    f[0] += share.x;
    f[1] += share.y;
    f[2] += share.z;
  }
}

namespace detail {

// Fills the assignment of an edge or vertex contact: the first triangle around the feature (so the
// choice does not depend on which candidate triangle found it) and the weights on its local nodes.
RAILCOSIM_HOST_DEVICE inline void assignToTriangle(const SurfaceMeshView& surface, std::int32_t triangle,
                                                   std::int32_t nodeA, double weightA, std::int32_t nodeB,
                                                   double weightB, SurfaceContact& contact) {
  contact.triangle = triangle;
  const std::int32_t* n = surface.triangles + 3 * static_cast<std::int64_t>(triangle);
  for (int k = 0; k < 3; ++k) {
    contact.nodes[k] = n[k];
    contact.weights[k] = n[k] == nodeA ? weightA : (n[k] == nodeB ? weightB : 0.0);
  }
}

// Sort key of the candidate list: nearest first; ties go to the higher-ranked type, then the lower index.
RAILCOSIM_HOST_DEVICE inline bool precedes(const SurfaceContact& a, const SurfaceContact& b) {
  if (a.distance != b.distance) return a.distance < b.distance;
  if (a.feature != b.feature) return static_cast<int>(a.feature) < static_cast<int>(b.feature);
  return a.featureIndex < b.featureIndex;
}

// Distance-hierarchy test (eq. 4.19, Table 4.3): is `candidate` shadowed by `kept`? With Vc = C − Pc,
// Pr_{i,j} ≥ |Vc_j| ⇔ Vc_i·Vc_j ≥ |Vc_j|², i.e. Pc_i lies on or behind the plane through Pc_j normal to Vc_j.
RAILCOSIM_HOST_DEVICE inline bool isShadowed(const SurfaceContact& candidate, const SurfaceContact& kept,
                                             const Vec3& centre, double coplanarTolerance) {
  const Vec3 candidateVector = centre - candidate.point;
  const Vec3 keptVector = centre - kept.point;
  return dot(candidateVector, keptVector) >= (1.0 - coplanarTolerance) * squaredNorm(keptVector);
}

} // namespace detail

// ---------------------------------------------------------------------------------------------------
// Per-element part of H² (Irazábal 2017 Table 4.2): facet check, then edge checks on the edges the
// projection lies outside of, each falling back to a vertex check. Within one convex element the
// distance hierarchy keeps only the element's closest point (Irazábal 2017, Table 4.3), so the element yields at
// most one contact: its closest point if nearer than the radius. Edge and vertex contacts are
// computed in a canonical orientation and assigned to a canonical triangle, so the same feature found
// from two triangles gives two bitwise-identical contacts. The velocity is not filled here.
// Returns false when the element does not touch the sphere.
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline bool triangleContact(const SurfaceMeshView& surface, std::int32_t triangle,
                                                  const Vec3& centre, double radius,
                                                  const SurfaceContactSettings& settings, SurfaceContact& contact) {
  contact.velocity = Vec3{0.0, 0.0, 0.0}; // filled by findSurfaceContacts for the contacts it keeps
  const std::int32_t* n = surface.triangles + 3 * static_cast<std::int64_t>(triangle);
  const Vec3 vertex[3] = {surfaceNodePosition(surface, n[0]), surfaceNodePosition(surface, n[1]),
                          surfaceNodePosition(surface, n[2])};
  // Facet check, eqs. 4.2–4.7.
  const Vec3 areaVector = cross(vertex[1] - vertex[0], vertex[2] - vertex[1]);
  const double twiceArea = norm(areaVector);
  double longestSquared = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double lengthSquared = squaredNorm(vertex[(a + 1) % 3] - vertex[a]);
    longestSquared = lengthSquared > longestSquared ? lengthSquared : longestSquared;
  }
  // A sliver whose area is at round-off level of its longest edge has no usable plane; its closest
  // point is then on an edge, which the edge checks below find.
  const bool hasPlane = twiceArea > 1.0e-12 * longestSquared;
  bool outside[3] = {true, true, true};
  if (hasPlane) {
    const Vec3 unitNormal = areaVector / twiceArea;
    const double signedDistance = dot(unitNormal, centre - vertex[0]); // d_π, eq. 4.4
    // Every point of the element is at least |d_π| away, so the element cannot touch the sphere.
    if (!(signedDistance < radius && signedDistance > -radius)) return false;
    if (!settings.twoSided && signedDistance < 0.0) return false;
    const Vec3 projection = centre - signedDistance * unitNormal; // C_π, eq. 4.5
    // Sub-triangle weights of C_π (eqs. 4.6–4.9): a negative one lies outside the edge opposite its node.
    const BarycentricWeights weights = planeWeights(projection, vertex[0], vertex[1], vertex[2], unitNormal);
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      outside[a] = weights[(a + 2) % 3] < 0.0;
      inside = inside && !outside[a];
    }
    if (inside) {
      contact.triangle = triangle;
      contact.feature = SurfaceFeature::Face;
      contact.featureIndex = triangle;
      for (int k = 0; k < 3; ++k) contact.nodes[k] = n[k];
      contact.weights = weights;
      contact.point = projection;
      const double distance = signedDistance >= 0.0 ? signedDistance : -signedDistance;
      contact.normal = signedDistance >= 0.0 ? unitNormal : -unitNormal;
      contact.distance = distance;
      contact.overlap = radius - distance;
      return true;
    }
  }
  // Edge checks (eqs. 4.12–4.17), vertex checks (eq. 4.18) through the clamped edge parameter η.
  bool found = false;
  double bestDistanceSquared = radius * radius;
  std::int32_t bestEdge = -1;
  double bestEta = 0.0;
  Vec3 bestPoint{0.0, 0.0, 0.0};
  for (int a = 0; a < 3; ++a) {
    if (!outside[a]) continue;
    const std::int32_t edge = surface.triangleEdges[3 * static_cast<std::int64_t>(triangle) + a];
    const std::int32_t nodeA = surface.edgeNodes[2 * static_cast<std::int64_t>(edge)];
    const std::int32_t nodeB = surface.edgeNodes[2 * static_cast<std::int64_t>(edge) + 1];
    const Vec3 start = surfaceNodePosition(surface, nodeA);
    const Vec3 direction = surfaceNodePosition(surface, nodeB) - start;
    const double lengthSquared = squaredNorm(direction);
    // η = p/|e| with p on the unit edge vector (eqs. 4.15–4.16, erratum 6), clamped to the segment.
    double eta = lengthSquared > 0.0 ? dot(centre - start, direction) / lengthSquared : 0.0;
    eta = eta < 0.0 ? 0.0 : (eta > 1.0 ? 1.0 : eta);
    const Vec3 point = eta == 1.0 ? surfaceNodePosition(surface, nodeB) : start + eta * direction;
    const double distanceSquared = squaredNorm(centre - point);
    if (distanceSquared < bestDistanceSquared) {
      found = true;
      bestDistanceSquared = distanceSquared;
      bestEdge = edge;
      bestEta = eta;
      bestPoint = point;
    }
  }
  if (!found) return false;
  const std::int32_t nodeA = surface.edgeNodes[2 * static_cast<std::int64_t>(bestEdge)];
  const std::int32_t nodeB = surface.edgeNodes[2 * static_cast<std::int64_t>(bestEdge) + 1];
  if (bestEta > 0.0 && bestEta < 1.0) {
    contact.feature = SurfaceFeature::Edge;
    contact.featureIndex = bestEdge;
    const std::int32_t owner = surface.edgeTriangleList[surface.edgeTriangleStart[bestEdge]];
    detail::assignToTriangle(surface, owner, nodeA, 1.0 - bestEta, nodeB, bestEta, contact); // eq. 4.17
  } else {
    const std::int32_t node = bestEta <= 0.0 ? nodeA : nodeB;
    contact.feature = SurfaceFeature::Vertex;
    contact.featureIndex = node;
    const std::int32_t owner = surface.nodeTriangleList[surface.nodeTriangleStart[node]];
    detail::assignToTriangle(surface, owner, node, 1.0, -1, 0.0, contact);
  }
  contact.point = bestPoint;
  const double distance = std::sqrt(bestDistanceSquared);
  contact.distance = distance;
  contact.overlap = radius - distance;
  // Edge and vertex normals run from Pc to the centre, which keeps the force continuous across
  // facet ↔ edge transitions (§4.3). A centre exactly on the edge has no such direction: use the plane's.
  if (distance > 0.0) {
    contact.normal = (centre - bestPoint) / distance;
  } else {
    contact.normal = surfaceTriangleNormal(surface, triangle);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------
// Full H² query for one sphere against candidate triangles from a broad phase (any order, duplicates
// allowed). Writes the surviving contacts, nearest first, into contacts[0 .. count) and fills their
// velocities. `contacts` is also the work buffer: capacity ≥ candidateCount always suffices, since each
// element yields at most one contact.
//
// Distance hierarchy: the candidates are taken nearest first and each is kept unless a contact kept
// before it shadows it (Table 4.3 test). A shadowing contact is never farther than the one it shadows
// (|Vc_j| ≤ |Vc_i| follows from the test), so this is the thesis' insertion loop run in one canonical
// order: the result does not depend on the candidate order, it equals the thesis' result whenever no
// eliminated contact was the only one shadowing another (always so on a convex surface), and otherwise
// it keeps the contact that only an eliminated one shadowed.
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline SurfaceContactCount findSurfaceContacts(const SurfaceMeshView& surface, const Vec3& centre,
                                                                     double radius, const std::int32_t* candidates,
                                                                     std::int32_t candidateCount,
                                                                     const SurfaceContactSettings& settings,
                                                                     SurfaceContact* contacts, std::int32_t capacity) {
  SurfaceContactCount result{0, false};
  std::int32_t stored = 0;
  for (std::int32_t c = 0; c < candidateCount; ++c) {
    SurfaceContact found;
    if (!triangleContact(surface, candidates[c], centre, radius, settings, found)) continue;
    // A feature shared by several candidates (edge, vertex, or a repeated triangle) enters once.
    bool duplicate = false;
    for (std::int32_t s = 0; s < stored && !duplicate; ++s)
      duplicate = contacts[s].feature == found.feature && contacts[s].featureIndex == found.featureIndex;
    if (duplicate) continue;
    // Insertion into the sorted buffer; when full, the farthest contact is the one dropped.
    std::int32_t position = stored;
    while (position > 0 && detail::precedes(found, contacts[position - 1])) --position;
    if (stored == capacity) {
      result.truncated = true;
      if (position == capacity) continue;
    } else {
      ++stored;
    }
    for (std::int32_t s = stored - 1; s > position; --s) contacts[s] = contacts[s - 1];
    contacts[position] = found;
  }
  std::int32_t kept = 0;
  for (std::int32_t s = 0; s < stored; ++s) {
    bool shadowed = false;
    for (std::int32_t k = 0; k < kept && !shadowed; ++k)
      shadowed = detail::isShadowed(contacts[s], contacts[k], centre, settings.coplanarTolerance);
    if (shadowed) continue;
    if (kept != s) contacts[kept] = contacts[s];
    ++kept;
  }
  for (std::int32_t k = 0; k < kept; ++k) contacts[k].velocity = interpolateSurfaceVelocity(surface, contacts[k]);
  result.count = kept;
  return result;
}

// Tangential history across element changes (thesis §4.5.3 loses it): index of the contact in
// `previous` that `current` continues — the same feature if present, otherwise the nearest previous
// contact point within `matchDistance` (e.g. the Hertz contact radius sqrt(Rδ), so the contact
// patches overlap) — or −1 for a new contact.
RAILCOSIM_HOST_DEVICE inline std::int32_t findContinuingContact(const SurfaceContact& current,
                                                                const SurfaceContact* previous,
                                                                std::int32_t previousCount, double matchDistance) {
  std::int32_t nearest = -1;
  double nearestSquared = matchDistance * matchDistance;
  for (std::int32_t p = 0; p < previousCount; ++p) {
    if (previous[p].feature == current.feature && previous[p].featureIndex == current.featureIndex) return p;
    const double distanceSquared = squaredNorm(previous[p].point - current.point);
    if (distanceSquared <= nearestSquared) {
      nearestSquared = distanceSquared;
      nearest = p;
    }
  }
  return nearest;
}

} // namespace railcosim::kernels
