// BoundedRollingFrictionEngine: gathers per-sphere rolling budgets and torques, calls the BROF kernel, adds the torque.
#include "BoundedRollingFrictionEngine.hpp"

#include <core/Scene.hpp>
#include <pkg/common/Sphere.hpp>
#include <pkg/dem/NewtonIntegrator.hpp>

#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "BallastContact.hpp"
#include "kernels/BoundedRollingFriction.hpp"

namespace yade {

YADE_PLUGIN((BoundedRollingFrictionEngine));

void BoundedRollingFrictionEngine::action() {
  namespace kernels = railcosim::kernels;
  for (const auto& engine : scene->engines) {
    const auto integrator = boost::dynamic_pointer_cast<NewtonIntegrator>(engine);
    if (integrator && integrator->damping != 0) {
      std::ostringstream message;
      message
          << "BoundedRollingFrictionEngine: " << engine->getClassName() << ".damping = " << integrator->damping
          << "; bounded rolling friction needs damping = 0 because Cundall damping amplifies the opposing torque and "
             "reverses spins it should stop. Set damping=0 (contact damping comes from BallastMat.restitution).";
      throw std::runtime_error(message.str());
    }
  }
  const Real timeStep = scene->dt;
  std::vector<double> budget(scene->bodies->size(), 0.0);
  for (const auto& interaction : *scene->interactions) {
    if (!interaction->isReal()) continue;
    const auto* phys = dynamic_cast<const BallastPhys*>(interaction->phys.get());
    if (!phys || phys->rollingResistance <= 0) continue;
    // This contact's share e_c |F_n| of both bodies' budgets, as the contact law evaluated it this step.
    const double moment = phys->rollingResistance;
    budget[interaction->getId1()] += moment;
    budget[interaction->getId2()] += moment;
  }
  scene->forces.sync();
  lastMaxBudget = 0;
  // Every sphere's applied torque is read before any is added: addTorque marks the container unsynchronised, and
  // the next getTorque would then throw (a bed of more than one rolling sphere).
  std::vector<std::pair<Body::id_t, Vector3r>> rollingTorques;
  for (const auto& body : *scene->bodies) {
    if (!body || !body->isDynamic() || !body->isStandalone() || budget[body->getId()] <= 0) continue;
    if (!dynamic_cast<const Sphere*>(body->shape.get())) continue;
    const State* state = body->state.get();
    if (!(state->inertia[0] > 0)) continue;
    const Body::id_t id = body->getId();
    const Vector3r applied = scene->forces.getTorque(id);
    const Vector3r spin = state->angVel;
    const kernels::Vec3 rolling = kernels::boundedRollingTorque(
        kernels::Vec3{double(spin[0]), double(spin[1]), double(spin[2])}, double(state->inertia[0]), double(timeStep),
        kernels::Vec3{double(applied[0]), double(applied[1]), double(applied[2])}, budget[id]);
    const Vector3r torque(rolling.x, rolling.y, rolling.z);
    lastMaxBudget = math::max(lastMaxBudget, Real(budget[id]));
    rollingTorques.emplace_back(id, torque);
  }
  for (const auto& [id, torque] : rollingTorques) scene->forces.addTorque(id, torque);
}

} // namespace yade
