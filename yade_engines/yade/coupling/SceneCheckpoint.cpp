// SceneCheckpoint: body states, interactions, summed forces and the clock, saved and restored in memory.
#include "SceneCheckpoint.hpp"

#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

#include <core/Bound.hpp>
#include <core/EnergyTracker.hpp>
#include <core/Interaction.hpp>
#include <core/InteractionContainer.hpp>
#include <core/Shape.hpp>
#include <core/State.hpp>
#include <lib/pyutil/gil.hpp>
#include <pkg/common/InsertionSortCollider.hpp>

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

// InsertionSortCollider keeps its sorted bound lists private and rebuilds them from scratch in a new process. A
// rebuilt list inserts new potential interactions in another order than the incremental sort of the uninterrupted
// run, and that order is the order in which contact forces add up on a body: the resumed run would drift from the
// uninterrupted one by round-off. A restart therefore saves and restores the lists themselves. They are reached the
// one way the language allows for private members: names in an explicit instantiation are not access-checked
// (C++17 [temp.explicit]/12); no private type is named anywhere else.
template <class Tag, auto Member>
struct PrivateMember {
  friend auto privateMember(Tag) { return Member; }
};
struct ColliderBounds {
  friend auto privateMember(ColliderBounds);
};
struct ColliderMinima {
  friend auto privateMember(ColliderMinima);
};
struct ColliderMaxima {
  friend auto privateMember(ColliderMaxima);
};
struct ColliderStride {
  friend auto privateMember(ColliderStride);
};
struct ColliderPeriodic {
  friend auto privateMember(ColliderPeriodic);
};
template struct PrivateMember<ColliderBounds, &InsertionSortCollider::BB>;
template struct PrivateMember<ColliderMinima, &InsertionSortCollider::minima>;
template struct PrivateMember<ColliderMaxima, &InsertionSortCollider::maxima>;
template struct PrivateMember<ColliderStride, &InsertionSortCollider::strideActive>;
template struct PrivateMember<ColliderPeriodic, &InsertionSortCollider::periodic>;

/// The colliders' sorted bound lists (per axis: coordinate, body id, period, flags, in list order) and stride state.
void writeColliders(const Scene& scene, railcosim::StateWriter& state) {
  for (const auto& engine : scene.engines) {
    const auto collider = YADE_PTR_DYN_CAST<InsertionSortCollider>(engine);
    state.flag(static_cast<bool>(collider));
    if (!collider) continue;
    auto& lists = (*collider).*privateMember(ColliderBounds{});
    for (int axis = 0; axis < 3; ++axis) {
      auto& list = lists[axis];
      std::vector<double> values;
      for (size_t i = 0; i < list.size(); ++i) {
        const auto& bound = list[static_cast<long>(i)];
        values.insert(values.end(), {double(bound.coord), double(bound.id), double(bound.period),
                                     double((bound.flags.hasBB ? 1 : 0) + (bound.flags.isMin ? 2 : 0))});
      }
      state.reals(values);
      state.i64(list.axis);
      state.real(list.cellDim);
      state.u64(list.loIdx);
    }
    const auto& minima = (*collider).*privateMember(ColliderMinima{});
    const auto& maxima = (*collider).*privateMember(ColliderMaxima{});
    state.reals(std::vector<double>(minima.begin(), minima.end()));
    state.reals(std::vector<double>(maxima.begin(), maxima.end()));
    state.flag((*collider).*privateMember(ColliderStride{}));
    state.flag((*collider).*privateMember(ColliderPeriodic{}));
    state.flag(static_cast<bool>(collider->newton));
  }
}

void readColliders(Scene& scene, railcosim::StateReader& state) {
  for (const auto& engine : scene.engines) {
    const auto collider = YADE_PTR_DYN_CAST<InsertionSortCollider>(engine);
    if (state.flag() != static_cast<bool>(collider))
      state.fail("the scene's engines differ from the saved ones (an InsertionSortCollider is missing or extra)");
    if (!collider) continue;
    auto& lists = (*collider).*privateMember(ColliderBounds{});
    for (int axis = 0; axis < 3; ++axis) {
      auto& list = lists[axis];
      using Bounds = std::decay_t<decltype(list[0])>;
      const std::vector<double> values = state.reals();
      if (values.size() % 4 != 0) state.fail("a bound list of " + std::to_string(values.size()) + " values");
      list.clear();
      for (size_t i = 0; i < values.size(); i += 4) {
        const int flags = static_cast<int>(values[i + 3]);
        Bounds bound(values[i], static_cast<Body::id_t>(values[i + 1]), (flags & 2) != 0);
        bound.period = static_cast<int>(values[i + 2]);
        bound.flags.hasBB = (flags & 1) != 0;
        list.push_back(bound);
      }
      list.axis = static_cast<int>(state.i64());
      list.cellDim = state.real();
      list.loIdx = state.u64();
    }
    const std::vector<double> minima = state.reals(), maxima = state.reals();
    ((*collider).*privateMember(ColliderMinima{})).assign(minima.begin(), minima.end());
    ((*collider).*privateMember(ColliderMaxima{})).assign(maxima.begin(), maxima.end());
    (*collider).*privateMember(ColliderStride{}) = state.flag();
    (*collider).*privateMember(ColliderPeriodic{}) = state.flag();
    // The integrator whose displacement record schedules the next collision detection: a collider without it runs
    // at the next step, which the uninterrupted run's did not (found as the collider finds it itself).
    if (state.flag() && !collider->newton)
      for (const auto& other : scene.engines)
        if ((collider->newton = YADE_PTR_DYN_CAST<NewtonIntegrator>(other))) break;
  }
}

