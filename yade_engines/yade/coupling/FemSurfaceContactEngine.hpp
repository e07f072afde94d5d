// Sphere contacts with a deforming FE interface mesh, found by the facet > edge > vertex hierarchy, forces from the
// contact law.
#pragma once

#include <core/Body.hpp>
#include <core/GlobalEngine.hpp>
#include <core/Material.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace railcosim {
class StateReader;
class StateWriter;
} // namespace railcosim

namespace railcosim::kernels {
class SurfaceTopology;
class SurfaceTriangleGrid;
struct SurfaceContact;
} // namespace railcosim::kernels

namespace yade {

class FemSurfaceContactEngine : public GlobalEngine {
public:
  struct ContactHistory;
  using History = std::map<Body::id_t, std::vector<ContactHistory>>;

  void action() override;
  /// Throws std::invalid_argument for a surface material that is neither a FrictMat nor a BallastMat or is invalid, or
  /// a restitution outside [0, 1].
  void checkSettings() const;
  /// Binds the engine to an interface mesh (triangles as node indices, 3 per triangle; reference coordinates,
  /// 3 per node, for the search grid's cell size). Checks the surface material.
  void attach(const std::vector<int32_t>& triangles, const std::vector<double>& coordinates);
  /// Where the surface is for the next action(): nodal positions [m] and velocities [m/s], 3 per node. The
  /// vectors must outlive that call.
  void setSurface(const std::vector<double>& positions, const std::vector<double>& velocities);
  /// Nodal forces on the surface [N] (3 per node) of the last action().
  const std::vector<double>& nodalForces() const { return nodal; }
  /// Tangential history of the contacts (replaced, never mutated, at every action(): a snapshot is a pointer).
  std::shared_ptr<const History> history() const { return contactHistory; }
  void restoreHistory(std::shared_ptr<const History> snapshot) { contactHistory = std::move(snapshot); }
  /// A history snapshot in a restart checkpoint, and back (null: none).
  static void writeHistory(const std::shared_ptr<const History>& history, railcosim::StateWriter& state);
  static std::shared_ptr<const History> readHistory(railcosim::StateReader& state);

  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS(FemSurfaceContactEngine, GlobalEngine,
		"Contacts of spherical particles (and clump members) with the FE interface surface of a :yref:`FemCouplingEngine` "
		"whose :yref:`contactModel<FemCouplingEngine.contactModel>` is ``meshContacts``: one contact per touching surface "
		"patch, found by the facet > edge > vertex hierarchy with shadowed contacts removed; the contact-point velocity is "
		"interpolated from the nodal velocities; the force from the one contact law of the kernels (docs/contact-models.md), "
		"its sub-models and parameters mixed from the particle's and the surface's materials as for a pair (a rough "
		":yref:`BallastMat` selects the Pohrt-Popov laws, a smooth one or a FrictMat Hertz-Mindlin; Coulomb cap at the smaller "
		"friction coefficient), the restitution of every particle-surface pair being :yref:`FemSurfaceContactEngine.restitution`; "
		"no rolling resistance. Forces and torques go to the particles, their reactions are lumped to the "
		"surface nodes with the barycentric weights of the contact points. Created and driven by the coupling engine; it "
		"does not run on its own in :yref:`Omega.engines`.",
		((shared_ptr<Material>, material, , , "Material of the surface (a :yref:`FrictMat`: Young's modulus, Poisson's ratio, friction angle; or a :yref:`BallastMat`, whose roughness and plastic unloading also count)."))
		((Real, restitution, 0.5, , "Coefficient of restitution of particle-surface impacts [-], turned into a Hertzian damping ratio."))
		((long, surfaceContacts, 0, Attr::readonly, "Number of particle-surface contacts at the last step."))
	);
  // clang-format on

private:
  std::shared_ptr<railcosim::kernels::SurfaceTopology> topology;
  std::shared_ptr<railcosim::kernels::SurfaceTriangleGrid> grid;
  std::shared_ptr<const History> contactHistory;
  const std::vector<double>* positions = nullptr;
  const std::vector<double>* velocities = nullptr;
  std::vector<double> nodal;
};
REGISTER_SERIALIZABLE(FemSurfaceContactEngine);

} // namespace yade
