// FacetSurface: interface triangles as YADE facets, placed every step, contact forces lumped to the nodes.
#include "FacetSurface.hpp"

#include "railcosim/ForceLumping.hpp"

#include <core/Aabb.hpp>
#include <core/Interaction.hpp>
#include <core/State.hpp>
#include <pkg/common/Facet.hpp>
#include <pkg/common/NormShearPhys.hpp>
#include <pkg/dem/DemXDofGeom.hpp>

#include <stdexcept>

namespace yade {

namespace {
Vector3r node(const std::vector<double>& xyz, int i) { return Vector3r(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

// Facet bodies must sit at the centre of the inscribed circle: YADE's facet contact geometry relies on it.
Vector3r inscribedCircleCentre(const Vector3r& a, const Vector3r& b, const Vector3r& c) {
  const Real la = (b - c).norm(), lb = (c - a).norm(), lc = (a - b).norm();
  return (la * a + lb * b + lc * c) / (la + lb + lc);
}
} // namespace

std::vector<Body::id_t> FacetSurface::insert(Scene& scene, const std::vector<int32_t>& triangles,
                                             const shared_ptr<Material>& material, int mask) {
  connectivity = triangles;
  facetIds.clear();
  for (size_t t = 0; t < triangles.size() / 3; ++t) {
    auto facet = shared_ptr<Facet>(new Facet);
    facet->color = Vector3r(0.6, 0.6, 0.7);
    auto body = shared_ptr<Body>(new Body);
    body->shape = facet;
    body->bound = shared_ptr<Aabb>(new Aabb);
    body->material = material;
    body->groupMask = mask;
    body->setDynamic(false);
    body->state->blockedDOFs = State::DOF_ALL;
    body->state->ori = body->state->refOri = Quaternionr::Identity();
    facetIds.push_back(scene.bodies->insert(body));
  }
  return facetIds;
}

void FacetSurface::place(Scene& scene, const std::vector<double>& positions, const std::vector<double>& velocities,
                         bool beforeIntegrator) const {
  for (size_t t = 0; t < facetIds.size(); ++t) {
    const Body::id_t id = facetIds[t];
    const auto& b = (*scene.bodies)[id];
    if (!b)
      throw std::runtime_error("FemCouplingEngine: coupled facet body #" + std::to_string(id) +
                               " was erased from the scene.");
    const int* tri = &connectivity[3 * t];
    const Vector3r v[3] = {node(positions, tri[0]), node(positions, tri[1]), node(positions, tri[2])};
    const Vector3r centre = inscribedCircleCentre(v[0], v[1], v[2]);
    auto* facet = static_cast<Facet*>(b->shape.get());
    for (int j = 0; j < 3; ++j) facet->vertices[j] = v[j] - centre;
    facet->postLoad(*facet);
    // Rigid-body velocity of the facet: mean of its vertices (in-plane stretching is not represented).
    const Vector3r velocity = (node(velocities, tri[0]) + node(velocities, tri[1]) + node(velocities, tri[2])) / 3.;
    b->state->vel = velocity;
    b->state->angVel = Vector3r::Zero();
    b->state->pos = beforeIntegrator ? Vector3r(centre - velocity * scene.dt) : centre;
  }
}

void FacetSurface::collectForces(const Scene& scene, const std::vector<double>& positions,
                                 std::vector<double>& nodal) const {
  nodal.assign(positions.size(), 0.0);
  // Only the facets' own interaction maps are visited: the cost follows the contacts on the surface.
  for (size_t t = 0; t < facetIds.size(); ++t) {
    const Body::id_t id = facetIds[t];
    const auto& b = (*scene.bodies)[id];
    for (const auto& entry : b->intrs) {
      const shared_ptr<Interaction>& I = entry.second;
      if (!I->isReal()) continue;
      const auto* geom = dynamic_cast<const GenericSpheresContact*>(I->geom.get());
      const auto* phys = dynamic_cast<const NormShearPhys*>(I->phys.get());
      if (!geom || !phys) continue;
      // The law applies -(Fn+Fs) to body 1 and +(Fn+Fs) to body 2.
      const Vector3r onSecond = phys->normalForce + phys->shearForce;
      const Vector3r force = (I->getId1() == id) ? Vector3r(-onSecond) : onSecond;
      const Vector3r& cp = geom->contactPoint;
      railcosim::lumpPointForce(positions, connectivity, t, {cp[0], cp[1], cp[2]}, {force[0], force[1], force[2]},
                                nodal);
    }
  }
}

} // namespace yade
