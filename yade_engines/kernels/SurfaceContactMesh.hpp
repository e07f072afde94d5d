// Host-side companions of SurfaceContact.hpp: surface topology built once, a triangle broad phase, a vector query.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "kernels/SurfaceContact.hpp"

namespace railcosim::kernels {

// Edges, edge → triangles and node → triangles of a triangulated surface, derived from the connectivity
// alone (positions change every step, the topology never does). Non-manifold edges (three or more
// triangles) and boundary edges (one triangle) are allowed.
class SurfaceTopology {
public:
  // triangles: 3 zero-based node indices per triangle. Throws std::invalid_argument naming the first
  // problem (size not a multiple of 3, index out of [0, nodeCount), a triangle repeating a node).
  SurfaceTopology(const std::vector<std::int32_t>& triangles, std::int32_t nodeCount)
      : nodeCount_(nodeCount), triangles_(triangles) {
    if (nodeCount < 0) fail("nodeCount is negative", nodeCount);
    if (triangles.size() % 3 != 0)
      fail("connectivity size is not a multiple of 3", static_cast<long long>(triangles.size()));
    const std::int32_t triangleCount = static_cast<std::int32_t>(triangles.size() / 3);
    for (std::int32_t t = 0; t < triangleCount; ++t) {
      for (int k = 0; k < 3; ++k) {
        const std::int32_t node = triangles[3 * t + k];
        if (node < 0 || node >= nodeCount) {
          std::ostringstream what;
          what << "triangle " << t << " refers to node " << node << ", outside [0, " << nodeCount << ")";
          fail(what.str());
        }
      }
      const std::int32_t* n = &triangles[3 * t];
      if (n[0] == n[1] || n[1] == n[2] || n[0] == n[2]) {
        std::ostringstream what;
        what << "triangle " << t << " repeats a node (" << n[0] << ", " << n[1] << ", " << n[2] << ")";
        fail(what.str());
      }
    }
    // Edges: sort the (lower node, higher node, triangle, local edge) records, one edge per distinct pair.
    struct Record {
      std::int32_t low, high, triangle, local;
    };
    std::vector<Record> records;
    records.reserve(triangles.size());
    for (std::int32_t t = 0; t < triangleCount; ++t)
      for (int a = 0; a < 3; ++a) {
        const std::int32_t p = triangles[3 * t + a], q = triangles[3 * t + (a + 1) % 3];
        records.push_back(Record{std::min(p, q), std::max(p, q), t, a});
      }
    std::sort(records.begin(), records.end(), [](const Record& x, const Record& y) {
      if (x.low != y.low) return x.low < y.low;
      if (x.high != y.high) return x.high < y.high;
      return x.triangle < y.triangle;
    });
    triangleEdges_.assign(triangles.size(), -1);
    edgeTriangleStart_.push_back(0);
    for (std::size_t r = 0; r < records.size(); ++r) {
      const bool newEdge = r == 0 || records[r].low != records[r - 1].low || records[r].high != records[r - 1].high;
      if (newEdge) {
        if (r > 0) edgeTriangleStart_.push_back(static_cast<std::int32_t>(edgeTriangleList_.size()));
        edgeNodes_.push_back(records[r].low);
        edgeNodes_.push_back(records[r].high);
      }
      const std::int32_t edge = static_cast<std::int32_t>(edgeNodes_.size() / 2) - 1;
      triangleEdges_[3 * records[r].triangle + records[r].local] = edge;
      edgeTriangleList_.push_back(records[r].triangle);
    }
    edgeTriangleStart_.push_back(static_cast<std::int32_t>(edgeTriangleList_.size()));
    if (records.empty()) edgeTriangleStart_.assign(1, 0);
    // Node → triangles by counting sort (triangle indices ascending within each node).
    nodeTriangleStart_.assign(static_cast<std::size_t>(nodeCount) + 1, 0);
    for (std::int32_t node : triangles) ++nodeTriangleStart_[node + 1];
    for (std::int32_t v = 0; v < nodeCount; ++v) nodeTriangleStart_[v + 1] += nodeTriangleStart_[v];
    nodeTriangleList_.resize(triangles.size());
    std::vector<std::int32_t> fill(nodeTriangleStart_.begin(), nodeTriangleStart_.end() - 1);
    for (std::int32_t t = 0; t < triangleCount; ++t)
      for (int k = 0; k < 3; ++k) nodeTriangleList_[fill[triangles[3 * t + k]]++] = t;
  }

