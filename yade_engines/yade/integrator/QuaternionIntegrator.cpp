// QuaternionIntegrator: gathers YADE body state, calls the rotation/translation kernels, scatters the result.
#include "QuaternionIntegrator.hpp"

#include "railcosim/StateStream.hpp"
#include "../common/PythonBytes.hpp"

#include <core/Clump.hpp>
#include <core/Scene.hpp>

#include <cstring>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace yade {

YADE_PLUGIN((QuaternionIntegrator));

namespace {
namespace kernels = railcosim::kernels;

kernels::Vec3 toKernel(const Vector3r& v) { return kernels::Vec3{double(v[0]), double(v[1]), double(v[2])}; }
Vector3r fromKernel(const kernels::Vec3& v) { return Vector3r(v.x, v.y, v.z); }
kernels::Quaternion toKernel(const Quaternionr& q) {
  return kernels::Quaternion{double(q.w()), double(q.x()), double(q.y()), double(q.z())};
}
Quaternionr fromKernel(const kernels::Quaternion& q) { return Quaternionr(q.w, q.x, q.y, q.z); }

// Cundall's non-viscous damping on one vector (as NewtonIntegrator::cundallDamp1st): each component is
// reduced by the factor (1 − damping) when it does work on the motion, increased when it opposes it.
void cundallDamp(Vector3r& load, const Vector3r& velocity, Real damping) {
  for (int i = 0; i < 3; ++i) load[i] *= 1 - damping * math::sign(load[i] * velocity[i]);
}

[[noreturn]] void throwBadBody(Body::id_t id, const char* what, const Vector3r& value) {
  std::ostringstream message;
  message << "QuaternionIntegrator: body #" << id << " has " << what << " " << value.transpose()
          << " but some of its degrees of freedom are free; give it positive mass and inertia, or block them "
             "(State.blockedDOFs) or set Body.dynamic=False";
  throw std::runtime_error(message.str());
}
} // namespace

void QuaternionIntegrator::integrateBody(const shared_ptr<Body>& b, kernels::RotationScheme rotationScheme) {
  State* state = b->state.get();
  const Body::id_t& id = b->getId();
  const Real& dt = scene->dt;
  BodySlot& slot = slots[id];
  Vector3r force = Vector3r::Zero();
  Vector3r torque = Vector3r::Zero();
  if (b->isClump()) {
    // F = Σ F_i, T = Σ T_i + Σ r_i × F_i (eqs. 5.9–5.10); member torques include rolling friction.
    b->shape->cast<Clump>().addForceTorqueFromMembers(state, scene, force, torque);
  }
  force += scene->forces.getForce(id);
  torque += scene->forces.getTorque(id);

  // A user (or another engine) who sets pos/vel/ori/angVel between steps restarts the body's integration
  // from that state; otherwise the scheme would overwrite the change with its stored half step.
  if (slot.predicted && (state->pos != slot.writtenPos || state->vel != slot.writtenVel ||
                         state->angVel != slot.writtenAngVel || state->ori.coeffs() != slot.writtenOri.coeffs())) {
    slot.predicted = false;
  }
  const unsigned blocked = state->blockedDOFs;
  const bool translational =
      (blocked & (State::DOF_X | State::DOF_Y | State::DOF_Z)) != (State::DOF_X | State::DOF_Y | State::DOF_Z);
  const bool rotational = (blocked & State::DOF_RXRYRZ) != State::DOF_RXRYRZ;
  if (translational && !(state->mass > 0)) throwBadBody(id, "mass", Vector3r::Constant(state->mass));
  if (rotational && !(state->inertia.minCoeff() > 0)) throwBadBody(id, "inertia", state->inertia);

  // Translation, velocity Verlet (eqs. 3.44–3.48). Blocked components keep their prescribed velocity.
  Vector3r acceleration = Vector3r::Zero();
  for (int i = 0; i < 3; ++i)
    if (!(blocked & State::axisDOF(i, false))) acceleration[i] = force[i] / state->mass + gravity[i];
  if (damping != 0 && state->isDamped) cundallDamp(acceleration, state->vel, damping);
  if (slot.predicted) state->vel += 0.5 * slot.timeStep * acceleration; // corrector of the previous step
  state->vel += 0.5 * dt * acceleration;                                // predictor of this step
  state->pos += dt * state->vel;

  // Rotation.
  if (damping != 0 && state->isDamped) cundallDamp(torque, state->angVel, damping);
  const bool asphericalFree = b->isAspherical() && (blocked & State::DOF_RXRYRZ) == State::DOF_NONE;
  if (asphericalFree) {
    const kernels::Vec3 inertia = toKernel(state->inertia);
    const kernels::Vec3 torqueWorld = toKernel(torque);
    if (slot.predicted) {
      kernels::correctRotation(rotationScheme, slot.rotation, inertia, torqueWorld, slot.timeStep);
    } else {
      slot.rotation = kernels::makeRotationState(toKernel(state->ori), toKernel(state->angVel), inertia);
    }
    kernels::predictRotation(rotationScheme, slot.rotation, inertia, torqueWorld, dt);
    state->ori = fromKernel(slot.rotation.orientation);
    state->angVel = fromKernel(slot.rotation.angularVelocity);
    state->angMom = fromKernel(slot.rotation.angularMomentum);
  } else {
    // Spheres (isotropic inertia) and bodies with blocked rotations: ω̇ = T/I per world axis (eq. 3.31),
    // velocity-Verlet half kicks, orientation advanced by the mid-step rotation (eqs. 3.49–3.53).
    Vector3r angularAcceleration = Vector3r::Zero();
    for (int i = 0; i < 3; ++i)
      if (!(blocked & State::axisDOF(i, true))) angularAcceleration[i] = torque[i] / state->inertia[i];
    if (slot.predicted) state->angVel += 0.5 * slot.timeStep * angularAcceleration;
    state->angVel += 0.5 * dt * angularAcceleration;
    const kernels::Quaternion increment = kernels::incrementalRotation(toKernel(state->angVel), dt);
    state->ori = fromKernel(kernels::normalized(increment * toKernel(state->ori)));
  }

  slot.predicted = true;
  slot.timeStep = dt;
  slot.writtenPos = state->pos;
  slot.writtenVel = state->vel;
  slot.writtenAngVel = state->angVel;
  slot.writtenOri = state->ori;

  if (scene->trackEnergy) {
    const Real translationEnergy = 0.5 * state->mass * state->vel.squaredNorm();
    const Real rotationEnergy =
        asphericalFree
            ? kernels::rotationalKineticEnergy(toKernel(state->ori), toKernel(state->inertia), toKernel(state->angVel))
            : 0.5 * state->angVel.dot(state->inertia.cwiseProduct(state->angVel));
    if (!kinSplit)
      scene->energy->add(translationEnergy + rotationEnergy, "kinetic", kinEnergyIx, true);
    else {
      scene->energy->add(translationEnergy, "kinTrans", kinEnergyTransIx, true);
      scene->energy->add(rotationEnergy, "kinRot", kinEnergyRotIx, true);
    }
    scene->energy->add(-gravity.dot(state->vel) * state->mass * dt, "gravWork", fieldWorkIx, false);
  }
  saveMaximaDisplacement(b);
  if (b->isClump()) Clump::moveMembers(b, scene, this);
}

