// Internal: host copy of the whole system and the interface both backends (CPU reference, CUDA) implement.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "polyhedra/PolyhedraStep.hpp"

namespace railcosim::polyhedra {

// Every array of the system in host memory. The CPU backend works on it directly; the CUDA backend keeps
// a device mirror and copies to/from it only when the facade asks.
struct HostData {
  int stoneCount = 0;
  std::vector<double> position, velocity;
  std::vector<kernels::RotationState> rotation;
  std::vector<double> force, torque, rollingBudget, referencePosition;
  std::vector<std::int32_t> shape;
  std::vector<ShapeData> shapes;
  std::vector<double> shapeVertices;
  std::vector<double> nodePosition, nodeVelocity;
  std::vector<std::int32_t> triangles;
  std::vector<std::int32_t> triangleMaterial; // index into wallLaws per triangle; empty: every triangle wallLaws[0]
  std::vector<double> triangleForceSum, trianglePointSum, triangleWeightSum;
  int maxPairs = 0, maxWalls = 0;
  std::vector<ContactSlot> pairSlots, pairSlotsPrevious, wallSlots, wallSlotsPrevious;
  // Normal-model history beside the slots (SystemView::pairNormalHistory); empty when the law keeps none.
  std::vector<kernels::NormalHistory> pairNormalHistory, pairNormalHistoryPrevious, wallNormalHistory,
      wallNormalHistoryPrevious;
  std::vector<ContactOutput> pairOutput, wallOutput;
  std::vector<ContactGeometry> wallGeometry;
  std::vector<std::int32_t> pairCount, pairCountPrevious, wallCount, wallCountPrevious;
  std::vector<std::uint32_t> cellKey;
  std::vector<std::int32_t> sortedStone, cellStart, cellEnd;
  std::vector<std::int32_t> largeBodies; // stored indices of the bodies outside the grid (SystemView::largeRadius)
  double largeRadius = 0.0;              // bounding radius above which a body is large; +inf: none is
  std::uint32_t tableSize = 0;
  double cellSize = 0.0;
  double timeStep = 0.0;
  Vec3 gravity{0.0, 0.0, 0.0};
  double damping = 0.0;
  double skin = 0.0;
  double featureTolerance = 0.0;
  int rebuildInterval = 10;
  bool adaptiveRebuild = true; // skip a due rebuild while no stone can outgrow the lists (Parameters)
  kernels::ContactLaw stoneLaw{};
  kernels::ContactLaw wallLaws[maxWallMaterials] = {}; // stone against wall material k (setWallMaterials)
  int wallLawCount = 1;
  unsigned long long counters[counterCount] = {};
  bool forcesValid = false; // force/torque hold the contact forces of the current state

