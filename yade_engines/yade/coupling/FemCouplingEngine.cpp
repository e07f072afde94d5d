// FemCouplingEngine: moves the FE surface inside each window, gathers its forces, lets the coupling scheme exchange
// them.
#include "FemCouplingEngine.hpp"

#include "../common/PythonBytes.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/ForceLumping.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"
#include "polyhedra/PolyhedraWindow.hpp"

#include <core/Scene.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace yade {

YADE_PLUGIN((FemCouplingEngine));
CREATE_LOGGER(FemCouplingEngine);

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

Vector3r node(const std::vector<double>& xyz, int i) { return Vector3r(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

const char* const stateFile = "dem_state.bin";

std::vector<double> flat(const std::vector<Vector3r>& vectors) {
  std::vector<double> values;
  for (const Vector3r& v : vectors) values.insert(values.end(), {v[0], v[1], v[2]});
  return values;
}

std::vector<Vector3r> vectors(const std::vector<double>& values) {
  std::vector<Vector3r> result;
  for (size_t i = 0; i + 2 < values.size(); i += 3) result.emplace_back(values[i], values[i + 1], values[i + 2]);
  return result;
}
} // namespace

FemCouplingEngine::Model FemCouplingEngine::surfaceModel() const {
  if (contactModel == "meshContacts") return Model::MeshContacts;
  if (contactModel == "hierarchy") {
    static bool warned = false;
    if (!warned)
      LOG_WARN("FemCouplingEngine: contactModel='hierarchy' is deprecated; it is now called 'meshContacts'.");
    warned = true;
    return Model::MeshContacts;
  }
  if (contactModel == "facets") return Model::Facets;
  if (contactModel == "polyhedra") return Model::Polyhedra;
  throw std::invalid_argument("FemCouplingEngine: contactModel='" + contactModel +
                              "' is not known; use 'facets', 'meshContacts' or 'polyhedra'.");
}

// The scene's one PolyhedraGpuEngine (contactModel 'polyhedra').
shared_ptr<PolyhedraGpuEngine> FemCouplingEngine::findPolyhedraEngine() const {
  shared_ptr<PolyhedraGpuEngine> found;
  int count = 0;
  for (const auto& engine : scene->engines)
    if (auto candidate = boost::dynamic_pointer_cast<PolyhedraGpuEngine>(engine)) {
      found = candidate;
      ++count;
    }
  if (count != 1)
    throw std::invalid_argument(
        "FemCouplingEngine: contactModel='polyhedra' couples the surface to the stones of the scene's one "
        "PolyhedraGpuEngine, but O.engines holds " +
        std::to_string(count) +
        (count == 0 ? "; add the PolyhedraGpuEngine that advances the stones to O.engines before connecting."
                    : "; keep one (a surface can join one polyhedra system)."));
  return found;
}

void FemCouplingEngine::attachPolyhedraSurface() {
  if (!connected && surfaceModel() == Model::Polyhedra) connect();
}

FemCouplingEngine::~FemCouplingEngine() {
  try {
    finalize();
  } catch (...) {
    // Destructors must not throw; the peer notices the closed connection anyway.
  }
}

railcosim::SchemeSettings FemCouplingEngine::schemeSettings() const {
  return railcosim::SchemeSettings::of(railcosim::parseCouplingScheme(scheme), implicitTolerance,
                                       implicitAbsoluteTolerance, implicitMaxIterations, implicitRelaxation, aitken);
}

void FemCouplingEngine::connect() {
  if (connected) return;
  if (endpoint.empty())
    throw std::invalid_argument(
        "FemCouplingEngine: 'endpoint' is empty; set it to the FEM participant's ZeroMQ endpoint.");
  if (!material)
    throw std::invalid_argument(
        "FemCouplingEngine: 'material' is not set; give the facets a material, e.g. material=O.materials[0].");
  railcosim::SchemeSettings settings;
  try {
    settings = schemeSettings();
  } catch (const railcosim::Error& e) {
    throw std::invalid_argument(std::string("FemCouplingEngine: ") + e.what() +
                                " (attributes scheme, implicitTolerance, implicitAbsoluteTolerance, "
                                "implicitMaxIterations, implicitRelaxation)");
  }
  const Model model = surfaceModel();
  const bool withMeshContacts = model == Model::MeshContacts;
  if (model == Model::Polyhedra) { // refused before the handshake, not after it
    polyhedra = findPolyhedraEngine();
    if (polyhedra->initialized())
      throw std::invalid_argument(
          "FemCouplingEngine (contactModel='polyhedra'): the PolyhedraGpuEngine was initialized before this engine "
          "connected, so the surface cannot join its walls; put both engines in O.engines before the first step, or "
          "call connect() before the PolyhedraGpuEngine's initialize().");
    PolyhedraGpuEngine::checkSurfaceMaterial(material, restitution);
  }
  if (withMeshContacts) {
    meshContact = shared_ptr<FemSurfaceContactEngine>(new FemSurfaceContactEngine);
    meshContact->material = material;
    meshContact->restitution = restitution;
    meshContact->scene = scene;
    meshContact->checkSettings();
  }
  if (!(restitution >= 0 && restitution <= 1))
    throw std::invalid_argument("FemCouplingEngine: restitution must be in [0, 1], got " + std::to_string(restitution));

  railcosim::ParticipantConfig config;
  config.name = participantName;
  config.endpoint = endpoint;
  config.timeoutSeconds = timeout;
  config.heartbeatSeconds = heartbeat;
  config.couplingScheme = railcosim::toString(settings.scheme);
  std::string resumedEngine;
  if (!resumeFrom.empty()) {
    // Checked whole before anything is exchanged: a damaged or foreign checkpoint is refused in one line.
    resumedManifest = railcosim::verifyCheckpoint(resumeFrom);
    std::ifstream in(resumeFrom + "/" + stateFile, std::ios::binary);
    if (!in) throw railcosim::CheckpointError("checkpoint " + resumeFrom + " has no " + stateFile + " of the DEM side");
    railcosim::StateReader state(in, resumeFrom + "/" + stateFile);
    state.section("dem coupling engine");
    resumedEngine = state.bytes();
    state.section("dem scene");
    resumedScene = state.bytes();
    state.section("dem python");
    resumedPython = state.bytes();
    state.section("end");
    config.resumedFrom = resumedManifest.name;
    config.resumedWindow = resumedManifest.window;
  }
  participant = std::make_shared<railcosim::DemParticipant>(config);
  const auto waitStart = Clock::now();
  const railcosim::InterfaceSetup setup = participant->initialize();
  waitTime += secondsSince(waitStart);

  femDt = setup.femTimeStep;
  if (!(femDt > 0))
    throw std::runtime_error("FemCouplingEngine: the FEM participant announced a non-positive time step.");
  if (subcycles <= 0) {
    if (!(scene->dt > 0))
      throw std::invalid_argument(
          "FemCouplingEngine: subcycles=0 needs a positive O.dt to derive the sub-cycling ratio; set O.dt or "
          "subcycles.");
    subcycles = std::max(1, static_cast<int>(std::ceil(femDt / scene->dt - 1e-9)));
  }
  scene->dt = femDt / subcycles;
  LOG_INFO("Coupled with '" << setup.peerName << "': " << setup.mesh.nodeCount() << " nodes, "
                            << setup.mesh.triangleCount() << " triangles, femDt=" << femDt << " s, " << subcycles
                            << " DEM steps per window, O.dt=" << scene->dt);

  triangles.clear();
  const std::vector<int32_t>& connectivity = setup.mesh.triangles;
  for (size_t t = 0; t < setup.mesh.triangleCount(); ++t)
    triangles.push_back(Vector3i(connectivity[3 * t], connectivity[3 * t + 1], connectivity[3 * t + 2]));
  facetIds.clear();
  interfaceTriangles = connectivity;
  if (model == Model::Polyhedra)
    polyhedra->attachSurface(connectivity, setup.mesh.coordinates, material, restitution);
  else if (withMeshContacts)
    meshContact->attach(connectivity, setup.mesh.coordinates);
  else
    facetIds = facets.insert(*scene, connectivity, material, mask);

  if (!resumeFrom.empty()) {
    std::istringstream saved(resumedEngine);
    readOwnState(saved, setup);
    lastCheckpoint = resumeFrom;
    connected = true;
    // The surface as the saved step left it for the next one (the facets' bodies come back with the scene).
    placeSurface(stepsInWindow * scene->dt, true);
    LOG_INFO("Resumed from " << resumeFrom << " at window " << window);
    return;
  }
  // Predictive: this receives the FEM's first step (run before any DEM force exists).
  const double waitBefore = participant->statistics().waitSeconds;
  coupling = railcosim::DemCouplingScheme::create(settings, *participant, setup);
  waitTime += participant->statistics().waitSeconds - waitBefore;
  forceSum.assign(3 * setup.mesh.nodeCount(), 0.0);
  nodalForces.assign(setup.mesh.nodeCount(), Vector3r::Zero());
  polyhedraForces.assign(3 * setup.mesh.nodeCount(), 0.0);
  stepsInWindow = 0;
  window = 0;
  timeAtConnect = scene->time;
  connected = true;
  if (model == Model::Polyhedra)
    startPolyhedraWindow();
  else
    placeSurface(0, false);
}

void FemCouplingEngine::placeSurface(Real tau, bool beforeIntegrator) {
  if (polyhedra) { // the linear motion the polyhedra system follows (attributes for Python)
    for (size_t i = 0; i < nodePositions.size(); ++i) {
      nodeVelocities[i] = node(windowVelocities, i);
      nodePositions[i] = node(windowStartPositions, i) + tau * nodeVelocities[i];
    }
    return;
  }
  coupling->surfaceAt(tau, surfacePositions, surfaceVelocities);
  const size_t nodes = surfacePositions.size() / 3;
  nodePositions.resize(nodes);
  nodeVelocities.resize(nodes);
  for (size_t i = 0; i < nodes; ++i) {
    nodePositions[i] = node(surfacePositions, i);
    nodeVelocities[i] = node(surfaceVelocities, i);
  }
  if (meshContact)
    meshContact->setSurface(surfacePositions, surfaceVelocities);
  else
    facets.place(*scene, surfacePositions, surfaceVelocities, beforeIntegrator);
}

void FemCouplingEngine::saveCheckpoint() {
  const auto start = Clock::now();
  sceneCheckpoint.save(*scene);
  savedWorkDem = interfaceWorkDem;
  savedWorkFem = interfaceWorkFem;
  savedHistory = meshContact ? meshContact->history() : nullptr;
  savedIntegrators.clear();
  for (const auto& engine : scene->engines)
    if (auto integrator = boost::dynamic_pointer_cast<QuaternionIntegrator>(engine))
      savedIntegrators.emplace_back(integrator, integrator->integrationState());
  if (polyhedra) polyhedra->saveSnapshot();
  checkpointTime += secondsSince(start);
}

void FemCouplingEngine::restoreIterationCheckpoint() {
  const auto start = Clock::now();
  struct AddTime { // also when the restore throws
    Real& total;
    Clock::time_point start;
    ~AddTime() { total += secondsSince(start); }
  } addTime{checkpointTime, start};
  try {
    sceneCheckpoint.restore(*scene);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("FemCouplingEngine (") + scheme + "): " + e.what() +
                             " The window cannot be repeated.");
  }
  interfaceWorkDem = savedWorkDem;
  interfaceWorkFem = savedWorkFem;
  if (meshContact) meshContact->restoreHistory(savedHistory);
  for (const auto& [integrator, state] : savedIntegrators) integrator->restoreIntegrationState(state);
  if (polyhedra) polyhedra->restoreSnapshot();
}

