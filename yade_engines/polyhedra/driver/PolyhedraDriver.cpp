// C interface of the dilated-polyhedra DEM without YADE (PolyhedraDriver.h). What it does mirrors YADE's
// PolyhedraGpuEngine (batches, moving facets) and FemCouplingEngine with contactModel 'polyhedra' (one window per
// batch), through the pieces both share: BodyFrameStones (stones in their body frames), PolyhedraWindow (the
// surface's motion in a window and the lumping of its forces), the bridge's DemCouplingScheme (message order, window
// repetition). Given the same bed, walls, steps and FEM side, both give the same states, bit for bit, wherever the
// polyhedra system is itself repeatable (PolyhedraSystem.hpp: the CPU reference on one thread).
#include "PolyhedraDriver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/BoundedRollingFriction.hpp"
#include "polyhedra/PolyhedraBodyFrames.hpp"
#include "polyhedra/PolyhedraSystem.hpp"
#include "polyhedra/PolyhedraWindow.hpp"
#include "railcosim/Checkpoint.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"

namespace poly = railcosim::polyhedra;

namespace {
thread_local std::string lastError;
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

poly::Material material(const double* m) {
  poly::Material result;
  result.youngModulus = m[0];
  result.poissonRatio = m[1];
  result.restitution = m[2];
  result.friction = m[3];
  return result;
}

poly::Backend backendOf(const std::string& name) {
  if (name == "automatic") return poly::Backend::Automatic;
  if (name == "cpu") return poly::Backend::Cpu;
  if (name == "cuda") return poly::Backend::Cuda;
  throw std::invalid_argument("backend '" + name + "' is not known; use 'automatic', 'cpu' or 'cuda'");
}

template <class F>
auto guarded(const char* what, F&& f, decltype(f()) failure) -> decltype(f()) {
  try {
    lastError.clear();
    return f();
  } catch (const std::exception& e) {
    lastError = std::string(what) + ": " + e.what();
  } catch (...) {
    lastError = std::string(what) + ": unknown error";
  }
  return failure;
}
} // namespace

struct rcp_bed {
  poly::Parameters parameters;
  std::unique_ptr<poly::PolyhedraSystem> system;
  poly::BodyFrameStones frames;
  bool initialized = false, stepped = false;
  double time = 0.0;         // advanced step by step, as a YADE scene's clock
  double meanContacts = 0.0; // of the last batch
  // Since the bed was made (not part of a checkpoint): evaluations whose cores intersected, and rebuilds after which a
  // stone had moved more than half the skin (StepStatistics), for a script's checks.
  std::int64_t coreOverlapFallbacks = 0, dangerousRebuilds = 0;
  // Walls: each triangle's three corners as nodes of their own, then the coupled surface's nodes. givenFacetNodes: as
  // rcp_set_walls gave them (a resumed run's script builds its walls so again; facetNodes have moved since).
  std::vector<double> facetNodes, facetNodeVelocities, givenFacetNodes;
  std::vector<std::int32_t> materialOfTriangle;
  std::vector<poly::Material> wallMaterials;
  std::vector<double> wallRollingFriction; // η_r of wall material k (rcp_set_rolling_friction); missing: 0
  bool facetsMove = false;
  std::vector<poly::ContactRecord> contacts;
  // Coupling (rcp_connect).
  std::unique_ptr<railcosim::DemParticipant> participant;
  std::unique_ptr<railcosim::DemCouplingScheme> coupling;
  poly::Material surfaceMaterial;
  std::vector<std::int32_t> surfaceConnectivity;
  std::vector<double> surfaceCoordinates;
  int surfaceFirstTriangle = 0, surfaceTriangles = 0;
  double femDt = 0.0;
  int subcycles = 0;
  long window = 0;
  std::vector<double> windowStart, windowVelocity, nodalForces;
  std::array<double, 3> totalForce{}, surfaceForce{};
  double workDem = 0.0, workFem = 0.0, savedTime = 0.0, savedWorkDem = 0.0, savedWorkFem = 0.0;
  long loadedTriangles = 0;
  bool warnedUnconverged = false;
  double polyhedraTime = 0.0, mappingTime = 0.0, bridgeTime = 0.0, waitTime = 0.0, checkpointTime = 0.0;
  railcosim::SchemeSettings settings;
  // Restart checkpoints (rcp_set_restart), as FemCouplingEngine's: ordered at a window's exchange, completed by the
  // driving script with its own state (rcp_complete_checkpoint).
  std::string checkpointFolder, checkpointRun, resumeFrom, checkpointPending;
  double checkpointEvery = 0.0, restartTime = 0.0;
  long checkpointsWritten = 0;
  std::vector<railcosim::CheckpointFile> femFiles;
  railcosim::CheckpointManifest resumedManifest;
  std::string resumedScript;
  bool resumedFilesRestored = false;
  static constexpr const char* stateFile = "dem_state.bin";

