// YADE side of the DEM-FEM coupling: the FEM interface surface as moving facets, forces lumped to nodes.
#pragma once

#include <core/Body.hpp>
#include <core/GlobalEngine.hpp>
#include <core/Material.hpp>

#include <memory>
#include <string>
#include <vector>

#include "../integrator/QuaternionIntegrator.hpp"
#include "../polyhedra/PolyhedraGpuEngine.hpp"
#include "FacetSurface.hpp"
#include "FemSurfaceContactEngine.hpp"
#include "SceneCheckpoint.hpp"

#include "railcosim/Checkpoint.hpp"

namespace railcosim {
class DemParticipant;
class DemCouplingScheme;
struct InterfaceSetup;
struct SchemeSettings;
} // namespace railcosim

namespace yade {

class FemCouplingEngine : public GlobalEngine, public PolyhedraSurfaceSource {
public:
  void action() override;
  void connect();
  void finalize();
  void attachPolyhedraSurface() override; // contactModel 'polyhedra': connects, which attaches the surface
  std::string completeCheckpoint(const std::vector<std::string>& files, const boost::python::object& pythonState);
  boost::python::object restoreCheckpoint();
  Real femTimeStepPy() const { return femDt; }
  virtual ~FemCouplingEngine();

  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(FemCouplingEngine, GlobalEngine,
		"Couples this scene with a FreeFEM structure through the railcosim bridge (ZeroMQ). At connection the FEM "
		"participant sends its interface surface (nodes + triangles); the engine inserts one non-dynamic :yref:`Facet` "
		"body per triangle, moves the facet vertices with the received nodal kinematics inside each coupling window, "
		"collects the contact forces on those facets, lumps them to the nodes with the barycentric weights of the "
		"contact points and sends them to the FEM side once per window.\n\n"
		"Place it in :yref:`Omega.engines` after the :yref:`InteractionLoop` and before the integrator. The coupling "
		"window is the FEM time step; the DEM performs :yref:`FemCouplingEngine.subcycles` steps per window and "
		":yref:`Omega.dt` is set to femTimeStep/subcycles at connection. Schemes: ``justInTime`` (DEM first, surface "
		"extrapolated with P+V t+A t^2/2 from the last received state) and ``predictive`` (FEM first, surface moved "
		"linearly between the FEM positions at the window ends) and ``implicit`` (DEM first; the window is repeated from a "
		"checkpoint of the scene until the FEM end state agrees with the one the surface was moved to, with Aitken relaxation; "
		"see :yref:`FemCouplingEngine.implicitTolerance`). The FEM solver must use the same scheme.\n\n"
		"Implicit scheme and the rest of the scene: a repeated window restores body states, interactions, forces, "
		":yref:`Omega.time` and :yref:`Omega.iter` as they were when the window started, so periodic engines "
		"(:yref:`PyRunner` with iterPeriod) fire once per accepted window; also the private state of the engines that keep "
		"one across steps: the half-step slots of every :yref:`QuaternionIntegrator` of O.engines (sphere clusters), the "
		"``meshContacts`` history, and the whole polyhedra system of the :yref:`PolyhedraGpuEngine` (``polyhedra``), so that "
		"the accepted pass is the pass a single run from the window start would make. Other engines' private state is "
		"not rolled back (:yref:`BoundedRollingFrictionEngine` keeps none across steps).\n\n"
		"Polyhedral stones (``contactModel='polyhedra'``): the interface joins the walls of the scene's one "
		":yref:`PolyhedraGpuEngine` (beside its Facet walls), and this engine drives it one window at a time: in the "
		"window's last iteration the polyhedra system advances the window's :yref:`FemCouplingEngine.subcycles` DEM "
		"steps in one batch (on the GPU when usable), the surface nodes moving linearly from the scheme's position at the "
		"window start to its position at the window end: exact for ``predictive`` and ``implicit``, whose surface moves "
		"linearly; for ``justInTime`` the end position is that of the P+V t+A t^2/2 extrapolation (the straight line "
		"between its ends, not the parabola). The stones' YADE bodies are synced at the end of the batch. The FEM receives "
		"the window's mean force on each triangle, lumped to its nodes with the barycentric weights of the triangle's "
		"force-weighted mean contact point on the surface at mid-window (the mean position of a linearly moving "
		"triangle): total force and impulse over the window are exact, as with :yref:`FemCouplingEngine.averageForces`, "
		"which this model always does. Contact law: the one of the kernels, the surface's material "
		":yref:`FemCouplingEngine.material` with restitution :yref:`FemCouplingEngine.restitution` mixed with the stones' "
		"by the one rule (docs/contact-models.md).",
		((string, endpoint, "", , "ZeroMQ endpoint of the FEM participant, e.g. ``ipc:///tmp/railcosim.sock`` or ``tcp://127.0.0.1:5555``."))
		((string, participantName, "dem", , "Name of this participant, shown in every message of the peer."))
		((string, scheme, "justInTime", , "Coupling scheme: ``justInTime``, ``predictive`` or ``implicit``."))
		((Real, implicitTolerance, 1e-3, , "``implicit``: a window is accepted when the rms difference between the FEM's end positions and those the surface was moved to is at most implicitTolerance times the rms interface displacement since t=0 plus :yref:`FemCouplingEngine.implicitAbsoluteTolerance`."))
		((Real, implicitAbsoluteTolerance, 1e-14, , "``implicit``: absolute floor of the convergence test [m] (rms over the interface values)."))
		((int, implicitMaxIterations, 30, , "``implicit``: passes per window; the last one is then accepted and counted in :yref:`FemCouplingEngine.unconvergedWindows`."))
		((Real, implicitRelaxation, 0.5, , "``implicit``: relaxation factor of the first corrective pass, in (0, 1]; without :yref:`FemCouplingEngine.aitken` it is used for every pass, with Aitken a window starts from the previous window's last factor when that lies in (0, 1]."))
		((bool, aitken, true, , "``implicit``: dynamic Aitken relaxation of the interface positions."))
		((long, implicitPasses, 0, Attr::readonly, "``implicit``: DEM passes over all windows so far (a window that converges at once counts 1)."))
		((long, lastWindowPasses, 0, Attr::readonly, "``implicit``: passes the last accepted window needed."))
		((long, maxWindowPasses, 0, Attr::readonly, "``implicit``: most passes any window needed."))
		((long, unconvergedWindows, 0, Attr::readonly, "``implicit``: windows accepted after implicitMaxIterations passes without meeting the tolerance."))
		((Real, lastResidual, 0, Attr::readonly, "``implicit``: rms position residual of the last judged pass [m]."))
		((Real, checkpointTime, 0, Attr::readonly, "Schemes that repeat windows (``implicit``): time spent saving and restoring the scene checkpoint, the engines' private state included [s]."))
		((string, contactModel, "facets", , "How particles touch the surface. ``facets``: one :yref:`Facet` body per triangle, contacts handled by the scene's own :yref:`InteractionLoop` functors (a sphere over an edge between two triangles gets a contact from each). ``meshContacts``: a :yref:`FemSurfaceContactEngine` run by this engine finds the sphere-surface contacts itself with the facet > edge > vertex hierarchy (one contact per touching surface patch, shadowed contacts removed), contact-point velocity interpolated from the nodal velocities, force from the one contact law of the kernels (docs/contact-models.md: sub-models and parameters mixed from the particle and surface materials as for a pair, restitution :yref:`FemCouplingEngine.restitution`); spheres and clump members (sphere clusters); no facet bodies are inserted. ``polyhedra``: the surface becomes part of the walls of the scene's one :yref:`PolyhedraGpuEngine`, which advances its stones one window per batch (see above); no facet bodies are inserted. ``hierarchy`` is the former name of ``meshContacts`` (deprecated, still accepted)."))
		((Real, restitution, 0.5, , "``meshContacts`` model: coefficient of restitution of particle-surface impacts [-], turned into a Hertzian damping ratio. ``polyhedra`` model: the restitution of the surface's material, mixed with the stones' (mean of the two damping ratios; equal values give that restitution)."))
		((long, surfaceContacts, 0, Attr::readonly, "``meshContacts`` model: number of particle-surface contacts at the last step. ``polyhedra`` model: number of surface triangles the stones loaded in the last window."))
		((Real, timeout, 60, , "Longest wait for any message of the FEM participant [s] before giving up with an error."))
		((Real, heartbeat, 1, , "Keepalive interval [s]: a frozen peer (silent, not even keepalives) is reported after three intervals; a dead one at once."))
		((int, subcycles, 0, , "DEM steps per coupling window. 0 (default): the smallest count for which femTimeStep/subcycles does not exceed the current :yref:`Omega.dt`. Omega.dt is set to femTimeStep/subcycles at connection."))
		((bool, averageForces, false, , "Send the time average of the nodal forces over the window's DEM steps instead of those of its last step (impulse-conserving). The ``polyhedra`` model always sends the window average."))
		((shared_ptr<Material>, material, , , "Material of the surface (required): of the inserted facets, of the mesh contacts, or of the polyhedra engine's surface triangles (FrictMat or BallastMat)."))
		((int, mask, 1, , ":yref:`Body.groupMask` of the inserted facets."))
		((Real, femDt, 0, Attr::readonly, "FEM time step = coupling window length [s], received at connection."))
		((long, window, 0, Attr::readonly, "Index of the current coupling window (number of completed exchanges)."))
		((vector<Body::id_t>, facetIds, , Attr::readonly, "Ids of the inserted facet bodies, one per interface triangle (same order)."))
		((vector<Vector3r>, nodePositions, , Attr::readonly, "Current positions of the interface nodes in the DEM scene [m]."))
		((vector<Vector3r>, nodeVelocities, , Attr::readonly, "Current velocities of the interface nodes in the DEM scene [m/s]."))
		((vector<Vector3r>, nodalForces, , Attr::readonly, "Nodal forces sent at the last exchange [N] (force exerted by the particles on the structure)."))
		((Vector3r, totalForce, Vector3r::Zero(), Attr::readonly, "Sum of :yref:`FemCouplingEngine.nodalForces` [N]."))
		((vector<Vector3i>, triangles, , Attr::readonly, "Interface triangles as node indices."))
		((long, exchanges, 0, Attr::readonly, "Number of completed windows (force/kinematics exchanges)."))
		((bool, auditEnergy, true, , "Accumulate the work of the interface forces as seen by each side (:yref:`FemCouplingEngine.interfaceWorkDem`, :yref:`FemCouplingEngine.interfaceWorkFem`)."))
		((Real, interfaceWorkDem, 0, Attr::readonly, "Work done by the particles on the structure, integrated on the DEM side over every DEM step: sum of nodal force . nodal velocity * dt [J]."))
		((Real, interfaceWorkFem, 0, Attr::readonly, "Work of the forces the FEM received, along the FEM's nodal displacements over each window: sum of F_sent . (P_end - P_start) [J]."))
		((Real, bridgeTime, 0, Attr::readonly, "Time spent in the exchanges (encoding, ZeroMQ transfer, decoding) [s], excluding waits for the FEM solver."))
		((Real, mappingTime, 0, Attr::readonly, "Time spent lumping facet contact forces to the nodes [s] (every DEM step when averaging or auditing energy, else once per window; once per window for ``polyhedra``)."))
		((Real, polyhedraTime, 0, Attr::readonly, "``polyhedra`` model: time spent advancing the polyhedra system's windows [s] (the DEM itself)."))
		((Real, waitTime, 0, Attr::readonly, "Time spent waiting for the FEM solver [s]."))
		((bool, connected, false, Attr::readonly, "Whether the handshake with the FEM participant is done."))
		((Real, checkpointEvery, 0, , "Restart checkpoints: simulated time between two [s] (0: none); rounded to a whole number of windows. At the end of every such window the engine orders the FEM side to save its state into :yref:`FemCouplingEngine.checkpointFolder` and sets :yref:`FemCouplingEngine.checkpointPending`; the last engine of that step then calls :yref:`FemCouplingEngine.completeCheckpoint` (railcosim.dem.CoupledDem does). The newest two complete checkpoints are kept (docs/protocol.md section 12)."))
		((string, checkpointFolder, "", , "Folder of the restart checkpoints (the FEM side's RAILCOSIM_CHECKPOINT_DIR)."))
		((string, checkpointRun, "", , "What identifies the run (case and parameters), stored in every checkpoint's manifest and compared when a run resumes."))
		((string, resumeFrom, "", , "Restart checkpoint folder this run resumes from (\"\": a fresh run). connect() then checks it, announces it at the handshake (the FEM side must resume from the same one) and takes up the coupling where it stopped; :yref:`FemCouplingEngine.restoreCheckpoint` puts the scene back."))
		((string, checkpointPending, "", Attr::readonly, "Name of the restart checkpoint ordered at this step's exchange and not yet completed (\"\" when none)."))
		((long, checkpointsWritten, 0, Attr::readonly, "Restart checkpoints ordered by this run and the runs it resumed (completed by completeCheckpoint)."))
		((string, lastCheckpoint, "", Attr::readonly, "Folder of the last restart checkpoint completed or resumed from."))
		((Real, checkpointWriteTime, 0, Attr::readonly, "Wall time spent writing restart checkpoints [s] (both sides' saves, as the DEM waits for the FEM's)."))
		, /* ctor */
		, /* py */
		.def("connect", &FemCouplingEngine::connect, "Handshake with the FEM participant now (otherwise done at the first step): receives the interface mesh, inserts the facets, sets O.dt.")
		.def("finalize", &FemCouplingEngine::finalize, "Tell the FEM participant that the run is over (it then writes its results and exits). Idempotent.")
		.def("completeCheckpoint", &FemCouplingEngine::completeCheckpoint, (py::arg("files"), py::arg("pythonState")), "Complete the restart checkpoint ordered at this step (:yref:`FemCouplingEngine.checkpointPending`): from the last engine of the step, after everything else of the step. Writes the scene (bodies, interactions, clock), this engine's and its coupling scheme's state and *pythonState* (bytes: the script's own, e.g. the other engines' attributes) to dem_state.bin, copies *files* (output files of this run, put back on resume), writes the manifest last and commits the checkpoint. Returns its folder.")
		.def("restoreCheckpoint", &FemCouplingEngine::restoreCheckpoint, "In a resumed run (:yref:`FemCouplingEngine.resumeFrom`), after connect() and once O.engines are complete: puts the DEM side's files and the scene back as they were when the checkpoint was written (next step: the one after it) and returns the *pythonState* bytes saved with it.")
	);
  // clang-format on
  DECLARE_LOGGER;

private:
  enum class Model { Facets, MeshContacts, Polyhedra };
  void placeSurface(Real tau, bool beforeIntegrator);
  void accumulateStep();
  Model surfaceModel() const;
  std::vector<double> windowForces(); // facets / meshContacts: what the window sends
  bool exchange(std::vector<double> forces); // false: the scheme repeats the window
  void saveCheckpoint();
  void polyhedraAction();
  void startPolyhedraWindow();
  void advancePolyhedraWindow();
  shared_ptr<PolyhedraGpuEngine> findPolyhedraEngine() const;
  void restoreIterationCheckpoint();
  void orderRestartCheckpoint();
  void writeOwnState(std::ostream& out) const;
  void readOwnState(std::istream& in, const railcosim::InterfaceSetup& setup);
  // The scheme and implicit attributes as bridge settings (throws railcosim::Error naming a bad one).
  railcosim::SchemeSettings schemeSettings() const;
  long engineIndex(const Engine* engine) const; // its place in O.engines