void FemCouplingEngine::accumulateStep() {
  if (!surfaceTouched)
    for (double f : stepForces)
      if (f != 0) {
        surfaceTouched = true;
        break;
      }
  if (averageForces)
    for (size_t k = 0; k < stepForces.size(); ++k) forceSum[k] += stepForces[k];
  if (auditEnergy) {
    Real power = 0;
    for (size_t i = 0; i < nodeVelocities.size(); ++i) power += node(stepForces, i).dot(nodeVelocities[i]);
    interfaceWorkDem += power * scene->dt;
  }
}

std::vector<double> FemCouplingEngine::windowForces() {
  std::vector<double> forces;
  if (averageForces) {
    forces = forceSum;
    for (double& f : forces) f /= stepsInWindow;
  } else if (auditEnergy || meshContact || coupling->iterates()) {
    forces = stepForces; // already gathered for this step
  } else {
    facets.collectForces(*scene, surfacePositions, forces);
  }
  return forces;
}

bool FemCouplingEngine::exchange(std::vector<double> forces) {
  const size_t nodes = forces.size() / 3;
  totalForce = Vector3r::Zero();
  for (size_t i = 0; i < nodes; ++i) {
    nodalForces[i] = node(forces, i);
    totalForce += nodalForces[i];
  }
  const double before = participant->statistics().waitSeconds;
  const railcosim::WindowResult result = coupling->completeWindow(std::move(forces), scene->time, surfaceTouched);
  waitTime += participant->statistics().waitSeconds - before;
  std::fill(forceSum.begin(), forceSum.end(), 0.0); // the window's sum is in the message
  surfaceTouched = false;
  const railcosim::WindowIterationStatistics& iterations = coupling->iterationStatistics();
  implicitPasses = iterations.passes;
  lastResidual = iterations.lastResidual;
  lastWindowPasses = iterations.lastWindowPasses;
  maxWindowPasses = iterations.maxWindowPasses;
  unconvergedWindows = iterations.unconvergedWindows;
  if (result.repeat) return false;
  if (!result.converged && unconvergedWindows == 1)
    LOG_WARN(scheme << " coupling: window " << window << " did not converge in " << implicitMaxIterations
                    << " passes (residual " << lastResidual << " m, limit " << iterations.lastLimit
                    << " m); its last pass is accepted. Counted in unconvergedWindows; reported once.");
  if (auditEnergy) interfaceWorkFem += result.femWork;
  ++window;
  ++exchanges;
  if (checkpointEvery > 0 && window % std::max(1L, std::lround(checkpointEvery / femDt)) == 0) orderRestartCheckpoint();
  return true;
}