  int nodeCount() const { return static_cast<int>(nodePosition.size() / 3); }
  int triangleCount() const { return static_cast<int>(triangles.size() / 3); }
  // The fastest surface node [m/s]. Nodes keep their velocity through a step call, so the way they went since the
  // last rebuild is this times the time since then (listsStaleWithWalls).
  double maxNodeSpeed() const {
    double fastest = 0.0;
    for (std::size_t k = 0; k + 2 < nodeVelocity.size(); k += 3)
      fastest = std::max(fastest, std::sqrt(nodeVelocity[k] * nodeVelocity[k] + nodeVelocity[k + 1] * nodeVelocity[k + 1] +
                                            nodeVelocity[k + 2] * nodeVelocity[k + 2]));
    return fastest;
  }
  // Sizes every per-stone and per-triangle array after stones/shapes/walls are known.
  void allocate();
  // View on the current lists (pairSlots) with `previous*` as the lists of the last rebuild.
  SystemView view();
  // Whether any wall law keeps a normal history (then every wall slot has one beside it).
  bool wallNormalHistoryKept() const;
};

// The arrays that hold the dynamic state between two step calls (PolyhedraSystem's snapshots and state
// streams), in a fixed order. Not listed, as every step call rebuilds them before reading them: the lists of the
// previous rebuild (`*Previous`: the call's first rebuild swaps the current lists into them and builds anew from
// them), the grid (cell keys, buckets) and the narrow-phase scratch (wallGeometry), the counters.
// Calls `visit(name, array)` for each, in that order.
template <class Data, class Visitor>
void visitStateArrays(Data& d, Visitor&& visit) {
  visit("position", d.position);
  visit("velocity", d.velocity);
  visit("rotation", d.rotation);
  visit("force", d.force);
  visit("torque", d.torque);
  visit("rollingBudget", d.rollingBudget);
  visit("referencePosition", d.referencePosition);
  visit("nodePosition", d.nodePosition);
  visit("nodeVelocity", d.nodeVelocity);
  visit("triangleForceSum", d.triangleForceSum);
  visit("trianglePointSum", d.trianglePointSum);
  visit("triangleWeightSum", d.triangleWeightSum);
  visit("pairSlots", d.pairSlots);
  visit("pairCount", d.pairCount);
  visit("pairNormalHistory", d.pairNormalHistory);
  visit("pairOutput", d.pairOutput);
  visit("wallSlots", d.wallSlots);
  visit("wallCount", d.wallCount);
  visit("wallNormalHistory", d.wallNormalHistory);
  visit("wallOutput", d.wallOutput);
}

// Parts of the state that PolyhedraBackend::downloadParts brings back.
constexpr int downloadStones = 1;    // position, velocity, rotation
constexpr int downloadTriangles = 2; // surface node positions and the triangles' force and contact-point sums

// What a step call reports back to the facade.
struct BackendCounters {
  unsigned long long values[counterCount] = {};
  long long rebuilds = 0;
};

class PolyhedraBackend {
public:
  virtual ~PolyhedraBackend() = default;
  // Takes over the host data (allocated) as the initial state.
  virtual void upload(HostData& data) = 0;
  // Surface node positions/velocities changed on the host.
  virtual void uploadSurface(HostData& data) = 0;
  virtual void step(HostData& data, int steps, BackendCounters& counters) = 0;
  // Scalar parameters (time step, gravity) changed: anything that baked them in must be redone.
  virtual void parametersChanged() {}
  // Brings stones, contact lists and surface outputs back into `data` (no-op for the CPU).
  virtual void download(HostData& data) = 0;
  // Brings back only `parts` (downloadStones | downloadTriangles) of the state: what the facade's per-window accessors
  // (stone states, triangle sums) need, without the contact lists, which dwarf them. Default: everything.
  virtual void downloadParts(HostData& data, int /*parts*/) { download(data); }
  // Brings back position, velocity and rotation of the stored stones `stones` only, into their places in `data`'s
  // arrays (a few sensor blocks read every few windows, without the bed). Default: every stone's.
  virtual void downloadStonesAt(HostData& data, const std::vector<std::int32_t>& /*stones*/) {
    downloadParts(data, downloadStones);
  }
  // The active contacts of the last force evaluation, gathered where the lists live: on the GPU only they cross to
  // the host (a few per stone, instead of every candidate slot with its history), in no particular order. With
  // `selected` (a flag per stored stone) only the contacts of flagged stones; empty: all.
  virtual std::vector<ActiveContact> activeContacts(HostData& data, const std::vector<std::uint8_t>& selected) = 0;
  // One in-memory copy of the state arrays (visitStateArrays) where they live: the host arrays for the CPU, device
  // buffers for CUDA (no transfer). restoreSnapshot puts it back and keeps it.
  virtual void saveSnapshot(HostData& data) = 0;
  virtual void restoreSnapshot(HostData& data) = 0;
};

std::unique_ptr<PolyhedraBackend> makeCpuBackend();
// nullptr with `reason` filled when no usable CUDA device exists or the library was built without CUDA.
std::unique_ptr<PolyhedraBackend> makeCudaBackend(std::string& reason);

} // namespace railcosim::polyhedra