/// Puts `saved` (a deserialized container) in place of the scene's interactions, in the saved container order: the
/// order in which InteractionLoop visits them, and so the order in which contact forces add up on a body.
void replaceInteractions(Scene& scene, const shared_ptr<InteractionContainer>& saved) {
  saved->postLoad__calledFromScene(scene.bodies); // binds the loaded copy to this scene's bodies
  scene.interactions->clear();
  for (const auto& I : *saved) scene.interactions->insert(I);
}
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
  replaceInteractions(scene, interactions);
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

void SceneCheckpoint::write(std::ostream& out) const {
  railcosim::StateWriter state(out);
  state.section("scene checkpoint");
  state.bytes(archive);
  std::vector<double> sums;
  for (size_t id = 0; id < force.size(); ++id)
    for (int k = 0; k < 3; ++k) {
      sums.push_back(force[id][k]);
      sums.push_back(torque[id][k]);
    }
  state.reals(sums);
  state.real(time);
  state.i64(iter);
}

void SceneCheckpoint::read(std::istream& in, const std::string& source) {
  railcosim::StateReader state(in, source);
  state.section("scene checkpoint");
  archive = state.bytes();
  const std::vector<double> sums = state.reals();
  if (sums.size() % 6 != 0) state.fail("force sums of " + std::to_string(sums.size()) + " values");
  force.assign(sums.size() / 6, Vector3r::Zero());
  torque.assign(sums.size() / 6, Vector3r::Zero());
  for (size_t id = 0; id < force.size(); ++id)
    for (int k = 0; k < 3; ++k) {
      force[id][k] = sums[6 * id + 2 * k];
      torque[id][k] = sums[6 * id + 2 * k + 1];
    }
  time = state.real();
  iter = state.i64();
}

void SceneCheckpoint::writeBetweenSteps(Scene& scene, std::ostream& out) {
  gilLock python; // see save()
  std::ostringstream archived;
  {
    boost::archive::binary_oarchive stream(archived);
    const long count = static_cast<long>(scene.bodies->size());
    stream << count;
    for (long id = 0; id < count; ++id) {
      const shared_ptr<Body>& b = (*scene.bodies)[id];
      bool present = static_cast<bool>(b);
      stream << present;
      if (!present) continue;
      std::string shapeClass = b->shape ? b->shape->getClassName() : std::string();
      stream << shapeClass << b->state << b->shape << b->bound << b->flags << b->groupMask << b->clumpId << b->iterBorn
             << b->timeBorn;
    }
    // Every interaction, potential ones included: YADE's own archive of the container keeps only those with a
    // geometry or physics and leaves the rest to a collider that starts afresh, which this one does not.
    std::vector<shared_ptr<Interaction>> interactions(scene.interactions->begin(), scene.interactions->end());
    std::vector<long> lastSeen;
    for (const auto& I : interactions) lastSeen.push_back(I->iterLastSeen);
    stream << interactions << lastSeen;
    stream << scene.energy;
  }
  scene.forces.sync();
  std::vector<double> permanent;
  if (scene.forces.getPermForceUsed()) {
    for (long id = 0; id < static_cast<long>(scene.bodies->size()); ++id) {
      if (!(*scene.bodies)[id]) continue;
      const Vector3r f = scene.forces.getPermForce(id), t = scene.forces.getPermTorque(id);
      permanent.insert(permanent.end(), {double(id), f[0], f[1], f[2], t[0], t[1], t[2]});
    }
  }
  // Bound corners are not serialized by YADE (Attr::noSave): they are written here.
  std::vector<double> corners;
  for (const auto& b : *scene.bodies) {
    if (!b || !b->bound) continue;
    corners.push_back(double(b->id));
    for (int k = 0; k < 3; ++k) corners.push_back(b->bound->min[k]);
    for (int k = 0; k < 3; ++k) corners.push_back(b->bound->max[k]);
  }
  railcosim::StateWriter state(out);
  state.section("yade scene between steps");
  state.i64(scene.iter);
  state.real(scene.time);
  state.real(scene.dt);
  state.flag(scene.trackEnergy);
  state.flag(scene.doSort);
  state.flag(scene.interactions->dirty);
  state.i64(scene.interactions->iterColliderLastRun);
  state.bytes(archived.str());
  state.reals(permanent);
  state.reals(corners);
  state.section("yade colliders");
  writeColliders(scene, state);
}

