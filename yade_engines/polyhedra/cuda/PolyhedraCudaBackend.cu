// CUDA backend: the step functions of PolyhedraStep.hpp as kernels, state resident on the device; one step =
// predict (fused with the previous step's correct), pair filter + narrow phase (+ resume of the deferred
// GJK runs), wall filter + narrow phase + law; a neighbour rebuild lists the candidates; replayed as CUDA
// Graphs of one rebuild interval, which ends with a correct.
#include <cub/device/device_radix_sort.cuh>
#include <cuda_runtime.h>

#include <cstring>
#include <string>
#include <vector>

#include "polyhedra/PolyhedraBackend.hpp"
#include "railcosim/Error.hpp"

namespace railcosim::polyhedra {

namespace {

void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess)
    throw Error(std::string("polyhedra CUDA backend: ") + what + " failed: " + cudaGetErrorString(status) +
                "; rerun with Backend::Cpu to use the CPU reference");
}

// Owning device array; plain RAII around cudaMalloc/cudaFree.
template <typename T>
class DeviceArray {
public:
  DeviceArray() = default;
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() {
    if (data_) cudaFree(data_);
  }
  void resize(std::size_t count) {
    if (count == count_ && data_) return;
    if (data_) cudaFree(data_);
    data_ = nullptr;
    count_ = count;
    if (count > 0) check(cudaMalloc(&data_, count * sizeof(T)), "cudaMalloc");
  }
  void upload(const std::vector<T>& host, cudaStream_t stream) {
    resize(host.size());
    if (!host.empty())
      check(cudaMemcpyAsync(data_, host.data(), host.size() * sizeof(T), cudaMemcpyHostToDevice, stream), "upload");
  }
  void download(std::vector<T>& host, cudaStream_t stream) const {
    host.resize(count_);
    if (count_ > 0)
      check(cudaMemcpyAsync(host.data(), data_, count_ * sizeof(T), cudaMemcpyDeviceToHost, stream), "download");
  }
  // Device-to-device copy of `source` (resized to fit), queued on `stream`.
  void copyFrom(const DeviceArray& source, cudaStream_t stream) {
    resize(source.count_);
    if (count_ > 0)
      check(cudaMemcpyAsync(data_, source.data_, count_ * sizeof(T), cudaMemcpyDeviceToDevice, stream), "device copy");
  }
  T* get() const { return data_; }
  std::size_t size() const { return count_; }

private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
};

constexpr int blockSize = 128;

int blocks(int count) { return (count + blockSize - 1) / blockSize; }

// Start of a step; with CorrectFirst also the end of the previous one (its correct and this predict need the
// same stone state, so one kernel reads and writes it once instead of twice; same operations per stone as
// the CPU reference's separate calls).
// The block's rotation states (240 bytes each, read and written field by field) pass through shared memory
// with coalesced copies: one thread per state touching 30 scattered doubles made these kernels
// transaction-bound (0.69 ms for correct + predict at 1e6 stones, ~1 TB/s).
template <bool CorrectFirst>
__global__ void __launch_bounds__(blockSize) predictKernel(SystemView s) {
  constexpr int words = sizeof(kernels::RotationState) / sizeof(double);
  __shared__ double staged[blockSize * words];
  const int blockFirst = blockIdx.x * blockDim.x;
  const int stones = min(blockSize, max(0, s.stoneCount - blockFirst));
  const double* global = reinterpret_cast<const double*>(s.rotation + blockFirst);
  for (int w = threadIdx.x; w < stones * words; w += blockSize) staged[w] = global[w];
  __syncthreads();
  const int k = blockFirst + threadIdx.x;
  if (k < s.stoneCount) {
    auto& rotation = reinterpret_cast<kernels::RotationState*>(staged)[threadIdx.x];
    if (CorrectFirst) correctStone(s, k, rotation);
    predictStone(s, k, rotation);
  } else if (k - s.stoneCount < s.nodeCount) {
    moveNode(s, k - s.stoneCount);
  }
  __syncthreads();
  double* out = reinterpret_cast<double*>(s.rotation + blockFirst);
  for (int w = threadIdx.x; w < stones * words; w += blockSize) out[w] = staged[w];
}

// Sum of `value` over the warp, added to the active-contact counter by one lane (one atomic per warp
// instead of one per contact on a single address). Every lane of the warp must call it.
__device__ inline void addActiveContactsOfWarp(const SystemView& s, unsigned value) {
  const unsigned total = __reduce_add_sync(0xffffffffu, value);
  if ((threadIdx.x & 31u) == 0 && total > 0)
    atomicAdd(&s.counters[counterActive], static_cast<unsigned long long>(total));
}

// Appends `index` to `list` for the lanes where `keep` holds (one atomic per warp). Every lane must call it.
__device__ inline void appendWhere(bool keep, long long index, std::uint32_t* list, unsigned* count) {
  const unsigned mask = __ballot_sync(0xffffffffu, keep);
  if (mask == 0) return;
  const unsigned lane = threadIdx.x & 31u;
  const unsigned leader = __ffs(mask) - 1;
  unsigned base = 0;
  if (lane == leader) base = atomicAdd(count, static_cast<unsigned>(__popc(mask)));
  base = __shfl_sync(0xffffffffu, base, leader);
  if (keep) list[base + __popc(mask & ((1u << lane) - 1u))] = static_cast<std::uint32_t>(index);
}

