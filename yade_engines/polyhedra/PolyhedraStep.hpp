// Per-stone work of one DEM step (integration, neighbour search, contact forces), compiled by g++ and nvcc.
#pragma once

#include <cmath>
#include <cstdint>

#include "kernels/ContactLaw.hpp"
#include "kernels/RotationIntegrators.hpp"
#include "kernels/Vector3.hpp"
#include "railcosim/HostDevice.hpp"
#include "railcosim/TriangleGeometry.hpp"
#include "polyhedra/PolyhedraGeometry.hpp"
#include "polyhedra/PolyhedraSystem.hpp"

#if defined(__CUDA_ARCH__)
#define RAILCOSIM_POLYHEDRA_DEVICE_PASS 1
#endif
#if defined(__CUDACC__)
#include "polyhedra/cuda/PolyhedraWarpSums.cuh"
#endif

namespace railcosim::polyhedra {

// Per-shape constants (one entry per template; read through the cache by every contact).
struct ShapeData {
  int firstVertex; // offset into the vertex array (in vertices)
  int vertexCount;
  double dilationRadius; // r_d [m]
  double boundingRadius; // core circumradius + r_d [m]
  double mass;           // [kg]
  double inertia[3];     // principal [kg m^2]
};

// History of one contact candidate, kept across steps and carried over by partner id at list rebuilds.
// 64 bytes, 16-byte aligned: two whole 32-byte memory sectors per slot. The contact passes read and write
// a slot per candidate every step; the earlier 72-byte slot straddled 3–4 sectors. The first sector holds
// all that the filter reads (partner, state, axis), the second the law's history and GJK's warm start.
struct alignas(16) ContactSlot {
  std::int32_t partner : 30; // stone j > i, or triangle index; −1: unused
  std::uint32_t active : 2;  // 1 if in contact at the last evaluation, 2 a duplicate wall contact, 0 not
  float tangentialStiffness; // k_t of the last evaluation [N/m]: only the unloading correction of the tangential
                             // spring reads it (a ratio of stiffnesses), single precision suffices
  double normal[3]; // last contact normal or separating axis (filter axis, GJK start without a simplex, core-overlap
                    // fallback)
  double elasticShear[3]; // elastic tangential force on the partner [N] (kernels/ContactLaw.hpp)
  std::uint64_t simplex;  // last GJK simplex (support vertex pairs, CoreDistance::simplex): warm start; 0 if none
};
static_assert(sizeof(ContactSlot) == 64, "a contact slot fills two memory sectors exactly");
constexpr int partnerLimit = 1 << 29; // stones and triangles a 30-bit signed partner field can name

// Output of an active contact (written only when active; read for reporting).
struct ContactOutput {
  double point[3];
  double force[3]; // on the partner [N]
  double overlap;  // δ [m]
};

// One active contact of the last force evaluation, gathered where the lists live (PolyhedraBackend::activeContacts):
// stone `stone` (stored index) and its partner (stored stone index, or triangle index for a wall contact).
struct ActiveContact {
  std::int32_t stone;
  std::int32_t partner;
  std::int32_t wall;
  double normal[3]; // stone -> partner
  ContactOutput output;
};

// The record of an active slot of stone i's pair list (wall = false) or wall list.
RAILCOSIM_HOST_DEVICE inline ActiveContact activeContactOf(const ContactSlot& slot, const ContactOutput& output, int i,
                                                           bool wall) {
  ActiveContact c{i, slot.partner, wall ? 1 : 0, {slot.normal[0], slot.normal[1], slot.normal[2]}, output};
  return c;
}

// Whether the contact of stone i with `partner` touches a selected stone (a flag per stored stone; null: all are).
RAILCOSIM_HOST_DEVICE inline bool contactSelected(const std::uint8_t* selected, int i, int partner, bool wall) {
  return !selected || selected[i] || (!wall && selected[partner]);
}

// Narrow-phase result of one candidate (kept between the two passes over wall candidates).
struct ContactGeometry {
  bool touching;
  double overlap; // δ [m]
  Vec3 normal;    // A -> B
  Vec3 point;
  bool unfinished; // GJK reached the caller's iteration limit: nothing decided, the slot holds the simplex to resume
                   // from
};

// Counters written by device code; index meaning below.
enum Counter : int {
  counterPairOverflow = 0, // largest candidate count that did not fit (0: none)
  counterWallOverflow = 1,
  counterCoreOverlap = 2,
  counterDangerous = 3, // a stone moved farther than skin/2 since the last rebuild
  counterActive = 4,
  counterMaxDisplacement = 5, // end of a rebuild interval: largest displacement since the last rebuild (double bits)
  counterMaxSpeed = 6,        // end of a rebuild interval: largest stone speed (double bits)
  counterCount = 7
};

// Raw pointers into host or device arrays; the same view drives both backends.
struct SystemView {
  int stoneCount;
  int nodeCount;
  int triangleCount;
  // stones (3 doubles per vector)
  double* position;
  double* velocity;                 // v^n after correct, v^{n+1/2} between predict and correct
  kernels::RotationState* rotation; // q, world ω (mid-step between predict and correct) and ZvW scratch
  double* force;
  double* torque;
  // Bounded rolling friction (Irazábal 2017 §5.2.1): Σ e_c |F_n| over the stone's contacts of the last evaluation
  // [N m], read by the next correct and predict; it acts on sphere stones only (a one-vertex core).
  double* rollingBudget;
  double* referencePosition; // position at the last neighbour rebuild
  const std::int32_t* shape;
  const ShapeData* shapes;
  const double* shapeVertices;
  // surface
  double* nodePosition;
  const double* nodeVelocity;
  const std::int32_t* triangles;
  const std::int32_t* triangleMaterial; // wall law index per triangle; null: wallLaws[0] for every triangle
  double* triangleForceSum;             // Σ over contacts and steps of the force on the triangle
  double* trianglePointSum;             // Σ |F| x_c
  double* triangleWeightSum;            // Σ |F|
  // contact candidates
  int maxPairs;
  int maxWalls;
  ContactSlot* pairSlots; // stoneCount × maxPairs
  // History of the normal sub-model per candidate slot (elasto-plastic Pohrt–Popov: F_max, δ_p), beside the slots so
  // that the 64-byte slot stays whole; null when the selected normal model keeps none (kernels::normalHistorySlots).
  kernels::NormalHistory* pairNormalHistory; // stoneCount × maxPairs, or null
  ContactOutput* pairOutput;
  std::int32_t* pairCount;
  ContactSlot* wallSlots;                    // stoneCount × maxWalls
  kernels::NormalHistory* wallNormalHistory; // stoneCount × maxWalls, or null
  ContactOutput* wallOutput;
  ContactGeometry* wallGeometry; // stoneCount × maxWalls: narrow-phase result of the current step
  std::int32_t* wallCount;
  // hashed uniform grid
  std::uint32_t* cellKey; // per stone, sorted in place with sortedStone
  std::int32_t* sortedStone;
  std::int32_t* cellStart; // per hash bucket, −1 when empty
  std::int32_t* cellEnd;
  std::uint32_t tableSize; // power of two
  double cellSize;         // ≥ the bounding diameter of every body but the large ones, plus the skin
  // Large bodies (bounding radius > largeRadius) are listed here, not found through the grid: each ordinary stone
  // lists those within reach as its partners, a large body only the large bodies after it.
  const std::int32_t* largeBodies;
  int largeCount;
  double largeRadius;
  // parameters
  double timeStep;
  Vec3 gravity;
  double damping; // non-viscous damping share (Parameters::damping); 0 in a physical run
  double skin;
  double featureTolerance; // fraction of r_d
  // Write pairOutput/wallOutput in this step. Only contacts() reads them, after a `step` call: the GPU
  // records them in the last step of each graph chunk (48 scattered bytes per contact and step saved in
  // the others); the CPU reference in every step.
  bool recordOutput;
  // The contact law of stone pairs and of stone–wall contacts per wall material (kernels/ContactLaw.hpp: sub-models
  // selected by keyword, materials mixed); R* and m* are set per contact.
  kernels::ContactLaw stoneLaw;
  kernels::ContactLaw wallLaws[maxWallMaterials];
  unsigned long long* counters;
};

// ---------------------------------------------------------------------------------------------------
// Small helpers shared by both passes.
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline Vec3 load3(const double* a, int i) { return Vec3{a[3 * i], a[3 * i + 1], a[3 * i + 2]}; }
RAILCOSIM_HOST_DEVICE inline void store3(double* a, int i, const Vec3& v) {
  a[3 * i] = v.x;
  a[3 * i + 1] = v.y;
  a[3 * i + 2] = v.z;
}

// Atomic accumulation: hardware atomics on the device, OpenMP atomics in the CPU reference.
// Contact point and force for contacts(), in the steps that record them (SystemView::recordOutput).
RAILCOSIM_HOST_DEVICE inline void writeContactOutput(const SystemView& s, ContactOutput& out, const Vec3& point,
                                                     const Vec3& force, double overlap) {
  if (!s.recordOutput) return;
  store3(out.point, 0, point);
  store3(out.force, 0, force);
  out.overlap = overlap;
}

RAILCOSIM_HOST_DEVICE inline void atomicAccumulate(double* address, double value) {
#if defined(RAILCOSIM_POLYHEDRA_DEVICE_PASS)
  atomicAdd(address, value);
#else
#pragma omp atomic
  *address += value;
#endif
}

RAILCOSIM_HOST_DEVICE inline void atomicAccumulate3(double* array, int i, const Vec3& v) {
  atomicAccumulate(array + 3 * i, v.x);
  atomicAccumulate(array + 3 * i + 1, v.y);
  atomicAccumulate(array + 3 * i + 2, v.z);
}

RAILCOSIM_HOST_DEVICE inline void atomicMaximum(unsigned long long* address, unsigned long long value) {
#if defined(RAILCOSIM_POLYHEDRA_DEVICE_PASS)
  atomicMax(address, value);
#else
  // Read-then-compare-and-swap loop without <atomic> on a plain array shared with the device layout.
#pragma omp critical(railcosimPolyhedraCounters)
  {
    if (*address < value) *address = value;
  }
#endif
}

RAILCOSIM_HOST_DEVICE inline void atomicIncrement(unsigned long long* address) {
#if defined(RAILCOSIM_POLYHEDRA_DEVICE_PASS)
  atomicAdd(address, 1ull);
#else
#pragma omp atomic
  *address += 1ull;
#endif
}

RAILCOSIM_HOST_DEVICE inline ConvexCore stoneCore(const SystemView& s, int i) {
  const ShapeData& shape = s.shapes[s.shape[i]];
  return ConvexCore{s.shapeVertices + 3 * shape.firstVertex, shape.vertexCount,
                    rotationMatrix(s.rotation[i].orientation), load3(s.position, i), nullptr};
}

// ---------------------------------------------------------------------------------------------------
// Integration: velocity Verlet for translation and the Zhao–van Wachem predictor–corrector for rotation,
// both from the shared kernels (kernels/RotationIntegrators.hpp, Irazábal 2017 §5.5 eqs. 5.47–5.55), split into
// PREDICT before and CORRECT after the force evaluation.
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline Vec3 principalInertia(const ShapeData& shape) {
  return Vec3{shape.inertia[0], shape.inertia[1], shape.inertia[2]};
}

// The torque that stone i's spin takes in a half kick from `omega`: the contacts' torque of the last evaluation
// plus, for a sphere with a rolling budget, the bounded rolling torque (kernels/BoundedRollingFriction.hpp). For a
// sphere (isotropic inertia, no gyroscopic term) both halves of Zhao–van Wachem are kicks ω += (Δt/2) T/I: the
// predictor's from ω^n with this evaluation's torque, the corrector's from ω^{n+1/2} (eq. 5.54a). Bounding each with
// h = Δt/2 stops a spin at zero and never reverses it. The corrector takes the body-frame spin of q^n and the torque
// in the frame of q^{n+1/2}; their difference leaves a stopped spin a residue of order |ω|Δt across the torque,
// which the next predictor's bound removes.
RAILCOSIM_HOST_DEVICE inline Vec3 halfKickTorque(const SystemView& s, int i, const ShapeData& shape,
                                                 const Vec3& omega) {
  const Vec3 torque = load3(s.torque, i);
  if (shape.vertexCount != 1) return torque;
  const double budget = s.rollingBudget[i];
  if (!(budget > 0.0)) return torque;
  return torque + kernels::boundedRollingTorque(omega, shape.inertia[0], 0.5 * s.timeStep, torque, budget);
}

// Non-viscous damping of a stone's translation (Cundall; YADE's NewtonIntegrator.damping): each component of the force
// (contacts and gravity) loses the share `damping` while it accelerates the stone along that axis and gains it while
// it brakes it, judged by the velocity at the start of each half kick (YADE: at the step's middle). It takes energy
// from a packing only; a physical run has damping = 0.
RAILCOSIM_HOST_DEVICE inline Vec3 dampedForce(Vec3 force, const Vec3& velocity, double damping) {
  if (damping == 0.0) return force;
  const auto share = [damping](double f, double v) {
    const double power = f * v;
    return 1.0 - damping * (power > 0.0 ? 1.0 : power < 0.0 ? -1.0 : 0.0);
  };
  force.x *= share(force.x, velocity.x);
  force.y *= share(force.y, velocity.y);
  force.z *= share(force.z, velocity.z);
  return force;
}

// `rotation`: stone i's rotation state, s.rotation[i] or a staged copy of it (the GPU stages a block's states
// through shared memory, since one thread per 240-byte state reads and writes them field by field).
RAILCOSIM_HOST_DEVICE inline void predictStone(const SystemView& s, int i, kernels::RotationState& rotation) {
  const ShapeData& shape = s.shapes[s.shape[i]];
  const double dt = s.timeStep;
  Vec3 velocity = load3(s.velocity, i);
  Vec3 position = load3(s.position, i);
  const Vec3 force = dampedForce(load3(s.force, i) + shape.mass * s.gravity, velocity, s.damping);
  kernels::velocityVerletHalfKick(velocity, force, shape.mass, dt);
  kernels::velocityVerletDrift(position, velocity, dt);
  store3(s.velocity, i, velocity);
  store3(s.position, i, position);
  kernels::zhaoVanWachemPredict(rotation, principalInertia(shape),
                                halfKickTorque(s, i, shape, rotation.angularVelocity), dt);
  // Forces of the next evaluation accumulate from zero.
  store3(s.force, i, Vec3{0.0, 0.0, 0.0});
  store3(s.torque, i, Vec3{0.0, 0.0, 0.0});
  s.rollingBudget[i] = 0.0;
  const Vec3 moved = position - load3(s.referencePosition, i);
  if (kernels::squaredNorm(moved) > 0.25 * s.skin * s.skin) atomicMaximum(&s.counters[counterDangerous], 1ull);
}

RAILCOSIM_HOST_DEVICE inline void correctStone(const SystemView& s, int i, kernels::RotationState& rotation) {
  const ShapeData& shape = s.shapes[s.shape[i]];
  Vec3 velocity = load3(s.velocity, i);
  const Vec3 force = dampedForce(load3(s.force, i) + shape.mass * s.gravity, velocity, s.damping);
  kernels::velocityVerletHalfKick(velocity, force, shape.mass, s.timeStep);
  store3(s.velocity, i, velocity);
  kernels::zhaoVanWachemCorrect(rotation, principalInertia(shape),
                                halfKickTorque(s, i, shape, rotation.angularVelocity), s.timeStep);
}

RAILCOSIM_HOST_DEVICE inline void predictStone(const SystemView& s, int i) { predictStone(s, i, s.rotation[i]); }
RAILCOSIM_HOST_DEVICE inline void correctStone(const SystemView& s, int i) { correctStone(s, i, s.rotation[i]); }

// Displacement of stone i since the last rebuild and its speed, for the stale test below.
RAILCOSIM_HOST_DEVICE inline void stoneMotion(const SystemView& s, int i, double& moved, double& speed) {
  moved = kernels::norm(load3(s.position, i) - load3(s.referencePosition, i));
  speed = kernels::norm(load3(s.velocity, i));
}

// Whether the lists may be outgrown before the next chance to rebuild them, `horizon` seconds away: the
// largest displacement since the last rebuild plus twice the way the fastest stone covers in the horizon
// (a stone at rest can be struck up to about that speed) exceeds half the skin (two stones approaching
// each other share the skin). Non-negative doubles order like their bit patterns, so the device keeps the
// maxima in integer counters.
inline bool listsStale(double maxDisplacement, double maxSpeed, double horizon, double skin) {
  return maxDisplacement + 2.0 * horizon * maxSpeed > 0.5 * skin;
}

// The stale test with moving walls (plates, a coupled surface): a stone–triangle gap closes by the stone's and the
// triangle's displacements, so the nodes' way since the last rebuild and their speed count as a stone's would.
inline bool listsStaleWithWalls(double maxDisplacement, double maxSpeed, double nodeMoved, double nodeSpeed,
                                double horizon, double skin) {
  return listsStale(maxDisplacement > nodeMoved ? maxDisplacement : nodeMoved,
                    maxSpeed > nodeSpeed ? maxSpeed : nodeSpeed, horizon, skin);
}

// Surface nodes move with their prescribed velocity during a coupling window.
RAILCOSIM_HOST_DEVICE inline void moveNode(const SystemView& s, int k) {
  store3(s.nodePosition, k, load3(s.nodePosition, k) + s.timeStep * load3(s.nodeVelocity, k));
}

// ---------------------------------------------------------------------------------------------------
// Broad phase: hashed uniform grid of cell size ≥ the largest bounding diameter + skin.
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline std::uint32_t cellHash(long long ix, long long iy, long long iz, std::uint32_t tableSize) {
  const std::uint64_t h = (static_cast<std::uint64_t>(ix) * 73856093ull) ^
                          (static_cast<std::uint64_t>(iy) * 19349663ull) ^
                          (static_cast<std::uint64_t>(iz) * 83492791ull);
  return static_cast<std::uint32_t>(h & (tableSize - 1));
}

RAILCOSIM_HOST_DEVICE inline void cellOf(const SystemView& s, const Vec3& x, long long& ix, long long& iy,
                                         long long& iz) {
  ix = static_cast<long long>(std::floor(x.x / s.cellSize));
  iy = static_cast<long long>(std::floor(x.y / s.cellSize));
  iz = static_cast<long long>(std::floor(x.z / s.cellSize));
}

RAILCOSIM_HOST_DEVICE inline void computeCellKey(const SystemView& s, int i) {
  long long ix, iy, iz;
  cellOf(s, load3(s.position, i), ix, iy, iz);
  s.cellKey[i] = cellHash(ix, iy, iz, s.tableSize);
  s.sortedStone[i] = i;
}

// After sorting (cellKey, sortedStone) by key: first and one-past-last sorted index of each bucket.
RAILCOSIM_HOST_DEVICE inline void findCellBounds(const SystemView& s, int k) {
  const std::uint32_t key = s.cellKey[k];
  if (k == 0 || s.cellKey[k - 1] != key) s.cellStart[key] = k;
  if (k == s.stoneCount - 1 || s.cellKey[k + 1] != key) s.cellEnd[key] = k + 1;
}

// Where partner `partner` stood in the previous list of stone i (−1 if absent), so that its history is carried over.
// Both lists come from the same cell scan, so their partners mostly appear in the same order: the search goes on
// from just after the last match (`cursor`, wrapping round), usually a single read instead of a scan of the old list.
RAILCOSIM_HOST_DEVICE inline int previousSlotIndex(const ContactSlot* previous, int previousCount, int partner,
                                                   int& cursor) {
  for (int n = 0; n < previousCount; ++n) {
    const int k = cursor + n < previousCount ? cursor + n : cursor + n - previousCount;
    if (previous[k].partner == partner) {
      cursor = k + 1 < previousCount ? k + 1 : 0;
      return k;
    }
  }
  return -1;
}

// Slot `count` of a new list for `partner`: the previous slot `k` (and its normal history, where one is kept), or a
// fresh one.
RAILCOSIM_HOST_DEVICE inline void carrySlot(ContactSlot* out, kernels::NormalHistory* outNormal, int count,
                                            const ContactSlot* previous, const kernels::NormalHistory* previousNormal,
                                            int k, int partner) {
  out[count] = k >= 0 ? previous[k] : ContactSlot{partner, 0, 0.0f, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0};
  if (outNormal) outNormal[count] = k >= 0 ? previousNormal[k] : kernels::NormalHistory{0.0, 0.0};
}

RAILCOSIM_HOST_DEVICE inline bool isLarge(const SystemView& s, int i) {
  return s.shapes[s.shape[i]].boundingRadius > s.largeRadius;
}

// Rebuilds the candidate lists of stone i from the sorted grid (partners j > i within the bounding
// distance plus skin; large bodies from their own list, see SystemView::largeBodies) and the triangle
// candidates, carrying the contact history over by partner id.
// `previous*NormalHistory`: the normal histories of the previous lists (null where none is kept).
RAILCOSIM_HOST_DEVICE inline void buildNeighbours(const SystemView& s, int i, const ContactSlot* previousPairs,
                                                  const std::int32_t* previousPairCount,
                                                  const ContactSlot* previousWalls,
                                                  const std::int32_t* previousWallCount,
                                                  const kernels::NormalHistory* previousPairNormalHistory,
                                                  const kernels::NormalHistory* previousWallNormalHistory) {
  const Vec3 x = load3(s.position, i);
  const double radius = s.shapes[s.shape[i]].boundingRadius;
  long long cx, cy, cz;
  cellOf(s, x, cx, cy, cz);
  const long long pairBase = static_cast<long long>(i) * s.maxPairs;
  ContactSlot* out = s.pairSlots + pairBase;
  const ContactSlot* old = previousPairs + pairBase;
  kernels::NormalHistory* outNormal = s.pairNormalHistory ? s.pairNormalHistory + pairBase : nullptr;
  const kernels::NormalHistory* oldNormal = s.pairNormalHistory ? previousPairNormalHistory + pairBase : nullptr;
  const int oldCount = previousPairCount[i];
  int count = 0;
  int needed = 0;
  int cursor = 0;
  const bool large = isLarge(s, i);
  auto consider = [&](int j) {
    const double reach = radius + s.shapes[s.shape[j]].boundingRadius + s.skin;
    if (kernels::squaredNorm(load3(s.position, j) - x) > reach * reach) return;
    ++needed;
    if (count < s.maxPairs) {
      carrySlot(out, outNormal, count, old, oldNormal, previousSlotIndex(old, oldCount, j, cursor), j);
      ++count;
    }
  };
  // Hash collisions can map two of the 27 cells to one bucket: remember visited buckets.
  std::uint32_t visited[27];
  int visitedCount = 0;
  for (int dz = large ? 2 : -1; dz <= 1; ++dz) { // a large body scans no cell
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const std::uint32_t bucket = cellHash(cx + dx, cy + dy, cz + dz, s.tableSize);
        bool seen = false;
        for (int k = 0; k < visitedCount; ++k) seen = seen || visited[k] == bucket;
        if (seen) continue;
        visited[visitedCount++] = bucket;
        const int start = s.cellStart[bucket];
        if (start < 0) continue;
        const int end = s.cellEnd[bucket];
        for (int k = start; k < end; ++k) {
          const int j = s.sortedStone[k];
          if (j > i && !isLarge(s, j)) consider(j);
        }
      }
    }
  }
  for (int n = 0; n < s.largeCount; ++n) {
    const int j = s.largeBodies[n];
    if (!large || j > i) consider(j);
  }
  s.pairCount[i] = count;
  if (needed > s.maxPairs) atomicMaximum(&s.counters[counterPairOverflow], static_cast<unsigned long long>(needed));

  const long long wallBase = static_cast<long long>(i) * s.maxWalls;
  ContactSlot* wallOut = s.wallSlots + wallBase;
  const ContactSlot* wallOld = previousWalls + wallBase;
  kernels::NormalHistory* wallOutNormal = s.wallNormalHistory ? s.wallNormalHistory + wallBase : nullptr;
  const kernels::NormalHistory* wallOldNormal = s.wallNormalHistory ? previousWallNormalHistory + wallBase : nullptr;
  const int wallOldCount = previousWallCount[i];
  int wallCount = 0;
  int wallNeeded = 0;
  int wallCursor = 0;
  for (int t = 0; t < s.triangleCount; ++t) {
    const Vec3 a = load3(s.nodePosition, s.triangles[3 * t]);
    const Vec3 b = load3(s.nodePosition, s.triangles[3 * t + 1]);
    const Vec3 c = load3(s.nodePosition, s.triangles[3 * t + 2]);
    const double reach = radius + s.skin;
    if (kernels::squaredNorm(closestPointOnTriangle(x, a, b, c) - x) > reach * reach) continue;
    ++wallNeeded;
    if (wallCount < s.maxWalls) {
      carrySlot(wallOut, wallOutNormal, wallCount, wallOld, wallOldNormal,
                previousSlotIndex(wallOld, wallOldCount, t, wallCursor), t);
      ++wallCount;
    }
  }
  s.wallCount[i] = wallCount;
  if (wallNeeded > s.maxWalls)
    atomicMaximum(&s.counters[counterWallOverflow], static_cast<unsigned long long>(wallNeeded));
  store3(s.referencePosition, i, x);
}

