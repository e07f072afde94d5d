// FemCouplingEngine: moves the FE surface inside each window, gathers its forces, lets the coupling scheme exchange
// them.
#include "FemCouplingEngine.hpp"

#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"

#include <core/Scene.hpp>

#include <chrono>
#include <cmath>
#include <sstream>

namespace yade {

YADE_PLUGIN((FemCouplingEngine));
CREATE_LOGGER(FemCouplingEngine);

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

Vector3r node(const std::vector<double>& xyz, int i) { return Vector3r(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }
} // namespace

bool FemCouplingEngine::meshContacts() const {
  if (contactModel == "meshContacts") return true;
  if (contactModel == "hierarchy") {
    static bool warned = false;
    if (!warned)
      LOG_WARN("FemCouplingEngine: contactModel='hierarchy' is deprecated; it is now called 'meshContacts'.");
    warned = true;
    return true;
  }
  if (contactModel == "facets") return false;
  throw std::invalid_argument("FemCouplingEngine: contactModel='" + contactModel +
                              "' is not known; use 'facets' or 'meshContacts'.");
}

FemCouplingEngine::~FemCouplingEngine() {
  try {
    finalize();
  } catch (...) {
    // Destructors must not throw; the peer notices the closed connection anyway.
  }
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
  settings.implicit.tolerance = implicitTolerance;
  settings.implicit.absoluteTolerance = implicitAbsoluteTolerance;
  settings.implicit.maxIterations = implicitMaxIterations;
  settings.implicit.relaxation = implicitRelaxation;
  settings.implicit.aitken = aitken;
  try {
    settings.scheme = railcosim::parseCouplingScheme(scheme);
    settings.validate();
  } catch (const railcosim::Error& e) {
    throw std::invalid_argument(std::string("FemCouplingEngine: ") + e.what() +
                                " (attributes scheme, implicitTolerance, implicitAbsoluteTolerance, "
                                "implicitMaxIterations, implicitRelaxation)");
  }
  const bool withMeshContacts = meshContacts();
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
  if (withMeshContacts)
    meshContact->attach(connectivity, setup.mesh.coordinates);
  else
    facetIds = facets.insert(*scene, connectivity, material, mask);

  // Predictive: this receives the FEM's first step (run before any DEM force exists).
  const double waitBefore = participant->statistics().waitSeconds;
  coupling = railcosim::DemCouplingScheme::create(settings, *participant, setup);
  waitTime += participant->statistics().waitSeconds - waitBefore;
  forceSum.assign(3 * setup.mesh.nodeCount(), 0.0);
  nodalForces.assign(setup.mesh.nodeCount(), Vector3r::Zero());
  stepsInWindow = 0;
  window = 0;
  connected = true;
  placeSurface(0, false);
}

void FemCouplingEngine::placeSurface(Real tau, bool beforeIntegrator) {
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
  sceneCheckpoint.save(*scene);
  savedWorkDem = interfaceWorkDem;
  savedWorkFem = interfaceWorkFem;
  savedHistory = meshContact ? meshContact->history() : nullptr;
  checkpointTime = sceneCheckpoint.seconds();
}

void FemCouplingEngine::restoreCheckpoint() {
  try {
    sceneCheckpoint.restore(*scene);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("FemCouplingEngine (") + scheme + "): " + e.what() +
                             " The window cannot be repeated.");
  }
  interfaceWorkDem = savedWorkDem;
  interfaceWorkFem = savedWorkFem;
  if (meshContact) meshContact->restoreHistory(savedHistory);
  checkpointTime = sceneCheckpoint.seconds();
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

bool FemCouplingEngine::exchange() {
  std::vector<double> forces;
  if (averageForces) {
    forces = forceSum;
    for (double& f : forces) f /= stepsInWindow;
  } else if (auditEnergy || meshContact || coupling->iterates()) {
    forces = stepForces; // already gathered for this step
  } else {
    facets.collectForces(*scene, surfacePositions, forces);
  }
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
  return true;
}

void FemCouplingEngine::action() {
  try {
    // Connecting here means the surface missed this step's contact evaluation; the window starts now.
    if (!connected) connect();
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
      const bool windowStands = exchange();
      bridgeTime += secondsSince(start) - (waitTime - waitBefore);
      stepsInWindow = 0;
      // Back to the window's start (states, contacts, forces, clock) for another pass.
      if (!windowStands) restoreCheckpoint();
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

void FemCouplingEngine::finalize() {
  if (participant) participant->finalize();
}

} // namespace yade