  int facetTriangles() const { return static_cast<int>(materialOfTriangle.size()); }

  // The walls as the system takes them: the facets, then the coupled surface with the last material.
  void applyWalls() { applyWalls(bool(coupling)); }
  void applyWallsWithSurface() { applyWalls(true); }
  void applyWalls(bool withSurface) {
    if (stepped) throw std::logic_error("the walls cannot change after the first step");
    std::vector<double> coordinates = facetNodes;
    std::vector<std::int32_t> triangles(3 * facetTriangles()), materials = materialOfTriangle;
    for (std::size_t k = 0; k < triangles.size(); ++k) triangles[k] = static_cast<std::int32_t>(k);
    std::vector<poly::Material> list = wallMaterials;
    // One value more than the walls' materials is the coupled surface's (rcp_set_rolling_friction).
    if (wallRollingFriction.size() > list.size() + 1)
      throw std::invalid_argument("rcp_set_rolling_friction named " + std::to_string(wallRollingFriction.size()) +
                                  " wall materials, rcp_set_walls gave " + std::to_string(list.size()) +
                                  " (and one more may be the coupled surface's)");
    for (std::size_t k = 0; k < std::min(wallRollingFriction.size(), list.size()); ++k)
      list[k].rollingFriction = wallRollingFriction[k];
    surfaceFirstTriangle = facetTriangles();
    if (withSurface) {
      const auto firstNode = static_cast<std::int32_t>(coordinates.size() / 3);
      coordinates.insert(coordinates.end(), surfaceCoordinates.begin(), surfaceCoordinates.end());
      for (std::int32_t node : surfaceConnectivity) triangles.push_back(firstNode + node);
      materials.insert(materials.end(), surfaceTriangles, static_cast<std::int32_t>(list.size()));
      list.push_back(surfaceMaterial);
      if (wallRollingFriction.size() == list.size()) list.back().rollingFriction = wallRollingFriction.back();
    }
    if (list.size() > static_cast<std::size_t>(poly::maxWallMaterials))
      throw std::invalid_argument(std::to_string(list.size()) + " wall materials, at most " +
                                  std::to_string(poly::maxWallMaterials));
    if (!triangles.empty()) {
      system->setWalls(coordinates, triangles);
      system->setWallMaterials(list, materials);
    }
    initialized = true;
  }

  void initialize() {
    if (initialized) return;
    if (system->stoneCount() == 0) throw std::invalid_argument("no stones; add them with rcp_add_stone first");
    applyWalls();
  }

  void stepBatch(int steps, const std::vector<double>& nodes, const std::vector<double>& velocities, bool moving) {
    initialize();
    system->setTimeStep(parameters.timeStep);
    system->setGravity(parameters.gravity);
    system->setDamping(parameters.damping);
    if (moving) system->setSurfaceKinematics(nodes, velocities);
    system->step(steps);
    stepped = true;
    for (int k = 0; k < steps; ++k) time += parameters.timeStep;
    meanContacts = system->lastStatistics().meanActiveContacts;
    coreOverlapFallbacks += system->lastStatistics().coreOverlapFallbacks;
    dangerousRebuilds += system->lastStatistics().dangerousRebuilds;
  }

  // One pass over the current window (FemCouplingEngine::advancePolyhedraWindow and the exchange after it).
  railcosim::WindowResult windowPass() {
    std::vector<double> nodes = facetNodes, velocities = facetNodeVelocities;
    nodes.insert(nodes.end(), windowStart.begin(), windowStart.end());
    velocities.insert(velocities.end(), windowVelocity.begin(), windowVelocity.end());
    const auto stepping = Clock::now();
    stepBatch(subcycles, nodes, velocities, true);
    polyhedraTime += secondsSince(stepping);
    const auto mapping = Clock::now();
    const std::vector<double> forces = system->triangleForces(), points = system->triangleContactPoints();
    const std::vector<double> triangleForces(forces.begin() + 3 * surfaceFirstTriangle,
                                             forces.begin() + 3 * (surfaceFirstTriangle + surfaceTriangles));
    const std::vector<double> contactPoints(points.begin() + 3 * surfaceFirstTriangle,
                                            points.begin() + 3 * (surfaceFirstTriangle + surfaceTriangles));
    surfaceForce = {0.0, 0.0, 0.0};
    for (int t = 0; t < surfaceTriangles; ++t)
      for (int k = 0; k < 3; ++k) surfaceForce[k] += triangleForces[3 * t + k];
    loadedTriangles = poly::lumpWindowForces(windowStart, windowVelocity, femDt, surfaceConnectivity, triangleForces,
                                             contactPoints, nodalForces);
    workDem += poly::windowWork(nodalForces, windowVelocity, femDt);
    mappingTime += secondsSince(mapping);
    const auto exchange = Clock::now();
    totalForce = {0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < nodalForces.size() / 3; ++i)
      for (int k = 0; k < 3; ++k) totalForce[k] += nodalForces[3 * i + k];
    const double waitBefore = participant->statistics().waitSeconds;
    railcosim::WindowResult result = coupling->completeWindow(nodalForces, time, loadedTriangles > 0);
    const double waited = participant->statistics().waitSeconds - waitBefore;
    waitTime += waited;
    bridgeTime += secondsSince(exchange) - waited;
    return result;
  }

