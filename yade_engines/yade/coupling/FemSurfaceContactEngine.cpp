// FemSurfaceContactEngine: sphere-surface contacts of the FE interface mesh with Hertz-Mindlin forces.
#include "FemSurfaceContactEngine.hpp"

#include "kernels/HertzMindlin.hpp"
#include "kernels/SurfaceContactMesh.hpp"

#include <core/Scene.hpp>
#include <core/State.hpp>
#include <pkg/common/Sphere.hpp>
#include <pkg/dem/FrictPhys.hpp>

#include <cmath>
#include <stdexcept>

namespace yade {

YADE_PLUGIN((FemSurfaceContactEngine));

struct FemSurfaceContactEngine::ContactHistory {
  railcosim::kernels::SurfaceContact contact; // where the contact was at the previous step
  railcosim::kernels::Vec3 elasticForce;      // tangential spring force carried to the next step [N]
  double overlap;                             // overlap at the previous step [m] (unloading correction)
};

namespace {
namespace k = railcosim::kernels;
k::Vec3 vec(const Vector3r& v) { return {v[0], v[1], v[2]}; }
Vector3r vec(const k::Vec3& v) { return Vector3r(v.x, v.y, v.z); }
const FrictMat& frictionMaterial(const shared_ptr<Material>& material, const std::string& owner) {
  const auto* frict = dynamic_cast<const FrictMat*>(material.get());
  if (!frict)
    throw std::invalid_argument("FemCouplingEngine (contactModel='meshContacts'): " + owner +
                                " needs a FrictMat (or derived) material for its moduli and friction.");
  return *frict;
}
} // namespace

void FemSurfaceContactEngine::checkSettings() const {
  frictionMaterial(material, "the surface 'material'");
  if (!(restitution >= 0 && restitution <= 1))
    throw std::invalid_argument("FemCouplingEngine: restitution must be in [0, 1], got " + std::to_string(restitution));
}

void FemSurfaceContactEngine::attach(const std::vector<int32_t>& triangles, const std::vector<double>& coordinates) {
  checkSettings();
  const size_t triangleCount = triangles.size() / 3;
  topology = std::make_shared<k::SurfaceTopology>(triangles, static_cast<int32_t>(coordinates.size() / 3));
  // Grid cells about one mean edge long: a sphere query then visits a handful of cells.
  auto node = [&](int32_t i) { return Vector3r(coordinates[3 * i], coordinates[3 * i + 1], coordinates[3 * i + 2]); };
  double edgeSum = 0;
  for (size_t t = 0; t < triangleCount; ++t)
    for (int e = 0; e < 3; ++e) edgeSum += (node(triangles[3 * t + e]) - node(triangles[3 * t + (e + 1) % 3])).norm();
  grid = std::make_shared<k::SurfaceTriangleGrid>(edgeSum / (3.0 * triangleCount));
  contactHistory = std::make_shared<History>();
}

void FemSurfaceContactEngine::setSurface(const std::vector<double>& surfacePositions,
                                         const std::vector<double>& surfaceVelocities) {
  positions = &surfacePositions;
  velocities = &surfaceVelocities;
}

void FemSurfaceContactEngine::action() {
  if (!topology || !positions)
    throw std::logic_error(
        "FemSurfaceContactEngine runs inside a FemCouplingEngine with contactModel='meshContacts', not on its own in "
        "O.engines.");
  const size_t nodes = positions->size() / 3;
  nodal.assign(3 * nodes, 0.0);
  const k::SurfaceMeshView view = topology->view(*positions, *velocities);
  grid->rebuild(view);
  const FrictMat& surface = frictionMaterial(material, "the surface 'material'");
  const double surfaceShear = k::shearModulus(surface.young, surface.poisson);
  const double dampingRatio = k::dampingRatioFromRestitution(restitution);
  const double dt = scene->dt;
  auto next = std::make_shared<History>();
  std::vector<int32_t> candidates;
  long count = 0;
  for (const auto& b : *scene->bodies) {
    if (!b || b->isClump()) continue;
    const auto* sphere = dynamic_cast<const Sphere*>(b->shape.get());
    if (!sphere) continue;
    const State& state = *b->state;
    const k::Vec3 centre = vec(state.pos);
    const double radius = sphere->radius;
    grid->candidates(centre, radius, candidates);
    if (candidates.empty()) continue;
    const std::vector<k::SurfaceContact> contacts = k::findSurfaceContacts(view, centre, radius, candidates);
    if (contacts.empty()) continue;

    const FrictMat& particle = frictionMaterial(b->material, "particle #" + std::to_string(b->id));
    // A clump member resists with the whole clump's inertia.
    const double mass = b->isClumpMember() ? (*scene->bodies)[b->clumpId]->state->mass : state.mass;
    const k::HertzMindlinParams params{
        k::effectiveYoungModulus(particle.young, particle.poisson, surface.young, surface.poisson),
        k::effectiveShearModulus(k::shearModulus(particle.young, particle.poisson), particle.poisson, surfaceShear,
                                 surface.poisson),
        radius, mass, dampingRatio};
    const double friction = std::min(std::tan(particle.frictionAngle), std::tan(surface.frictionAngle));
    const auto found = contactHistory->find(b->id);
    std::vector<k::SurfaceContact> previousContacts;
    if (found != contactHistory->end())
      for (const ContactHistory& h : found->second) previousContacts.push_back(h.contact);
    std::vector<ContactHistory>& kept = (*next)[b->id];
    for (const k::SurfaceContact& c : contacts) {
      const k::Vec3 branch = c.point - centre;
      const k::Vec3 pointVel = vec(state.vel) + cross(vec(state.angVel), branch);
      const k::Vec3 relative = pointVel - c.velocity; // particle relative to the surface at the contact
      const double overlapRate = -dot(relative, c.normal);
      const double normalForce = k::hertzNormalForce(params, c.overlap, overlapRate);
      const int32_t continued =
          previousContacts.empty()
              ? -1
              : k::findContinuingContact(c, previousContacts.data(), static_cast<int32_t>(previousContacts.size()),
                                         k::hertzContactRadius(params, c.overlap));
      const k::Vec3 elastic = continued >= 0 ? found->second[continued].elasticForce : k::Vec3{0, 0, 0};
      const double lastOverlap = continued >= 0 ? found->second[continued].overlap : c.overlap;
      const k::TangentialForceResult tangential = k::mindlinTangentialForce(
          params, elastic, c.normal, c.overlap, lastOverlap, relative * dt, relative, friction, normalForce);
      const k::Vec3 force = normalForce * c.normal + tangential.force; // on the particle
      scene->forces.addForce(b->id, vec(force));
      scene->forces.addTorque(b->id, vec(cross(branch, force)));
      k::lumpContactForce(c, -1.0 * force, nodal.data());
      kept.push_back({c, tangential.elasticForce, c.overlap});
      ++count;
    }
  }
  contactHistory = next;
  surfaceContacts = count;
}

} // namespace yade