// ---------------------------------------------------------------------------------------------------
// Narrow phase and contact law of one candidate, as two steps: the geometry (GJK) first, the kinematics
// and the force law only for candidates in contact (most candidates are not, and on the GPU the
// kinematics of both bodies held across GJK would only add to its register demand).
// ---------------------------------------------------------------------------------------------------
struct ContactKinematics {
  Vec3 velocity; // of the body's reference point [m/s]
  Vec3 omega;    // world angular velocity [rad/s]
  Vec3 centre;   // reference point for the lever arm [m]
};

struct ContactResult {
  bool active;
  double overlap;
  Vec3 normal; // A -> B
  Vec3 point;
  Vec3 forceOnB;
};

// Releases the history of a candidate whose dilated bodies are apart; `axis` (unit, A -> B, along which
// they were proven apart) is kept in the normal field as the next test axis and GJK warm start.
RAILCOSIM_HOST_DEVICE inline void releaseContact(ContactSlot& slot, const Vec3& axis) {
  slot.active = 0;
  slot.elasticShear[0] = slot.elasticShear[1] = slot.elasticShear[2] = 0.0;
  slot.tangentialStiffness = 0.0f;
  slot.normal[0] = axis.x;
  slot.normal[1] = axis.y;
  slot.normal[2] = axis.z;
}