  // As FemCouplingEngine::orderRestartCheckpoint: the FEM side saves its part at once, at its window boundary.
  void orderRestartCheckpoint() {
    if (checkpointFolder.empty()) throw std::invalid_argument("a checkpoint interval is set but no checkpoint folder");
    if (!checkpointPending.empty())
      railcosim::log(railcosim::LogLevel::Warning, "polyhedra driver: restart checkpoint " + checkpointPending +
                                                       " was ordered but never completed; it is not resumed from");
    const auto start = Clock::now();
    const std::string name = railcosim::checkpointName(static_cast<std::uint64_t>(window));
    railcosim::prepareCheckpoint(checkpointFolder, name);
    const double waitBefore = participant->statistics().waitSeconds;
    femFiles = coupling->orderRestart(name, time); // the clock starts at the handshake (rcp_connect: no step before)
    waitTime += participant->statistics().waitSeconds - waitBefore;
    checkpointPending = name;
    ++checkpointsWritten;
    restartTime += secondsSince(start);
  }

  // The driver's state between two windows: the system (with an implicit window's snapshot), the clock, sums,
  // counters and timings, the surface's motion in the next window and the coupling scheme's own state.
  void writeOwnState(std::ostream& out) {
    railcosim::StateWriter state(out);
    state.section("polyhedra driver");
    state.real(femDt);
    state.i64(subcycles);
    state.reals(std::vector<double>(surfaceConnectivity.begin(), surfaceConnectivity.end()));
    state.i64(window);
    state.reals({time, meanContacts, workDem, workFem, savedTime, savedWorkDem, savedWorkFem});
    state.reals(givenFacetNodes);
    state.reals(facetNodes);
    state.reals(facetNodeVelocities);
    state.flag(facetsMove);
    state.reals(windowStart);
    state.reals(windowVelocity);
    state.reals(nodalForces);
    state.reals({totalForce[0], totalForce[1], totalForce[2], surfaceForce[0], surfaceForce[1], surfaceForce[2]});
    state.i64(loadedTriangles);
    state.flag(warnedUnconverged);
    state.i64(checkpointsWritten);
    state.reals({polyhedraTime, mappingTime, bridgeTime, waitTime, checkpointTime, restartTime});
    system->writeRestartState(state);
    std::ostringstream scheme;
    coupling->writeState(scheme);
    state.bytes(scheme.str());
  }

  void readOwnState(std::istream& in, const railcosim::InterfaceSetup& setup) {
    const std::string source = resumeFrom + "/" + stateFile;
    railcosim::StateReader state(in, source);
    auto refuse = [&](const std::string& what) { railcosim::refuseResume(resumeFrom, what); };
    state.section("polyhedra driver");
    railcosim::SavedCoupling saved;
    saved.femDt = state.real();
    saved.subcycles = state.i64();
    saved.triangles = state.reals();
    saved.window = state.i64();
    railcosim::checkSavedCoupling(resumeFrom, saved, femDt, subcycles,
                                  std::vector<double>(surfaceConnectivity.begin(), surfaceConnectivity.end()),
                                  resumedManifest.window);
    window = saved.window;
    const std::vector<double> clock = state.reals();
    if (clock.size() != 7) state.fail("7 clock and work figures expected");
    time = clock[0], meanContacts = clock[1], workDem = clock[2], workFem = clock[3];
    savedTime = clock[4], savedWorkDem = clock[5], savedWorkFem = clock[6];
    const std::vector<double> given = state.reals();
    if (given != givenFacetNodes) refuse("the walls differ from the saved ones");
    std::vector<double> nodes = state.reals(), velocities = state.reals();
    if (nodes.size() != facetNodes.size() || velocities.size() != facetNodes.size())
      state.fail("wall node positions and velocities of the given walls expected");
    facetNodes = std::move(nodes);
    facetNodeVelocities = std::move(velocities);
    facetsMove = state.flag();
    windowStart = state.reals();
    windowVelocity = state.reals();
    nodalForces = state.reals();
    const std::vector<double> forces = state.reals();
    if (forces.size() != 6) state.fail("6 force components expected");
    totalForce = {forces[0], forces[1], forces[2]};
    surfaceForce = {forces[3], forces[4], forces[5]};
    loadedTriangles = state.i64();
    warnedUnconverged = state.flag();
    checkpointsWritten = state.i64();
    const std::vector<double> timings = state.reals();
    if (timings.size() != 6) state.fail("6 timings expected");
    polyhedraTime = timings[0], mappingTime = timings[1], bridgeTime = timings[2];
    waitTime += timings[3];
    checkpointTime = timings[4], restartTime = timings[5];
    system->readRestartState(state);
    stepped = true;
    std::istringstream scheme(state.bytes());
    coupling = railcosim::DemCouplingScheme::resume(settings, *participant, setup, scheme);
  }

