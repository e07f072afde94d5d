// YADE engine advancing the scene's polyhedral stones as dilated polyhedra on the GPU (or its CPU reference).
#pragma once

#include <core/Body.hpp>
#include <core/GlobalEngine.hpp>

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
  void addStone(Body::id_t id, const std::vector<Vector3r>& vertices);
  /// Restart checkpoints (railcosim.dem.CoupledDem): the polyhedra system's state (stones, contact histories,
  /// neighbour lists), which no attribute holds. Refused until PolyhedraSystem can write and read it (issue 17).
  boost::python::object restartState() const;
  void restoreRestartState(const boost::python::object& state);
  virtual ~PolyhedraGpuEngine();

  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(PolyhedraGpuEngine, GlobalEngine,
		"Advances the scene's polyhedral stones with railcosim's dilated-polyhedra DEM. A stone is any YADE body (a "
		":yref:`Sphere` of the stone's circumradius is convenient for display and output) registered with "
		":yref:`PolyhedraGpuEngine.addStone` together with its convex core vertices in the body frame; the stone is that "
		"core dilated by :yref:`PolyhedraGpuEngine.dilationRadius`, and identical cores share one shape template. Contacts: gap between the cores (GJK), Hertz-Mindlin with the dilation curvature, damping from "
		":yref:`PolyhedraGpuEngine.restitution`, Coulomb friction with tangential history; :yref:`Facet` bodies are fixed "
		"triangle walls. Integration: velocity Verlet and the Zhao-van Wachem quaternion scheme, with :yref:`Omega.dt`. "
		"The stones are advanced in batches of :yref:`PolyhedraGpuEngine.syncInterval` steps; at the end of each batch "
		"(when the scene's time has caught up) their positions, orientations and velocities are written back to the YADE "
		"bodies, for output, coupling and Python access (the YADE bodies' own shapes take no part in the contacts). "
		"Stone material: the first stone's FrictMat (young, poisson, "
		"frictionAngle, density). The engine integrates the stones itself: do not put a NewtonIntegrator in the same "
		"scene. Runs on the GPU when one is usable, else on the CPU reference (said once).",
		((int, syncInterval, 100, , "Steps per batch; the YADE bodies are updated at the end of each batch."))
		((Real, dilationRadius, 0.002, , "Dilation radius r_d of every stone [m] (the stone is its YADE polyhedron dilated by r_d)."))
		((Real, restitution, 0.3, , "Coefficient of restitution of all contacts [-]."))
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
		.def("addStone", &PolyhedraGpuEngine::addStone, (py::arg("id"), py::arg("vertices")), "Register body *id* as a stone whose convex core has *vertices* (list of Vector3, body frame, m). Before the first step only.")
		.def("restartState", &PolyhedraGpuEngine::restartState, "The polyhedra system's state (bytes) for a restart checkpoint. Not yet available: raises.")
		.def("restoreRestartState", &PolyhedraGpuEngine::restoreRestartState, (py::arg("state")), "Put back what restartState() returned. Not yet available: raises.")
	);
  // clang-format on
  DECLARE_LOGGER;

private:
  void syncBack();

  std::shared_ptr<railcosim::polyhedra::PolyhedraSystem> system;
  std::vector<Body::id_t> stoneIds;
  std::vector<std::vector<Vector3r>> stoneCores; // registered core vertices, same order
  std::vector<Quaternionr> principalToBody;      // rotation from the stone's principal frame to the YADE body frame
  std::vector<Vector3r> centroidInBody;          // stone centroid in the YADE body frame
};
REGISTER_SERIALIZABLE(PolyhedraGpuEngine);

} // namespace yade
