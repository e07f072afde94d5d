// YADE engine advancing the scene's polyhedral stones as dilated polyhedra on the GPU (or its CPU reference).
#pragma once

#include <core/Body.hpp>
#include <core/GlobalEngine.hpp>
#include <core/Material.hpp>

#include <memory>

#include "polyhedra/PolyhedraBodyFrames.hpp"
#include <string>
#include <vector>

namespace railcosim::polyhedra {
class PolyhedraSystem;
}

namespace yade {

/// An engine that brings a coupled surface to the scene's PolyhedraGpuEngine (FemCouplingEngine with
/// contactModel='polyhedra'). Before it builds its system, the polyhedra engine asks every such engine of O.engines to
/// attach its surface, so that the order of the engines does not matter.
class PolyhedraSurfaceSource {
public:
  virtual ~PolyhedraSurfaceSource();
  /// Attach the surface now (connecting to the FEM side first if need be) if this engine couples through the
  /// polyhedra engine; nothing otherwise.
  virtual void attachPolyhedraSurface() = 0;
};

class PolyhedraGpuEngine : public GlobalEngine {
public:
  void action() override;
  void initialize();
  void addStone(Body::id_t id, const std::vector<Vector3r>& vertices, Real stoneDilationRadius = -1);
  /// Volume of the convex hull of `vertices` dilated by `dilationRadius` (Steiner formula, as the engine computes it).
  static Real dilatedVolume(const std::vector<Vector3r>& vertices, Real dilationRadius);
  void setWallVelocity(const std::vector<Body::id_t>& facets, const Vector3r& velocity);
  Vector3r wallForce(const std::vector<Body::id_t>& facets) const;
  Real criticalTimeStep(Real normalForce, Real impactVelocity);
  /// Restart checkpoints (railcosim.dem.CoupledDem): the polyhedra system's state (stones, contact histories,
  /// neighbour lists) and its kept snapshot, which no attribute holds.
  boost::python::object restartState();
  void restoreRestartState(const boost::python::object& state);
  virtual ~PolyhedraGpuEngine();

  // The coupled surface (C++ side of FemCouplingEngine with contactModel='polyhedra').
  /// Adds an FE interface to the wall mesh, after the Facet walls: `triangles` as node indices (3 each), reference
  /// `coordinates` (3 per node, m). Its material is `material` (FrictMat or BallastMat) with restitution
  /// `restitution`, mixed with the stones' by the contact law's one rule. Before the engine is initialized only.
  void attachSurface(const std::vector<int32_t>& triangles, const std::vector<double>& coordinates,
                     const shared_ptr<Material>& material, Real restitution);
  bool hasSurface() const { return surfaceNodes > 0; }
  bool initialized() const { return bool(system); }
  /// Throws std::invalid_argument for a surface material attachSurface would refuse (checked before connecting).
  static void checkSurfaceMaterial(const shared_ptr<Material>& material, Real restitution);
  /// One coupling window in one batch: the surface nodes start at `positions` [m] and move at `velocities` [m/s]
  /// (3 per node) for `steps` steps of O.dt; the stones' YADE bodies are synced at its end. Returns the window's mean
  /// force on each surface triangle [N] and the force-weighted mean contact point [m] (3 per triangle each).
  void advanceWindow(const std::vector<double>& positions, const std::vector<double>& velocities, int steps,
                     std::vector<double>& triangleForces, std::vector<double>& contactPoints);
  /// The polyhedra state, kept in memory (on the device for CUDA), for a window that is repeated.
  void saveSnapshot();
  void restoreSnapshot();