// Appends the slots 0..count−1 of stone i (slot numbers i · perStone + k) to `list`, one atomic per warp.
// Every lane must call it.
__device__ inline void appendSlots(int i, int count, int perStone, std::uint32_t* list, unsigned* total) {
  const unsigned lane = threadIdx.x & 31u;
  int scan = count; // inclusive prefix sum over the warp's lanes
  for (int d = 1; d < 32; d <<= 1) {
    const int below = __shfl_up_sync(0xffffffffu, scan, d);
    if (lane >= static_cast<unsigned>(d)) scan += below;
  }
  const int warpTotal = __shfl_sync(0xffffffffu, scan, 31);
  unsigned base = 0;
  if (lane == 31u && warpTotal > 0) base = atomicAdd(total, static_cast<unsigned>(warpTotal));
  base = __shfl_sync(0xffffffffu, base, 31);
  const unsigned start = base + static_cast<unsigned>(scan - count);
  for (int k = 0; k < count; ++k)
    list[start + k] = static_cast<std::uint32_t>(static_cast<long long>(i) * perStone + k);
}

// Flat lists of every candidate slot (pairs, walls) and of the stones with wall candidates, rebuilt with
// the neighbour lists: the filters then run one thread per existing candidate instead of one per possible
// slot (24 per stone, most of them empty: 0.92 ms of a 4.4 ms step at 1e6 stones went to launching and
// retiring those), and the wall law one per stone near a wall instead of one per stone.
// counts: pair slots, wall slots, wall stones.
__global__ void __launch_bounds__(blockSize)
    listCandidatesKernel(SystemView s, std::uint32_t* pairList, std::uint32_t* wallList, std::uint32_t* wallStones,
                         unsigned* counts) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const bool stone = i < s.stoneCount;
  const int walls = stone ? s.wallCount[i] : 0;
  appendSlots(i, stone ? s.pairCount[i] : 0, s.maxPairs, pairList, counts);
  appendSlots(i, walls, s.maxWalls, wallList, counts + 1);
  appendWhere(walls > 0, i, wallStones, counts + 2);
}

// Candidates, first pass: one thread per listed candidate slot (grid-stride over resident blocks). Slots not
// proven apart by the cheap tests are appended to `survivors`. Wall = true: the wall candidates.
template <bool Wall>
__global__ void __launch_bounds__(blockSize)
    filterKernel(SystemView s, const std::uint32_t* candidates, const unsigned* candidateCount,
                 std::uint32_t* survivors, unsigned* survivorCount) {
  const unsigned count = *candidateCount;
  const unsigned stride = gridDim.x * blockDim.x;
  const unsigned first = blockIdx.x * blockDim.x + threadIdx.x;
  const unsigned warpFirst = first - (threadIdx.x & 31u);
  const int perStone = Wall ? s.maxWalls : s.maxPairs;
  for (unsigned t = first, w = warpFirst; w < count; t += stride, w += stride) {
    bool survives = false;
    long long index = 0;
    if (t < count) {
      index = candidates[t];
      const int i = static_cast<int>(index / perStone);
      survives = Wall ? !wallProvenApart(s, i, index) : !pairProvenApart(s, i, index);
    }
    appendWhere(survives, index, survivors, survivorCount);
  }
}

// Second pass: GJK (and for pairs the contact law) of the survivors, one per thread (grid-stride over a grid
// of resident blocks, since the survivor count is only known on the device). Minimum resident blocks per
// multiprocessor caps its registers (1 → 254, 3 → 168 with spills: 6 % slower at 1e6 stones, measured);
// override with -DRAILCOSIM_POLYHEDRA_CONTACT_MIN_BLOCKS=n.
// Pairs run in two launches: the first stops GJK after pairFirstPassIterations and appends the unfinished
// candidates to `deferred`; the second (Resume) finishes those (PolyhedraStep.hpp, pairFirstPassIterations).
// The first pass needs 174 registers (2 blocks of 128 per multiprocessor); capping it with
// -DRAILCOSIM_POLYHEDRA_FIRST_PASS_MIN_BLOCKS=3 (168, no spills) measured 5.81e8 and 5.90e8 particle-steps/s
// at 1e6 stones against 6.03e8: more resident warps do not help it.
#ifndef RAILCOSIM_POLYHEDRA_CONTACT_MIN_BLOCKS
#define RAILCOSIM_POLYHEDRA_CONTACT_MIN_BLOCKS 1
#endif
#ifndef RAILCOSIM_POLYHEDRA_FIRST_PASS_MIN_BLOCKS
#define RAILCOSIM_POLYHEDRA_FIRST_PASS_MIN_BLOCKS RAILCOSIM_POLYHEDRA_CONTACT_MIN_BLOCKS
#endif
template <bool Wall, bool Resume>
__global__ void __launch_bounds__(blockSize, Wall || Resume ? RAILCOSIM_POLYHEDRA_CONTACT_MIN_BLOCKS
                                                            : RAILCOSIM_POLYHEDRA_FIRST_PASS_MIN_BLOCKS)
    narrowPhaseKernel(SystemView s, const std::uint32_t* survivors, const unsigned* survivorCount,
                      std::uint32_t* deferred, unsigned* deferredCount) {
  const unsigned count = *survivorCount;
  const unsigned stride = gridDim.x * blockDim.x;
  unsigned active = 0;
  // Every lane runs the same number of rounds so that the warp reduction below sees all of them.
  const unsigned first = blockIdx.x * blockDim.x + threadIdx.x;
  const unsigned warpFirst = first - (threadIdx.x & 31u);
  for (unsigned t = first, w = warpFirst; w < count; t += stride, w += stride) {
    bool defer = false;
    long long index = 0;
    if (t < count) {
      index = survivors[t];
      if (Wall) {
        wallNarrowPhase(s, static_cast<int>(index / s.maxWalls), index);
      } else {
        const PairOutcome outcome =
            pairContact(s, static_cast<int>(index / s.maxPairs), index, Resume ? 64 : pairFirstPassIterations);
        active += outcome == PairOutcome::touching ? 1u : 0u;
        defer = outcome == PairOutcome::deferred;
      }
    }
    if (!Wall && !Resume) appendWhere(defer, index, deferred, deferredCount);
  }
  if (!Wall) addActiveContactsOfWarp(s, active);
}

