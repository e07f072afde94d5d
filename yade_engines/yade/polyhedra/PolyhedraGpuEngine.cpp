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

void PolyhedraGpuEngine::addStone(Body::id_t id, const std::vector<Vector3r>& vertices) {
  if (system) throw std::runtime_error("PolyhedraGpuEngine.addStone: stones can only be added before the first step.");
  if (id < 0 || id >= static_cast<Body::id_t>(scene->bodies->size()) || !(*scene->bodies)[id])
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: no body #" + std::to_string(id) + " in the scene.");
  if (vertices.size() < 4)
    throw std::invalid_argument("PolyhedraGpuEngine.addStone: a convex core needs at least 4 vertices.");
  stoneIds.push_back(id);
  stoneCores.push_back(vertices);
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
  parameters.rebuildInterval = rebuildInterval;
  parameters.adaptiveRebuild = adaptiveRebuild;
  parameters.backend = parseBackend(backend);
  system = std::make_shared<poly::PolyhedraSystem>(parameters);

  // 2. One template per distinct core (vertices in the body frame, compared exactly).
  std::map<std::vector<double>, int> templateOf;
  principalToBody.clear();
  centroidInBody.clear();
  for (size_t i = 0; i < stoneIds.size(); ++i) {
    std::vector<double> vertices;
    for (const Vector3r& v : stoneCores[i])
      for (int k = 0; k < 3; ++k) vertices.push_back(v[k]);
    auto found = templateOf.find(vertices);
    if (found == templateOf.end())
      found = templateOf
                  .emplace(vertices,
                           system->addShape(poly::convexHullTemplate(vertices, dilationRadius, material->density)))
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
  for (const auto& b : *scene->bodies) {
    const auto* facet = b ? dynamic_cast<const Facet*>(b->shape.get()) : nullptr;
    if (!facet) continue;
    for (int j = 0; j < 3; ++j) {
      const Vector3r world = b->state->pos + b->state->ori * facet->vertices[j];
      for (int k = 0; k < 3; ++k) coordinates.push_back(world[k]);
      triangles.push_back(static_cast<std::int32_t>(triangles.size()));
    }
  }
  if (!triangles.empty()) system->setWalls(coordinates, triangles);

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

void PolyhedraGpuEngine::action() {
  initialize();
  // Advance a whole batch on the last iteration of it, so that the bodies match the scene time after it.
  if ((scene->iter + 1) % syncInterval != 0) return;
  system->setTimeStep(scene->dt);
  system->setGravity({gravity[0], gravity[1], gravity[2]});
  system->step(syncInterval);
  meanContacts = system->lastStatistics().meanActiveContacts;
  syncBack();
}

// RESTART HOOK (issue 17, item 1): once PolyhedraSystem::writeState(std::ostream&) / readState(std::istream&) exist,
// restartState() returns initialize()'d system->writeState() as bytes and restoreRestartState() calls initialize()
// then system->readState() on them (the stones' registration comes back with the rebuilt scene's addStone calls).
// Until then a run with this engine refuses to checkpoint rather than resume from a state it cannot restore.
boost::python::object PolyhedraGpuEngine::restartState() const {
  throw std::runtime_error(
      "PolyhedraGpuEngine: restart checkpoints are not supported yet (the polyhedra system cannot write its state: "
      "PolyhedraSystem::writeState, issue 17); run without --checkpoint-every / --resume");
}

void PolyhedraGpuEngine::restoreRestartState(const boost::python::object&) {
  throw std::runtime_error(
      "PolyhedraGpuEngine: restart checkpoints are not supported yet (the polyhedra system cannot read its state: "
      "PolyhedraSystem::readState, issue 17)");
}

} // namespace yade