  // As FemCouplingEngine::completeCheckpoint, with the script's state in place of the YADE scene's and Python's.
  std::string completeCheckpoint(const std::vector<std::string>& files, const std::string& script) {
    if (checkpointPending.empty()) throw std::logic_error("no restart checkpoint was ordered at the last window");
    const auto start = Clock::now();
    std::ostringstream own;
    writeOwnState(own);
    railcosim::CheckpointManifest manifest;
    manifest.name = checkpointPending;
    manifest.window = static_cast<std::uint64_t>(window);
    manifest.time = time;
    manifest.scheme = railcosim::toString(coupling->scheme());
    manifest.run = checkpointRun;
    const std::string folder = railcosim::completeDemCheckpoint(
        checkpointFolder, manifest,
        {stateFile, {{"polyhedra driver", own.str()}, {"driver script", script}}, files, "rcp_complete_checkpoint"},
        femFiles);
    checkpointPending.clear();
    femFiles.clear();
    restartTime += secondsSince(start);
    return folder;
  }

  // Moving wall triangles (plates, turning flaps) have covered `duration` at their nodes' constant velocities: the
  // system's nodes went the same way in the batch (stepBatch), and the next batch starts where they ended.
  void advanceFacets(double duration) {
    for (std::size_t k = 0; k < facetNodes.size(); ++k) facetNodes[k] += facetNodeVelocities[k] * duration;
  }

  // Sets the velocities of the corners of wall triangles `triangles` (9 values per triangle, or 3 for all corners).
  void setFacetVelocities(const int32_t* triangles, int count, const double* velocities, bool perCorner) {
    initialize();
    if (count > 0 && (!triangles || !velocities)) throw std::invalid_argument("null triangles or velocities");
    // Everything checked before anything is set: a refused call leaves the walls' motion as it was.
    for (int k = 0; k < count; ++k) {
      const int t = triangles[k];
      if (t < 0 || t >= facetTriangles())
        throw std::invalid_argument("wall triangle " + std::to_string(t) + " out of range");
      for (int c = 0; c < (perCorner ? 9 : 3); ++c)
        if (!std::isfinite(velocities[(perCorner ? 9 * k : 0) + c]))
          throw std::invalid_argument("a wall velocity is not finite");
    }
    for (int k = 0; k < count; ++k)
      for (int corner = 0; corner < 3; ++corner)
        for (int c = 0; c < 3; ++c)
          facetNodeVelocities[9 * static_cast<std::size_t>(triangles[k]) + 3 * corner + c] =
              perCorner ? velocities[9 * k + 3 * corner + c] : velocities[c];
    facetsMove = true;
  }

  void runWindow() {
    if (!coupling) throw std::logic_error("not coupled: rcp_connect first");
    while (true) {
      if (coupling->requiresWritingCheckpoint()) {
        const auto start = Clock::now();
        system->saveSnapshot();
        savedTime = time;
        savedWorkDem = workDem;
        savedWorkFem = workFem;
        coupling->markCheckpointWritten();
        checkpointTime += secondsSince(start);
      }
      const railcosim::WindowResult result = windowPass();
      if (result.repeat) {
        const auto start = Clock::now();
        system->restoreSnapshot();
        time = savedTime;
        workDem = savedWorkDem;
        workFem = savedWorkFem;
        checkpointTime += secondsSince(start);
        poly::beginSurfaceWindow(*coupling, femDt, windowStart, windowVelocity);
        continue;
      }
      const railcosim::WindowIterationStatistics& iterations = coupling->iterationStatistics();
      if (!result.converged && !warnedUnconverged) {
        std::ostringstream message;
        message << "polyhedra driver: window " << window << " did not converge (residual " << iterations.lastResidual
                << " m, limit " << iterations.lastLimit << " m); its last pass is accepted (reported once)";
        railcosim::log(railcosim::LogLevel::Warning, message.str());
        warnedUnconverged = true;
      }
      workFem += result.femWork;
      advanceFacets(subcycles * parameters.timeStep);
      ++window;
      poly::beginSurfaceWindow(*coupling, femDt, windowStart, windowVelocity);
      if (checkpointEvery > 0 && window % std::max(1L, std::lround(checkpointEvery / femDt)) == 0)
        orderRestartCheckpoint();
      return;
    }
  }
};

