// CPU reference backend: the per-stone functions of PolyhedraStep.hpp in OpenMP loops (also the fallback).
#include <algorithm>
#include <cstring>
#include <numeric>

#include "polyhedra/PolyhedraBackend.hpp"

namespace railcosim::polyhedra {

void HostData::allocate() {
  const std::size_t n = static_cast<std::size_t>(stoneCount);
  auto resize = [](std::vector<double>& a, std::size_t size) { a.resize(size, 0.0); };
  resize(force, 3 * n);
  resize(torque, 3 * n);
  resize(rollingBudget, n);
  resize(referencePosition, 3 * n);
  const ContactSlot empty{-1, 0, 0.0f, {0, 0, 0}, {0, 0, 0}, 0};
  pairSlots.assign(n * maxPairs, empty);
  pairSlotsPrevious.assign(n * maxPairs, empty);
  wallSlots.assign(n * maxWalls, empty);
  wallSlotsPrevious.assign(n * maxWalls, empty);
  const kernels::NormalHistory fresh{0.0, 0.0};
  const bool pairHistory = kernels::normalHistorySlots(stoneLaw.config) > 0;
  const bool wallHistory = wallNormalHistoryKept();
  pairNormalHistory.assign(pairHistory ? n * maxPairs : 0, fresh);
  pairNormalHistoryPrevious.assign(pairHistory ? n * maxPairs : 0, fresh);
  wallNormalHistory.assign(wallHistory ? n * maxWalls : 0, fresh);
  wallNormalHistoryPrevious.assign(wallHistory ? n * maxWalls : 0, fresh);
  pairOutput.assign(n * maxPairs, ContactOutput{});
  wallOutput.assign(n * maxWalls, ContactOutput{});
  wallGeometry.assign(n * maxWalls, ContactGeometry{});
  pairCount.assign(n, 0);
  pairCountPrevious.assign(n, 0);
  wallCount.assign(n, 0);
  wallCountPrevious.assign(n, 0);
  cellKey.assign(n, 0);
  sortedStone.assign(n, 0);
  tableSize = 1024;
  while (tableSize < 2 * n) tableSize *= 2;
  cellStart.assign(tableSize, -1);
  cellEnd.assign(tableSize, -1);
  const std::size_t t = static_cast<std::size_t>(triangleCount());
  triangleForceSum.assign(3 * t, 0.0);
  trianglePointSum.assign(3 * t, 0.0);
  triangleWeightSum.assign(t, 0.0);
  if (nodeVelocity.size() != nodePosition.size()) nodeVelocity.assign(nodePosition.size(), 0.0);
}

bool HostData::wallNormalHistoryKept() const {
  for (int k = 0; k < wallLawCount; ++k)
    if (kernels::normalHistorySlots(wallLaws[k].config) > 0) return true;
  return false;
}

SystemView HostData::view() {
  SystemView v{};
  v.stoneCount = stoneCount;
  v.nodeCount = nodeCount();
  v.triangleCount = triangleCount();
  v.position = position.data();
  v.velocity = velocity.data();
  v.rotation = rotation.data();
  v.force = force.data();
  v.torque = torque.data();
  v.rollingBudget = rollingBudget.data();
  v.referencePosition = referencePosition.data();
  v.shape = shape.data();
  v.shapes = shapes.data();
  v.shapeVertices = shapeVertices.data();
  v.nodePosition = nodePosition.data();
  v.nodeVelocity = nodeVelocity.data();
  v.triangles = triangles.data();
  v.triangleMaterial = triangleMaterial.empty() ? nullptr : triangleMaterial.data();
  v.triangleForceSum = triangleForceSum.data();
  v.trianglePointSum = trianglePointSum.data();
  v.triangleWeightSum = triangleWeightSum.data();
  v.maxPairs = maxPairs;
  v.maxWalls = maxWalls;
  v.pairSlots = pairSlots.data();
  v.pairNormalHistory = pairNormalHistory.empty() ? nullptr : pairNormalHistory.data();
  v.pairOutput = pairOutput.data();
  v.pairCount = pairCount.data();
  v.wallSlots = wallSlots.data();
  v.wallNormalHistory = wallNormalHistory.empty() ? nullptr : wallNormalHistory.data();
  v.wallOutput = wallOutput.data();
  v.wallGeometry = wallGeometry.data();
  v.wallCount = wallCount.data();
  v.cellKey = cellKey.data();
  v.sortedStone = sortedStone.data();
  v.cellStart = cellStart.data();
  v.cellEnd = cellEnd.data();
  v.tableSize = tableSize;
  v.cellSize = cellSize;
  v.largeBodies = largeBodies.empty() ? nullptr : largeBodies.data();
  v.largeCount = static_cast<int>(largeBodies.size());
  v.largeRadius = largeRadius;
  v.timeStep = timeStep;
  v.gravity = gravity;
  v.damping = damping;
  v.skin = skin;
  v.featureTolerance = featureTolerance;
  v.recordOutput = true;
  v.stoneLaw = stoneLaw;
  for (int k = 0; k < maxWallMaterials; ++k) v.wallLaws[k] = wallLaws[k];
  v.counters = counters;
  return v;
}

namespace {

// Below this many stones a parallel region costs more than it saves (several per step).
constexpr int parallelThreshold = 512;

class CpuBackend final : public PolyhedraBackend {
public:
  std::vector<ActiveContact> activeContacts(HostData& d, const std::vector<std::uint8_t>& selected) override {
    std::vector<ActiveContact> result;
    const std::uint8_t* flags = selected.empty() ? nullptr : selected.data();
    for (int i = 0; i < d.stoneCount; ++i) {
      for (int k = 0; k < d.pairCount[i]; ++k) {
        const std::size_t index = static_cast<std::size_t>(i) * d.maxPairs + k;
        const ContactSlot& slot = d.pairSlots[index];
        if (slot.active == 1 && contactSelected(flags, i, slot.partner, false))
          result.push_back(activeContactOf(slot, d.pairOutput[index], i, false));
      }
      for (int k = 0; k < d.wallCount[i]; ++k) {
        const std::size_t index = static_cast<std::size_t>(i) * d.maxWalls + k;
        const ContactSlot& slot = d.wallSlots[index];
        if (slot.active == 1 && contactSelected(flags, i, slot.partner, true))
          result.push_back(activeContactOf(slot, d.wallOutput[index], i, true));
      }
    }
    return result;
  }
  void upload(HostData&) override {}
  void uploadSurface(HostData&) override {}
  void download(HostData&) override {}