  std::int32_t nodeCount() const { return nodeCount_; }
  std::int32_t triangleCount() const { return static_cast<std::int32_t>(triangles_.size() / 3); }
  std::int32_t edgeCount() const { return static_cast<std::int32_t>(edgeNodes_.size() / 2); }
  const std::vector<std::int32_t>& triangles() const { return triangles_; }
  const std::vector<std::int32_t>& triangleEdges() const { return triangleEdges_; }
  const std::vector<std::int32_t>& edgeNodes() const { return edgeNodes_; }
  const std::vector<std::int32_t>& edgeTriangleStart() const { return edgeTriangleStart_; }
  const std::vector<std::int32_t>& edgeTriangleList() const { return edgeTriangleList_; }
  const std::vector<std::int32_t>& nodeTriangleStart() const { return nodeTriangleStart_; }
  const std::vector<std::int32_t>& nodeTriangleList() const { return nodeTriangleList_; }

  // Number of triangles sharing edge e (1: boundary, 2: manifold interior, more: non-manifold).
  std::int32_t edgeValence(std::int32_t edge) const { return edgeTriangleStart_[edge + 1] - edgeTriangleStart_[edge]; }

  // Kernel view over this topology and the caller's current nodal arrays (3 doubles per node each;
  // velocities may be null). The arrays must outlive the view and hold nodeCount() nodes.
  SurfaceMeshView view(const double* positions, const double* velocities) const {
    return SurfaceMeshView{nodeCount_,
                           triangleCount(),
                           edgeCount(),
                           positions,
                           velocities,
                           triangles_.data(),
                           triangleEdges_.data(),
                           edgeNodes_.data(),
                           edgeTriangleStart_.data(),
                           edgeTriangleList_.data(),
                           nodeTriangleStart_.data(),
                           nodeTriangleList_.data()};
  }

  // Same, checking the array sizes (3 per node; velocities may be empty for a surface at rest).
  SurfaceMeshView view(const std::vector<double>& positions, const std::vector<double>& velocities) const {
    if (positions.size() != 3 * static_cast<std::size_t>(nodeCount_))
      fail("positions must hold 3 values per node", static_cast<long long>(positions.size()));
    if (!velocities.empty() && velocities.size() != positions.size())
      fail("velocities must be empty or hold 3 values per node", static_cast<long long>(velocities.size()));
    return view(positions.data(), velocities.empty() ? nullptr : velocities.data());
  }

private:
  [[noreturn]] static void fail(const std::string& what) {
    throw std::invalid_argument("SurfaceTopology: " + what +
                                "; pass the FEM surface connectivity (3 node indices per triangle)");
  }
  [[noreturn]] static void fail(const char* what, long long value) {
    std::ostringstream message;
    message << what << " (got " << value << ")";
    fail(message.str());
  }

  std::int32_t nodeCount_;
  std::vector<std::int32_t> triangles_;
  std::vector<std::int32_t> triangleEdges_;
  std::vector<std::int32_t> edgeNodes_;
  std::vector<std::int32_t> edgeTriangleStart_;
  std::vector<std::int32_t> edgeTriangleList_;
  std::vector<std::int32_t> nodeTriangleStart_;
  std::vector<std::int32_t> nodeTriangleList_;
};

// Broad phase of the DE/FE search (Irazábal 2017 §4.2, M5): triangle bounding boxes hashed into a
// uniform grid, queried with a sphere's box. Rebuild once per step (or per neighbour-search interval,
// with `margin` ≥ the largest node or sphere displacement over the interval). Host only.
class SurfaceTriangleGrid {
public:
  // cellSize [m]: the thesis' GNS advice is a few times the mean object size; the larger of the mean
  // triangle size and the sphere diameter is a good choice.
  explicit SurfaceTriangleGrid(double cellSize) : cellSize_(cellSize) {
    if (!(cellSize > 0.0) || !std::isfinite(cellSize)) {
      std::ostringstream message;
      message << "SurfaceTriangleGrid: cellSize must be positive and finite, got " << cellSize
              << "; use about the larger of the mean triangle edge and the sphere diameter";
      throw std::invalid_argument(message.str());
    }
  }