// Wall contact law, one thread per listed stone (the coplanar-duplicate test needs all of a stone's wall
// contacts); grid-stride over the list of stones with wall candidates.
__global__ void __launch_bounds__(blockSize)
    wallForcesKernel(SystemView s, const std::uint32_t* stones, const unsigned* stoneCount) {
  const unsigned count = *stoneCount;
  const unsigned stride = gridDim.x * blockDim.x;
  const unsigned first = blockIdx.x * blockDim.x + threadIdx.x;
  const unsigned warpFirst = first - (threadIdx.x & 31u);
  unsigned active = 0;
  for (unsigned t = first, w = warpFirst; w < count; t += stride, w += stride) {
    if (t < count) active += static_cast<unsigned>(stoneWallForces(s, static_cast<int>(stones[t])));
  }
  addActiveContactsOfWarp(s, active);
}

__global__ void __launch_bounds__(blockSize) correctKernel(SystemView s) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < s.stoneCount) correctStone(s, i);
}
static_assert(sizeof(kernels::RotationState) % sizeof(double) == 0, "rotation states are staged as doubles");

// End of a rebuild interval: the largest displacement since the last rebuild and the largest speed
// (counterMaxDisplacement, counterMaxSpeed, as double bits), for the host's stale test. One atomic per warp.
__global__ void __launch_bounds__(blockSize) motionKernel(SystemView s) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  double moved = 0.0, speed = 0.0;
  if (i < s.stoneCount) stoneMotion(s, i, moved, speed);
  for (int offset = 16; offset > 0; offset /= 2) {
    moved = fmax(moved, __shfl_xor_sync(0xffffffffu, moved, offset));
    speed = fmax(speed, __shfl_xor_sync(0xffffffffu, speed, offset));
  }
  if ((threadIdx.x & 31u) == 0) {
    atomicMax(&s.counters[counterMaxDisplacement], static_cast<unsigned long long>(__double_as_longlong(moved)));
    atomicMax(&s.counters[counterMaxSpeed], static_cast<unsigned long long>(__double_as_longlong(speed)));
  }
}

__global__ void __launch_bounds__(blockSize) cellKeyKernel(SystemView s) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < s.stoneCount) computeCellKey(s, i);
}

__global__ void __launch_bounds__(blockSize) cellBoundsKernel(SystemView s) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < s.stoneCount) findCellBounds(s, k);
}

__global__ void __launch_bounds__(blockSize)
    neighbourKernel(SystemView s, const ContactSlot* previousPairs, const std::int32_t* previousPairCount,
                    const ContactSlot* previousWalls, const std::int32_t* previousWallCount,
                    const kernels::NormalHistory* previousPairNormal,
                    const kernels::NormalHistory* previousWallNormal) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < s.stoneCount)
    buildNeighbours(s, i, previousPairs, previousPairCount, previousWalls, previousWallCount, previousPairNormal,
                    previousWallNormal);
}

// The active contacts of stone i's lists appended to `out` (up to `capacity`; `count` counts them all); with
// `selected`, only those of flagged stones (contactSelected).
__global__ void __launch_bounds__(blockSize) activeContactsKernel(SystemView s, const std::uint8_t* selected,
                                                                  ActiveContact* out, unsigned capacity,
                                                                  unsigned* count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= s.stoneCount) return;
  for (int k = 0; k < s.pairCount[i]; ++k) {
    const long long index = static_cast<long long>(i) * s.maxPairs + k;
    if (s.pairSlots[index].active != 1 || !contactSelected(selected, i, s.pairSlots[index].partner, false)) continue;
    const unsigned slot = atomicAdd(count, 1u);
    if (slot < capacity) out[slot] = activeContactOf(s.pairSlots[index], s.pairOutput[index], i, false);
  }
  for (int k = 0; k < s.wallCount[i]; ++k) {
    const long long index = static_cast<long long>(i) * s.maxWalls + k;
    if (s.wallSlots[index].active != 1 || !contactSelected(selected, i, s.wallSlots[index].partner, true)) continue;
    const unsigned slot = atomicAdd(count, 1u);
    if (slot < capacity) out[slot] = activeContactOf(s.wallSlots[index], s.wallOutput[index], i, true);
  }
}

constexpr auto startStepKernel = predictKernel<false>;
constexpr auto nextStepKernel = predictKernel<true>;
constexpr auto pairFilterKernel = filterKernel<false>;
constexpr auto wallFilterKernel = filterKernel<true>;
constexpr auto pairNarrowPhaseKernel = narrowPhaseKernel<false, false>;
constexpr auto pairResumeKernel = narrowPhaseKernel<false, true>;
constexpr auto wallNarrowPhaseKernel = narrowPhaseKernel<true, false>;

