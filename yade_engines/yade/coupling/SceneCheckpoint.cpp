// SceneCheckpoint: body states, interactions, summed forces and the clock, saved and restored in memory.
#include "SceneCheckpoint.hpp"

#include <core/Interaction.hpp>
#include <core/InteractionContainer.hpp>
#include <core/State.hpp>
#include <lib/pyutil/gil.hpp>

#include <boost/archive/binary_iarchive.hpp>
#include <boost/archive/binary_oarchive.hpp>
#include <boost/serialization/shared_ptr.hpp>
#include <boost/serialization/vector.hpp>

#include <chrono>
#include <sstream>
#include <stdexcept>

namespace yade {

namespace {
using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }
} // namespace

void SceneCheckpoint::save(Scene& scene) {
  const auto start = Clock::now();
  // YADE objects touch Python while they are (de)serialized, and objects made in Python scripts (states
  // of bodies created there) must be released with the GIL held.
  gilLock python;
  std::vector<shared_ptr<State>> states(scene.bodies->size());
  for (const auto& b : *scene.bodies)
    if (b) states[b->id] = b->state;
  std::ostringstream out;
  {
    boost::archive::binary_oarchive stream(out);
    stream << states;
    stream << scene.interactions;
  }
  archive = out.str();
  scene.forces.sync();
  force.resize(states.size());
  torque.resize(states.size());
  for (size_t id = 0; id < states.size(); ++id) {
    force[id] = states[id] ? scene.forces.getForce(id) : Vector3r::Zero();
    torque[id] = states[id] ? scene.forces.getTorque(id) : Vector3r::Zero();
  }
  time = scene.time;
  iter = scene.iter;
  elapsed += secondsSince(start);
}

void SceneCheckpoint::restore(Scene& scene) const {
  const auto start = Clock::now();
  if (archive.empty()) throw std::logic_error("SceneCheckpoint: restore() before any save() (internal error).");
  gilLock python; // see save()
  std::vector<shared_ptr<State>> states;
  shared_ptr<InteractionContainer> interactions;
  {
    std::istringstream in(archive);
    boost::archive::binary_iarchive stream(in);
    stream >> states;
    stream >> interactions;
  }
  if (states.size() != scene.bodies->size())
    throw std::runtime_error("bodies were added or erased since the checkpoint (" + std::to_string(states.size()) +
                             " then, " + std::to_string(scene.bodies->size()) + " now); the scene cannot be restored.");
  for (const auto& b : *scene.bodies) {
    if (!b) continue;
    if (!states[b->id])
      throw std::runtime_error("body #" + std::to_string(b->id) +
                               " appeared since the checkpoint; the scene cannot be restored.");
    b->state = states[b->id];
  }
  // Interactions as they were; the collider rebuilds its sorted bounds from scratch (dirty flag).
  interactions->postLoad__calledFromScene(scene.bodies); // binds the loaded copy to this scene's bodies
  scene.interactions->clear();
  for (const auto& I : *interactions) scene.interactions->insert(I);
  scene.interactions->dirty = true;
  // Summed forces of the step the checkpoint was taken in: the integrator that runs next applies them again.
  // Read every current sum first: an addition marks the container unsynchronised for further reads.
  scene.forces.sync();
  std::vector<Vector3r> forceChange(force.size()), torqueChange(force.size());
  for (size_t id = 0; id < force.size(); ++id) {
    if (!states[id]) continue;
    forceChange[id] = force[id] - scene.forces.getForce(id);
    torqueChange[id] = torque[id] - scene.forces.getTorque(id);
  }
  for (size_t id = 0; id < force.size(); ++id) {
    if (!states[id]) continue;
    scene.forces.addForce(id, forceChange[id]);
    scene.forces.addTorque(id, torqueChange[id]);
  }
  scene.time = time;
  scene.iter = iter;
  elapsed += secondsSince(start);
}

} // namespace yade