extern "C" {

const char* rcp_last_error(void) { return lastError.c_str(); }

rcp_bed* rcp_create(double timeStep, const double* gravity, const double* stoneMaterial, int maxNeighbours,
                    int maxWallNeighbours, int rebuildInterval, double neighbourSkin, int adaptiveRebuild,
                    double largeBodyRatio, const char* backend) {
  return guarded(
      "rcp_create",
      [&]() -> rcp_bed* {
        auto bed = std::make_unique<rcp_bed>();
        poly::Parameters& p = bed->parameters;
        p.timeStep = timeStep;
        p.gravity = {gravity[0], gravity[1], gravity[2]};
        p.stone = material(stoneMaterial);
        p.wall = p.stone;
        p.maxNeighbours = maxNeighbours;
        p.maxWallNeighbours = maxWallNeighbours;
        p.rebuildInterval = rebuildInterval;
        p.neighbourSkin = neighbourSkin;
        p.adaptiveRebuild = adaptiveRebuild != 0;
        p.largeBodyRatio = largeBodyRatio;
        p.backend = backendOf(backend ? backend : "automatic");
        bed->system = std::make_unique<poly::PolyhedraSystem>(p);
        return bed.release();
      },
      nullptr);
}

void rcp_destroy(rcp_bed* bed) { delete bed; }

int rcp_add_stone(rcp_bed* bed, const double* vertices, int vertexCount, double dilation, double density,
                  const double* position, const double* orientation, const double* velocity,
                  const double* angularVelocity) {
  return guarded(
      "rcp_add_stone",
      [&] {
        if (bed->initialized) throw std::logic_error("stones can only be added before the bed is initialized");
        return bed->frames.add(*bed->system, std::vector<double>(vertices, vertices + 3 * vertexCount), dilation, density,
                               {position[0], position[1], position[2]},
                               {orientation[0], orientation[1], orientation[2], orientation[3]},
                               {velocity[0], velocity[1], velocity[2]},
                               {angularVelocity[0], angularVelocity[1], angularVelocity[2]});
      },
      -1);
}

int rcp_set_walls(rcp_bed* bed, const double* corners, int triangleCount, const int32_t* materialOfTriangle,
                  const double* materials, int materialCount) {
  return guarded(
      "rcp_set_walls",
      [&] {
        if (bed->initialized) throw std::logic_error("walls can only be set before the bed is initialized");
        bed->facetNodes.assign(corners, corners + 9 * triangleCount);
        bed->givenFacetNodes = bed->facetNodes;
        bed->facetNodeVelocities.assign(bed->facetNodes.size(), 0.0);
        bed->materialOfTriangle.assign(materialOfTriangle, materialOfTriangle + triangleCount);
        bed->wallMaterials.clear();
        for (int k = 0; k < materialCount; ++k) bed->wallMaterials.push_back(material(materials + 4 * k));
        for (int32_t m : bed->materialOfTriangle)
          if (m < 0 || m >= materialCount) throw std::invalid_argument("a triangle names a material out of range");
        return 0;
      },
      -1);
}

int rcp_set_rolling_friction(rcp_bed* bed, double stones, const double* walls, int wallCount) {
  return guarded(
      "rcp_set_rolling_friction",
      [&] {
        // The system is rebuilt below: nothing may have reached it yet (a failed rcp_add_stone may have added a shape).
        if (bed->system->stoneCount() > 0 || bed->frames.templates() > 0 || bed->initialized)
          throw std::logic_error("rolling friction must be set before the first stone is added");
        if (wallCount < 0) throw std::invalid_argument("wall_count must be >= 0, got " + std::to_string(wallCount));
        if (wallCount > 0 && !walls) throw std::invalid_argument("wall_count is " + std::to_string(wallCount) +
                                                                 " but no wall values were given");
        std::vector<double> wall(walls, walls + wallCount);
        for (double eta : wall) // the contact law's own check (it would refuse them at the walls' set-up otherwise)
          railcosim::kernels::validate(railcosim::kernels::BoundedRollingFrictionParams{eta}, "a wall's rolling friction");
        // The stone material is the system's construction parameter: a new, still empty system takes it (and
        // validates it).
        poly::Parameters p = bed->parameters;
        p.stone.rollingFriction = stones;
        p.wall.rollingFriction = stones;
        bed->system = std::make_unique<poly::PolyhedraSystem>(p);
        bed->parameters = p;
        bed->wallRollingFriction = wall;
        return 0;
      },
      -1);
}

int rcp_initialize(rcp_bed* bed) {
  return guarded("rcp_initialize", [&] { bed->initialize(); return 0; }, -1);
}

double rcp_critical_time_step(rcp_bed* bed, double normalForce, double impactVelocity) {
  return guarded("rcp_critical_time_step", [&] {
    bed->initialize();
    return bed->system->criticalTimeStep(normalForce, impactVelocity);
  }, -1.0);
}

int rcp_set_time_step(rcp_bed* bed, double timeStep) {
  return guarded("rcp_set_time_step", [&] {
    if (!(timeStep > 0)) throw std::invalid_argument("the time step must be positive");
    bed->parameters.timeStep = timeStep;
    return 0;
  }, -1);
}

double rcp_time_step(rcp_bed* bed) { return bed->parameters.timeStep; }

int rcp_set_damping(rcp_bed* bed, double damping) {
  return guarded(
      "rcp_set_damping",
      [&] {
        if (!(damping >= 0.0 && damping < 1.0))
          throw std::invalid_argument("the damping share must be in [0, 1), got " + std::to_string(damping));
        bed->parameters.damping = damping;
        return 0;
      },
      -1);
}

int rcp_set_wall_velocity(rcp_bed* bed, const int32_t* triangles, int count, const double* velocity) {
  return guarded("rcp_set_wall_velocity", [&] {
    bed->setFacetVelocities(triangles, count, velocity, false);
    return 0;
  }, -1);
}

int rcp_set_wall_node_velocities(rcp_bed* bed, const int32_t* triangles, int count, const double* velocities) {
  return guarded("rcp_set_wall_node_velocities", [&] {
    bed->setFacetVelocities(triangles, count, velocities, true);
    return 0;
  }, -1);
}

int rcp_step(rcp_bed* bed, int steps) {
  return guarded("rcp_step", [&] {
    if (bed->coupling) throw std::logic_error("a coupled bed advances by rcp_window");
    bed->stepBatch(steps, bed->facetNodes, bed->facetNodeVelocities, bed->facetsMove);
    bed->advanceFacets(steps * bed->parameters.timeStep);
    return 0;
  }, -1);
}

int rcp_wall_force(rcp_bed* bed, const int32_t* triangles, int count, double* force) {
  return guarded("rcp_wall_force", [&] {
    const std::vector<double> forces = bed->system->triangleForces();
    double total[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < count; ++k)
      for (int c = 0; c < 3; ++c) total[c] += forces.at(3 * static_cast<std::size_t>(triangles[k]) + c);
    std::copy(total, total + 3, force);
    return 0;
  }, -1);
}

double rcp_time(rcp_bed* bed) { return bed->time; }
int rcp_stone_count(rcp_bed* bed) { return static_cast<int>(bed->system->stoneCount()); }
int rcp_templates(rcp_bed* bed) { return bed->frames.templates(); }
double rcp_mean_contacts(rcp_bed* bed) { return bed->meanContacts; }

int rcp_step_counters(rcp_bed* bed, int64_t* counters) {
  return guarded("rcp_step_counters", [&] {
    counters[0] = bed->coreOverlapFallbacks;
    counters[1] = bed->dangerousRebuilds;
    return 0;
  }, -1);
}

int rcp_backend(rcp_bed* bed, char* reason, int size) {
  return guarded("rcp_backend", [&] {
    if (reason && size > 0) {
      std::strncpy(reason, bed->system->backendReason().c_str(), static_cast<std::size_t>(size) - 1);
      reason[size - 1] = '\0';
    }
    return bed->system->activeBackend() == poly::Backend::Cuda ? 1 : 0;
  }, -1);
}

int rcp_states(rcp_bed* bed, const int32_t* indices, int count, double* positions, double* orientations,
               double* velocities, double* angularVelocities, double* masses) {
  return guarded("rcp_states", [&] {
    if (indices && count < 0) throw std::invalid_argument("count " + std::to_string(count) + " must be >= 0");
    std::vector<double> p, q, v, w;
    if (indices) {
      bed->system->stoneStates({indices, indices + count}, p, q, v, w); // k-th entry: stone indices[k]; checks them
    } else {
      p = bed->system->positions(), q = bed->system->orientations();
      v = bed->system->velocities(), w = bed->system->angularVelocities();
    }
    std::array<double, 3> position, velocity, angularVelocity;
    std::array<double, 4> ori;
    const std::size_t n = indices ? static_cast<std::size_t>(count) : bed->frames.size();
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = indices ? static_cast<std::size_t>(indices[k]) : k;
      bed->frames.bodyState(i, k, p, q, v, w, position, ori, velocity, angularVelocity);
      if (positions) std::copy(position.begin(), position.end(), positions + 3 * k);
      if (orientations) std::copy(ori.begin(), ori.end(), orientations + 4 * k);
      if (velocities) std::copy(velocity.begin(), velocity.end(), velocities + 3 * k);
      if (angularVelocities) std::copy(angularVelocity.begin(), angularVelocity.end(), angularVelocities + 3 * k);
      if (masses) masses[k] = bed->frames.mass(i);
    }
    return static_cast<int>(n);
  }, -1);
}

