// The FE interface surface as non-dynamic YADE Facet bodies, moved with the nodes, forces read back from them.
#pragma once

#include <core/Body.hpp>
#include <core/Material.hpp>
#include <core/Scene.hpp>

#include <cstdint>
#include <vector>

namespace yade {

/// One Facet body per interface triangle; the scene's own InteractionLoop finds and resolves their contacts.
class FacetSurface {
public:
  /// Inserts one facet per triangle (node indices, 3 per triangle) into `scene`; returns their ids.
  std::vector<Body::id_t> insert(Scene& scene, const std::vector<int32_t>& triangles,
                                 const shared_ptr<Material>& material, int mask);
  /// Moves the facets to the nodal positions [m] with the mean nodal velocity [m/s] (3 values per node each).
  /// `beforeIntegrator`: the integrator that runs next moves non-dynamic bodies by vel*dt, so the facets are
  /// placed that far back and land on the positions when the next contacts are evaluated.
  void place(Scene& scene, const std::vector<double>& positions, const std::vector<double>& velocities,
             bool beforeIntegrator) const;
  /// Forces of the facets' contacts on the structure, lumped to the nodes with the barycentric weights of the
  /// contact points on the triangles at `positions` [N, 3 per node].
  void collectForces(const Scene& scene, const std::vector<double>& positions, std::vector<double>& nodal) const;
  const std::vector<Body::id_t>& ids() const { return facetIds; }

private:
  std::vector<int32_t> connectivity;
  std::vector<Body::id_t> facetIds;
};

} // namespace yade