// A restart checkpoint is ordered at the exchange that ends a window: the FEM side saves at once, at its window
// boundary; this side's state is complete only once the step's remaining engines have run (completeCheckpoint()).
void FemCouplingEngine::orderRestartCheckpoint() {
  if (checkpointFolder.empty())
    throw std::invalid_argument("FemCouplingEngine: checkpointEvery is set but checkpointFolder is empty.");
  if (!checkpointPending.empty())
    LOG_WARN(
        "Restart checkpoint " << checkpointPending << " was ordered but never completed (completeCheckpoint() "
                              << "from the last engine of its step); it stays incomplete and is not resumed from.");
  const auto start = Clock::now();
  const std::string name = railcosim::checkpointName(window);
  railcosim::prepareCheckpoint(checkpointFolder, name);
  const double waitBefore = participant->statistics().waitSeconds;
  femFiles = coupling->orderRestart(name, scene->time - timeAtConnect);
  waitTime += participant->statistics().waitSeconds - waitBefore;
  checkpointPending = name;
  ++checkpointsWritten;
  checkpointWriteTime += secondsSince(start);
}

std::string FemCouplingEngine::completeCheckpoint(const std::vector<std::string>& files,
                                                  const boost::python::object& pythonState) {
  if (checkpointPending.empty())
    throw std::runtime_error("FemCouplingEngine.completeCheckpoint: no restart checkpoint was ordered at this step.");
  const auto start = Clock::now();
  try {
    std::ostringstream own, sceneState;
    writeOwnState(own);
    SceneCheckpoint::writeBetweenSteps(*scene, sceneState);
    railcosim::CheckpointManifest manifest;
    manifest.name = checkpointPending;
    manifest.window = static_cast<std::uint64_t>(window);
    manifest.time = scene->time - timeAtConnect;
    manifest.scheme = railcosim::toString(coupling->scheme());
    manifest.run = checkpointRun;
    railcosim::completeDemCheckpoint(
        checkpointFolder, manifest,
        {stateFile,
         {{"dem coupling engine", own.str()},
          {"dem scene", sceneState.str()},
          {"dem python", bytesFromPython(pythonState, "FemCouplingEngine: completeCheckpoint's pythonState")}},
         files,
         "FemCouplingEngine.completeCheckpoint"},
        femFiles);
  } catch (const railcosim::Error& e) {
    throw std::runtime_error("FemCouplingEngine.completeCheckpoint (" + checkpointPending + "): " + e.what());
  }
  lastCheckpoint = (std::filesystem::path(checkpointFolder) / checkpointPending).string();
  checkpointPending.clear();
  femFiles.clear();
  checkpointWriteTime += secondsSince(start);
  return lastCheckpoint;
}