class CudaBackend final : public PolyhedraBackend {
public:
  CudaBackend() { check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate"); }
  ~CudaBackend() override {
    invalidateGraphs();
    if (stream_) cudaStreamDestroy(stream_);
  }

  void upload(HostData& d) override {
    position_.upload(d.position, stream_);
    velocity_.upload(d.velocity, stream_);
    rotation_.upload(d.rotation, stream_);
    force_.upload(d.force, stream_);
    torque_.upload(d.torque, stream_);
    rollingBudget_.upload(d.rollingBudget, stream_);
    reference_.upload(d.referencePosition, stream_);
    shape_.upload(d.shape, stream_);
    shapes_.upload(d.shapes, stream_);
    vertices_.upload(d.shapeVertices, stream_);
    nodePosition_.upload(d.nodePosition, stream_);
    nodeVelocity_.upload(d.nodeVelocity, stream_);
    triangles_.upload(d.triangles, stream_);
    triangleMaterial_.upload(d.triangleMaterial, stream_);
    triangleForce_.upload(d.triangleForceSum, stream_);
    trianglePoint_.upload(d.trianglePointSum, stream_);
    triangleWeight_.upload(d.triangleWeightSum, stream_);
    for (int b = 0; b < 2; ++b) {
      pairSlots_[b].upload(b == current_ ? d.pairSlots : d.pairSlotsPrevious, stream_);
      pairCount_[b].upload(b == current_ ? d.pairCount : d.pairCountPrevious, stream_);
      wallSlots_[b].upload(b == current_ ? d.wallSlots : d.wallSlotsPrevious, stream_);
      wallCount_[b].upload(b == current_ ? d.wallCount : d.wallCountPrevious, stream_);
      pairNormal_[b].upload(b == current_ ? d.pairNormalHistory : d.pairNormalHistoryPrevious, stream_);
      wallNormal_[b].upload(b == current_ ? d.wallNormalHistory : d.wallNormalHistoryPrevious, stream_);
    }
    pairOutput_.upload(d.pairOutput, stream_);
    wallOutput_.upload(d.wallOutput, stream_);
    cellKey_.upload(d.cellKey, stream_);
    sortedStone_.upload(d.sortedStone, stream_);
    rawKey_.resize(d.cellKey.size());
    rawStone_.resize(d.sortedStone.size());
    cellStart_.upload(d.cellStart, stream_);
    cellEnd_.upload(d.cellEnd, stream_);
    largeBodies_.upload(d.largeBodies, stream_);
    counters_.resize(counterCount);
    const long long slots = static_cast<long long>(d.stoneCount) * d.maxPairs;
    if (slots >= (1ll << 31) || static_cast<long long>(d.stoneCount) * d.maxWalls >= (1ll << 31))
      throw Error("polyhedra CUDA backend: stones × maxNeighbours (or maxWallNeighbours) = " + std::to_string(slots) +
                  " does not fit the 32-bit candidate lists; lower maxNeighbours or split the system");
    survivors_.resize(static_cast<std::size_t>(slots > 0 ? slots : 1));
    deferred_.resize(static_cast<std::size_t>(slots > 0 ? slots : 1));
    pairCandidates_.resize(static_cast<std::size_t>(slots > 0 ? slots : 1));
    wallCandidates_.resize(static_cast<std::size_t>(d.stoneCount) * (d.maxWalls > 0 ? d.maxWalls : 1));
    wallStones_.resize(static_cast<std::size_t>(d.stoneCount > 0 ? d.stoneCount : 1));
    candidateCount_.resize(3); // pair slots, wall slots, wall stones
    wallSurvivors_.resize(static_cast<std::size_t>(d.stoneCount) * (d.maxWalls > 0 ? d.maxWalls : 1));
    wallGeometry_.resize(static_cast<std::size_t>(d.stoneCount) * (d.maxWalls > 0 ? d.maxWalls : 1));
    survivorCount_.resize(3); // pairs, walls, deferred pairs
    int device = 0, multiprocessors = 0;
    check(cudaGetDevice(&device), "cudaGetDevice");
    check(cudaDeviceGetAttribute(&multiprocessors, cudaDevAttrMultiProcessorCount, device), "device attribute");
    // Grid-stride kernels get the blocks that can be resident at once, each by its own register count (the first
    // pass and the long GJK runs may be built with different launch bounds).
    auto residentBlocks = [&](const void* kernel) {
      int perMultiprocessor = 0;
      check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&perMultiprocessor, kernel, blockSize, 0), "occupancy query");
      return multiprocessors * (perMultiprocessor > 0 ? perMultiprocessor : 1);
    };
    contactBlocks_ = residentBlocks(reinterpret_cast<const void*>(pairNarrowPhaseKernel));
    resumeBlocks_ = residentBlocks(reinterpret_cast<const void*>(pairResumeKernel));
    wallNarrowBlocks_ = residentBlocks(reinterpret_cast<const void*>(wallNarrowPhaseKernel));
    filterBlocks_ = residentBlocks(reinterpret_cast<const void*>(pairFilterKernel));
    std::size_t bytes = 0;
    check(cub::DeviceRadixSort::SortPairs(nullptr, bytes, rawKey_.get(), cellKey_.get(), rawStone_.get(),
                                          sortedStone_.get(), d.stoneCount, 0, sortBits(d.tableSize), stream_),
          "cub sort size query");
    sortTemp_.resize(bytes > 0 ? bytes : 1);
    enqueueCandidateLists(d); // the uploaded neighbour lists
    check(cudaStreamSynchronize(stream_), "upload");
    invalidateGraphs();
  }

  void parametersChanged() override { invalidateGraphs(); }

  void uploadSurface(HostData& d) override {
    nodePosition_.upload(d.nodePosition, stream_);
    nodeVelocity_.upload(d.nodeVelocity, stream_);
    check(cudaStreamSynchronize(stream_), "surface upload");
  }

  // Gathered on the device into a buffer that grows to the largest count seen (a second pass when it had to grow).
  std::vector<ActiveContact> activeContacts(HostData& d, const std::vector<std::uint8_t>& selected) override {
    std::vector<ActiveContact> result;
    if (d.stoneCount == 0) return result;
    if (activeCount_.size() == 0) activeCount_.resize(1);
    if (!selected.empty()) selected_.upload(selected, stream_);
    for (int pass = 0; pass < 2; ++pass) {
      check(cudaMemsetAsync(activeCount_.get(), 0, sizeof(unsigned), stream_), "memset");
      activeContactsKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(
          view(d), selected.empty() ? nullptr : selected_.get(), active_.get(), static_cast<unsigned>(active_.size()),
          activeCount_.get());
      check(cudaGetLastError(), "active contacts kernel");
      unsigned count = 0;
      check(cudaMemcpyAsync(&count, activeCount_.get(), sizeof(unsigned), cudaMemcpyDeviceToHost, stream_), "count");
      check(cudaStreamSynchronize(stream_), "active contacts");
      if (count <= active_.size()) {
        result.resize(count);
        if (count > 0) {
          check(cudaMemcpyAsync(result.data(), active_.get(), count * sizeof(ActiveContact), cudaMemcpyDeviceToHost,
                                stream_),
                "active contacts download");
          check(cudaStreamSynchronize(stream_), "active contacts download");
        }
        return result;
      }
      active_.resize(count + count / 4);
    }
    throw Error("polyhedra CUDA backend: the active contacts changed between two gathering passes");
  }

  void downloadParts(HostData& d, int parts) override {
    if (parts & downloadStones) {
      position_.download(d.position, stream_);
      velocity_.download(d.velocity, stream_);
      rotation_.download(d.rotation, stream_);
    }
    if (parts & downloadTriangles) {
      nodePosition_.download(d.nodePosition, stream_);
      triangleForce_.download(d.triangleForceSum, stream_);
      trianglePoint_.download(d.trianglePointSum, stream_);
      triangleWeight_.download(d.triangleWeightSum, stream_);
    }
    check(cudaStreamSynchronize(stream_), "download");
  }

  // One small copy per stone and array: a handful of stones cost microseconds, the whole bed tens of megabytes.
  void downloadStonesAt(HostData& d, const std::vector<std::int32_t>& stones) override {
    const auto copy = [&](void* host, const void* device, std::size_t bytes) {
      check(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream_), "stone download");
    };
    for (std::int32_t i : stones) {
      copy(&d.position[3 * i], position_.get() + 3 * i, 3 * sizeof(double));
      copy(&d.velocity[3 * i], velocity_.get() + 3 * i, 3 * sizeof(double));
      copy(&d.rotation[i], rotation_.get() + i, sizeof(d.rotation[i]));
    }
    check(cudaStreamSynchronize(stream_), "stone download");
  }

  void download(HostData& d) override {
    position_.download(d.position, stream_);
    velocity_.download(d.velocity, stream_);
    rotation_.download(d.rotation, stream_);
    force_.download(d.force, stream_);
    torque_.download(d.torque, stream_);
    rollingBudget_.download(d.rollingBudget, stream_);
    reference_.download(d.referencePosition, stream_);
    nodePosition_.download(d.nodePosition, stream_);
    triangleForce_.download(d.triangleForceSum, stream_);
    trianglePoint_.download(d.trianglePointSum, stream_);
    triangleWeight_.download(d.triangleWeightSum, stream_);
    pairSlots_[current_].download(d.pairSlots, stream_);
    pairCount_[current_].download(d.pairCount, stream_);
    wallSlots_[current_].download(d.wallSlots, stream_);
    wallCount_[current_].download(d.wallCount, stream_);
    pairSlots_[1 - current_].download(d.pairSlotsPrevious, stream_);
    pairCount_[1 - current_].download(d.pairCountPrevious, stream_);
    wallSlots_[1 - current_].download(d.wallSlotsPrevious, stream_);
    wallCount_[1 - current_].download(d.wallCountPrevious, stream_);
    pairNormal_[current_].download(d.pairNormalHistory, stream_);
    wallNormal_[current_].download(d.wallNormalHistory, stream_);
    pairNormal_[1 - current_].download(d.pairNormalHistoryPrevious, stream_);
    wallNormal_[1 - current_].download(d.wallNormalHistoryPrevious, stream_);
    pairOutput_.download(d.pairOutput, stream_);
    wallOutput_.download(d.wallOutput, stream_);
    check(cudaStreamSynchronize(stream_), "download");
  }

  // The state arrays of visitStateArrays, device to device; the current lists are whichever buffer `current_` names
  // at the time (restoring into the present parity keeps the captured graphs valid: no buffer moves).
  void saveSnapshot(HostData&) override {
    forEachStateBuffer([&](auto& live, auto& saved) { saved.copyFrom(live, stream_); });
    check(cudaStreamSynchronize(stream_), "snapshot");
  }

  void restoreSnapshot(HostData&) override {
    forEachStateBuffer([&](auto& live, auto& saved) { live.copyFrom(saved, stream_); });
    check(cudaStreamSynchronize(stream_), "snapshot restore");
  }

  void step(HostData& d, int steps, BackendCounters& result) override {
    check(cudaMemsetAsync(counters_.get(), 0, counterCount * sizeof(unsigned long long), stream_), "counter reset");
    zeroTriangleSums();
    if (!d.forcesValid) {
      // The initial forces accumulate from zero (after setState the buffers hold those of the replaced state).
      check(cudaMemsetAsync(force_.get(), 0, force_.size() * sizeof(double), stream_), "force reset");
      check(cudaMemsetAsync(torque_.get(), 0, torque_.size() * sizeof(double), stream_), "torque reset");
      check(cudaMemsetAsync(rollingBudget_.get(), 0, rollingBudget_.size() * sizeof(double), stream_), "budget reset");
      enqueueRebuild(d);
      SystemView prime = view(d);
      prime.timeStep = 0.0; // initial forces without moving the tangential springs
      enqueueForces(d, prime);
      zeroTriangleSums();
      check(cudaMemsetAsync(counters_.get() + counterActive, 0, sizeof(unsigned long long), stream_), "counter reset");
      d.forcesValid = true;
      ++result.rebuilds;
    }
    const int interval = d.rebuildInterval;
    // Every call starts with a rebuild; a later one is skipped when the stale test at the end of the
    // previous interval (read back here: one small copy and wait per interval) found no stone that could
    // outgrow the lists (the CPU reference decides the same way).
    const bool mayskip = d.adaptiveRebuild;
    const double nodeSpeed = d.maxNodeSpeed();
    bool rebuild = true;
    int done = 0, sinceRebuild = 0; // steps since the start of the chunk that rebuilt last

    while (steps - done >= interval) {
      // A chunk with a rebuild turns buffer `current_` into `1 − current_`: graphs per parity and kind.
      const int parity = current_;
      cudaGraphExec_t& exec = graphs_[parity][rebuild ? 1 : 0];
      if (!exec) {
        cudaGraph_t graph;
        check(cudaStreamBeginCapture(stream_, cudaStreamCaptureModeThreadLocal), "graph capture");
        enqueueChunk(d, interval, rebuild);
        check(cudaStreamEndCapture(stream_, &graph), "graph capture");
        check(cudaGraphInstantiate(&exec, graph, 0), "graph instantiate");
        cudaGraphDestroy(graph);
        current_ = parity; // capture only recorded the chunk; replay below performs it
      }
      check(cudaGraphLaunch(exec, stream_), "graph launch");
      if (rebuild) {
        current_ = 1 - parity;
        result.rebuilds += 1;
        sinceRebuild = 0;
      }
      done += interval;
      sinceRebuild += interval;
      rebuild = !mayskip || listsOutgrown(d, sinceRebuild * d.timeStep * nodeSpeed, nodeSpeed);
    }
    if (done < steps) {
      enqueueChunk(d, steps - done, rebuild);
      if (rebuild) result.rebuilds += 1;
    }
    std::vector<unsigned long long> counters(counterCount);
    check(cudaMemcpyAsync(counters.data(), counters_.get(), counterCount * sizeof(unsigned long long),
                          cudaMemcpyDeviceToHost, stream_),
          "counter download");
    check(cudaStreamSynchronize(stream_), "step");
    for (int k = 0; k < counterCount; ++k) result.values[k] = counters[k];
  }