RAILCOSIM_HOST_DEVICE inline Vec3 slotNormal(const ContactSlot& slot) {
  return Vec3{slot.normal[0], slot.normal[1], slot.normal[2]};
}

RAILCOSIM_HOST_DEVICE inline bool hasSlotNormal(const ContactSlot& slot) {
  return kernels::squaredNorm(slotNormal(slot)) > 0.5;
}

// Separating-axis test along the slot's last normal or separating axis: the cores are at least
// max_B(−n·x) − max_A(n·x) apart, so the dilated bodies are apart when that reaches r_A + r_B (the same
// criterion as GJK's early exit). Two support scans instead of a GJK run: between neighbour-list rebuilds
// most candidates that were apart at the last step are still apart along the same axis.
RAILCOSIM_HOST_DEVICE inline bool provenApartAlongSlotAxis(const ConvexCore& A, const ConvexCore& B, double reach,
                                                           const ContactSlot& slot) {
  if (!hasSlotNormal(slot)) return false;
  return -coreOverlapAlong(A, B, slotNormal(slot)) >= reach;
}

// Contact geometry from the core distance `d` (GJK's or an exact special case's): normal, overlap and contact
// point, or the slot's history released when the dilated bodies are apart. `guess`: the normal kept when the
// cores intersect.
RAILCOSIM_HOST_DEVICE inline ContactGeometry geometryFromDistance(const ConvexCore& A, const ConvexCore& B,
                                                                  double radiusA, double radiusB, const CoreDistance& d,
                                                                  const Vec3& guess, double featureTolerance,
                                                                  ContactSlot& slot, unsigned long long* counters) {
  ContactGeometry result{false, 0.0, Vec3{0.0, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}, false};
  slot.simplex = d.simplex;
  if (d.unfinished) {
    result.unfinished = true;
    return result;
  }
  Vec3 n;
  double gap;
  Vec3 midpoint;
  if (d.beyondCutoff || (!d.intersecting && d.distance > 1e-12 * (radiusA + radiusB))) {
    if (d.beyondCutoff || d.distance >= radiusA + radiusB) { // dilated bodies apart: the history is released
      releaseContact(slot, d.beyondCutoff ? d.axis : (d.pointB - d.pointA) / d.distance);
      return result;
    }
    n = (d.pointB - d.pointA) / d.distance;
    gap = d.distance;
    midpoint = 0.5 * (d.pointA + d.pointB);
  } else {
    // Cores touch or intersect: far beyond the intended overlap (δ ≥ r_A + r_B). Keep the last normal
    // (or the centre line) and measure the core overlap along it; counted so the user can react.
    atomicIncrement(&counters[counterCoreOverlap]);
    n = guess / kernels::norm(guess);
    gap = -coreOverlapAlong(A, B, n);
    midpoint = 0.5 * (support(A, n) + support(B, -n));
  }
  const double overlap = radiusA + radiusB - gap; // Ullrich 2022 eq. 2.5: δ = r_A + r_B − Δ
  // Mid-plane of the overlapping dilation spheres, measured along n from A's core surface.
  const double planeHeight = kernels::dot(midpoint, n) + 0.5 * (radiusA - radiusB);
  const Vec3 fallback = midpoint + (0.5 * (radiusA - radiusB)) * n;
  // Feature band: a fraction of the smaller positive dilation radius (a flat wall has none).
  const double bandRadius = radiusB > 0.0 && radiusB < radiusA ? radiusB : radiusA;
  result.touching = true;
  result.overlap = overlap;
  result.normal = n;
  result.point = featureTolerance > 0.0
                     ? contactPatchCentre(A, B, n, planeHeight, fallback, featureTolerance * bandRadius)
                     : fallback;
  return result;
}