void QuaternionIntegrator::action() {
  if (scene->isPeriodic) {
    throw std::runtime_error(
        "QuaternionIntegrator: periodic cells are not supported (no homothetic cell motion); "
        "use NewtonIntegrator for periodic scenes");
  }
  const kernels::RotationScheme rotationScheme = kernels::rotationSchemeFromName(scheme);
  scene->forces.sync();
  if (slots.size() != scene->bodies->size()) slots.resize(scene->bodies->size());
  maxVelocitySq = 0;
#ifdef YADE_OPENMP
  for (Real& threadMax : threadMaxVelocitySq) threadMax = 0;
#endif
  YADE_PARALLEL_FOREACH_BODY_BEGIN(const shared_ptr<Body>& b, scene->bodies) {
    if (b->isClumpMember()) continue; // moved with their clump
    if ((mask > 0) && !b->maskCompatible(mask)) continue;
    integrateBody(b, rotationScheme);
  }
  YADE_PARALLEL_FOREACH_BODY_END();
#ifdef YADE_OPENMP
  for (const Real& threadMax : threadMaxVelocitySq) maxVelocitySq = math::max(maxVelocitySq, threadMax);
#endif
}

// The kernels' rotation state is plain doubles; it is stored as its bytes, which this build reads back as written.
static_assert(std::is_trivially_copyable<railcosim::kernels::RotationState>::value,
              "the rotation state must be plain data to be checkpointed byte for byte");

void QuaternionIntegrator::writeSlots(railcosim::StateWriter& state, const std::vector<BodySlot>& bodySlots) {
  state.section("quaternion integrator");
  state.u64(bodySlots.size());
  for (const BodySlot& slot : bodySlots) {
    state.flag(slot.predicted);
    state.real(slot.timeStep);
    std::string rotation(sizeof(slot.rotation), '\0');
    std::memcpy(&rotation[0], &slot.rotation, sizeof(slot.rotation));
    state.bytes(rotation);
    const Quaternionr& q = slot.writtenOri;
    state.reals({slot.writtenPos[0], slot.writtenPos[1], slot.writtenPos[2], slot.writtenVel[0], slot.writtenVel[1],
                 slot.writtenVel[2], slot.writtenAngVel[0], slot.writtenAngVel[1], slot.writtenAngVel[2], q.w(), q.x(),
                 q.y(), q.z()});
  }
}

std::vector<QuaternionIntegrator::BodySlot> QuaternionIntegrator::readSlots(railcosim::StateReader& state) {
  state.section("quaternion integrator");
  std::vector<BodySlot> restored(state.u64());
  for (BodySlot& slot : restored) {
    slot.predicted = state.flag();
    slot.timeStep = state.real();
    const std::string rotation = state.bytes();
    if (rotation.size() != sizeof(slot.rotation))
      state.fail("a rotation state of " + std::to_string(rotation.size()) + " bytes");
    std::memcpy(&slot.rotation, rotation.data(), sizeof(slot.rotation));
    const std::vector<double> v = state.reals();
    if (v.size() != 13) state.fail("13 values per body expected");
    slot.writtenPos = Vector3r(v[0], v[1], v[2]);
    slot.writtenVel = Vector3r(v[3], v[4], v[5]);
    slot.writtenAngVel = Vector3r(v[6], v[7], v[8]);
    slot.writtenOri = Quaternionr(v[9], v[10], v[11], v[12]);
  }
  return restored;
}

boost::python::object QuaternionIntegrator::restartState() const {
  std::ostringstream out;
  railcosim::StateWriter state(out);
  writeSlots(state, slots);
  const std::string bytes = out.str();
  return pythonBytes(bytes);
}

void QuaternionIntegrator::restoreRestartState(const boost::python::object& saved) {
  std::istringstream in(bytesFromPython(saved, "QuaternionIntegrator.restoreRestartState: the state"));
  railcosim::StateReader state(in, "of QuaternionIntegrator");
  slots = readSlots(state);
}

} // namespace yade
