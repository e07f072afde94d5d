// YADE engine advancing the scene's polyhedral stones as dilated polyhedra on the GPU (or its CPU reference).
#pragma once

#include <core/Body.hpp>
#include <core/GlobalEngine.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace railcosim::polyhedra {
class PolyhedraSystem;
}

namespace yade {

class PolyhedraGpuEngine : public GlobalEngine {
public:
  void action() override;
  void initialize();
  void addStone(Body::id_t id, const std::vector<Vector3r>& vertices, Real stoneDilation);
  void setWallVelocity(const std::vector<Body::id_t>& facets, const Vector3r& velocity);
  Vector3r wallForce(const std::vector<Body::id_t>& facets) const;
  Real criticalTimeStep(Real normalForce, Real impactVelocity);
  virtual ~PolyhedraGpuEngine();

  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(PolyhedraGpuEngine, GlobalEngine,
		"Advances the scene's polyhedral stones with railcosim's dilated-polyhedra DEM. A stone is any YADE body (a "
		":yref:`Sphere` of the stone's circumradius is convenient for display and output) registered with "
		":yref:`PolyhedraGpuEngine.addStone` together with its convex core vertices in the body frame; the stone is that "
		"core dilated by :yref:`PolyhedraGpuEngine.dilationRadius`, and identical cores share one shape template. Contacts: gap between the cores (GJK), Hertz-Mindlin with the dilation curvature, damping from "
		":yref:`PolyhedraGpuEngine.restitution`, Coulomb friction with tangential history; :yref:`Facet` bodies are "
		"triangle walls, fixed unless moved with :yref:`PolyhedraGpuEngine.setWallVelocity`. Integration: velocity Verlet and the Zhao-van Wachem quaternion scheme, with :yref:`Omega.dt`. "
		"The stones are advanced in batches of :yref:`PolyhedraGpuEngine.syncInterval` steps; at the end of each batch "
		"(when the scene's time has caught up) their positions, orientations and velocities are written back to the YADE "
		"bodies, for output, coupling and Python access (the YADE bodies' own shapes take no part in the contacts). "
		"Stone material: the first stone's FrictMat (young, poisson, "
		"frictionAngle, density). The engine integrates the stones itself: do not put a NewtonIntegrator in the same "
		"scene. Runs on the GPU when one is usable, else on the CPU reference (said once).",
		((int, syncInterval, 100, , "Steps per batch; the YADE bodies are updated at the end of each batch."))
		((Real, dilationRadius, 0.002, , "Dilation radius r_d of every stone [m] (the stone is its YADE polyhedron dilated by r_d)."))
		((Real, restitution, 0.3, , "Coefficient of restitution of all contacts [-]."))
		((Real, wallFriction, -1, , "Coulomb coefficient of the wall material [-] (a stone-wall pair takes the smaller of it and the stones'); negative: the stones' own. 0 makes the walls frictionless mirror planes."))
		((int, maxNeighbours, 24, , "Stone candidates stored per stone (partners with a larger index) [-]; raise it for a scene with a few stones much larger than the others (e.g. sensor blocks)."))
		((int, maxWallNeighbours, 8, , "Wall triangles stored per stone [-]."))
		((Vector3r, gravity, Vector3r(0, 0, -9.81), , "Gravity acceleration [m/s^2]."))
		((string, backend, "automatic", , "``automatic`` (GPU when usable, else CPU), ``cpu`` or ``cuda``."))
		((int, rebuildInterval, 10, , "Steps between neighbour-list rebuilds (each batch starts with one)."))
		((bool, adaptiveRebuild, true, , "Skip a due rebuild while no stone can outgrow the lists: largest displacement since the last rebuild plus twice the fastest stone's travel over the next interval below half the skin. Never skipped while the surface moves."))
		((string, activeBackend, "", Attr::readonly, "Backend in use after initialization: ``cpu`` or ``cuda``."))
		((string, backendReason, "", Attr::readonly, "Why this backend runs (e.g. no usable GPU)."))
		((int, stones, 0, Attr::readonly, "Number of stones handed to the polyhedra system."))
		((int, shapes, 0, Attr::readonly, "Number of distinct shape templates."))
		((Real, meanContacts, 0, Attr::readonly, "Mean number of active contacts (stone-stone + stone-wall) over the last batch."))
		, /* ctor */
		, /* py */
		.def("initialize", &PolyhedraGpuEngine::initialize, "Hand the stones and walls to the polyhedra system now (otherwise done at the first step).")
		.def("addStone", &PolyhedraGpuEngine::addStone, (py::arg("id"), py::arg("vertices"), py::arg("dilationRadius") = 0), "Register body *id* as a stone whose convex core has *vertices* (list of Vector3, body frame, m), dilated by *dilationRadius* [m] (0: :yref:`PolyhedraGpuEngine.dilationRadius`). Before the first step only.")
		.def("setWallVelocity", &PolyhedraGpuEngine::setWallVelocity, (py::arg("facets"), py::arg("velocity")), "Move the :yref:`Facet` bodies *facets* (ids) rigidly with *velocity* [m/s] from the next batch on, until changed (e.g. a compaction plate); the facets' YADE states follow at the end of each batch.")
		.def("criticalTimeStep", &PolyhedraGpuEngine::criticalTimeStep, (py::arg("normalForce") = 0, py::arg("impactVelocity") = 0), "Smallest critical time step of the registered stones [s] for contacts carrying *normalForce* [N] and impacts at *impactVelocity* [m/s] (whichever are > 0): Hertz contact-oscillator limit (kernels/CriticalTimeStep.hpp) of two equal stones and of a stone on a wall, over the shape templates. Initializes the system. Take 0.2-0.5 of it.")
		.def("wallForce", &PolyhedraGpuEngine::wallForce, (py::arg("facets")), "Force of the stones on the :yref:`Facet` bodies *facets* (ids) [N], mean over the steps of the last batch.")
	);
  // clang-format on
  DECLARE_LOGGER;

private:
  void syncBack();
  int triangleOf(Body::id_t facet) const;
  void moveWalls(Real duration);

  std::shared_ptr<railcosim::polyhedra::PolyhedraSystem> system;
  std::vector<Body::id_t> stoneIds;
  std::vector<std::vector<Vector3r>> stoneCores; // registered core vertices, same order
  std::vector<Quaternionr> principalToBody;      // rotation from the stone's principal frame to the YADE body frame
  std::vector<Vector3r> centroidInBody;          // stone centroid in the YADE body frame
  std::vector<Real> stoneDilations;              // r_d of each registered stone [m], 0: dilationRadius
  // Wall mesh as handed to the system: 3 nodes per facet; node positions and velocities [m, m/s] of moving facets.
  std::map<Body::id_t, int> triangleOfFacet;
  std::vector<double> wallNodePositions, wallNodeVelocities;
  bool wallsMove = false;
};
REGISTER_SERIALIZABLE(PolyhedraGpuEngine);

} // namespace yade