// Narrow phase: distance of the cores A and B dilated by radiusA and radiusB (GJK, warm-started from the
// slot's simplex or normal), normal, overlap and contact point; releases the slot's history when they are
// apart. With an iterationLimit GJK may stop unfinished (see ContactGeometry::unfinished); calling again
// with the updated slot resumes it.
RAILCOSIM_HOST_DEVICE inline ContactGeometry contactGeometry(const ConvexCore& A, const ConvexCore& B, double radiusA,
                                                             double radiusB, const Vec3& centreLine,
                                                             double featureTolerance, ContactSlot& slot,
                                                             unsigned long long* counters, int iterationLimit = 64) {
  const Vec3 guess = hasSlotNormal(slot) ? slotNormal(slot) : centreLine;
  const CoreDistance d = coreDistance(A, B, guess, radiusA + radiusB, slot.simplex, iterationLimit);
  return geometryFromDistance(A, B, radiusA, radiusB, d, guess, featureTolerance, slot, counters);
}

// Contact law of a touching candidate: the composed law of kernels/ContactLaw.hpp for this contact's R* and m*;
// updates the slot's history (and the normal history, where the law keeps one) and returns the force on B.
// effectiveRadius: Hertz curvature of the dilation (Ullrich 2022 eq. 2.20: the dilating spheres touch, so
// R* = r_A r_B / (r_A + r_B); r_A for a flat wall).
RAILCOSIM_HOST_DEVICE inline Vec3 contactForce(const ContactGeometry& g, double effectiveRadius, double effectiveMass,
                                               const kernels::ContactLaw& pairLaw, const ContactKinematics& kinematicsA,
                                               const ContactKinematics& kinematicsB, double timeStep, ContactSlot& slot,
                                               kernels::NormalHistory* normalHistory, double* rollingMoment = nullptr) {
  const Vec3 n = g.normal;
  const Vec3 velocityA = kinematicsA.velocity + kernels::cross(kinematicsA.omega, g.point - kinematicsA.centre);
  const Vec3 velocityB = kinematicsB.velocity + kernels::cross(kinematicsB.omega, g.point - kinematicsB.centre);
  const Vec3 relative = velocityB - velocityA; // of B with respect to A at the contact point
  const Vec3 tangentialVelocity = kernels::tangentialPart(relative, n);

  kernels::ContactLaw law = pairLaw;
  kernels::setContactGeometry(law, effectiveRadius, effectiveMass);
  kernels::ContactHistory history{Vec3{0.0, 0.0, 0.0}, 0.0, kernels::NormalHistory{0.0, 0.0}};
  if (slot.active) {
    history.elasticShearForce = Vec3{slot.elasticShear[0], slot.elasticShear[1], slot.elasticShear[2]};
    history.previousTangentialStiffness = slot.tangentialStiffness;
    if (normalHistory) history.normal = *normalHistory;
  }
  const kernels::ContactStiffness stiffness = kernels::contactStiffness(law, history.normal, g.overlap);
  // The slot keeps the last k_t in single precision. The unloading correction is one-sided (it scales the spring
  // whenever the stiffness fell), so an unchanged stiffness must compare equal: a rounded-up copy would shrink a
  // static spring by up to 3e-8 every step (3 % per 1e6 steps).
  if (slot.active && static_cast<float>(stiffness.tangential) == slot.tangentialStiffness)
    history.previousTangentialStiffness = stiffness.tangential;
  const kernels::ContactKinematics kinematics{g.overlap, -kernels::dot(relative, n), n, timeStep * tangentialVelocity,
                                              tangentialVelocity};
  const kernels::ContactLawResult r = kernels::contactLawForces(law, history, kinematics, stiffness);

  slot.active = 1;
  slot.elasticShear[0] = r.history.elasticShearForce.x;
  slot.elasticShear[1] = r.history.elasticShearForce.y;
  slot.elasticShear[2] = r.history.elasticShearForce.z;
  slot.normal[0] = n.x;
  slot.normal[1] = n.y;
  slot.normal[2] = n.z;
  slot.tangentialStiffness = static_cast<float>(r.history.previousTangentialStiffness);
  if (normalHistory) *normalHistory = r.history.normal;
  if (rollingMoment) *rollingMoment = r.rollingResistanceMoment;
  return r.normalForce * n + r.shearForce;
}