boost::python::object FemCouplingEngine::restoreCheckpoint() {
  if (resumeFrom.empty() || !connected)
    throw std::runtime_error(
        "FemCouplingEngine.restoreCheckpoint: only in a resumed run (resumeFrom), after connect().");
  try {
    railcosim::restoreCheckpointFiles(resumeFrom, resumedManifest, "dem", std::filesystem::current_path().string());
    std::istringstream saved(resumedScene);
    SceneCheckpoint::readBetweenSteps(*scene, saved, resumeFrom + "/" + stateFile);
  } catch (const railcosim::Error& e) {
    throw std::runtime_error(std::string("FemCouplingEngine.restoreCheckpoint: ") + e.what());
  }
  const std::string python = resumedPython;
  resumedScene.clear();
  resumedPython.clear();
  return pythonBytes(python);
}

// This engine's state between two steps: the window, the sums and counters of its attributes, the surface of the
// next step, the implicit scheme's window-start snapshot and the coupling scheme's own state.
void FemCouplingEngine::writeOwnState(std::ostream& out) const {
  railcosim::StateWriter state(out);
  state.section("fem coupling engine");
  state.real(femDt);
  state.i64(subcycles);
  state.real(timeAtConnect);
  std::vector<double> connectivity;
  for (const Vector3i& t : triangles)
    connectivity.insert(connectivity.end(), {double(t[0]), double(t[1]), double(t[2])});
  state.reals(connectivity);
  state.i64(window);
  state.i64(exchanges);
  state.i64(stepsInWindow);
  state.flag(surfaceTouched);
  state.reals(forceSum);
  state.reals(stepForces);
  state.real(interfaceWorkDem);
  state.real(interfaceWorkFem);
  state.reals(flat(nodalForces));
  state.reals(flat({totalForce}));
  state.i64(surfaceContacts);
  state.i64(implicitPasses);
  state.i64(lastWindowPasses);
  state.i64(maxWindowPasses);
  state.i64(unconvergedWindows);
  state.real(lastResidual);
  state.i64(checkpointsWritten);
  state.reals({bridgeTime, mappingTime, waitTime, checkpointTime, checkpointWriteTime});
  state.flag(!sceneCheckpoint.empty());
  if (!sceneCheckpoint.empty()) sceneCheckpoint.write(out);
  state.real(savedWorkDem);
  state.real(savedWorkFem);
  FemSurfaceContactEngine::writeHistory(savedHistory, state);
  FemSurfaceContactEngine::writeHistory(meshContact ? meshContact->history() : nullptr, state);
  std::ostringstream schemeState;
  coupling->writeState(schemeState);
  state.bytes(schemeState.str());
  // The window's own state: the integrators' slots kept at its start (a repeated implicit pass restores them) and,
  // with contactModel 'polyhedra', the surface's straight-line motion and the forces of the window stepped last.
  state.section("window state");
  state.u64(savedIntegrators.size());
  for (const auto& [integrator, slots] : savedIntegrators) {
    state.i64(engineIndex(integrator.get()));
    QuaternionIntegrator::writeSlots(state, slots);
  }
  state.reals(windowStartPositions);
  state.reals(windowVelocities);
  state.reals(polyhedraForces);
  state.real(polyhedraTime);
}

