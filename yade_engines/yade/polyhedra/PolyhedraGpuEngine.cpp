// PolyhedraGpuEngine: hands YADE's polyhedra to the dilated-polyhedra system, advances it in batches, syncs back.
#include "PolyhedraGpuEngine.hpp"

#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraSystem.hpp"

#include <core/Scene.hpp>
#include <core/State.hpp>
#include <pkg/common/Facet.hpp>
#include <pkg/dem/FrictPhys.hpp>
#include <pkg/dem/NewtonIntegrator.hpp>

#include <map>

namespace yade {

YADE_PLUGIN((PolyhedraGpuEngine));
CREATE_LOGGER(PolyhedraGpuEngine);

namespace {
namespace poly = railcosim::polyhedra;
Quaternionr quaternion(const double* wxyz) { return Quaternionr(wxyz[0], wxyz[1], wxyz[2], wxyz[3]); }

poly::Backend parseBackend(const std::string& name) {
  if (name == "automatic") return poly::Backend::Automatic;
  if (name == "cpu") return poly::Backend::Cpu;
  if (name == "cuda") return poly::Backend::Cuda;
  throw std::invalid_argument("PolyhedraGpuEngine.backend='" + name +
                              "' is not known; use 'automatic', 'cpu' or 'cuda'.");
}
} // namespace

PolyhedraGpuEngine::~PolyhedraGpuEngine() = default;

void PolyhedraGpuEngine::addStone(Body::id_t id, const std::vector<Vector3r>& vertices, Real stoneDilation) {
  if (system) throw std::runtime_error("PolyhedraGpuEngine.addStone: stones can only be added before the first step.");
  if (id < 0 || id >= static_cast<Body::id_t>(scene->bodies->size()) || !(*scene->bodies)[id])
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: no body #" + std::to_string(id) + " in the scene.");
  if (vertices.size() < 4)
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: a convex core needs at least 4 vertices.");
  if (!(stoneDilation >= 0))
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: dilationRadius must be >= 0 m (0: the engine's).");
  stoneIds.push_back(id);
  stoneCores.push_back(vertices);
  stoneDilations.push_back(stoneDilation);
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

  // 1. Stones: the registered bodies; the first one's material stands for all.
  if (stoneIds.empty())
    throw std::invalid_argument("PolyhedraGpuEngine: no stones; register them with addStone(id, vertices) first.");
  const FrictMat* material = dynamic_cast<const FrictMat*>((*scene->bodies)[stoneIds.front()]->material.get());
  if (!material) throw std::invalid_argument("PolyhedraGpuEngine: the stones need a FrictMat material.");

  poly::Parameters parameters;
  parameters.timeStep = scene->dt;
  parameters.gravity = {gravity[0], gravity[1], gravity[2]};
  parameters.stone = {material->young, material->poisson, restitution, std::tan(material->frictionAngle)};
  parameters.wall = parameters.stone;
  if (wallFriction >= 0) parameters.wall.friction = wallFriction;
  parameters.maxNeighbours = maxNeighbours;
  parameters.maxWallNeighbours = maxWallNeighbours;
  parameters.rebuildInterval = rebuildInterval;
  parameters.adaptiveRebuild = adaptiveRebuild;
  parameters.backend = parseBackend(backend);
  system = std::make_shared<poly::PolyhedraSystem>(parameters);

  // 2. One template per distinct core and dilation (vertices in the body frame, compared exactly).
  std::map<std::vector<double>, int> templateOf;
  principalToBody.clear();
  centroidInBody.clear();
  for (size_t i = 0; i < stoneIds.size(); ++i) {
    const double dilation = stoneDilations[i] > 0 ? stoneDilations[i] : dilationRadius;
    std::vector<double> vertices;
    for (const Vector3r& v : stoneCores[i])
      for (int k = 0; k < 3; ++k) vertices.push_back(v[k]);
    std::vector<double> key = vertices;
    key.push_back(dilation);
    auto found = templateOf.find(key);
    if (found == templateOf.end())
      found = templateOf
                  .emplace(key, system->addShape(poly::convexHullTemplate(vertices, dilation, material->density)))
                  .first;
    const int shapeIndex = found->second;
    const poly::ShapeProperties& props = system->shapeProperties(shapeIndex);
    const Quaternionr toBody = quaternion(props.principalToGiven.data());
    const Vector3r centroid(props.centroid[0], props.centroid[1], props.centroid[2]);
    const State& s = *(*scene->bodies)[stoneIds[i]]->state;
    const Vector3r position = s.pos + s.ori * centroid;
    const Quaternionr ori = s.ori * toBody;
    const Vector3r velocity = s.vel + s.angVel.cross(position - s.pos);
    system->addStone(shapeIndex, {position[0], position[1], position[2]}, {ori.w(), ori.x(), ori.y(), ori.z()},
                     {velocity[0], velocity[1], velocity[2]}, {s.angVel[0], s.angVel[1], s.angVel[2]});
    principalToBody.push_back(toBody);
    centroidInBody.push_back(centroid);
  }

  // 3. Facets are fixed triangle walls (each facet's three vertices; shared nodes need not be merged).
  std::vector<double> coordinates;
  std::vector<std::int32_t> triangles;
  triangleOfFacet.clear();
  for (const auto& b : *scene->bodies) {
    const auto* facet = b ? dynamic_cast<const Facet*>(b->shape.get()) : nullptr;
    if (!facet) continue;
    triangleOfFacet[b->id] = static_cast<int>(triangles.size() / 3);
    for (int j = 0; j < 3; ++j) {
      const Vector3r world = b->state->pos + b->state->ori * facet->vertices[j];
      for (int k = 0; k < 3; ++k) coordinates.push_back(world[k]);
      triangles.push_back(static_cast<std::int32_t>(triangles.size()));
    }
  }
  if (!triangles.empty()) system->setWalls(coordinates, triangles);
  wallNodePositions = coordinates;
  if (wallNodeVelocities.size() != coordinates.size()) wallNodeVelocities.assign(coordinates.size(), 0.0);

  stones = static_cast<int>(stoneIds.size());
  shapes = static_cast<int>(templateOf.size());
  activeBackend = poly::backendName(system->activeBackend());
  backendReason = system->backendReason();
  LOG_INFO("PolyhedraGpuEngine: " << stones << " stones, " << shapes << " shapes, " << triangles.size() / 3
                                  << " wall triangles on " << activeBackend << " (" << backendReason << ")");
}

void PolyhedraGpuEngine::syncBack() {
  const std::vector<double> p = system->positions(), q = system->orientations(), v = system->velocities(),
                            w = system->angularVelocities();
  for (size_t i = 0; i < stoneIds.size(); ++i) {
    State& s = *(*scene->bodies)[stoneIds[i]]->state;
    const Vector3r position(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    const Quaternionr ori = quaternion(&q[4 * i]);
    const Vector3r angularVelocity(w[3 * i], w[3 * i + 1], w[3 * i + 2]);
    s.ori = (ori * principalToBody[i].conjugate()).normalized();
    s.pos = position - s.ori * centroidInBody[i];
    s.angVel = angularVelocity;
    s.vel = Vector3r(v[3 * i], v[3 * i + 1], v[3 * i + 2]) + angularVelocity.cross(s.pos - position);
  }
}

int PolyhedraGpuEngine::triangleOf(Body::id_t facet) const {
  const auto found = triangleOfFacet.find(facet);
  if (found == triangleOfFacet.end())
    throw std::invalid_argument("PolyhedraGpuEngine: body #" + std::to_string(facet) +
                                " is not one of the wall facets handed to the polyhedra system at initialization.");
  return found->second;
}

void PolyhedraGpuEngine::setWallVelocity(const std::vector<Body::id_t>& facets, const Vector3r& velocity) {
  initialize();
  for (Body::id_t id : facets) {
    const int triangle = triangleOf(id);
    for (int node = 3 * triangle; node < 3 * triangle + 3; ++node)
      for (int k = 0; k < 3; ++k) wallNodeVelocities[3 * node + k] = velocity[k];
    (*scene->bodies)[id]->state->vel = velocity;
  }
  wallsMove = true;
}

Real PolyhedraGpuEngine::criticalTimeStep(Real normalForce, Real impactVelocity) {
  initialize();
  return system->criticalTimeStep(normalForce, impactVelocity);
}

Vector3r PolyhedraGpuEngine::wallForce(const std::vector<Body::id_t>& facets) const {
  if (!system) throw std::runtime_error("PolyhedraGpuEngine.wallForce: no batch has run yet.");
  const std::vector<double> forces = system->triangleForces();
  Vector3r total = Vector3r::Zero();
  for (Body::id_t id : facets) {
    const int triangle = triangleOf(id);
    total += Vector3r(forces[3 * triangle], forces[3 * triangle + 1], forces[3 * triangle + 2]);
  }
  return total;
}

// Moving facets: the system moves their nodes at constant velocity through a batch (setSurfaceKinematics);
// the engine keeps the node positions and moves the facet bodies by the same displacement.
void PolyhedraGpuEngine::moveWalls(Real duration) {
  for (size_t k = 0; k < wallNodePositions.size(); ++k) wallNodePositions[k] += wallNodeVelocities[k] * duration;
  for (const auto& [id, triangle] : triangleOfFacet) {
    const double* v = &wallNodeVelocities[9 * triangle];
    (*scene->bodies)[id]->state->pos += Vector3r(v[0], v[1], v[2]) * duration;
  }
}

void PolyhedraGpuEngine::action() {
  initialize();
  // Advance a whole batch on the last iteration of it, so that the bodies match the scene time after it.
  if ((scene->iter + 1) % syncInterval != 0) return;
  system->setTimeStep(scene->dt);
  system->setGravity({gravity[0], gravity[1], gravity[2]});
  if (wallsMove) system->setSurfaceKinematics(wallNodePositions, wallNodeVelocities);
  system->step(syncInterval);
  if (wallsMove) moveWalls(syncInterval * scene->dt);
  meanContacts = system->lastStatistics().meanActiveContacts;
  syncBack();
}

} // namespace yade