// Both steps for one candidate: the history slot is updated and the force on B returned (−force acts on A).
RAILCOSIM_HOST_DEVICE inline ContactResult evaluateContact(
    const ConvexCore& A, const ConvexCore& B, double radiusA, double radiusB, double effectiveRadius,
    double effectiveMass, const kernels::ContactLaw& law, const ContactKinematics& kinematicsA,
    const ContactKinematics& kinematicsB, double timeStep, double featureTolerance, ContactSlot& slot,
    unsigned long long* counters, kernels::NormalHistory* normalHistory = nullptr) {
  const ContactGeometry g = contactGeometry(A, B, radiusA, radiusB, kinematicsB.centre - kinematicsA.centre,
                                            featureTolerance, slot, counters);
  if (!g.touching) return ContactResult{false, 0.0, Vec3{0.0, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}, Vec3{0.0, 0.0, 0.0}};
  const Vec3 force =
      contactForce(g, effectiveRadius, effectiveMass, law, kinematicsA, kinematicsB, timeStep, slot, normalHistory);
  return ContactResult{true, g.overlap, g.normal, g.point, force};
}

// ---------------------------------------------------------------------------------------------------
// Stone pairs: one candidate slot at a time (slot `index` = i · maxPairs + k of stone i's list), so that
// the GPU can give each candidate its own thread. The CPU reference runs the same two functions per slot.
// ---------------------------------------------------------------------------------------------------