long FemCouplingEngine::engineIndex(const Engine* engine) const {
  for (size_t k = 0; k < scene->engines.size(); ++k)
    if (scene->engines[k].get() == engine) return static_cast<long>(k);
  throw std::logic_error("FemCouplingEngine: an integrator of the saved window is no longer in O.engines");
}

void FemCouplingEngine::readOwnState(std::istream& in, const railcosim::InterfaceSetup& setup) {
  const std::string source = resumeFrom + "/" + stateFile;
  railcosim::StateReader state(in, source);
  auto refuse = [&](const std::string& what) { railcosim::refuseResume(resumeFrom, what); };
  state.section("fem coupling engine");
  railcosim::SavedCoupling saved;
  saved.femDt = state.real();
  saved.subcycles = state.i64();
  timeAtConnect = state.real();
  saved.triangles = state.reals();
  saved.window = state.i64();
  std::vector<double> connectivity;
  for (const Vector3i& t : triangles)
    connectivity.insert(connectivity.end(), {double(t[0]), double(t[1]), double(t[2])});
  railcosim::checkSavedCoupling(resumeFrom, saved, femDt, subcycles, connectivity, resumedManifest.window);
  window = saved.window;
  exchanges = state.i64();
  stepsInWindow = state.i64();
  surfaceTouched = state.flag();
  forceSum = state.reals();
  stepForces = state.reals();
  interfaceWorkDem = state.real();
  interfaceWorkFem = state.real();
  nodalForces = vectors(state.reals());
  const std::vector<Vector3r> total = vectors(state.reals());
  totalForce = total.empty() ? Vector3r::Zero() : total[0];
  surfaceContacts = state.i64();
  implicitPasses = state.i64();
  lastWindowPasses = state.i64();
  maxWindowPasses = state.i64();
  unconvergedWindows = state.i64();
  lastResidual = state.real();
  checkpointsWritten = state.i64();
  const std::vector<double> timings = state.reals();
  if (timings.size() != 5) state.fail("5 timings expected");
  bridgeTime = timings[0];
  mappingTime = timings[1];
  waitTime += timings[2];
  checkpointTime = timings[3];
  checkpointWriteTime = timings[4];
  if (state.flag()) sceneCheckpoint.read(in, source);
  savedWorkDem = state.real();
  savedWorkFem = state.real();
  savedHistory = FemSurfaceContactEngine::readHistory(state);
  const auto history = FemSurfaceContactEngine::readHistory(state);
  if (meshContact) meshContact->restoreHistory(history);
  std::istringstream schemeState(state.bytes());
  coupling = railcosim::DemCouplingScheme::resume(schemeSettings(), *participant, setup, schemeState);
  state.section("window state");
  savedIntegrators.clear();
  for (std::uint64_t k = 0, count = state.u64(); k < count; ++k) {
    const long index = state.i64();
    std::vector<QuaternionIntegrator::BodySlot> slots = QuaternionIntegrator::readSlots(state);
    auto integrator = index >= 0 && index < static_cast<long>(scene->engines.size())
                          ? boost::dynamic_pointer_cast<QuaternionIntegrator>(scene->engines[index])
                          : shared_ptr<QuaternionIntegrator>();
    if (!integrator) refuse("O.engines[" + std::to_string(index) + "] is not the saved QuaternionIntegrator");
    savedIntegrators.emplace_back(integrator, std::move(slots));
  }
  windowStartPositions = state.reals();
  windowVelocities = state.reals();
  polyhedraForces = state.reals();
  polyhedraTime = state.real();
  if (windowStartPositions.size() != windowVelocities.size() || windowStartPositions.size() % 3 != 0 ||
      (polyhedra && windowStartPositions.size() != 3 * setup.mesh.nodeCount()))
    refuse("the polyhedra window state does not fit the interface's " + std::to_string(setup.mesh.nodeCount()) +
           " nodes");
  nodePositions.resize(windowStartPositions.size() / 3);
  nodeVelocities.resize(windowStartPositions.size() / 3);
}