void SceneCheckpoint::readBetweenSteps(Scene& scene, std::istream& in, const std::string& source) {
  railcosim::StateReader state(in, source);
  state.section("yade scene between steps");
  const long iter = state.i64();
  const Real time = state.real();
  const Real dt = state.real();
  const bool trackEnergy = state.flag();
  const bool doSort = state.flag();
  const bool dirty = state.flag();
  const long iterColliderLastRun = state.i64();
  const std::string archived = state.bytes();
  const std::vector<double> permanent = state.reals();
  const std::vector<double> corners = state.reals();
  gilLock python; // see save()
  std::istringstream input(archived);
  boost::archive::binary_iarchive stream(input);
  long count = 0;
  stream >> count;
  if (count != static_cast<long>(scene.bodies->size()))
    throw railcosim::CheckpointError(
        "checkpoint " + source + " holds " + std::to_string(count) + " bodies, the scene built for the resumed run " +
        std::to_string(scene.bodies->size()) + "; resume with the case and parameters of the interrupted run");
  struct Saved {
    shared_ptr<State> state;
    shared_ptr<Shape> shape;
    shared_ptr<Bound> bound;
    int flags = 0;
    decltype(Body::groupMask) groupMask{};
    Body::id_t clumpId = Body::ID_NONE;
    long iterBorn = 0;
    Real timeBorn = 0;
  };
  std::vector<Saved> saved(count);
  for (long id = 0; id < count; ++id) {
    bool present = false;
    stream >> present;
    const shared_ptr<Body>& b = (*scene.bodies)[id];
    if (present != static_cast<bool>(b))
      throw railcosim::CheckpointError("checkpoint " + source + ": body #" + std::to_string(id) + " is " +
                                       (present ? "missing from" : "extra in") +
                                       " the scene built for the resumed run");
    if (!present) continue;
    std::string shapeClass;
    Saved& s = saved[id];
    stream >> shapeClass >> s.state >> s.shape >> s.bound >> s.flags >> s.groupMask >> s.clumpId >> s.iterBorn >>
        s.timeBorn;
    const std::string now = b->shape ? b->shape->getClassName() : std::string();
    if (shapeClass != now)
      throw railcosim::CheckpointError("checkpoint " + source + ": body #" + std::to_string(id) + " was a " +
                                       shapeClass + ", it is a " + now + " in the scene built for the resumed run");
  }
  std::vector<shared_ptr<Interaction>> interactions;
  std::vector<long> lastSeen;
  shared_ptr<EnergyTracker> energy;
  stream >> interactions >> lastSeen >> energy;
  if (lastSeen.size() != interactions.size()) state.fail("interactions and their last collider steps differ in number");
  for (long id = 0; id < count; ++id) {
    const shared_ptr<Body>& b = (*scene.bodies)[id];
    if (!b) continue;
    Saved& s = saved[id];
    b->state = s.state;
    b->shape = s.shape;
    b->bound = s.bound;
    b->flags = s.flags;
    b->groupMask = s.groupMask;
    b->clumpId = s.clumpId;
    b->iterBorn = s.iterBorn;
    b->timeBorn = s.timeBorn;
  }
  scene.interactions->clear();
  for (size_t k = 0; k < interactions.size(); ++k) {
    interactions[k]->iterLastSeen = lastSeen[k];
    scene.interactions->insert(interactions[k]);
  }
  scene.interactions->dirty = dirty; // clear() marked them dirty, which would re-sort the collider's bounds
  scene.interactions->iterColliderLastRun = iterColliderLastRun;
  scene.energy = energy;
  scene.trackEnergy = trackEnergy;
  scene.doSort = doSort;
  if (!permanent.empty()) {
    if (permanent.size() % 7 != 0) state.fail("permanent forces of " + std::to_string(permanent.size()) + " values");
    for (size_t k = 0; k < permanent.size(); k += 7) {
      const Body::id_t id = static_cast<Body::id_t>(permanent[k]);
      scene.forces.setPermForce(id, Vector3r(permanent[k + 1], permanent[k + 2], permanent[k + 3]));
      scene.forces.setPermTorque(id, Vector3r(permanent[k + 4], permanent[k + 5], permanent[k + 6]));
    }
  }
  if (corners.size() % 7 != 0) state.fail("bound corners of " + std::to_string(corners.size()) + " values");
  for (size_t k = 0; k < corners.size(); k += 7) {
    const Body::id_t id = static_cast<Body::id_t>(corners[k]);
    const auto& b = (*scene.bodies)[id];
    if (!b || !b->bound) state.fail("bound corners of body #" + std::to_string(id) + ", which has no bound");
    b->bound->min = Vector3r(corners[k + 1], corners[k + 2], corners[k + 3]);
    b->bound->max = Vector3r(corners[k + 4], corners[k + 5], corners[k + 6]);
  }
  state.section("yade colliders");
  readColliders(scene, state);
  // Written by the last engine of step `iter`: what YADE does after that engine (Scene::moveToNextTimeStep).
  scene.dt = dt;
  scene.iter = iter + 1;
  scene.time = time + dt;
  scene.subStep = -1;
}

} // namespace yade