// True when candidate `index` of stone i is proven apart without GJK: bounding spheres apart, or (for a
// candidate not in contact at the last step) the slot's axis still separating the cores by r_A + r_B. Its
// history is then released.
RAILCOSIM_HOST_DEVICE inline bool pairProvenApart(const SystemView& s, int i, long long index) {
  ContactSlot& slotRef = s.pairSlots[index];
  const int partner = slotRef.partner;
  const ShapeData& shapeA = s.shapes[s.shape[i]];
  const ShapeData& shapeB = s.shapes[s.shape[partner]];
  const Vec3 xA = load3(s.position, i), xB = load3(s.position, partner);
  const double reach = shapeA.boundingRadius + shapeB.boundingRadius;
  bool apart = kernels::squaredNorm(xB - xA) >= reach * reach; // bounding spheres apart
  if (!apart) {
    const ContactSlot slot = slotRef;
    // A contact active at the last step is almost always still one, and its narrow phase decides the
    // rare separation anyway (GJK's cutoff exit): the axis test would be two wasted support scans.
    if (slot.active || !hasSlotNormal(slot)) return false;
    apart = provenApartAlongSlotAxis(stoneCore(s, i), stoneCore(s, partner),
                                     shapeA.dilationRadius + shapeB.dilationRadius, slot);
  }
  if (apart && slotRef.active) {
    slotRef.active = 0;
    slotRef.elasticShear[0] = slotRef.elasticShear[1] = slotRef.elasticShear[2] = 0.0;
    slotRef.tangentialStiffness = 0.0f;
  }
  return apart;
}

// Support points a pair's GJK may add in the first pass before it is deferred. Warm-started from the last
// simplex, 97 % of the pair runs in the packed benchmark bed end at the first support test (the rest need
// 1–11 more iterations), and a GPU warp waits for its slowest lane. With 0 the first pass is only that
// test: its code holds no simplex growth (fewer registers), and the runs that must go on resume from the
// unchanged starting simplex in a second pass (on the GPU a second kernel over just those), so the long
// searches share warps with each other. The resumed run repeats the test and continues exactly as one
// undivided run would; the CPU reference makes the same two calls.
#ifndef RAILCOSIM_POLYHEDRA_PAIR_FIRST_PASS_ITERATIONS
#define RAILCOSIM_POLYHEDRA_PAIR_FIRST_PASS_ITERATIONS 0
#endif
constexpr int pairFirstPassIterations = RAILCOSIM_POLYHEDRA_PAIR_FIRST_PASS_ITERATIONS;

enum class PairOutcome { apart, touching, deferred };