int rcp_contact_count(rcp_bed* bed) {
  return guarded("rcp_contact_count", [&] {
    bed->contacts = bed->system->contacts();
    return static_cast<int>(bed->contacts.size());
  }, -1);
}

int rcp_contact_count_of(rcp_bed* bed, const int32_t* indices, int count) {
  return guarded("rcp_contact_count_of", [&] {
    if (!indices || count < 0) throw std::invalid_argument("give the stones' indices and their count");
    bed->contacts = bed->system->contacts(std::vector<std::int32_t>(indices, indices + count));
    return static_cast<int>(bed->contacts.size());
  }, -1);
}

int rcp_contacts(rcp_bed* bed, int32_t* first, int32_t* second, int32_t* wall, double* point, double* normal,
                 double* force, double* overlap) {
  return guarded("rcp_contacts", [&] {
    for (std::size_t k = 0; k < bed->contacts.size(); ++k) {
      const poly::ContactRecord& c = bed->contacts[k];
      first[k] = c.first;
      second[k] = c.second;
      wall[k] = c.wall ? 1 : 0;
      overlap[k] = c.overlap;
      for (int j = 0; j < 3; ++j) {
        point[3 * k + j] = c.point[j];
        normal[3 * k + j] = c.normal[j];
        force[3 * k + j] = c.force[j];
      }
    }
    return static_cast<int>(bed->contacts.size());
  }, -1);
}