void FemCouplingEngine::action() {
  try {
    // Connecting here means the surface missed this step's contact evaluation; the window starts now.
    if (!connected) connect();
    if (polyhedra) { // the polyhedra system finds the surface contacts itself, one window per batch
      polyhedraAction();
      return;
    }
    // Forces of this step's contact evaluation belong to the configuration at t_i + stepsInWindow*dt.
    const bool everyStep = averageForces || auditEnergy || coupling->iterates();
    if (meshContact) {
      meshContact->action();
      stepForces = meshContact->nodalForces();
      surfaceContacts = meshContact->surfaceContacts;
    } else if (stepsInWindow > 0 && everyStep) {
      const auto mapping = Clock::now();
      facets.collectForces(*scene, surfacePositions, stepForces);
      mappingTime += secondsSince(mapping);
    }
    if (stepsInWindow > 0 && everyStep) accumulateStep();
    if (stepsInWindow == subcycles) {
      const auto start = Clock::now();
      const double waitBefore = waitTime;
      const bool windowStands = exchange(windowForces());
      bridgeTime += secondsSince(start) - (waitTime - waitBefore);
      stepsInWindow = 0;
      // Back to the window's start (states, contacts, forces, clock) for another pass.
      if (!windowStands) restoreIterationCheckpoint();
    }
    // connect() may have run from Python before the first step: the first window then starts here.
    if (coupling->requiresWritingCheckpoint()) {
      saveCheckpoint();
      coupling->markCheckpointWritten();
    }
    ++stepsInWindow;
    placeSurface(stepsInWindow * scene->dt, true);
  } catch (const railcosim::Error& e) {
    std::ostringstream context;
    context << "FemCouplingEngine at iteration " << scene->iter << " (t=" << scene->time << " s, window " << window
            << "): " << e.what();
    throw std::runtime_error(context.str());
  }
}

