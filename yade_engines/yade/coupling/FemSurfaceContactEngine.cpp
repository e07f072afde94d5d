// FemSurfaceContactEngine: sphere-surface contacts of the FE interface mesh, forces from the one contact law.
#include "FemSurfaceContactEngine.hpp"

#include "railcosim/StateStream.hpp"

#include "../contact/BallastContact.hpp"
#include "kernels/ContactLaw.hpp"
#include "kernels/SurfaceContactMesh.hpp"

#include <core/Scene.hpp>
#include <core/State.hpp>
#include <pkg/common/Sphere.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <map>
#include <stdexcept>

namespace yade {

YADE_PLUGIN((FemSurfaceContactEngine));

struct FemSurfaceContactEngine::ContactHistory {
  railcosim::kernels::SurfaceContact contact; // where the contact was at the previous step
  railcosim::kernels::ContactHistory law;     // the contact law's history (tangential spring, normal model's)
};

namespace {
namespace k = railcosim::kernels;
k::Vec3 vec(const Vector3r& v) { return {v[0], v[1], v[2]}; }
Vector3r vec(const k::Vec3& v) { return Vector3r(v.x, v.y, v.z); }
const double infinity = std::numeric_limits<double>::infinity();

// The contact material of a body for a particle-surface contact: the restitution of the pair is the engine's.
k::ContactMaterial surfaceContactMaterial(const shared_ptr<Material>& material, const std::string& owner,
                                          double restitution) {
  if (!material)
    throw std::invalid_argument("FemCouplingEngine (contactModel='meshContacts'): " + owner + " has no material.");
  try {
    k::ContactMaterial m = contactMaterialOf(*material, owner);
    m.restitution = restitution;
    return m;
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("FemCouplingEngine (contactModel='meshContacts'): ") + e.what());
  }
}
} // namespace

void FemSurfaceContactEngine::checkSettings() const {
  if (!(restitution >= 0 && restitution <= 1))
    throw std::invalid_argument("FemCouplingEngine: restitution must be in [0, 1], got " + std::to_string(restitution));
  k::validate(surfaceContactMaterial(material, "the surface 'material'", restitution),
              "FemCouplingEngine: the surface 'material'");
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
  const k::ContactMaterial surface = surfaceContactMaterial(material, "the surface 'material'", restitution);
  // One law per particle material (mixed with the surface's: docs/contact-models.md); R* and m* per sphere. Spheres
  // on the surface get no rolling resistance here: BoundedRollingFrictionEngine sums the budgets of BallastPhys
  // interactions only.
  std::map<const Material*, k::ContactLaw> lawOf;
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

    auto known = lawOf.find(b->material.get());
    if (known == lawOf.end()) {
      const k::ContactMaterial particle =
          surfaceContactMaterial(b->material, "particle #" + std::to_string(b->id), restitution);
      known = lawOf.emplace(b->material.get(), k::mixContactLaw(particle, surface)).first;
    }
    k::ContactLaw law = known->second;
    // A clump member resists with the whole clump's inertia; the surface is flat (R = ∞) and moves as prescribed.
    const double mass = b->isClumpMember() ? (*scene->bodies)[b->clumpId]->state->mass : state.mass;
    k::setContactGeometry(law, radius, infinity, mass, infinity);
    const auto found = contactHistory->find(b->id);
    std::vector<k::SurfaceContact> previousContacts;
    if (found != contactHistory->end())
      for (const ContactHistory& h : found->second) previousContacts.push_back(h.contact);
    std::vector<ContactHistory>& kept = (*next)[b->id];
    for (const k::SurfaceContact& c : contacts) {
      const k::Vec3 branch = c.point - centre;
      const k::Vec3 pointVel = vec(state.vel) + cross(vec(state.angVel), branch);
      const k::Vec3 relative = pointVel - c.velocity; // particle relative to the surface at the contact
      const int32_t continued =
          previousContacts.empty()
              ? -1
              : k::findContinuingContact(c, previousContacts.data(), static_cast<int32_t>(previousContacts.size()),
                                         k::hertzContactRadius(law.params.hertzMindlin, c.overlap));
      const k::ContactHistory history = continued >= 0
                                            ? found->second[continued].law
                                            : k::ContactHistory{k::Vec3{0, 0, 0}, 0.0, k::NormalHistory{0.0, 0.0}};
      // Body 1 the surface, body 2 the particle: n from the surface to the centre, motion of the particle.
      const k::Vec3 tangentialVelocity = k::tangentialPart(relative, c.normal);
      const k::ContactLawResult r =
          k::contactLawForces(law, history,
                              k::ContactKinematics{c.overlap, -dot(relative, c.normal), c.normal,
                                                   tangentialVelocity * dt, tangentialVelocity});
      const k::Vec3 force = r.normalForce * c.normal + r.shearForce; // on the particle
      scene->forces.addForce(b->id, vec(force));
      scene->forces.addTorque(b->id, vec(cross(branch, force)));
      k::lumpContactForce(c, -1.0 * force, nodal.data());
      kept.push_back({c, r.history});
      ++count;
    }
  }
  contactHistory = next;
  surfaceContacts = count;
}

// The history is plain data (positions, weights, forces); it is stored as the bytes of each record, which this
// build reads back as written.
static_assert(std::is_trivially_copyable<railcosim::kernels::SurfaceContact>::value &&
                  std::is_trivially_copyable<railcosim::kernels::ContactHistory>::value,
              "the mesh contact history must be plain data to be checkpointed byte for byte");

void FemSurfaceContactEngine::writeHistory(const std::shared_ptr<const History>& history,
                                           railcosim::StateWriter& state) {
  state.flag(static_cast<bool>(history));
  if (!history) return;
  state.u64(history->size());
  for (const auto& [id, contacts] : *history) {
    state.i64(id);
    std::string bytes(contacts.size() * sizeof(ContactHistory), '\0');
    if (!contacts.empty()) std::memcpy(&bytes[0], contacts.data(), bytes.size());
    state.bytes(bytes);
  }
}

std::shared_ptr<const FemSurfaceContactEngine::History> FemSurfaceContactEngine::readHistory(
    railcosim::StateReader& state) {
  if (!state.flag()) return nullptr;
  auto history = std::make_shared<History>();
  const std::uint64_t bodies = state.u64();
  for (std::uint64_t k = 0; k < bodies; ++k) {
    const Body::id_t id = static_cast<Body::id_t>(state.i64());
    const std::string bytes = state.bytes();
    if (bytes.size() % sizeof(ContactHistory) != 0)
      state.fail("a mesh contact history of " + std::to_string(bytes.size()) + " bytes");
    std::vector<ContactHistory>& contacts = (*history)[id];
    contacts.resize(bytes.size() / sizeof(ContactHistory));
    if (!bytes.empty()) std::memcpy(contacts.data(), bytes.data(), bytes.size());
  }
  return history;
}

} // namespace yade