private:
  template <class Visitor>
  void forEachStateBuffer(Visitor&& visit) {
    visit(position_, saved_.position);
    visit(velocity_, saved_.velocity);
    visit(rotation_, saved_.rotation);
    visit(force_, saved_.force);
    visit(torque_, saved_.torque);
    visit(rollingBudget_, saved_.rollingBudget);
    visit(reference_, saved_.reference);
    visit(nodePosition_, saved_.nodePosition);
    visit(nodeVelocity_, saved_.nodeVelocity);
    visit(triangleForce_, saved_.triangleForce);
    visit(trianglePoint_, saved_.trianglePoint);
    visit(triangleWeight_, saved_.triangleWeight);
    visit(pairSlots_[current_], saved_.pairSlots);
    visit(pairCount_[current_], saved_.pairCount);
    visit(pairNormal_[current_], saved_.pairNormal);
    visit(pairOutput_, saved_.pairOutput);
    visit(wallSlots_[current_], saved_.wallSlots);
    visit(wallCount_[current_], saved_.wallCount);
    visit(wallNormal_[current_], saved_.wallNormal);
    visit(wallOutput_, saved_.wallOutput);
  }

  static int sortBits(std::uint32_t tableSize) {
    int bits = 0;
    while ((1u << bits) < tableSize) ++bits;
    return bits;
  }

  SystemView view(HostData& d) {
    SystemView v = d.view(); // scalars; pointers replaced by device ones
    v.position = position_.get();
    v.velocity = velocity_.get();
    v.rotation = rotation_.get();
    v.force = force_.get();
    v.torque = torque_.get();
    v.rollingBudget = rollingBudget_.get();
    v.referencePosition = reference_.get();
    v.shape = shape_.get();
    v.shapes = shapes_.get();
    v.shapeVertices = vertices_.get();
    v.nodePosition = nodePosition_.get();
    v.nodeVelocity = nodeVelocity_.get();
    v.triangles = triangles_.get();
    v.triangleMaterial = triangleMaterial_.get(); // null when every triangle has the first wall law
    v.triangleForceSum = triangleForce_.get();
    v.trianglePointSum = trianglePoint_.get();
    v.triangleWeightSum = triangleWeight_.get();
    v.pairSlots = pairSlots_[current_].get();
    v.pairNormalHistory = pairNormal_[current_].get(); // null when the law keeps no normal history
    v.pairOutput = pairOutput_.get();
    v.pairCount = pairCount_[current_].get();
    v.wallSlots = wallSlots_[current_].get();
    v.wallNormalHistory = wallNormal_[current_].get();
    v.wallOutput = wallOutput_.get();
    v.wallGeometry = wallGeometry_.get();
    v.wallCount = wallCount_[current_].get();
    v.cellKey = cellKey_.get();
    v.sortedStone = sortedStone_.get();
    v.cellStart = cellStart_.get();
    v.cellEnd = cellEnd_.get();
    v.largeBodies = largeBodies_.get();
    v.counters = counters_.get();
    return v;
  }

  void zeroTriangleSums() {
    if (triangleForce_.size() == 0) return;
    check(cudaMemsetAsync(triangleForce_.get(), 0, triangleForce_.size() * sizeof(double), stream_), "memset");
    check(cudaMemsetAsync(trianglePoint_.get(), 0, trianglePoint_.size() * sizeof(double), stream_), "memset");
    check(cudaMemsetAsync(triangleWeight_.get(), 0, triangleWeight_.size() * sizeof(double), stream_), "memset");
  }

  void enqueueRebuild(HostData& d) {
    SystemView raw = view(d);
    raw.cellKey = rawKey_.get();
    raw.sortedStone = rawStone_.get();
    cellKeyKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(raw);
    check(cudaGetLastError(), "cell key kernel");
    std::size_t bytes = sortTemp_.size();
    check(cub::DeviceRadixSort::SortPairs(sortTemp_.get(), bytes, rawKey_.get(), cellKey_.get(), rawStone_.get(),
                                          sortedStone_.get(), d.stoneCount, 0, sortBits(d.tableSize), stream_),
          "cub sort");
    check(cudaMemsetAsync(cellStart_.get(), 0xff, cellStart_.size() * sizeof(std::int32_t), stream_), "memset");
    SystemView v = view(d);
    cellBoundsKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(v);
    check(cudaGetLastError(), "cell bounds kernel");
    const int previous = current_;
    current_ = 1 - current_;
    v = view(d);
    neighbourKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(
        v, pairSlots_[previous].get(), pairCount_[previous].get(), wallSlots_[previous].get(),
        wallCount_[previous].get(), pairNormal_[previous].get(), wallNormal_[previous].get());
    check(cudaGetLastError(), "neighbour kernel");
    enqueueCandidateLists(d);
  }

  void enqueueCandidateLists(HostData& d) {
    check(cudaMemsetAsync(candidateCount_.get(), 0, 3 * sizeof(unsigned), stream_), "memset");
    if (d.stoneCount == 0) return;
    listCandidatesKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(
        view(d), pairCandidates_.get(), wallCandidates_.get(), wallStones_.get(), candidateCount_.get());
    check(cudaGetLastError(), "candidate list kernel");
  }

  // Contact forces of the state in `v`: pair candidates (filter, then GJK and contact law on the survivors),
  // then wall triangles.
  void enqueueForces(HostData& d, const SystemView& v) {
    check(cudaMemsetAsync(survivorCount_.get(), 0, 3 * sizeof(unsigned), stream_), "memset");
    const long long slots = static_cast<long long>(d.stoneCount) * d.maxPairs;
    if (slots > 0) {
      pairFilterKernel<<<filterBlocks_, blockSize, 0, stream_>>>(v, pairCandidates_.get(), candidateCount_.get(),
                                                                 survivors_.get(), survivorCount_.get());
      check(cudaGetLastError(), "pair filter kernel");
      pairNarrowPhaseKernel<<<contactBlocks_, blockSize, 0, stream_>>>(v, survivors_.get(), survivorCount_.get(),
                                                                       deferred_.get(), survivorCount_.get() + 2);
      check(cudaGetLastError(), "pair contact kernel");
      pairResumeKernel<<<resumeBlocks_, blockSize, 0, stream_>>>(v, deferred_.get(), survivorCount_.get() + 2, nullptr,
                                                                  nullptr);
      check(cudaGetLastError(), "pair resume kernel");
    }
    const long long wallSlots = static_cast<long long>(d.stoneCount) * d.maxWalls;
    if (d.triangleCount() > 0 && wallSlots > 0) {
      wallFilterKernel<<<filterBlocks_, blockSize, 0, stream_>>>(v, wallCandidates_.get(), candidateCount_.get() + 1,
                                                                 wallSurvivors_.get(), survivorCount_.get() + 1);
      check(cudaGetLastError(), "wall filter kernel");
      wallNarrowPhaseKernel<<<wallNarrowBlocks_, blockSize, 0, stream_>>>(v, wallSurvivors_.get(),
                                                                       survivorCount_.get() + 1, nullptr, nullptr);
      check(cudaGetLastError(), "wall narrow-phase kernel");
      wallForcesKernel<<<filterBlocks_, blockSize, 0, stream_>>>(v, wallStones_.get(), candidateCount_.get() + 2);
      check(cudaGetLastError(), "wall force kernel");
    }
  }

  // The stale test on the motion recorded at the end of the last chunk (waits for that chunk).
  bool listsOutgrown(const HostData& d, double nodeMoved, double nodeSpeed) {
    unsigned long long bits[2] = {0, 0};
    check(
        cudaMemcpyAsync(bits, counters_.get() + counterMaxDisplacement, sizeof(bits), cudaMemcpyDeviceToHost, stream_),
        "motion");
    check(cudaStreamSynchronize(stream_), "motion");
    double motion[2];
    std::memcpy(motion, bits, sizeof(motion));
    return listsStaleWithWalls(motion[0], motion[1], nodeMoved, nodeSpeed, (d.rebuildInterval + 1) * d.timeStep, d.skin);
  }

  // `count` steps, the first with a neighbour rebuild if `rebuild` (as the CPU reference: at step index
  // % interval == 0). Each step's correct runs fused with the next step's predict; the chunk ends
  // corrected, with the stale test for the next chunk.
  void enqueueChunk(HostData& d, int count, bool rebuild) {
    for (int s = 0; s < count; ++s) {
      SystemView v = view(d);
      if (s == 0) {
        startStepKernel<<<blocks(d.stoneCount + v.nodeCount), blockSize, 0, stream_>>>(v);
      } else {
        nextStepKernel<<<blocks(d.stoneCount + v.nodeCount), blockSize, 0, stream_>>>(v);
      }
      check(cudaGetLastError(), "predict kernel");
      if (s == 0 && rebuild) enqueueRebuild(d);
      v = view(d);
      v.recordOutput = s == count - 1; // contact outputs: only a call's last step is ever read
      enqueueForces(d, v);
    }
    const SystemView v = view(d);
    correctKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(v);
    check(cudaGetLastError(), "correct kernel");
    if (count == d.rebuildInterval) {
      check(cudaMemsetAsync(counters_.get() + counterMaxDisplacement, 0, 2 * sizeof(unsigned long long), stream_),
            "memset");
      motionKernel<<<blocks(d.stoneCount), blockSize, 0, stream_>>>(v);
      check(cudaGetLastError(), "motion kernel");
    }
  }

  void invalidateGraphs() {
    for (auto& byKind : graphs_) {
      for (auto& g : byKind) {
        if (g) cudaGraphExecDestroy(g);
        g = nullptr;
      }
    }
  }

  cudaStream_t stream_ = nullptr;
  cudaGraphExec_t graphs_[2][2] = {{nullptr, nullptr}, {nullptr, nullptr}}; // [parity][with rebuild]
  int current_ = 0;
  DeviceArray<kernels::RotationState> rotation_;
  DeviceArray<double> position_, velocity_, force_, torque_, rollingBudget_, reference_, vertices_, nodePosition_, nodeVelocity_,
      triangleForce_, trianglePoint_, triangleWeight_;
  DeviceArray<std::int32_t> shape_, triangles_, triangleMaterial_, pairCount_[2], wallCount_[2], sortedStone_, rawStone_, cellStart_, largeBodies_,
      cellEnd_;
  DeviceArray<ShapeData> shapes_;
  DeviceArray<ContactSlot> pairSlots_[2], wallSlots_[2];
  DeviceArray<kernels::NormalHistory> pairNormal_[2], wallNormal_[2]; // empty unless the law keeps a normal history
  DeviceArray<ContactOutput> pairOutput_, wallOutput_;
  DeviceArray<std::uint32_t> cellKey_, rawKey_;
  DeviceArray<unsigned long long> counters_;
  DeviceArray<unsigned char> sortTemp_;
  DeviceArray<std::uint32_t> survivors_, wallSurvivors_, deferred_, pairCandidates_, wallCandidates_, wallStones_;
  DeviceArray<unsigned> candidateCount_;
  DeviceArray<ContactGeometry> wallGeometry_;
  DeviceArray<unsigned> survivorCount_;
  DeviceArray<ActiveContact> active_; // activeContacts' gathering buffer
  DeviceArray<std::uint8_t> selected_; // activeContacts' stone flags
  DeviceArray<unsigned> activeCount_;
  // saveSnapshot's copy of the state buffers (forEachStateBuffer pairs them with the live ones).
  struct SavedState {
    DeviceArray<double> position, velocity, force, torque, rollingBudget, reference, nodePosition, nodeVelocity, triangleForce,
        trianglePoint, triangleWeight;
    DeviceArray<kernels::RotationState> rotation;
    DeviceArray<ContactSlot> pairSlots, wallSlots;
    DeviceArray<std::int32_t> pairCount, wallCount;
    DeviceArray<kernels::NormalHistory> pairNormal, wallNormal;
    DeviceArray<ContactOutput> pairOutput, wallOutput;
  } saved_;
  int contactBlocks_ = 1; // resident blocks of the pair narrow phase's first pass (grid-stride over the survivors)
  int resumeBlocks_ = 1;     // ... of the resumed (deferred) pair GJK runs
  int wallNarrowBlocks_ = 1; // ... of the wall narrow phase
  int filterBlocks_ = 1;  // resident blocks of the filter kernels (grid-stride over the candidate lists)
};

} // namespace

std::unique_ptr<PolyhedraBackend> makeCudaBackend(std::string& reason) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    reason = std::string("no CUDA device: ") + cudaGetErrorString(status);
    cudaGetLastError(); // clear the sticky-free error so later runtime calls are not confused
    return nullptr;
  }
  if (count == 0) {
    reason = "no CUDA device found";
    return nullptr;
  }
  cudaDeviceProp properties{};
  if (cudaGetDeviceProperties(&properties, 0) != cudaSuccess || properties.major < 6) {
    reason = "CUDA device 0 is older than compute capability 6.0 (double atomics needed)";
    return nullptr;
  }
  reason = std::string("CUDA device 0: ") + properties.name;
  return std::make_unique<CudaBackend>();
}

} // namespace railcosim::polyhedra