// Narrow phase and contact law of candidate `index` of stone i; adds the force and torque to both stones
// (atomically: other threads add to the same stones) and writes the contact output. With an iteration
// limit the outcome may be `deferred`: nothing applied yet, the slot holds the simplex to resume from.
RAILCOSIM_HOST_DEVICE inline PairOutcome pairContact(const SystemView& s, int i, long long index,
                                                     int iterationLimit = 64) {
  ContactSlot slot = s.pairSlots[index];
  const int partner = slot.partner;
  const bool wasActive = slot.active != 0;
  const ShapeData& shapeA = s.shapes[s.shape[i]];
  const ShapeData& shapeB = s.shapes[s.shape[partner]];
  const ConvexCore coreA = stoneCore(s, i);
  const ConvexCore coreB = stoneCore(s, partner);
  const ContactGeometry g =
      contactGeometry(coreA, coreB, shapeA.dilationRadius, shapeB.dilationRadius, coreB.position - coreA.position,
                      s.featureTolerance, slot, s.counters, iterationLimit);
  if (!g.touching) {
    // Not touching and not touching before: only the axis and the simplex changed (the spring and the
    // overlap stay zero), so only they are written.
    if (wasActive) {
      s.pairSlots[index] = slot;
    } else {
      ContactSlot& stored = s.pairSlots[index];
      stored.normal[0] = slot.normal[0];
      stored.normal[1] = slot.normal[1];
      stored.normal[2] = slot.normal[2];
      stored.simplex = slot.simplex;
    }
    return g.unfinished ? PairOutcome::deferred : PairOutcome::apart;
  }
  const ContactKinematics kinematicsA{load3(s.velocity, i), s.rotation[i].angularVelocity, load3(s.position, i)};
  const ContactKinematics kinematicsB{load3(s.velocity, partner), s.rotation[partner].angularVelocity,
                                      load3(s.position, partner)};
  double rollingMoment = 0.0;
  const Vec3 force =
      contactForce(g, kernels::effectiveRadius(shapeA.dilationRadius, shapeB.dilationRadius),
                   kernels::effectiveMass(shapeA.mass, shapeB.mass), s.stoneLaw, kinematicsA, kinematicsB, s.timeStep,
                   slot, s.pairNormalHistory ? s.pairNormalHistory + index : nullptr, &rollingMoment);
  s.pairSlots[index] = slot;
  const bool sphereA = shapeA.vertexCount == 1, sphereB = shapeB.vertexCount == 1;
  if (rollingMoment > 0.0 && (sphereA || sphereB)) {
    // Between two spheres the arm is η_r R* (eq. 5.2); a sphere on a polyhedron rolls on a locally flat face, as on a
    // wall (YADE counts a non-sphere as flat): η_r R_sphere. Only spheres take the torque, so only they are summed.
    const double armScale = sphereA && sphereB
                                ? 1.0
                                : (sphereA ? shapeA.dilationRadius : shapeB.dilationRadius) /
                                      kernels::effectiveRadius(shapeA.dilationRadius, shapeB.dilationRadius);
    if (sphereA) atomicAccumulate(s.rollingBudget + i, armScale * rollingMoment);
    if (sphereB) atomicAccumulate(s.rollingBudget + partner, armScale * rollingMoment);
  }
  writeContactOutput(s, s.pairOutput[index], g.point, force, g.overlap);
  atomicAccumulate3(s.force, partner, force);
  atomicAccumulate3(s.torque, partner, kernels::cross(g.point - kinematicsB.centre, force));
  atomicAccumulate3(s.force, i, -force);
  atomicAccumulate3(s.torque, i, -kernels::cross(g.point - kinematicsA.centre, force));
  return PairOutcome::touching;
}

// Both passes of candidate `index` of stone i in one call (the CPU reference's order of work per candidate).
RAILCOSIM_HOST_DEVICE inline bool pairContactBothPasses(const SystemView& s, int i, long long index) {
  PairOutcome outcome = pairContact(s, i, index, pairFirstPassIterations);
  if (outcome == PairOutcome::deferred) outcome = pairContact(s, i, index);
  return outcome == PairOutcome::touching;
}

// ---------------------------------------------------------------------------------------------------
// Wall triangles, in two passes: the narrow phase per candidate slot (`index` = i · maxWalls + k; on the
// GPU one thread each), its result kept in wallGeometry; then the contact law per stone, because one flat
// region of the surface split into several coplanar triangles must act once, not once per triangle: a
// contact with the same normal and overlap as an accepted one is a duplicate (active = 2).
// ---------------------------------------------------------------------------------------------------
RAILCOSIM_HOST_DEVICE inline ConvexCore triangleCore(const SystemView& s, int triangle) {
  // The triangle as a 3-vertex core read straight from the node array through its connectivity.
  return ConvexCore{s.nodePosition, 3, Rotation{{1, 0, 0, 0, 1, 0, 0, 0, 1}}, Vec3{0.0, 0.0, 0.0},
                    s.triangles + 3 * triangle};
}

// Point of triangle t nearest to x: lever arm and barycentric wall velocity of a wall contact.
RAILCOSIM_HOST_DEVICE inline Vec3 nearestOnTriangle(const SystemView& s, int t, const Vec3& x) {
  return railcosim::closestPointOnTriangle(x, load3(s.nodePosition, s.triangles[3 * t]),
                                           load3(s.nodePosition, s.triangles[3 * t + 1]),
                                           load3(s.nodePosition, s.triangles[3 * t + 2]));
}

// True when wall candidate `index` of stone i is proven apart along the slot's axis (history released,
// no-contact geometry recorded).
RAILCOSIM_HOST_DEVICE inline bool wallProvenApart(const SystemView& s, int i, long long index) {
  const ContactSlot slot = s.wallSlots[index];
  if (!hasSlotNormal(slot)) return false;
  if (!provenApartAlongSlotAxis(stoneCore(s, i), triangleCore(s, slot.partner), s.shapes[s.shape[i]].dilationRadius,
                                slot))
    return false;
  if (slot.active) {
    ContactSlot& slotRef = s.wallSlots[index];
    slotRef.active = 0;
    slotRef.elasticShear[0] = slotRef.elasticShear[1] = slotRef.elasticShear[2] = 0.0;
    slotRef.tangentialStiffness = 0.0f;
  }
  s.wallGeometry[index].touching = false;
  return true;
}

// Adds a wall contact's force to the sums of triangle t (force, |F| x_c and |F|). Many stones rest on one
// floor triangle: on the device the lanes of a warp that hit the same triangle first add among themselves,
// so that one atomic per triangle and warp reaches each shared address instead of one per contact.
RAILCOSIM_HOST_DEVICE inline void accumulateTriangleSums(const SystemView& s, int t, const Vec3& force,
                                                         const Vec3& point) {
  const double magnitude = kernels::norm(force);
  const Vec3 weighted = magnitude * point;
#if defined(RAILCOSIM_POLYHEDRA_DEVICE_PASS)
  addTriangleSumsWarpAggregated(t, force, weighted, magnitude, s.triangleForceSum, s.trianglePointSum,
                                s.triangleWeightSum);
#else
  atomicAccumulate3(s.triangleForceSum, t, force);
  atomicAccumulate3(s.trianglePointSum, t, weighted);
  atomicAccumulate(s.triangleWeightSum + t, magnitude);
#endif
}