int rcp_connect(rcp_bed* bed, const char* endpoint, const char* name, const char* scheme, double timeout,
                double heartbeat, int subcycles, double implicitTolerance, double implicitAbsoluteTolerance,
                int implicitMaxIterations, double implicitRelaxation, int aitken, const double* surfaceMaterial) {
  return guarded("rcp_connect", [&] {
    if (bed->coupling) throw std::logic_error("already connected");
    if (bed->stepped) throw std::logic_error("connect before the first step (the surface joins the walls)");
    bed->settings =
        railcosim::SchemeSettings::of(railcosim::parseCouplingScheme(scheme), implicitTolerance,
                                      implicitAbsoluteTolerance, implicitMaxIterations, implicitRelaxation, aitken != 0);
    railcosim::ParticipantConfig config;
    config.name = name;
    config.endpoint = endpoint;
    config.timeoutSeconds = timeout;
    config.heartbeatSeconds = heartbeat;
    config.couplingScheme = railcosim::toString(bed->settings.scheme);
    std::string resumedOwn;
    if (!bed->resumeFrom.empty()) {
      // Checked whole before anything is exchanged: a damaged or foreign checkpoint is refused in one line.
      bed->resumedManifest = railcosim::verifyCheckpoint(bed->resumeFrom);
      const std::string path = bed->resumeFrom + "/" + rcp_bed::stateFile;
      std::ifstream in(path, std::ios::binary);
      if (!in) throw railcosim::CheckpointError("checkpoint " + bed->resumeFrom + " has no " + rcp_bed::stateFile +
                                                " of the DEM side");
      railcosim::StateReader state(in, path);
      state.section("polyhedra driver");
      resumedOwn = state.bytes();
      state.section("driver script");
      bed->resumedScript = state.bytes();
      state.section("end");
      config.resumedFrom = bed->resumedManifest.name;
      config.resumedWindow = bed->resumedManifest.window;
    }
    bed->participant = std::make_unique<railcosim::DemParticipant>(config);
    const auto waitStart = Clock::now();
    const railcosim::InterfaceSetup setup = bed->participant->initialize();
    bed->waitTime += secondsSince(waitStart);
    bed->femDt = setup.femTimeStep;
    if (!(bed->femDt > 0)) throw std::runtime_error("the FEM participant announced a non-positive time step");
    // As FemCouplingEngine::connect: the fewest steps per window not longer than the current step.
    bed->subcycles = subcycles > 0 ? subcycles
                                   : std::max(1, static_cast<int>(std::ceil(bed->femDt / bed->parameters.timeStep - 1e-9)));
    bed->parameters.timeStep = bed->femDt / bed->subcycles;
    bed->surfaceConnectivity = setup.mesh.triangles;
    bed->surfaceCoordinates = setup.mesh.coordinates;
    bed->surfaceTriangles = static_cast<int>(setup.mesh.triangleCount());
    bed->surfaceMaterial = material(surfaceMaterial);
    if (!bed->resumeFrom.empty()) {
      bed->nodalForces.assign(3 * setup.mesh.nodeCount(), 0.0);
      // The walls with the surface, then the saved state over them; the scheme resumes from its saved state
      // (nothing is exchanged before the next window).
      bed->initialized = false;
      bed->applyWallsWithSurface();
      std::istringstream saved(resumedOwn);
      bed->readOwnState(saved, setup);
      return bed->subcycles;
    }
    const double waitBefore = bed->participant->statistics().waitSeconds;
    bed->coupling = railcosim::DemCouplingScheme::create(bed->settings, *bed->participant, setup);
    bed->waitTime += bed->participant->statistics().waitSeconds - waitBefore;
    bed->nodalForces.assign(3 * setup.mesh.nodeCount(), 0.0);
    bed->initialized = false; // the walls again, with the surface
    bed->applyWallsWithSurface();
    poly::beginSurfaceWindow(*bed->coupling, bed->femDt, bed->windowStart, bed->windowVelocity);
    return bed->subcycles;
  }, -1);
}