  std::shared_ptr<railcosim::DemParticipant> participant;
  std::shared_ptr<railcosim::DemCouplingScheme> coupling;  // orders the messages, moves the surface, judges windows
  FacetSurface facets;                                     // contactModel 'facets'
  shared_ptr<FemSurfaceContactEngine> meshContact;         // contactModel 'meshContacts'
  std::vector<double> forceSum;                            // for averageForces
  std::vector<double> stepForces;                          // nodal forces of the current DEM step
  std::vector<double> surfacePositions, surfaceVelocities; // flat copies of nodePositions/nodeVelocities
  long stepsInWindow = 0;
  bool surfaceTouched = false; // any interface force during this pass
  // What a repeated window restores: the scene, and this engine's own sums and contact history.
  SceneCheckpoint sceneCheckpoint;
  Real savedWorkDem = 0, savedWorkFem = 0;
  std::shared_ptr<const FemSurfaceContactEngine::History> savedHistory;
  std::vector<std::pair<shared_ptr<QuaternionIntegrator>, std::vector<QuaternionIntegrator::BodySlot>>> savedIntegrators;
  // contactModel 'polyhedra': the stones' engine, the window's linear surface motion and its forces.
  shared_ptr<PolyhedraGpuEngine> polyhedra;
  std::vector<double> windowStartPositions, windowVelocities; // 3 per node: P(t_i), (P(t_i+1) - P(t_i))/femDt
  std::vector<double> polyhedraForces;                        // nodal forces of the window stepped last
  std::vector<int32_t> interfaceTriangles;                    // 3 node indices each
  // Restart checkpoints: the FEM side's files of the one ordered, and what a resumed run read at connect().
  Real timeAtConnect = 0;                          // scene time of the handshake: checkpoint times count from it
  std::vector<railcosim::CheckpointFile> femFiles; // of checkpointPending
  railcosim::CheckpointManifest resumedManifest;
  std::string resumedScene, resumedPython; // parts of dem_state.bin read by restoreCheckpoint()
};
REGISTER_SERIALIZABLE(FemCouplingEngine);

} // namespace yade