  // Bins every triangle's box, enlarged by `margin` [m] on each side, at the surface's current positions.
  void rebuild(const SurfaceMeshView& surface, double margin = 0.0) {
    entries_.clear();
    for (std::int32_t t = 0; t < surface.triangleCount; ++t) {
      Vec3 low{1e300, 1e300, 1e300}, high{-1e300, -1e300, -1e300};
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = surfaceNodePosition(surface, surface.triangles[3 * t + k]);
        low = Vec3{std::min(low.x, p.x), std::min(low.y, p.y), std::min(low.z, p.z)};
        high = Vec3{std::max(high.x, p.x), std::max(high.y, p.y), std::max(high.z, p.z)};
      }
      const std::array<std::int64_t, 3> first = cellOf(low - Vec3{margin, margin, margin});
      const std::array<std::int64_t, 3> last = cellOf(high + Vec3{margin, margin, margin});
      for (std::int64_t i = first[0]; i <= last[0]; ++i)
        for (std::int64_t j = first[1]; j <= last[1]; ++j)
          for (std::int64_t k = first[2]; k <= last[2]; ++k) entries_.emplace_back(key(i, j, k), t);
    }
    std::sort(entries_.begin(), entries_.end());
    seen_.assign(static_cast<std::size_t>(surface.triangleCount), 0);
    stamp_ = 0;
  }

  // Triangles whose (enlarged) box shares a cell with the box of the sphere (centre, radius), each once,
  // in ascending order. A superset of the triangles the sphere touches; the H² query sorts it out.
  void candidates(const Vec3& centre, double radius, std::vector<std::int32_t>& out) {
    out.clear();
    if (++stamp_ == 0) { // stamp wrapped around: clear the marks once
      std::fill(seen_.begin(), seen_.end(), 0);
      stamp_ = 1;
    }
    const std::array<std::int64_t, 3> first = cellOf(centre - Vec3{radius, radius, radius});
    const std::array<std::int64_t, 3> last = cellOf(centre + Vec3{radius, radius, radius});
    for (std::int64_t i = first[0]; i <= last[0]; ++i)
      for (std::int64_t j = first[1]; j <= last[1]; ++j)
        for (std::int64_t k = first[2]; k <= last[2]; ++k) {
          const std::uint64_t cell = key(i, j, k);
          auto range = std::equal_range(entries_.begin(), entries_.end(), std::make_pair(cell, std::int32_t{0}),
                                        [](const Entry& a, const Entry& b) { return a.first < b.first; });
          for (auto it = range.first; it != range.second; ++it) {
            if (seen_[it->second] == stamp_) continue;
            seen_[it->second] = stamp_;
            out.push_back(it->second);
          }
        }
    std::sort(out.begin(), out.end());
  }

private:
  using Entry = std::pair<std::uint64_t, std::int32_t>;

  std::array<std::int64_t, 3> cellOf(const Vec3& p) const {
    return {static_cast<std::int64_t>(std::floor(p.x / cellSize_)),
            static_cast<std::int64_t>(std::floor(p.y / cellSize_)),
            static_cast<std::int64_t>(std::floor(p.z / cellSize_))};
  }
  // 21 bits per axis: cells 2^21 apart share a key, which only adds candidates (never loses one).
  static std::uint64_t key(std::int64_t i, std::int64_t j, std::int64_t k) {
    const std::uint64_t mask = (std::uint64_t{1} << 21) - 1;
    return ((static_cast<std::uint64_t>(i) & mask) << 42) | ((static_cast<std::uint64_t>(j) & mask) << 21) |
           (static_cast<std::uint64_t>(k) & mask);
  }

  double cellSize_;
  std::vector<Entry> entries_;
  std::vector<std::uint32_t> seen_;
  std::uint32_t stamp_ = 0;
};

// Host convenience over findSurfaceContacts: contacts of one sphere with the candidate triangles.
inline std::vector<SurfaceContact> findSurfaceContacts(
    const SurfaceMeshView& surface, const Vec3& centre, double radius, const std::vector<std::int32_t>& candidates,
    const SurfaceContactSettings& settings = SurfaceContactSettings{}) {
  std::vector<SurfaceContact> contacts(candidates.size());
  const SurfaceContactCount found =
      findSurfaceContacts(surface, centre, radius, candidates.data(), static_cast<std::int32_t>(candidates.size()),
                          settings, contacts.data(), static_cast<std::int32_t>(contacts.size()));
  contacts.resize(static_cast<std::size_t>(found.count));
  return contacts;
}

} // namespace railcosim::kernels