  // Python.
  boost::python::list contactsPy();
  boost::python::dict stoneForcesPy();
  boost::python::dict stoneTorquesPy();
  void writeStatePy(const std::string& path);
  void readStatePy(const std::string& path);

  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(PolyhedraGpuEngine, GlobalEngine,
		"Advances the scene's polyhedral stones with railcosim's dilated-polyhedra DEM. A stone is any YADE body (a "
		":yref:`Sphere` of the stone's circumradius is convenient for display and output) registered with "
		":yref:`PolyhedraGpuEngine.addStone` together with its convex core vertices in the body frame; the stone is that "
		"core dilated by :yref:`PolyhedraGpuEngine.dilationRadius`, and identical cores share one shape template. Contacts: gap between the cores (GJK), "
		"the one contact law of the kernels (docs/contact-models.md) with the dilation curvature: Hertz-Mindlin, or the "
		"Pohrt-Popov laws for a rough :yref:`BallastMat`, damping from restitution, Coulomb friction (stress-dependent "
		"between stones where the BallastMat sets it) with tangential history. :yref:`Facet` bodies are "
		"triangle walls, fixed unless moved with :yref:`PolyhedraGpuEngine.setWallVelocity`, each meeting the stones with its own material (at most 3 distinct facet materials beside a coupled surface). "
		"Integration: velocity Verlet and the Zhao-van Wachem quaternion scheme, with :yref:`Omega.dt`. "
		"The stones are advanced in batches of :yref:`PolyhedraGpuEngine.syncInterval` steps; at the end of each batch "
		"(when the scene's time has caught up) their positions, orientations and velocities are written back to the YADE "
		"bodies, for output, coupling and Python access (the YADE bodies' own shapes take no part in the contacts). "
		"Materials: the stones' is the first stone's :yref:`FrictMat` (young, poisson, frictionAngle, density; restitution "
		":yref:`PolyhedraGpuEngine.restitution`) or :yref:`BallastMat` (also its restitution, roughness, plasticUnloading, "
		"stress-dependent friction), the walls' that of each facet (a FrictMat facet with :yref:`PolyhedraGpuEngine.restitution`); "
		"a pair mixes them by the contact law's one rule. "
		"Coupled to FreeFEM: a :yref:`FemCouplingEngine` with :yref:`contactModel<FemCouplingEngine.contactModel>` "
		"``'polyhedra'`` adds its interface to the walls and drives this engine one coupling window at a time "
		"(:yref:`PolyhedraGpuEngine.syncInterval` is then not used: a window is one batch). "
		"The engine integrates the stones itself: do not put a NewtonIntegrator in the same "
		"scene. Runs on the GPU when one is usable, else on the CPU reference (said once).",
		((int, syncInterval, 100, , "Steps per batch; the YADE bodies are updated at the end of each batch. Not used while a FemCouplingEngine drives the engine (one batch per coupling window)."))
		((Real, dilationRadius, 0.002, , "Dilation radius r_d of every stone [m] (the stone is its YADE polyhedron dilated by r_d)."))
		((Real, restitution, 0.3, , "Coefficient of restitution [-] of the stones' and the facets' materials when they are FrictMat (a BallastMat has its own); a pair mixes the two damping ratios."))
		((Vector3r, gravity, Vector3r(0, 0, -9.81), , "Gravity acceleration [m/s^2]."))
		((string, backend, "automatic", , "``automatic`` (GPU when usable, else CPU), ``cpu`` or ``cuda``."))
		((int, rebuildInterval, 10, , "Steps between neighbour-list rebuilds (each batch starts with one)."))
		((Real, neighbourSkin, -1, , "Verlet skin of the neighbour lists [m]; < 0: a fifth of the mean dilation radius. Over one rebuild interval no two stones may close more than half of it (a warning reports it): fast stones need a larger skin or a shorter interval."))
		((bool, adaptiveRebuild, true, , "Skip a due rebuild while no stone can outgrow the lists: largest displacement since the last rebuild plus twice the fastest stone's travel over the next interval below half the skin. Never skipped while the surface moves."))
		((int, maxNeighbours, 24, , "Candidate partner stones stored per stone [-] (raise it if a step reports an overflow)."))
		((int, maxWallNeighbours, 8, , "Candidate wall or surface triangles stored per stone [-]."))
		((Real, largeBodyRatio, 2.5, , "Bodies whose bounding radius exceeds this multiple of the median one (pressure cells, blocks) stay out of the neighbour grid: every other stone lists those within reach, so that maxNeighbours counts them too [-]. <= 0: none."))
		((string, activeBackend, "", Attr::readonly, "Backend in use after initialization: ``cpu`` or ``cuda``."))
		((string, backendReason, "", Attr::readonly, "Why this backend runs (e.g. no usable GPU)."))
		((int, stones, 0, Attr::readonly, "Number of stones handed to the polyhedra system."))
		((int, shapes, 0, Attr::readonly, "Number of distinct shape templates."))
		((int, wallTriangles, 0, Attr::readonly, "Triangles of the wall mesh: the facets', then those of a coupled surface."))
		((Real, meanContacts, 0, Attr::readonly, "Mean number of active contacts (stone-stone + stone-wall) over the last batch."))
		((Vector3r, surfaceForce, Vector3r::Zero(), Attr::readonly, "Total force the stones exerted on the coupled surface, mean over the last coupling window [N] (zero without a coupled surface)."))
		, /* ctor */
		, /* py */
		.def("initialize", &PolyhedraGpuEngine::initialize, "Hand the stones and walls to the polyhedra system now (otherwise done at the first step). A FemCouplingEngine with contactModel='polyhedra' in O.engines connects first, so that its surface joins the walls.")
		.def("addStone", &PolyhedraGpuEngine::addStone, (py::arg("id"), py::arg("vertices"), py::arg("dilationRadius") = -1), "Register body *id* as a stone whose convex core has *vertices* (list of Vector3, body frame, m), dilated by *dilationRadius* [m] (default: :yref:`PolyhedraGpuEngine.dilationRadius`). Stones with the same core and dilation share a template. Before the first step only. At initialization the body's :yref:`State.mass` becomes the dilated stone's mass [kg] (density of its material; its inertia stays the YADE body's own, unused by the engine).")
		.def("dilatedVolume", &PolyhedraGpuEngine::dilatedVolume, (py::arg("vertices"), py::arg("dilationRadius"))).staticmethod("dilatedVolume")
		.def("setWallVelocity", &PolyhedraGpuEngine::setWallVelocity, (py::arg("facets"), py::arg("velocity")), "Move the :yref:`Facet` bodies *facets* (ids) rigidly with *velocity* [m/s] from the next batch on, until changed (e.g. a compaction plate); the facets' YADE states follow at the end of each batch. Not while a coupled surface drives the engine.")
		.def("wallForce", &PolyhedraGpuEngine::wallForce, (py::arg("facets")), "Force of the stones on the :yref:`Facet` bodies *facets* (ids) [N], mean over the steps of the last batch.")
		.def("criticalTimeStep", &PolyhedraGpuEngine::criticalTimeStep, (py::arg("normalForce") = 0, py::arg("impactVelocity") = 0), "Smallest critical time step of the registered stones [s] for contacts carrying *normalForce* [N] and impacts at *impactVelocity* [m/s] (whichever are > 0): Hertz contact-oscillator limit (kernels/CriticalTimeStep.hpp) of two equal stones and of a stone on a wall, over the shape templates. Initializes the system. Take 0.2-0.5 of it.")
		.def("contacts", &PolyhedraGpuEngine::contactsPy, "Active contacts at the last force evaluation of the last batch, a list of dicts: ``id1``, ``id2`` (YADE body ids of the two stones; ``id2`` = -1 for a wall or surface contact), ``triangle`` (index in the wall mesh, -1 between stones), ``facet`` (the Facet body's id, -1 otherwise), ``surfaceTriangle`` (index in the coupled surface's triangles, :yref:`FemCouplingEngine.triangles`, -1 otherwise), ``point`` (contact point [m]), ``normal`` (unit, from id1 towards id2 or the wall), ``force`` (force on id2 or on the wall [N]; id1 receives the opposite), ``overlap`` [m].")
		.def("stoneForces", &PolyhedraGpuEngine::stoneForcesPy, "Contact force on each stone at the last force evaluation, gravity excluded: dict {body id: Vector3} [N].")
		.def("stoneTorques", &PolyhedraGpuEngine::stoneTorquesPy, "Contact torque on each stone about its centre of mass at the last force evaluation: dict {body id: Vector3} [N m].")
		.def("writeState", &PolyhedraGpuEngine::writeStatePy, (py::arg("path")), "Write the polyhedra system's whole state (stones, contact histories, surface, time) to the file *path* (binary; PolyhedraSystem::writeState).")
		.def("readState", &PolyhedraGpuEngine::readStatePy, (py::arg("path")), "Read a state written by writeState into this engine's system (built the same way: same stones, shapes and walls) and sync the YADE bodies to it; a file that does not fit is refused with the reason.")
		.def("restartState", &PolyhedraGpuEngine::restartState, "The polyhedra system's state (bytes) for a restart checkpoint: stones, contact histories, neighbour lists, the snapshot an implicit window keeps, moving facets.")
		.def("restoreRestartState", &PolyhedraGpuEngine::restoreRestartState, (py::arg("state")), "Put back what restartState() returned, in a scene rebuilt the same way (the stream's counts and shapes are checked; a state that does not fit is refused with the reason).")
	);
  // clang-format on
  DECLARE_LOGGER;

private:
  void syncBack();
  void requireSystem(const char* what) const;
  int triangleOfFacet(Body::id_t facet) const;

  std::shared_ptr<railcosim::polyhedra::PolyhedraSystem> system;
  std::vector<Body::id_t> stoneIds;
  std::vector<std::vector<Vector3r>> stoneCores; // registered core vertices, same order
  std::vector<Real> stoneDilation;               // r_d per stone [m]; < 0: dilationRadius
  std::vector<double> facetNodeVelocities;       // [m/s], 3 per facet node (setWallVelocity)
  bool facetsMove = false;
  railcosim::polyhedra::BodyFrameStones frames; // the stones' YADE body frames <-> the system's principal frames
  // Wall mesh: the facets' triangles (three nodes each, at rest), then the coupled surface's.
  std::vector<Body::id_t> facetOfTriangle; // per facet triangle
  std::vector<double> facetNodes;          // 3 per node
  int surfaceFirstTriangle = 0, surfaceTriangles = 0, surfaceNodes = 0;
  std::vector<int32_t> surfaceConnectivity;
  std::vector<double> surfaceCoordinates;
  shared_ptr<Material> surfaceMaterial;
  Real surfaceRestitution = 0;
};
REGISTER_SERIALIZABLE(PolyhedraGpuEngine);

} // namespace yade