// Narrow phase of wall candidate `index` of stone i, kept in wallGeometry: the exact plane test when the
// stone's lowest vertex lies over the triangle's interior (a stone on a floor or surface element), GJK
// otherwise. GJK against a large triangle cannot meet its relative tolerance (the Minkowski points carry the
// far vertices' roundoff) and ran 2.3 iterations on average to its no-progress stop (3 for most floor
// contacts, measured on the benchmark bed); the plane test is one support scan.
RAILCOSIM_HOST_DEVICE inline void wallNarrowPhase(const SystemView& s, int i, long long index) {
  ContactSlot slot = s.wallSlots[index];
  const ConvexCore coreA = stoneCore(s, i);
  const ConvexCore triangle = triangleCore(s, slot.partner);
  const double radius = s.shapes[s.shape[i]].dilationRadius;
  CoreDistance d;
  Vec3 guess;
  if (coreOverTriangleInterior(coreA, triangle, d)) {
    guess = d.pointB - d.pointA;
  } else {
    guess =
        hasSlotNormal(slot) ? slotNormal(slot) : nearestOnTriangle(s, slot.partner, coreA.position) - coreA.position;
    d = coreDistance(coreA, triangle, guess, radius, slot.simplex);
  }
  const ContactGeometry g =
      geometryFromDistance(coreA, triangle, radius, 0.0, d, guess, s.featureTolerance, slot, s.counters);
  // Apart: the released slot. Touching: only the new simplex (the law pass reads the slot and writes the
  // rest), so that the next step's GJK starts from this step's features.
  if (g.touching) {
    s.wallSlots[index].simplex = slot.simplex;
  } else {
    s.wallSlots[index] = slot;
  }
  s.wallGeometry[index] = g;
}

// Contact law of the wall contacts of stone i found by the narrow phase; returns the active contacts.
RAILCOSIM_HOST_DEVICE inline int stoneWallForces(const SystemView& s, int i) {
  const int total = s.wallCount[i];
  if (total == 0) return 0;
  const ShapeData& shapeA = s.shapes[s.shape[i]];
  const Vec3 xA = load3(s.position, i);
  Vec3 forceA{0.0, 0.0, 0.0}, torqueA{0.0, 0.0, 0.0};
  double rollingA = 0.0;
  int active = 0;
  constexpr int maxAccepted = 4;
  Vec3 acceptedNormal[maxAccepted];
  double acceptedOverlap[maxAccepted];
  int acceptedCount = 0;
  for (int k = 0; k < total; ++k) {
    const long long index = static_cast<long long>(i) * s.maxWalls + k;
    const ContactGeometry g = s.wallGeometry[index];
    if (!g.touching) continue;
    ContactSlot slot = s.wallSlots[index];
    const int partner = slot.partner;
    const int n0 = s.triangles[3 * partner], n1 = s.triangles[3 * partner + 1], n2 = s.triangles[3 * partner + 2];
    const Vec3 a = load3(s.nodePosition, n0), b = load3(s.nodePosition, n1), c = load3(s.nodePosition, n2);
    // The triangle's point nearest the stone's centre: lever arm and barycentric wall velocity.
    const BarycentricWeights weights = closestPointWeights(xA, a, b, c);
    const Vec3 nearest = pointAt(weights, a, b, c);
    const Vec3 velocity = weights[0] * load3(s.nodeVelocity, n0) + weights[1] * load3(s.nodeVelocity, n1) +
                          weights[2] * load3(s.nodeVelocity, n2);
    // A flat rigid wall has no rotation, so its lever arm is irrelevant; no dilation: R* = r_A, m* = m_A.
    const ContactKinematics kinematicsA{load3(s.velocity, i), s.rotation[i].angularVelocity, xA};
    const ContactKinematics kinematicsB{velocity, Vec3{0.0, 0.0, 0.0}, nearest};
    // A duplicate keeps its tangential spring up to date too (it takes over when its twin separates).
    const kernels::ContactLaw& wallLaw = s.wallLaws[s.triangleMaterial ? s.triangleMaterial[partner] : 0];
    double rollingMoment = 0.0;
    const Vec3 force =
        contactForce(g, shapeA.dilationRadius, shapeA.mass, wallLaw, kinematicsA, kinematicsB, s.timeStep, slot,
                     s.wallNormalHistory ? s.wallNormalHistory + index : nullptr, &rollingMoment);
    bool duplicate = false;
    for (int m = 0; m < acceptedCount; ++m) {
      duplicate = duplicate || (kernels::dot(acceptedNormal[m], g.normal) > 1.0 - 1e-9 &&
                                std::fabs(acceptedOverlap[m] - g.overlap) <= 1e-9 * shapeA.dilationRadius);
    }
    if (duplicate) {
      slot.active = 2;
      s.wallSlots[index] = slot;
      continue;
    }
    if (acceptedCount < maxAccepted) {
      acceptedNormal[acceptedCount] = g.normal;
      acceptedOverlap[acceptedCount] = g.overlap;
      ++acceptedCount;
    }
    s.wallSlots[index] = slot;
    ++active;
    writeContactOutput(s, s.wallOutput[index], g.point, force, g.overlap);
    forceA -= force;
    torqueA -= kernels::cross(g.point - xA, force);
    rollingA += rollingMoment;
    accumulateTriangleSums(s, partner, force, g.point);
  }
  if (active > 0) {
    atomicAccumulate3(s.force, i, forceA);
    atomicAccumulate3(s.torque, i, torqueA);
    if (rollingA > 0.0 && shapeA.vertexCount == 1) atomicAccumulate(s.rollingBudget + i, rollingA);
  }
  return active;
}

RAILCOSIM_HOST_DEVICE inline void addActiveContacts(const SystemView& s, unsigned long long count) {
  if (count == 0) return;
#if defined(RAILCOSIM_POLYHEDRA_DEVICE_PASS)
  atomicAdd(&s.counters[counterActive], count);
#else
#pragma omp atomic
  s.counters[counterActive] += count;
#endif
}

// All candidates of stone i in one loop (the CPU reference; the GPU runs the same per-slot functions in
// separate kernels).
RAILCOSIM_HOST_DEVICE inline void stoneForces(const SystemView& s, int i) {
  int active = 0;
  const int pairCount = s.pairCount[i];
  for (int k = 0; k < pairCount; ++k) {
    const long long index = static_cast<long long>(i) * s.maxPairs + k;
    if (!pairProvenApart(s, i, index) && pairContactBothPasses(s, i, index)) ++active;
  }
  const int wallCount = s.wallCount[i];
  for (int k = 0; k < wallCount; ++k) {
    const long long index = static_cast<long long>(i) * s.maxWalls + k;
    if (!wallProvenApart(s, i, index)) wallNarrowPhase(s, i, index);
  }
  active += stoneWallForces(s, i);
  addActiveContacts(s, static_cast<unsigned long long>(active));
}

} // namespace railcosim::polyhedra