// contactModel 'polyhedra'. The window's DEM steps run in one batch in its last iteration, so that the stones' bodies
// match the scene's time after it; the exchange follows at the next iteration, where the other models exchange too.
void FemCouplingEngine::polyhedraAction() {
  if (stepsInWindow == subcycles) {
    const auto start = Clock::now();
    const double waitBefore = waitTime;
    const bool windowStands = exchange(polyhedraForces);
    bridgeTime += secondsSince(start) - (waitTime - waitBefore);
    stepsInWindow = 0;
    if (!windowStands) restoreIterationCheckpoint(); // the scene, the integrators and the polyhedra system
    startPolyhedraWindow();
  }
  if (coupling->requiresWritingCheckpoint()) {
    saveCheckpoint();
    coupling->markCheckpointWritten();
  }
  ++stepsInWindow;
  placeSurface(stepsInWindow * scene->dt, true);
  if (stepsInWindow == subcycles) advancePolyhedraWindow();
}

// The straight line the surface follows in the window: from the scheme's position at its start to that at its end.
void FemCouplingEngine::startPolyhedraWindow() {
  railcosim::polyhedra::beginSurfaceWindow(*coupling, femDt, windowStartPositions, windowVelocities);
  nodePositions.resize(windowStartPositions.size() / 3);
  nodeVelocities.resize(windowStartPositions.size() / 3);
  placeSurface(0, false);
}

void FemCouplingEngine::advancePolyhedraWindow() {
  std::vector<double> triangleForces, contactPoints;
  const auto stepping = Clock::now();
  polyhedra->advanceWindow(windowStartPositions, windowVelocities, subcycles, triangleForces, contactPoints);
  polyhedraTime += secondsSince(stepping);
  const auto mapping = Clock::now();
  const long loaded = railcosim::polyhedra::lumpWindowForces(windowStartPositions, windowVelocities, femDt,
                                                             interfaceTriangles, triangleForces, contactPoints,
                                                             polyhedraForces);
  surfaceContacts = loaded;
  surfaceTouched = loaded > 0;
  if (auditEnergy) interfaceWorkDem += railcosim::polyhedra::windowWork(polyhedraForces, windowVelocities, femDt);
  mappingTime += secondsSince(mapping);
}

void FemCouplingEngine::finalize() {
  if (participant) participant->finalize();
}

} // namespace yade