  // Byte copies of the state arrays: every element type there is trivially copyable, and the sizes are fixed once
  // the arrays are allocated.
  // A repeated save reuses the buffers of the last one (a fresh allocation per window cost 40x the copy itself).
  void saveSnapshot(HostData& d) override {
    std::size_t k = 0;
    visitStateArrays(d, [&](const char*, const auto& array) {
      if (saved_.size() <= k) saved_.emplace_back();
      const auto* bytes = reinterpret_cast<const unsigned char*>(array.data());
      saved_[k++].assign(bytes, bytes + array.size() * sizeof(array[0]));
    });
  }

  void restoreSnapshot(HostData& d) override {
    std::size_t k = 0;
    visitStateArrays(d, [&](const char*, auto& array) {
      const std::vector<unsigned char>& bytes = saved_[k++];
      array.resize(bytes.size() / sizeof(array[0]));
      if (!bytes.empty()) std::memcpy(static_cast<void*>(array.data()), bytes.data(), bytes.size());
    });
  }

  void step(HostData& d, int steps, BackendCounters& result) override {
    std::fill(std::begin(d.counters), std::end(d.counters), 0ull);
    std::fill(d.triangleForceSum.begin(), d.triangleForceSum.end(), 0.0);
    std::fill(d.trianglePointSum.begin(), d.trianglePointSum.end(), 0.0);
    std::fill(d.triangleWeightSum.begin(), d.triangleWeightSum.end(), 0.0);
    const int n = d.stoneCount;
    if (!d.forcesValid) {
      // Forces of the initial state; Δt = 0 so that the tangential springs do not move. They accumulate from zero:
      // after setState the arrays still hold the forces of the state it replaced.
      std::fill(d.force.begin(), d.force.end(), 0.0);
      std::fill(d.torque.begin(), d.torque.end(), 0.0);
      std::fill(d.rollingBudget.begin(), d.rollingBudget.end(), 0.0);
      rebuild(d);
      SystemView prime = d.view();
      prime.timeStep = 0.0;
#pragma omp parallel for schedule(dynamic, 64) if (n >= parallelThreshold)
      for (int i = 0; i < n; ++i) stoneForces(prime, i);
      d.forcesValid = true;
      std::fill(d.triangleForceSum.begin(), d.triangleForceSum.end(), 0.0);
      std::fill(d.trianglePointSum.begin(), d.trianglePointSum.end(), 0.0);
      std::fill(d.triangleWeightSum.begin(), d.triangleWeightSum.end(), 0.0);
      d.counters[counterActive] = 0;
      ++result.rebuilds;
    }
    // Every call starts with a rebuild; later rebuilds, every rebuildInterval steps, are skipped while the
    // stale test at the end of the previous interval found no stone that could outgrow the lists.
    const bool mayskip = d.adaptiveRebuild;
    // The predict of the step that rebuilds moves the stones once more before the new lists: + 1 step.
    const double horizon = (d.rebuildInterval + 1) * d.timeStep;
    const double nodeSpeed = d.maxNodeSpeed();
    int lastRebuild = 0; // step index of the last rebuild in this call
    bool stale = true;
    for (int s = 0; s < steps; ++s) {
      SystemView v = d.view();
#pragma omp parallel for schedule(static) if (n >= parallelThreshold)
      for (int i = 0; i < n; ++i) predictStone(v, i);
      for (int k = 0; k < v.nodeCount; ++k) moveNode(v, k);
      if (s % d.rebuildInterval == 0 && (s == 0 || !mayskip || stale)) {
        rebuild(d);
        lastRebuild = s;
        ++result.rebuilds;
        v = d.view();
      }
#pragma omp parallel for schedule(dynamic, 64) if (n >= parallelThreshold)
      for (int i = 0; i < n; ++i) stoneForces(v, i);
#pragma omp parallel for schedule(static) if (n >= parallelThreshold)
      for (int i = 0; i < n; ++i) correctStone(v, i);
      if ((s + 1) % d.rebuildInterval == 0) {
        double maxMoved = 0.0, maxSpeed = 0.0;
        for (int i = 0; i < n; ++i) {
          double moved, speed;
          stoneMotion(v, i, moved, speed);
          maxMoved = std::max(maxMoved, moved);
          maxSpeed = std::max(maxSpeed, speed);
        }
        // The nodes moved in the predicts of steps lastRebuild + 1 .. s (and lastRebuild's, before the lists: + 1).
        const double nodeMoved = (s + 1 - lastRebuild) * d.timeStep * nodeSpeed;
        stale = listsStaleWithWalls(maxMoved, maxSpeed, nodeMoved, nodeSpeed, horizon, d.skin);
      }
    }
    for (int k = 0; k < counterCount; ++k) result.values[k] = d.counters[k];
  }

private:
  std::vector<std::vector<unsigned char>> saved_; // saveSnapshot's copy, in visitStateArrays order

