// PolyhedraGpuEngine: hands YADE's polyhedra to the dilated-polyhedra system, advances it in batches, syncs back.
#include "PolyhedraGpuEngine.hpp"

#include "railcosim/StateStream.hpp"

#include "../common/PythonBytes.hpp"
#include "../contact/BallastContact.hpp"
#include "polyhedra/PolyhedraBodyFrames.hpp"
#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraSystem.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

#include <core/Scene.hpp>
#include <core/State.hpp>
#include <pkg/common/Facet.hpp>
#include <pkg/dem/FrictPhys.hpp>
#include <pkg/dem/NewtonIntegrator.hpp>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

namespace yade {

YADE_PLUGIN((PolyhedraGpuEngine));
CREATE_LOGGER(PolyhedraGpuEngine);

PolyhedraSurfaceSource::~PolyhedraSurfaceSource() = default;

namespace {
namespace poly = railcosim::polyhedra;
Vector3r toVector3r(const double* xyz) { return Vector3r(xyz[0], xyz[1], xyz[2]); }
Vector3r toVector3r(const std::array<double, 3>& xyz) { return Vector3r(xyz[0], xyz[1], xyz[2]); }

poly::Backend parseBackend(const std::string& name) {
  if (name == "automatic") return poly::Backend::Automatic;
  if (name == "cpu") return poly::Backend::Cpu;
  if (name == "cuda") return poly::Backend::Cuda;
  throw std::invalid_argument("PolyhedraGpuEngine.backend='" + name +
                              "' is not known; use 'automatic', 'cpu' or 'cuda'.");
}

// A YADE material as the polyhedra library takes it, through the one material-to-law conversion of the contact plugin
// (contactMaterialOf): every attribute of a BallastMat; a FrictMat's moduli and friction with `restitution`.
poly::Material polyhedraMaterial(const Material& material, const std::string& owner, Real restitution) {
  railcosim::kernels::ContactMaterial m = contactMaterialOf(material, "PolyhedraGpuEngine: " + owner);
  if (!dynamic_cast<const BallastMat*>(&material)) m.restitution = restitution;
  railcosim::kernels::validate(m, "PolyhedraGpuEngine: " + owner);
  return poly::materialOf(m);
}

// {body id: the stone's 3 values of `perStone`} for Python.
boost::python::dict byBodyId(const std::vector<Body::id_t>& ids, const std::vector<double>& perStone) {
  boost::python::dict result;
  for (size_t i = 0; i < ids.size(); ++i) result[ids[i]] = toVector3r(&perStone[3 * i]);
  return result;
}
} // namespace

PolyhedraGpuEngine::~PolyhedraGpuEngine() = default;

void PolyhedraGpuEngine::addStone(Body::id_t id, const std::vector<Vector3r>& vertices, Real stoneDilationRadius) {
  if (system) throw std::runtime_error("PolyhedraGpuEngine.addStone: stones can only be added before the first step.");
  if (id < 0 || id >= static_cast<Body::id_t>(scene->bodies->size()) || !(*scene->bodies)[id])
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: no body #" + std::to_string(id) + " in the scene.");
  if (vertices.size() < 4)
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: a convex core needs at least 4 vertices.");
  if (!(stoneDilationRadius > 0) && stoneDilationRadius != -1)
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: dilationRadius must be positive [m] (or left out).");
  stoneIds.push_back(id);
  stoneCores.push_back(vertices);
  stoneDilation.push_back(stoneDilationRadius);
}

Real PolyhedraGpuEngine::dilatedVolume(const std::vector<Vector3r>& vertices, Real dilationRadius) {
  std::vector<double> points;
  for (const Vector3r& v : vertices)
    for (int k = 0; k < 3; ++k) points.push_back(v[k]);
  try {
    poly::Parameters parameters;
    parameters.backend = poly::Backend::Cpu;
    poly::PolyhedraSystem system(parameters);
    return system.shapeProperties(system.addShape(poly::convexHullTemplate(points, dilationRadius, 1.0))).dilatedVolume;
  } catch (const railcosim::Error& e) {
    throw std::invalid_argument(std::string("PolyhedraGpuEngine.dilatedVolume: ") + e.what());
  }
}

void PolyhedraGpuEngine::attachSurface(const std::vector<int32_t>& triangles, const std::vector<double>& coordinates,
                                       const shared_ptr<Material>& material, Real restitution) {
  if (system)
    throw std::runtime_error(
        "PolyhedraGpuEngine: a coupled surface must be attached before the engine is initialized (it was initialized "
        "before the FemCouplingEngine connected; put both engines in O.engines before the first step, or call "
        "FemCouplingEngine.connect() before PolyhedraGpuEngine.initialize()).");
  if (hasSurface())
    throw std::runtime_error("PolyhedraGpuEngine: a coupled surface is already attached; one FemCouplingEngine with "
                             "contactModel='polyhedra' per polyhedra engine.");
  checkSurfaceMaterial(material, restitution); // refused now rather than at initialization
  surfaceConnectivity = triangles;
  surfaceCoordinates = coordinates;
  surfaceMaterial = material;
  surfaceRestitution = restitution;
  surfaceNodes = static_cast<int>(coordinates.size() / 3);
  surfaceTriangles = static_cast<int>(triangles.size() / 3);
}

void PolyhedraGpuEngine::checkSurfaceMaterial(const shared_ptr<Material>& material, Real restitution) {
  if (!material) throw std::invalid_argument("PolyhedraGpuEngine: the coupled surface has no material.");
  polyhedraMaterial(*material, "the coupled surface's material", restitution);
}

void PolyhedraGpuEngine::initialize() {
  if (system) return;
  if (syncInterval < 1)
    throw std::invalid_argument("PolyhedraGpuEngine.syncInterval must be at least 1, got " +
                                std::to_string(syncInterval));
  if (!(dilationRadius > 0)) throw std::invalid_argument("PolyhedraGpuEngine.dilationRadius must be positive [m].");
  for (const auto& engine : scene->engines)
    if (boost::dynamic_pointer_cast<NewtonIntegrator>(engine))
      throw std::invalid_argument("PolyhedraGpuEngine integrates the stones itself: remove " + engine->getClassName() +
                                  " from O.engines (it would move the stones a second time).");
  // A coupling engine's surface joins the walls; it may have to connect to the FEM side first.
  for (const auto& engine : scene->engines)
    if (auto* source = dynamic_cast<PolyhedraSurfaceSource*>(engine.get())) source->attachPolyhedraSurface();
  if (system) return; // attaching initialized this engine (a coupling engine that drives it)

  // 1. Stones: the registered bodies; the first one's material stands for all.
  if (stoneIds.empty())
    throw std::invalid_argument("PolyhedraGpuEngine: no stones; register them with addStone(id, vertices) first.");
  const shared_ptr<Material>& stoneMaterial = (*scene->bodies)[stoneIds.front()]->material;
  if (!stoneMaterial) throw std::invalid_argument("PolyhedraGpuEngine: the first stone has no material.");
  for (Body::id_t id : stoneIds)
    if ((*scene->bodies)[id]->material != stoneMaterial) {
      LOG_WARN("PolyhedraGpuEngine: stones have different materials; the first stone's ("
               << stoneMaterial->getClassName() << " '" << stoneMaterial->label << "') is used for all.");
      break;
    }
  const auto* frict = dynamic_cast<const FrictMat*>(stoneMaterial.get());
  if (!frict)
    throw std::invalid_argument("PolyhedraGpuEngine: the stones need a FrictMat or BallastMat material, got a " +
                                stoneMaterial->getClassName() + ".");

  poly::Parameters parameters;
  parameters.timeStep = scene->dt;
  parameters.gravity = {gravity[0], gravity[1], gravity[2]};
  parameters.stone = polyhedraMaterial(*stoneMaterial, "the stones' material", restitution);
  parameters.wall = parameters.stone;
  parameters.rebuildInterval = rebuildInterval;
  parameters.neighbourSkin = neighbourSkin;
  parameters.largeBodyRatio = largeBodyRatio;
  parameters.adaptiveRebuild = adaptiveRebuild;
  parameters.maxNeighbours = maxNeighbours;
  parameters.maxWallNeighbours = maxWallNeighbours;
  parameters.backend = parseBackend(backend);
  system = std::make_shared<poly::PolyhedraSystem>(parameters);

  // 2. One template per distinct core and dilation (vertices in the body frame, compared exactly; BodyFrameStones).
  frames.clear();
  for (size_t i = 0; i < stoneIds.size(); ++i) {
    std::vector<double> vertices;
    for (const Vector3r& v : stoneCores[i])
      for (int k = 0; k < 3; ++k) vertices.push_back(v[k]);
    const double radius = stoneDilation[i] > 0 ? stoneDilation[i] : dilationRadius;
    State& s = *(*scene->bodies)[stoneIds[i]]->state;
    const Quaternionr& o = s.ori;
    frames.add(*system, vertices, radius, frict->density, {s.pos[0], s.pos[1], s.pos[2]}, {o.w(), o.x(), o.y(), o.z()},
               {s.vel[0], s.vel[1], s.vel[2]}, {s.angVel[0], s.angVel[1], s.angVel[2]});
    s.mass = frames.mass(i); // the dilated stone's, for momentum and energy sums over the YADE bodies
  }

  // 3. Walls: the facets (each facet's three vertices; shared nodes need not be merged), then the coupled surface.
  //    Materials: one per distinct facet material, the surface's last.
  std::vector<double> coordinates;
  std::vector<std::int32_t> triangles, materialOfTriangle;
  std::vector<poly::Material> materials;
  std::map<const Material*, int> materialIndex;
  facetOfTriangle.clear();
  for (const auto& b : *scene->bodies) {
    const auto* facet = b ? dynamic_cast<const Facet*>(b->shape.get()) : nullptr;
    if (!facet) continue;
    if (!b->material) throw std::invalid_argument("PolyhedraGpuEngine: facet #" + std::to_string(b->id) + " has no material.");
    auto known = materialIndex.find(b->material.get());
    if (known == materialIndex.end()) {
      known = materialIndex.emplace(b->material.get(), static_cast<int>(materials.size())).first;
      materials.push_back(polyhedraMaterial(*b->material, "facet #" + std::to_string(b->id), restitution));
    }
    for (int j = 0; j < 3; ++j) {
      const Vector3r world = b->state->pos + b->state->ori * facet->vertices[j];
      for (int k = 0; k < 3; ++k) coordinates.push_back(world[k]);
      triangles.push_back(static_cast<std::int32_t>(triangles.size()));
    }
    materialOfTriangle.push_back(known->second);
    facetOfTriangle.push_back(b->id);
  }
  facetNodes = coordinates;
  if (facetNodeVelocities.size() != facetNodes.size()) facetNodeVelocities.assign(facetNodes.size(), 0.0);
  surfaceFirstTriangle = static_cast<int>(facetOfTriangle.size());
  if (hasSurface()) {
    const auto firstNode = static_cast<std::int32_t>(coordinates.size() / 3);
    coordinates.insert(coordinates.end(), surfaceCoordinates.begin(), surfaceCoordinates.end());
    for (int32_t node : surfaceConnectivity) triangles.push_back(firstNode + node);
    materialOfTriangle.insert(materialOfTriangle.end(), surfaceTriangles, static_cast<int32_t>(materials.size()));
    materials.push_back(polyhedraMaterial(*surfaceMaterial, "the coupled surface's material", surfaceRestitution));
  }
  if (materials.size() > static_cast<size_t>(poly::maxWallMaterials))
    throw std::invalid_argument("PolyhedraGpuEngine: " + std::to_string(materials.size()) +
                                " wall materials (distinct facet materials" +
                                (hasSurface() ? std::string(" and the coupled surface's") : std::string()) +
                                "), at most " + std::to_string(poly::maxWallMaterials) +
                                "; give the facets fewer distinct materials.");
  if (!triangles.empty()) {
    system->setWalls(coordinates, triangles);
    system->setWallMaterials(materials, materialOfTriangle);
  }

  stones = static_cast<int>(stoneIds.size());
  shapes = frames.templates();
  wallTriangles = static_cast<int>(triangles.size() / 3);
  activeBackend = poly::backendName(system->activeBackend());
  backendReason = system->backendReason();
  LOG_INFO("PolyhedraGpuEngine: " << stones << " stones, " << shapes << " shapes, " << surfaceFirstTriangle
                                  << " facet triangles, " << surfaceTriangles << " coupled surface triangles on "
                                  << activeBackend << " (" << backendReason << ")");
}

void PolyhedraGpuEngine::requireSystem(const char* what) const {
  if (!system)
    throw std::runtime_error(std::string("PolyhedraGpuEngine.") + what +
                             ": the engine is not initialized yet (run a step or call initialize()).");
}

void PolyhedraGpuEngine::syncBack() {
  const std::vector<double> p = system->positions(), q = system->orientations(), v = system->velocities(),
                            w = system->angularVelocities();
  std::array<double, 3> position, velocity, angularVelocity;
  std::array<double, 4> ori;
  for (size_t i = 0; i < stoneIds.size(); ++i) {
    frames.bodyState(i, p, q, v, w, position, ori, velocity, angularVelocity);
    State& s = *(*scene->bodies)[stoneIds[i]]->state;
    s.ori = Quaternionr(ori[0], ori[1], ori[2], ori[3]);
    s.pos = toVector3r(position);
    s.angVel = toVector3r(angularVelocity);
    s.vel = toVector3r(velocity);
  }
}

int PolyhedraGpuEngine::triangleOfFacet(Body::id_t facet) const {
  const auto found = std::find(facetOfTriangle.begin(), facetOfTriangle.end(), facet);
  if (found == facetOfTriangle.end())
    throw std::invalid_argument("PolyhedraGpuEngine: body #" + std::to_string(facet) +
                                " is not one of the facets handed to the polyhedra system at initialization.");
  return static_cast<int>(found - facetOfTriangle.begin());
}

void PolyhedraGpuEngine::setWallVelocity(const std::vector<Body::id_t>& facets, const Vector3r& velocity) {
  initialize();
  if (hasSurface())
    throw std::runtime_error("PolyhedraGpuEngine.setWallVelocity: facets stay fixed while a coupled surface drives the engine.");
  for (Body::id_t id : facets) {
    const int triangle = triangleOfFacet(id);
    for (int node = 3 * triangle; node < 3 * triangle + 3; ++node)
      for (int k = 0; k < 3; ++k) facetNodeVelocities[3 * node + k] = velocity[k];
    (*scene->bodies)[id]->state->vel = velocity;
  }
  facetsMove = true;
}

Vector3r PolyhedraGpuEngine::wallForce(const std::vector<Body::id_t>& facets) const {
  requireSystem("wallForce");
  const std::vector<double> forces = system->triangleForces();
  Vector3r total = Vector3r::Zero();
  for (Body::id_t id : facets) total += toVector3r(&forces[3 * triangleOfFacet(id)]);
  return total;
}

Real PolyhedraGpuEngine::criticalTimeStep(Real normalForce, Real impactVelocity) {
  initialize();
  return system->criticalTimeStep(normalForce, impactVelocity);
}

void PolyhedraGpuEngine::action() {
  initialize();
  if (hasSurface()) return; // the coupling engine advances the stones, one window per batch
  // Advance a whole batch on the last iteration of it, so that the bodies match the scene time after it.
  if ((scene->iter + 1) % syncInterval != 0) return;
  system->setTimeStep(scene->dt);
  system->setGravity({gravity[0], gravity[1], gravity[2]});
  // Moving facets (setWallVelocity): the system moves their nodes at constant velocity through the batch; the engine
  // keeps the node positions and moves the facet bodies by the same displacement.
  if (facetsMove) system->setSurfaceKinematics(facetNodes, facetNodeVelocities);
  system->step(syncInterval);
  if (facetsMove) {
    const Real duration = syncInterval * scene->dt;
    for (size_t k = 0; k < facetNodes.size(); ++k) facetNodes[k] += facetNodeVelocities[k] * duration;
    for (size_t t = 0; t < facetOfTriangle.size(); ++t)
      (*scene->bodies)[facetOfTriangle[t]]->state->pos += toVector3r(&facetNodeVelocities[9 * t]) * duration;
  }
  meanContacts = system->lastStatistics().meanActiveContacts;
  syncBack();
}

void PolyhedraGpuEngine::advanceWindow(const std::vector<double>& positions, const std::vector<double>& velocities,
                                       int steps, std::vector<double>& triangleForces,
                                       std::vector<double>& contactPoints) {
  initialize();
  if (!hasSurface()) throw std::logic_error("PolyhedraGpuEngine::advanceWindow without a coupled surface.");
  if (positions.size() != 3 * static_cast<size_t>(surfaceNodes) || velocities.size() != positions.size())
    throw std::logic_error("PolyhedraGpuEngine::advanceWindow: surface kinematics of the wrong size.");
  // The facets' nodes stay where they are; the surface's follow the window's motion.
  std::vector<double> nodes = facetNodes, nodeVelocities(facetNodes.size(), 0.0);
  nodes.insert(nodes.end(), positions.begin(), positions.end());
  nodeVelocities.insert(nodeVelocities.end(), velocities.begin(), velocities.end());
  system->setTimeStep(scene->dt);
  system->setGravity({gravity[0], gravity[1], gravity[2]});
  system->setSurfaceKinematics(nodes, nodeVelocities);
  system->step(steps);
  meanContacts = system->lastStatistics().meanActiveContacts;
  syncBack();
  const std::vector<double> forces = system->triangleForces(), points = system->triangleContactPoints();
  const auto first = forces.begin() + 3 * surfaceFirstTriangle;
  triangleForces.assign(first, first + 3 * surfaceTriangles);
  contactPoints.assign(points.begin() + 3 * surfaceFirstTriangle,
                       points.begin() + 3 * (surfaceFirstTriangle + surfaceTriangles));
  surfaceForce = Vector3r::Zero();
  for (int t = 0; t < surfaceTriangles; ++t) surfaceForce += toVector3r(&triangleForces[3 * t]);
}

void PolyhedraGpuEngine::saveSnapshot() {
  initialize();
  system->saveSnapshot();
}

void PolyhedraGpuEngine::restoreSnapshot() {
  requireSystem("restoreSnapshot");
  system->restoreSnapshot();
  // The YADE bodies are the scene checkpoint's business; they hold the same state.
}

boost::python::list PolyhedraGpuEngine::contactsPy() {
  requireSystem("contacts");
  boost::python::list result;
  for (const poly::ContactRecord& c : system->contacts()) {
    boost::python::dict contact;
    const bool surface = c.wall && c.second >= surfaceFirstTriangle;
    contact["id1"] = stoneIds[c.first];
    contact["id2"] = c.wall ? Body::id_t(-1) : stoneIds[c.second];
    contact["triangle"] = c.wall ? c.second : -1;
    contact["facet"] = c.wall && !surface ? facetOfTriangle[c.second] : Body::id_t(-1);
    contact["surfaceTriangle"] = surface ? c.second - surfaceFirstTriangle : -1;
    contact["point"] = toVector3r(c.point);
    contact["normal"] = toVector3r(c.normal);
    contact["force"] = toVector3r(c.force);
    contact["overlap"] = c.overlap;
    result.append(contact);
  }
  return result;
}

boost::python::dict PolyhedraGpuEngine::stoneForcesPy() {
  requireSystem("stoneForces");
  return byBodyId(stoneIds, system->forces());
}

boost::python::dict PolyhedraGpuEngine::stoneTorquesPy() {
  requireSystem("stoneTorques");
  return byBodyId(stoneIds, system->torques());
}

void PolyhedraGpuEngine::writeStatePy(const std::string& path) {
  initialize();
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("PolyhedraGpuEngine.writeState: cannot open '" + path + "' for writing.");
  try {
    system->writeState(out);
  } catch (const railcosim::Error& e) {
    throw std::runtime_error(std::string("PolyhedraGpuEngine.writeState('") + path + "'): " + e.what());
  }
}

void PolyhedraGpuEngine::readStatePy(const std::string& path) {
  initialize();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("PolyhedraGpuEngine.readState: cannot open '" + path + "'.");
  try {
    system->readState(in);
  } catch (const railcosim::Error& e) {
    throw std::runtime_error(std::string("PolyhedraGpuEngine.readState('") + path + "'): " + e.what());
  }
  syncBack();
}

// Restart checkpoints: the system's state stream (writeState), and the snapshot an implicit window keeps of its start
// as a second stream (written by restoring the snapshot, writing, and reading the current state back: readState
// restores a state exactly). The engine's own moving facets and reported figures go with them. Before the system
// exists (a script asking whether the engine can checkpoint) the state says only that.
boost::python::object PolyhedraGpuEngine::restartState() {
  std::ostringstream out;
  railcosim::StateWriter state(out);
  state.section("polyhedra engine");
  state.flag(bool(system));
  if (system) {
    try {
      system->writeRestartState(state);
    } catch (const railcosim::Error& e) {
      throw std::runtime_error(std::string("PolyhedraGpuEngine.restartState: ") + e.what());
    }
    state.reals(facetNodes);
    state.reals(facetNodeVelocities);
    state.flag(facetsMove);
    state.reals({meanContacts, surfaceForce[0], surfaceForce[1], surfaceForce[2]});
  }
  const std::string bytes = out.str();
  return pythonBytes(bytes);
}

void PolyhedraGpuEngine::restoreRestartState(const boost::python::object& saved) {
  std::istringstream in(bytesFromPython(saved, "PolyhedraGpuEngine.restoreRestartState: the state"));
  railcosim::StateReader state(in, "of PolyhedraGpuEngine");
  state.section("polyhedra engine");
  if (!state.flag()) return; // saved before the system existed: it is built at the first step as then
  initialize();
  try {
    system->readRestartState(state);
  } catch (const railcosim::Error& e) {
    throw std::runtime_error(std::string("PolyhedraGpuEngine.restoreRestartState: ") + e.what() +
                             "; resume with the case and parameters of the interrupted run");
  }
  std::vector<double> nodes = state.reals(), velocities = state.reals();
  if (nodes.size() != facetNodes.size() || velocities.size() != facetNodeVelocities.size())
    state.fail("the facets' nodes differ from this scene's");
  facetNodes = std::move(nodes);
  facetNodeVelocities = std::move(velocities);
  facetsMove = state.flag();
  const std::vector<double> figures = state.reals();
  if (figures.size() != 4) state.fail("4 figures expected");
  meanContacts = figures[0];
  surfaceForce = Vector3r(figures[1], figures[2], figures[3]);
  syncBack();
}

} // namespace yade