int rcp_window(rcp_bed* bed) {
  return guarded("rcp_window", [&] { bed->runWindow(); return 0; }, -1);
}

int rcp_coupling_figures(rcp_bed* bed, double* f) {
  return guarded("rcp_coupling_figures", [&] {
    if (!bed->coupling) throw std::logic_error("not coupled");
    const railcosim::WindowIterationStatistics& s = bed->coupling->iterationStatistics();
    const double values[RCP_FIGURES] = {bed->femDt, double(bed->subcycles), double(bed->window),
                                        double(bed->surfaceCoordinates.size() / 3), double(bed->surfaceTriangles),
                                        bed->totalForce[0], bed->totalForce[1], bed->totalForce[2],
                                        bed->surfaceForce[0], bed->surfaceForce[1], bed->surfaceForce[2],
                                        bed->workDem, bed->workFem, double(s.passes), double(s.lastWindowPasses),
                                        double(s.maxWindowPasses), double(s.unconvergedWindows), s.lastResidual,
                                        double(bed->loadedTriangles), bed->polyhedraTime, bed->mappingTime,
                                        bed->bridgeTime, bed->waitTime, bed->checkpointTime, bed->time,
                                        bed->restartTime, double(bed->checkpointsWritten)};
    std::copy(values, values + RCP_FIGURES, f);
    return 0;
  }, -1);
}

int rcp_surface_triangles(rcp_bed* bed, int32_t* triangles) {
  return guarded("rcp_surface_triangles", [&] {
    std::copy(bed->surfaceConnectivity.begin(), bed->surfaceConnectivity.end(), triangles);
    return bed->surfaceTriangles;
  }, -1);
}

int rcp_surface_state(rcp_bed* bed, double* positions, double* forces) {
  return guarded("rcp_surface_state", [&] {
    if (!bed->coupling) throw std::logic_error("not coupled: rcp_connect first");
    if (positions) std::copy(bed->windowStart.begin(), bed->windowStart.end(), positions);
    if (forces) std::copy(bed->nodalForces.begin(), bed->nodalForces.end(), forces);
    return static_cast<int>(bed->windowStart.size() / 3);
  }, -1);
}

int rcp_set_restart(rcp_bed* bed, const char* folder, const char* run, double every, const char* resumeFrom) {
  return guarded("rcp_set_restart", [&] {
    if (bed->coupling) throw std::logic_error("set restart checkpoints before rcp_connect");
    if (!(every >= 0)) throw std::invalid_argument("the checkpoint interval must be >= 0 s");
    bed->checkpointFolder = folder ? folder : "";
    bed->checkpointRun = run ? run : "";
    bed->checkpointEvery = every;
    bed->resumeFrom = resumeFrom ? resumeFrom : "";
    if (every > 0 && bed->checkpointFolder.empty())
      throw std::invalid_argument("a checkpoint interval needs a checkpoint folder");
    return 0;
  }, -1);
}

int rcp_checkpoint_pending(rcp_bed* bed) { return bed->checkpointPending.empty() ? 0 : 1; }

int rcp_complete_checkpoint(rcp_bed* bed, const char* files, const char* state, long size) {
  return guarded("rcp_complete_checkpoint", [&] {
    std::vector<std::string> paths;
    std::istringstream lines(files ? files : "");
    for (std::string line; std::getline(lines, line);)
      if (!line.empty()) paths.push_back(line);
    try {
      bed->completeCheckpoint(paths, std::string(state, state + size));
    } catch (const railcosim::Error& e) {
      throw std::runtime_error("(" + bed->checkpointPending + "): " + e.what());
    }
    return 0;
  }, -1);
}

long rcp_resumed_state(rcp_bed* bed, char* buffer, long capacity) {
  return guarded("rcp_resumed_state", [&]() -> long {
    if (bed->resumeFrom.empty() || !bed->coupling) throw std::logic_error("only in a resumed run, after rcp_connect");
    if (!bed->resumedFilesRestored) {
      railcosim::restoreCheckpointFiles(bed->resumeFrom, bed->resumedManifest, "dem",
                                        std::filesystem::current_path().string());
      bed->resumedFilesRestored = true;
    }
    const long size = static_cast<long>(bed->resumedScript.size());
    if (buffer && capacity >= size) std::copy(bed->resumedScript.begin(), bed->resumedScript.end(), buffer);
    return size;
  }, -1L);
}

int rcp_finalize(rcp_bed* bed) {
  return guarded("rcp_finalize", [&] {
    if (bed->participant) bed->participant->finalize();
    return 0;
  }, -1);
}

} // extern "C"