  static void rebuild(HostData& d) {
    const int n = d.stoneCount;
    // Dangerous-displacement flag refers to the list being replaced; keep what predict reported.
    SystemView v = d.view();
    for (int i = 0; i < n; ++i) computeCellKey(v, i);
    std::vector<std::int32_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    // Stable by key so that the order inside a bucket is the stone order, as the device radix sort gives.
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return d.cellKey[a] < d.cellKey[b]; });
    std::vector<std::uint32_t> keys(n);
    for (int k = 0; k < n; ++k) keys[k] = d.cellKey[order[k]];
    d.cellKey = keys;
    d.sortedStone = order;
    std::fill(d.cellStart.begin(), d.cellStart.end(), -1);
    std::fill(d.cellEnd.begin(), d.cellEnd.end(), -1);
    v = d.view();
    for (int k = 0; k < n; ++k) findCellBounds(v, k);
    d.pairSlots.swap(d.pairSlotsPrevious);
    d.pairCount.swap(d.pairCountPrevious);
    d.wallSlots.swap(d.wallSlotsPrevious);
    d.wallCount.swap(d.wallCountPrevious);
    d.pairNormalHistory.swap(d.pairNormalHistoryPrevious);
    d.wallNormalHistory.swap(d.wallNormalHistoryPrevious);
    v = d.view();
    const ContactSlot* previousPairs = d.pairSlotsPrevious.data();
    const std::int32_t* previousPairCount = d.pairCountPrevious.data();
    const ContactSlot* previousWalls = d.wallSlotsPrevious.data();
    const std::int32_t* previousWallCount = d.wallCountPrevious.data();
    const kernels::NormalHistory* previousPairNormal = d.pairNormalHistoryPrevious.data();
    const kernels::NormalHistory* previousWallNormal = d.wallNormalHistoryPrevious.data();
#pragma omp parallel for schedule(dynamic, 64) if (n >= parallelThreshold)
    for (int i = 0; i < n; ++i)
      buildNeighbours(v, i, previousPairs, previousPairCount, previousWalls, previousWallCount, previousPairNormal,
                      previousWallNormal);
  }
};

} // namespace

std::unique_ptr<PolyhedraBackend> makeCpuBackend() { return std::make_unique<CpuBackend>(); }

} // namespace railcosim::polyhedra
