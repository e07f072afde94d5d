// Facade of the polyhedra DEM: shape templates, parameter checks, backend choice and host-side accessors.
#include "polyhedra/PolyhedraSystem.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <istream>
#include <limits>
#include <map>
#include <ostream>
#include <sstream>
#include <type_traits>
#include <utility>

#include <Eigen/Eigenvalues>

#include "kernels/CriticalTimeStep.hpp"
#include "kernels/MathConstants.hpp"
#include "polyhedra/PolyhedraBackend.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/Log.hpp"
#include "railcosim/StateStream.hpp"

namespace railcosim::polyhedra {

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw Error("PolyhedraSystem::" + where + ": " + what);
}

// The state of one stone (3, 4, 3, 3 values) as addStone and setState accept it: finite, non-zero quaternion.
void checkStoneState(const std::string& where, std::size_t stone, const double* position, const double* orientation,
                     const double* velocity, const double* angularVelocity) {
  bool finite = true;
  double norm2 = 0.0;
  for (int c = 0; c < 3; ++c)
    finite = finite && std::isfinite(position[c]) && std::isfinite(velocity[c]) && std::isfinite(angularVelocity[c]);
  for (int c = 0; c < 4; ++c) norm2 += orientation[c] * orientation[c];
  if (!finite || !std::isfinite(norm2))
    fail(where, "stone " + std::to_string(stone) + ": position, orientation and velocities must be finite numbers");
  if (!(norm2 > 1e-24)) fail(where, "stone " + std::to_string(stone) + ": the orientation quaternion is zero");
}

// `values` (width per stone) with the values of stone k moved to stone target(k).
template <typename Values, typename Target>
Values scattered(const Values& values, std::size_t width, std::size_t count, Target target) {
  Values result(values.size());
  for (std::size_t k = 0; k < count; ++k)
    for (std::size_t c = 0; c < width; ++c) result[width * target(k) + c] = values[width * k + c];
  return result;
}

// Principal moments and axes of a symmetric inertia tensor, from Eigen's SelfAdjointEigenSolver (Householder
// tridiagonalisation and implicit symmetric QR, Golub & Van Loan 2013, §8.3). Eigenvectors are defined only up
// to order, sign and, for equal moments, any rotation within their eigenspace; the principal frame is taken as
// the eigenvector frame closest to the frame the template was given in, so that it does not depend on the
// solver and a template already in principal axes keeps its frame:
//   1. a tensor diagonal to round-off (sum of squared off-diagonal terms ≤ 1e-30 of that of the diagonal)
//      is taken as it is: the given axes, its diagonal as the moments;
//   2. moments within 1e-10 of the largest span one eigenspace: three equal moments give the given axes; for two,
//      the odd eigenvector takes the given axis it is most aligned with and the two other given axes, projected
//      onto the plane normal to it (Gram–Schmidt in axis order), span the double eigenspace;
//   3. three distinct moments: given axis k takes eigenvector p(k), p the permutation maximising Σ_k |v_p(k)·e_k|;
//   4. every axis is signed so that v_k·e_k ≥ 0; a left-handed frame gets its least aligned axis reversed.
// The moments are the Rayleigh quotients v_kᵀ I v_k of the chosen axes. axes[r][c]: component r of axis c.
void principalAxes(const double inertia[3][3], double moments[3], double axes[3][3]) {
  Eigen::Matrix3d tensor;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) tensor(r, c) = inertia[r][c];
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity(); // column k: principal axis k in the given frame
  const double offDiagonal = tensor(0, 1) * tensor(0, 1) + tensor(0, 2) * tensor(0, 2) + tensor(1, 2) * tensor(1, 2);
  const double diagonal = tensor(0, 0) * tensor(0, 0) + tensor(1, 1) * tensor(1, 1) + tensor(2, 2) * tensor(2, 2);
  if (offDiagonal > 1e-30 * diagonal) { // else case 1: the given axes
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(tensor);
    if (solver.info() != Eigen::Success)
      fail("addShape", "the eigen-decomposition of the inertia tensor did not converge");
    const Eigen::Vector3d values = solver.eigenvalues(); // ascending
    const Eigen::Matrix3d vectors = solver.eigenvectors();
    const double tolerance = 1e-10 * std::max(std::fabs(values(0)), std::fabs(values(2)));
    const bool lowPair = values(1) - values(0) <= tolerance, highPair = values(2) - values(1) <= tolerance;
    if (lowPair != highPair) {
      const Eigen::Vector3d odd = vectors.col(lowPair ? 2 : 0);
      int oddAxis = 0;
      odd.cwiseAbs().maxCoeff(&oddAxis);
      frame.col(oddAxis) = odd;
      bool first = true;
      for (int k = 0; k < 3; ++k) {
        if (k == oddAxis) continue;
        Eigen::Vector3d axis = Eigen::Vector3d::Unit(k);
        axis -= axis.dot(odd) * odd;
        if (!first) {
          const Eigen::Vector3d previous = frame.col(3 - oddAxis - k);
          axis -= axis.dot(previous) * previous;
        }
        frame.col(k) = axis.normalized();
        first = false;
      }
    } else if (!lowPair) {
      static const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
      int best = 0;
      double bestAlignment = -1.0;
      for (int p = 0; p < 6; ++p) {
        double alignment = 0.0;
        for (int k = 0; k < 3; ++k) alignment += std::fabs(vectors(k, permutations[p][k]));
        if (alignment > bestAlignment) {
          bestAlignment = alignment;
          best = p;
        }
      }
      for (int k = 0; k < 3; ++k) frame.col(k) = vectors.col(permutations[best][k]);
    }
    for (int k = 0; k < 3; ++k)
      if (frame(k, k) < 0.0) frame.col(k) = -frame.col(k);
    if (frame.determinant() < 0.0) {
      int leastAligned = 0;
      frame.diagonal().minCoeff(&leastAligned);
      frame.col(leastAligned) = -frame.col(leastAligned);
    }
  }
  for (int k = 0; k < 3; ++k) {
    moments[k] = frame.col(k).dot(tensor * frame.col(k)); // exactly tensor(k, k) for the given axes
    for (int r = 0; r < 3; ++r) axes[r][k] = frame(r, k);
  }
}

Quat quaternionFromMatrix(const double m[3][3]) {
  const double trace = m[0][0] + m[1][1] + m[2][2];
  Quat q;
  if (trace > 0.0) {
    const double s = 0.5 / std::sqrt(trace + 1.0);
    q = Quat{0.25 / s, (m[2][1] - m[1][2]) * s, (m[0][2] - m[2][0]) * s, (m[1][0] - m[0][1]) * s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    q = Quat{(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
  } else if (m[1][1] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
    q = Quat{(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
    q = Quat{(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
  }
  return normalized(q);
}

kernels::ContactMaterial contactMaterialOf(const Material& m) {
  return kernels::ContactMaterial{
      m.youngModulus,     m.poissonRatio,     m.restitution,      m.friction,         m.roughnessRms,
      m.fractalDimension, m.plasticUnloading, m.frictionExponent, m.maxContactStress, m.rollingFriction};
}

// The one mixing rule of the contact law (kernels/ContactLaw.hpp). Stones are separate particles, so the
// stress-dependent friction of different clusters applies between them (where its parameters are set), never against
// a wall. Every law carries the rolling arm of its η_r; the rolling torque acts on sphere stones only
// (PolyhedraStep.hpp, halfKickTorque).
kernels::ContactLaw lawOf(const Material& a, const Material& b, bool betweenStones, const char* which) {
  try {
    return kernels::mixContactLaw(contactMaterialOf(a), contactMaterialOf(b),
                                  kernels::ContactPairOptions{betweenStones, true});
  } catch (const std::invalid_argument& e) {
    fail("PolyhedraSystem", std::string("material of ") + which + " contacts: " + e.what());
  }
}


// State streams (writeState/readState): a magic tag and a format version, raised whenever the layout of the stream
// or of a record it holds changes; the record sizes are written too, so that a changed struct is caught even if
// the version was not raised.
constexpr char stateMagic[8] = {'R', 'C', 'P', 'O', 'L', 'Y', 'S', 'T'};
constexpr std::uint32_t stateVersion = 2; // 2: the rolling budget (bounded rolling friction) after the torque

template <class T>
void writeValue(std::ostream& out, const T& value) {
  static_assert(std::is_trivially_copyable_v<T>, "state records are written as bytes");
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
void writeArray(std::ostream& out, const std::vector<T>& array) {
  static_assert(std::is_trivially_copyable_v<T>, "state records are written as bytes");
  writeValue<std::uint64_t>(out, array.size());
  if (!array.empty())
    out.write(reinterpret_cast<const char*>(array.data()), static_cast<std::streamsize>(array.size() * sizeof(T)));
}

// A fresh list entry of each kind (HostData::allocate's).
ContactSlot freshEntry(const ContactSlot&) { return ContactSlot{-1, 0, 0.0f, {0, 0, 0}, {0, 0, 0}, 0}; }
kernels::NormalHistory freshEntry(const kernels::NormalHistory&) { return kernels::NormalHistory{0.0, 0.0}; }
ContactOutput freshEntry(const ContactOutput&) { return ContactOutput{}; }

// A copy of a per-stone list array (`width` entries per stone) in the form a state stream holds: the entries past each
// stone's count made fresh, and an output entry whose slot is not an acting contact (active != 1: apart, or a
// duplicate wall contact) made fresh too, since outputs are written only by acting contacts and otherwise keep an
// earlier occupant's. An unkept array (an empty normal history) passes unchanged.
template <class T>
std::vector<T> canonicalList(const std::vector<T>& array, const std::vector<std::int32_t>& counts, int width,
                             const std::vector<ContactSlot>& slots) {
  if (array.empty()) return array;
  if (array.size() != counts.size() * static_cast<std::size_t>(width) || slots.size() != array.size())
    fail("writeState", "a contact list's size differs from stones x list width (internal error)");
  std::vector<T> canonical = array;
  for (std::size_t i = 0; i < counts.size(); ++i)
    for (std::size_t k = 0; k < static_cast<std::size_t>(width); ++k) {
      const std::size_t index = i * width + k;
      const bool past = k >= static_cast<std::size_t>(std::max(counts[i], 0));
      if (past || (std::is_same_v<T, ContactOutput> && slots[index].active != 1))
        canonical[index] = freshEntry(canonical[index]);
    }
  return canonical;
}

template <class T>
T readValue(std::istream& in, const std::string& what) {
  T value{};
  in.read(reinterpret_cast<char*>(&value), sizeof(T));
  if (!in) fail("readState", "the stream ends inside " + what + " (truncated or not a polyhedra state)");
  return value;
}

// Reads an array written by writeArray; its length must be `expected`.
template <class T>
std::vector<T> readArray(std::istream& in, std::size_t expected, const std::string& what) {
  const std::uint64_t count = readValue<std::uint64_t>(in, "the length of " + what);
  if (count != expected)
    fail("readState", what + " holds " + std::to_string(count) + " records in the stream, this system has " +
                          std::to_string(expected) + "; the state was written by a system built differently");
  std::vector<T> array(count);
  if (count > 0) in.read(reinterpret_cast<char*>(array.data()), static_cast<std::streamsize>(count * sizeof(T)));
  if (!in) fail("readState", "the stream ends inside " + what + " (truncated)");
  return array;
}

// The counts and record sizes the stream header states; a reader compares its own with them, field by field.
struct StateHeader {
  const char* name;
  std::uint64_t value;
};
} // namespace

Material materialOf(const kernels::ContactMaterial& m) {
  Material result;
  result.youngModulus = m.youngModulus;
  result.poissonRatio = m.poissonRatio;
  result.restitution = m.restitution;
  result.friction = m.frictionCoefficient;
  result.roughnessRms = m.roughnessRms;
  result.fractalDimension = m.fractalDimension;
  result.plasticUnloading = m.plasticUnloading;
  result.frictionExponent = m.frictionExponent;
  result.maxContactStress = m.maxContactStress;
  result.rollingFriction = m.rollingFriction;
  return result;
}

const char* backendName(Backend backend) {
  switch (backend) {
    case Backend::Automatic:
      return "automatic";
    case Backend::Cpu:
      return "cpu";
    case Backend::Cuda:
      return "cuda";
  }
  return "?";
}

struct PolyhedraSystem::Implementation {
  Parameters parameters;
  HostData data;
  std::vector<ShapeProperties> properties;
  std::vector<ShapeTemplate> templates; // in the principal frame
  std::unique_ptr<PolyhedraBackend> backend;
  Backend active = Backend::Cpu;
  std::string reason;
  bool started = false;
  bool hostCurrent = true; // host arrays hold the latest state
  int partsCurrent = 0;     // parts of it downloaded since it last changed on the device (sync(parts))
  bool warnedDangerous = false;
  int lastSteps = 0;
  double time = 0.0;
  StepStatistics statistics;
  // Storage order (set at the first step): stone k of the arrays is the user's stone userOf[k]; empty
  // before the first step, when the arrays are in the user's (addStone) order.
  std::vector<std::int32_t> userOf, storedOf;
  // What saveSnapshot keeps beside the backend's copy of the state arrays: the facade's own state, and the host's
  // surface velocities (read on the host by the rebuild decision; the CUDA backend never downloads them).
  struct Snapshot {
    bool saved = false;
    double time = 0.0;
    int lastSteps = 0;
    bool forcesValid = false;
    StepStatistics statistics;
    std::vector<double> nodePosition, nodeVelocity;
  } snapshot;

  std::size_t stored(std::size_t user) const {
    return storedOf.empty() ? user : static_cast<std::size_t>(storedOf[user]);
  }
  // stored() of an index a caller gave (addStone order), refused with `where` when there is no such stone.
  std::size_t storedChecked(const char* where, std::int32_t user) const {
    if (user < 0 || static_cast<std::size_t>(user) >= data.rotation.size())
      fail(where, "stone " + std::to_string(user) + " out of range (" + std::to_string(data.rotation.size()) +
                      " stones)");
    return stored(static_cast<std::size_t>(user));
  }
  std::size_t user(std::size_t storedIndex) const {
    return userOf.empty() ? storedIndex : static_cast<std::size_t>(userOf[storedIndex]);
  }
  // `width` values per stone, stored order -> user order.
  std::vector<double> inUserOrder(const std::vector<double>& values, std::size_t width) const {
    if (userOf.empty()) return values;
    return scattered(values, width, userOf.size(), [&](std::size_t k) { return user(k); });
  }
  void storeInSpatialOrder();
  void storeInOrder(const std::vector<std::int32_t>& order);
  void restoreUserOrder();
  // Everything the first step does before stepping (checks, skin, grid, spatial order, arrays, upload).
  void start();
  // Per-stone arrays that exist before the first step, permuted by storeInSpatialOrder.
  // Moves the values of stone k to stone target(k).
  template <typename Target>
  void permuteStones(Target target) {
    HostData& d = data;
    const std::size_t n = userOf.size();
    d.position = scattered(d.position, 3, n, target);
    d.velocity = scattered(d.velocity, 3, n, target);
    d.rotation = scattered(d.rotation, 1, n, target);
    d.shape = scattered(d.shape, 1, n, target);
  }

  void sync() {
    if (!hostCurrent) {
      backend->download(data);
      hostCurrent = true;
    }
  }
  // The active contacts in user indices; `selected` as PolyhedraBackend::activeContacts takes it (empty: all).
  std::vector<ContactRecord> contacts(const std::vector<std::uint8_t>& selected);
  // Only `parts` of the state (downloadStones, downloadTriangles) current on the host: the accessors a coupling
  // window calls every window. A later sync() still brings back everything.
  void sync(int parts) {
    if (hostCurrent || (partsCurrent & parts) == parts) return;
    backend->downloadParts(data, parts & ~partsCurrent);
    partsCurrent |= parts;
  }
};

// Stones are stored in Morton (Z-curve) order of their grid cells at the first step: neighbours in space
// become neighbours in memory, so the contact passes, which read the state of both stones of every
// candidate, find the partner's state in cache. Measured on the 1e6-stone benchmark bed added layer by
// layer: 4.10e8 -> 4.61e8 particle-steps/s (the bed's state, ~400 MB, is far larger than the L2 cache; at
// 1e5 stones it fits and the order made no difference). Stones move little in a bed, so the order stays
// good; the accessors translate back to the user's order.
void PolyhedraSystem::Implementation::storeInSpatialOrder() {
  HostData& d = data;
  const std::size_t n = static_cast<std::size_t>(d.stoneCount);
  Vec3 lowest{1e300, 1e300, 1e300};
  for (std::size_t i = 0; i < n; ++i) {
    lowest.x = std::min(lowest.x, d.position[3 * i]);
    lowest.y = std::min(lowest.y, d.position[3 * i + 1]);
    lowest.z = std::min(lowest.z, d.position[3 * i + 2]);
  }
  // 21 bits per axis: 2e6 cells along each, far beyond any bed that fits in memory (clamped if not).
  auto spread = [](std::uint64_t v) {
    std::uint64_t r = 0;
    for (int b = 0; b < 21; ++b) r |= ((v >> b) & 1u) << (3 * b);
    return r;
  };
  auto cell = [&](double x, double origin) {
    const double c = std::floor((x - origin) / d.cellSize);
    return c >= 0.0 ? static_cast<std::uint64_t>(std::min(c, 2097151.0)) : std::uint64_t{0}; // NaN: 0
  };
  std::vector<std::pair<std::uint64_t, std::int32_t>> keyed(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = spread(cell(d.position[3 * i], lowest.x)) |
                              (spread(cell(d.position[3 * i + 1], lowest.y)) << 1) |
                              (spread(cell(d.position[3 * i + 2], lowest.z)) << 2);
    keyed[i] = {key, static_cast<std::int32_t>(i)};
  }
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::int32_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = keyed[k].second;
  storeInOrder(order);
}

// Stores the stones (still in the user's order) so that stone k of the arrays is the user's stone order[k].
void PolyhedraSystem::Implementation::storeInOrder(const std::vector<std::int32_t>& order) {
  const std::size_t n = order.size();
  userOf = order;
  storedOf.resize(n);
  for (std::size_t k = 0; k < n; ++k) storedOf[order[k]] = static_cast<std::int32_t>(k);
  permuteStones([&](std::size_t k) { return stored(k); });
}

// Undoes storeInSpatialOrder when the first step fails before it started (e.g. out of device memory), so
// that a retry, or more addStone calls, find the arrays in the user's order again.
void PolyhedraSystem::Implementation::restoreUserOrder() {
  if (userOf.empty()) return;
  permuteStones([&](std::size_t k) { return user(k); });
  userOf.clear();
  storedOf.clear();
}

namespace {

// The bounding radius above which a body is large (Parameters::largeBodyRatio): `ratio` times the median one; when
// more than maxLargeBodies exceed it, the radius of the (maxLargeBodies + 1)-th largest body (the largest ones go).
// +inf when none is large.
double largeBodyRadius(const HostData& d, double ratio) {
  const double none = std::numeric_limits<double>::infinity();
  if (!(ratio > 0.0) || d.stoneCount == 0) return none;
  std::vector<double> radii(d.shape.size());
  for (std::size_t i = 0; i < radii.size(); ++i) radii[i] = d.shapes[d.shape[i]].boundingRadius;
  std::nth_element(radii.begin(), radii.begin() + radii.size() / 2, radii.end());
  double threshold = ratio * radii[radii.size() / 2];
  if (radii.size() > static_cast<std::size_t>(maxLargeBodies)) {
    std::nth_element(radii.begin(), radii.begin() + maxLargeBodies, radii.end(), std::greater<double>());
    threshold = std::max(threshold, radii[maxLargeBodies]);
  }
  const bool any = std::any_of(radii.begin(), radii.end(), [&](double r) { return r > threshold; });
  return any ? threshold : none;
}

// Stored indices of the large bodies (after the storage order is set).
std::vector<std::int32_t> largeBodiesOf(const HostData& d) {
  std::vector<std::int32_t> large;
  for (int i = 0; i < d.stoneCount; ++i)
    if (d.shapes[d.shape[i]].boundingRadius > d.largeRadius) large.push_back(i);
  return large;
}

} // namespace

void PolyhedraSystem::Implementation::start() {
  if (started) return;
  HostData& d = data;
  if (d.stoneCount == 0) fail("step", "no stones: add stones before stepping");
  // A contact slot keeps its partner (stone or triangle) in 30 bits.
  if (d.stoneCount >= partnerLimit || d.triangleCount() >= partnerLimit)
    fail("step", std::to_string(d.stoneCount) + " stones and " + std::to_string(d.triangleCount()) +
                     " triangles: at most " + std::to_string(partnerLimit - 1) + " of each");
  if (!d.triangleMaterial.empty() && d.triangleMaterial.size() != static_cast<std::size_t>(d.triangleCount()))
    fail("step", "setWallMaterials named " + std::to_string(d.triangleMaterial.size()) + " triangles, the walls have " +
                     std::to_string(d.triangleCount()) + "; call it again after setWalls");
  double meanDilation = 0.0;
  for (std::int32_t s : d.shape) meanDilation += d.shapes[s].dilationRadius;
  meanDilation /= d.stoneCount;
  // Default skin: a fifth of the dilation radius, the scale on which contacts open and close.
  d.skin = parameters.neighbourSkin >= 0.0 ? parameters.neighbourSkin : 0.2 * meanDilation;
  d.largeRadius = largeBodyRadius(d, parameters.largeBodyRatio);
  double maxBounding = 0.0;
  for (std::int32_t s : d.shape)
    if (d.shapes[s].boundingRadius <= d.largeRadius) maxBounding = std::max(maxBounding, d.shapes[s].boundingRadius);
  d.cellSize = 2.0 * maxBounding + d.skin;
  storeInSpatialOrder();
  d.largeBodies = largeBodiesOf(d);
  try {
    d.allocate();
    backend->upload(d);
  } catch (...) {
    restoreUserOrder();
    throw;
  }
  started = true;
}

PolyhedraSystem::PolyhedraSystem(const Parameters& p) : implementation_(std::make_unique<Implementation>()) {
  if (!(p.timeStep > 0.0)) fail("PolyhedraSystem", "timeStep must be > 0 s, got " + std::to_string(p.timeStep));
  if (p.rebuildInterval < 1) fail("PolyhedraSystem", "rebuildInterval must be >= 1");
  if (!(p.largeBodyRatio <= 0.0 || p.largeBodyRatio >= 1.0))
    fail("PolyhedraSystem", "largeBodyRatio must be >= 1 (or <= 0: no large bodies), got " +
                                std::to_string(p.largeBodyRatio));
  if (p.maxNeighbours < 1 || p.maxWallNeighbours < 1)
    fail("PolyhedraSystem", "maxNeighbours and maxWallNeighbours must be >= 1");
  if (!(p.featureTolerance >= 0.0 && p.featureTolerance < 1.0))
    fail("PolyhedraSystem", "featureTolerance must be in [0, 1) (fraction of the dilation radius)");
  Implementation& m = *implementation_;
  m.parameters = p;
  HostData& d = m.data;
  d.timeStep = p.timeStep;
  d.gravity = Vec3{p.gravity[0], p.gravity[1], p.gravity[2]};
  if (!(p.damping >= 0.0 && p.damping < 1.0))
    fail("PolyhedraSystem", "damping must be in [0, 1), got " + std::to_string(p.damping));
  d.damping = p.damping;
  d.featureTolerance = p.featureTolerance;
  d.rebuildInterval = p.rebuildInterval;
  d.adaptiveRebuild = p.adaptiveRebuild;
  d.maxPairs = p.maxNeighbours;
  d.maxWalls = p.maxWallNeighbours;
  d.stoneLaw = lawOf(p.stone, p.stone, true, "stone-stone");
  d.wallLaws[0] = lawOf(p.wall, p.stone, false, "stone-wall");
  if (p.backend != Backend::Cpu) {
    m.backend = makeCudaBackend(m.reason);
    if (m.backend) {
      m.active = Backend::Cuda;
    } else if (p.backend == Backend::Cuda) {
      fail("PolyhedraSystem", "the CUDA backend was requested but is unusable: " + m.reason +
                                  "; use Backend::Automatic or Backend::Cpu to run on the CPU reference");
    }
  } else {
    m.reason = "CPU reference requested";
  }
  if (!m.backend) {
    m.backend = makeCpuBackend();
    m.active = Backend::Cpu;
    if (p.backend == Backend::Automatic) {
      // Said once per process: a bed of many systems should not repeat it.
      static bool said = false;
      if (!said) {
        log(LogLevel::Warning, "polyhedra: running on the CPU reference, GPU unavailable (" + m.reason + ")");
        said = true;
      }
    }
  }
}

PolyhedraSystem::~PolyhedraSystem() = default;

int PolyhedraSystem::addShape(const ShapeTemplate& shape) {
  Implementation& m = *implementation_;
  if (m.started) fail("addShape", "shapes must be added before the first step");
  const std::size_t vertexCount = shape.vertices.size() / 3;
  if (shape.vertices.size() % 3 != 0 || vertexCount < 1)
    fail("addShape", "vertices must hold 3 coordinates per vertex and at least one vertex");
  if (!(shape.dilationRadius > 0.0)) fail("addShape", "dilationRadius must be > 0 m");
  if (!(shape.density > 0.0)) fail("addShape", "density must be > 0 kg/m^3");
  for (double x : shape.vertices)
    if (!std::isfinite(x)) fail("addShape", "a vertex coordinate is not finite");
  auto vertex = [&](std::int32_t k) {
    return Vec3{shape.vertices[3 * k], shape.vertices[3 * k + 1], shape.vertices[3 * k + 2]};
  };
  // Volume, centroid and inertia of the core from its closed triangulation (signed tetrahedra with the
  // origin); a single vertex, a segment or a flat core has no volume: treated as a point mass sphere.
  double volume = 0.0;
  Vec3 firstMoment{0, 0, 0};
  double second[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}; // ∫ x_i x_j dV about the origin
  double area = 0.0;
  if (shape.triangles.size() % 3 != 0) fail("addShape", "triangles must hold 3 indices per triangle");
  for (std::size_t t = 0; t < shape.triangles.size(); t += 3) {
    for (int c = 0; c < 3; ++c)
      if (shape.triangles[t + c] < 0 || static_cast<std::size_t>(shape.triangles[t + c]) >= vertexCount)
        fail("addShape", "triangle " + std::to_string(t / 3) + " refers to a vertex out of range");
    const Vec3 a = vertex(shape.triangles[t]), b = vertex(shape.triangles[t + 1]), c = vertex(shape.triangles[t + 2]);
    const double v6 = kernels::dot(a, kernels::cross(b, c)); // 6 × signed tetra volume
    volume += v6 / 6.0;
    firstMoment += (v6 / 24.0) * (a + b + c);
    const double pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        second[i][j] += v6 / 120.0 *
                        (2 * (pa[i] * pa[j] + pb[i] * pb[j] + pc[i] * pc[j]) + pa[i] * pb[j] + pb[i] * pa[j] +
                         pa[i] * pc[j] + pc[i] * pa[j] + pb[i] * pc[j] + pc[i] * pb[j]);
    area += 0.5 * kernels::norm(kernels::cross(b - a, c - a));
  }
  ShapeProperties props;
  const double r = shape.dilationRadius;
  Vec3 centroid{0, 0, 0};
  double principal[3] = {0, 0, 0};
  double axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const double sphereVolume = 4.0 / 3.0 * kernels::pi * r * r * r;
  if (!shape.triangles.empty()) {
    if (!(volume > 0.0))
      fail("addShape", "the core triangulation encloses no positive volume (" + std::to_string(volume) +
                           " m^3); triangles must be closed and counter-clockwise seen from outside");
    centroid = firstMoment / volume;
    // Convexity: every vertex lies behind every triangle's plane (tolerance 1e-9 of the size).
    double size = 0.0;
    for (std::size_t k = 0; k < vertexCount; ++k) size = std::max(size, kernels::norm(vertex(k) - centroid));
    for (std::size_t t = 0; t < shape.triangles.size(); t += 3) {
      const Vec3 a = vertex(shape.triangles[t]), b = vertex(shape.triangles[t + 1]), c = vertex(shape.triangles[t + 2]);
      Vec3 normal = kernels::cross(b - a, c - a);
      const double length = kernels::norm(normal);
      if (length <= 0.0) continue;
      normal = normal / length;
      for (std::size_t k = 0; k < vertexCount; ++k)
        if (kernels::dot(vertex(k) - a, normal) > 1e-9 * size)
          fail("addShape", "the core is not convex: vertex " + std::to_string(k) +
                               " lies outside the plane of triangle " + std::to_string(t / 3) +
                               "; use the convex hull of the stone");
    }
    // Inertia about the centroid (per unit density): I = tr(S) 1 − S with S the second moment.
    double s[3][3];
    const double c3[3] = {centroid.x, centroid.y, centroid.z};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) s[i][j] = second[i][j] - volume * c3[i] * c3[j];
    const double traceS = s[0][0] + s[1][1] + s[2][2];
    double inertia[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) inertia[i][j] = (i == j ? traceS : 0.0) - s[i][j];
    principalAxes(inertia, principal, axes); // right-handed
    // Steiner: V(K ⊕ rB) = V + S r + M r² + (4/3)π r³, with M = ½ Σ_edges L φ (φ: angle between the
    // normals of the two triangles of the edge; coplanar triangles contribute nothing).
    std::map<std::pair<int, int>, std::vector<Vec3>> edgeNormals;
    for (std::size_t t = 0; t < shape.triangles.size(); t += 3) {
      const Vec3 a = vertex(shape.triangles[t]), b = vertex(shape.triangles[t + 1]), c = vertex(shape.triangles[t + 2]);
      Vec3 normal = kernels::cross(b - a, c - a);
      normal = normal / kernels::norm(normal);
      for (int e = 0; e < 3; ++e) {
        int u = shape.triangles[t + e], w = shape.triangles[t + (e + 1) % 3];
        edgeNormals[{std::min(u, w), std::max(u, w)}].push_back(normal);
      }
    }
    double meanCurvatureIntegral = 0.0;
    for (const auto& [edge, normals] : edgeNormals) {
      if (normals.size() != 2)
        fail("addShape",
             "the core triangulation is not closed (an edge has " + std::to_string(normals.size()) + " triangles)");
      const double angle = std::acos(std::clamp(kernels::dot(normals[0], normals[1]), -1.0, 1.0));
      meanCurvatureIntegral += 0.5 * kernels::norm(vertex(edge.first) - vertex(edge.second)) * angle;
    }
    props.dilatedVolume = volume + area * r + meanCurvatureIntegral * r * r + sphereVolume;
    // Inertia of the dilated body approximated by the core scaled to the dilated volume (I ∝ V^{5/3}):
    // exact for a sphere-like core, within a few % for r_d ≤ 0.1 of the stone size.
    const double scale = std::pow(props.dilatedVolume / volume, 5.0 / 3.0);
    for (int k = 0; k < 3; ++k) principal[k] *= shape.density * scale;
  } else {
    if (vertexCount != 1) fail("addShape", "a core with several vertices needs its triangles (for mass and inertia)");
    centroid = vertex(0);
    props.dilatedVolume = sphereVolume;
    for (int k = 0; k < 3; ++k) principal[k] = 0.4 * shape.density * sphereVolume * r * r;
  }
  props.mass = shape.density * props.dilatedVolume;
  props.centroid = {centroid.x, centroid.y, centroid.z};
  const Quat toGiven = quaternionFromMatrix(axes);
  props.principalToGiven = {toGiven.w, toGiven.x, toGiven.y, toGiven.z};
  ShapeTemplate principalTemplate = shape;
  double circumradius = 0.0;
  for (std::size_t k = 0; k < vertexCount; ++k) {
    const Vec3 local = rotateInverse(toGiven, vertex(k) - centroid);
    principalTemplate.vertices[3 * k] = local.x;
    principalTemplate.vertices[3 * k + 1] = local.y;
    principalTemplate.vertices[3 * k + 2] = local.z;
    circumradius = std::max(circumradius, kernels::norm(local));
  }
  props.circumradius = circumradius + r;
  for (int k = 0; k < 3; ++k) props.principalInertia[k] = principal[k];
  ShapeData data{};
  data.firstVertex = static_cast<int>(m.data.shapeVertices.size() / 3);
  data.vertexCount = static_cast<int>(vertexCount);
  data.dilationRadius = r;
  data.boundingRadius = props.circumradius;
  data.mass = props.mass;
  for (int k = 0; k < 3; ++k) data.inertia[k] = principal[k];
  m.data.shapeVertices.insert(m.data.shapeVertices.end(), principalTemplate.vertices.begin(),
                              principalTemplate.vertices.end());
  m.data.shapes.push_back(data);
  m.properties.push_back(props);
  m.templates.push_back(principalTemplate);
  return static_cast<int>(m.data.shapes.size() - 1);
}

const ShapeProperties& PolyhedraSystem::shapeProperties(int shape) const {
  if (shape < 0 || static_cast<std::size_t>(shape) >= implementation_->properties.size())
    fail("shapeProperties", "no shape with index " + std::to_string(shape));
  return implementation_->properties[shape];
}

int PolyhedraSystem::addStone(int shape, const std::array<double, 3>& position,
                              const std::array<double, 4>& orientation, const std::array<double, 3>& velocity,
                              const std::array<double, 3>& angularVelocity) {
  Implementation& m = *implementation_;
  if (m.started) fail("addStone", "stones must be added before the first step");
  if (shape < 0 || static_cast<std::size_t>(shape) >= m.data.shapes.size())
    fail("addStone", "shape index " + std::to_string(shape) + " does not exist; call addShape first");
  HostData& d = m.data;
  checkStoneState("addStone", static_cast<std::size_t>(d.stoneCount), position.data(), orientation.data(),
                  velocity.data(), angularVelocity.data());
  Quat q = normalized(Quat{orientation[0], orientation[1], orientation[2], orientation[3]});
  d.position.insert(d.position.end(), position.begin(), position.end());
  d.velocity.insert(d.velocity.end(), velocity.begin(), velocity.end());
  const ShapeData& data = d.shapes[shape];
  d.rotation.push_back(kernels::makeRotationState(q, Vec3{angularVelocity[0], angularVelocity[1], angularVelocity[2]},
                                                  Vec3{data.inertia[0], data.inertia[1], data.inertia[2]}));
  d.shape.push_back(shape);
  ++d.stoneCount;
  return d.stoneCount - 1;
}

void PolyhedraSystem::setWalls(const std::vector<double>& coordinates, const std::vector<std::int32_t>& triangles) {
  Implementation& m = *implementation_;
  if (m.started) fail("setWalls", "walls must be set before the first step (then move them with setSurfaceKinematics)");
  if (coordinates.size() % 3 != 0 || triangles.size() % 3 != 0)
    fail("setWalls", "coordinates and triangles must hold 3 values per node / triangle");
  for (std::int32_t k : triangles)
    if (k < 0 || static_cast<std::size_t>(k) >= coordinates.size() / 3)
      fail("setWalls", "triangle node index " + std::to_string(k) + " out of range");
  m.data.nodePosition = coordinates;
  m.data.nodeVelocity.assign(coordinates.size(), 0.0);
  m.data.triangles = triangles;
  m.data.triangleMaterial.clear();
  m.data.wallLawCount = 1;
  m.data.wallLaws[0] = lawOf(m.parameters.wall, m.parameters.stone, false, "stone-wall");
}

void PolyhedraSystem::setWallMaterials(const std::vector<Material>& materials,
                                       const std::vector<std::int32_t>& materialOfTriangle) {
  Implementation& m = *implementation_;
  HostData& d = m.data;
  if (m.started) fail("setWallMaterials", "wall materials must be set before the first step");
  if (materials.empty() || materials.size() > static_cast<std::size_t>(maxWallMaterials))
    fail("setWallMaterials", "between 1 and " + std::to_string(maxWallMaterials) + " materials, got " +
                                 std::to_string(materials.size()));
  if (materialOfTriangle.size() != static_cast<std::size_t>(d.triangleCount()))
    fail("setWallMaterials", "one material index per wall triangle: " + std::to_string(d.triangleCount()) +
                                 " triangles, got " + std::to_string(materialOfTriangle.size()) + " indices");
  for (std::size_t t = 0; t < materialOfTriangle.size(); ++t)
    if (materialOfTriangle[t] < 0 || static_cast<std::size_t>(materialOfTriangle[t]) >= materials.size())
      fail("setWallMaterials", "triangle " + std::to_string(t) + " names material " +
                                   std::to_string(materialOfTriangle[t]) + " of " + std::to_string(materials.size()));
  kernels::ContactLaw laws[maxWallMaterials] = {};
  for (std::size_t k = 0; k < materials.size(); ++k)
    laws[k] = lawOf(materials[k], m.parameters.stone, false, ("wall material " + std::to_string(k)).c_str());
  std::copy(std::begin(laws), std::end(laws), std::begin(d.wallLaws));
  d.wallLawCount = static_cast<int>(materials.size());
  d.triangleMaterial = materialOfTriangle;
}

void PolyhedraSystem::setSurfaceKinematics(const std::vector<double>& positions,
                                           const std::vector<double>& velocities) {
  Implementation& m = *implementation_;
  if (positions.size() != m.data.nodePosition.size() || velocities.size() != positions.size())
    fail("setSurfaceKinematics", "expected " + std::to_string(m.data.nodePosition.size()) +
                                     " position and velocity values, got " + std::to_string(positions.size()) +
                                     " and " + std::to_string(velocities.size()));
  // No download first: the host's node arrays are replaced whole and uploaded, so a later download brings the same
  // positions back (the CUDA backend would otherwise copy the whole state to the host once per coupling window).
  m.data.nodePosition = positions;
  m.data.nodeVelocity = velocities;
  if (m.started) m.backend->uploadSurface(m.data);
}

// Both setters leave the backend alone when the value is the one it has: the CUDA backend's captured graphs bake the
// parameters in, and a driver that sets them before every coupling window would otherwise recapture them each time.
void PolyhedraSystem::setTimeStep(double timeStep) {
  if (!(timeStep > 0.0)) fail("setTimeStep", "timeStep must be > 0 s, got " + std::to_string(timeStep));
  if (timeStep == implementation_->data.timeStep) return;
  implementation_->data.timeStep = timeStep;
  implementation_->parameters.timeStep = timeStep;
  if (implementation_->started) implementation_->backend->parametersChanged();
}

void PolyhedraSystem::setGravity(const std::array<double, 3>& gravity) {
  const Vec3& g = implementation_->data.gravity;
  if (gravity[0] == g.x && gravity[1] == g.y && gravity[2] == g.z) return;
  implementation_->data.gravity = Vec3{gravity[0], gravity[1], gravity[2]};
  implementation_->parameters.gravity = gravity;
  if (implementation_->started) implementation_->backend->parametersChanged();
}

void PolyhedraSystem::setDamping(double damping) {
  if (!(damping >= 0.0 && damping < 1.0))
    fail("setDamping", "damping must be in [0, 1), got " + std::to_string(damping));
  if (damping == implementation_->data.damping) return;
  implementation_->data.damping = damping;
  implementation_->parameters.damping = damping;
  if (implementation_->started) implementation_->backend->parametersChanged();
}

void PolyhedraSystem::step(int steps) {
  Implementation& m = *implementation_;
  if (steps < 0) fail("step", "steps must be >= 0");
  HostData& d = m.data;
  m.start();
  if (steps == 0) return;
  // No download here: the CPU backend's arrays are the host arrays, the CUDA backend's state stays on the device.
  BackendCounters counters;
  m.backend->step(d, steps, counters);
  m.hostCurrent = m.active == Backend::Cpu;
  m.partsCurrent = 0;
  if (counters.values[counterPairOverflow] > 0 || counters.values[counterWallOverflow] > 0) {
    std::ostringstream message;
    message << "neighbour list overflow:";
    if (counters.values[counterPairOverflow] > 0)
      message << " a stone had " << counters.values[counterPairOverflow] << " stone candidates (maxNeighbours = "
              << d.maxPairs << ")";
    if (counters.values[counterWallOverflow] > 0)
      message << " a stone had " << counters.values[counterWallOverflow] << " wall candidates (maxWallNeighbours = "
              << d.maxWalls << ")";
    message << "; contacts were lost, the state is invalid. Raise the limit or lower neighbourSkin";
    fail("step", message.str());
  }
  m.statistics = StepStatistics{};
  m.statistics.steps = steps;
  m.statistics.neighbourRebuilds = counters.rebuilds;
  m.statistics.dangerousRebuilds = static_cast<std::int64_t>(counters.values[counterDangerous]);
  m.statistics.coreOverlapFallbacks = static_cast<std::int64_t>(counters.values[counterCoreOverlap]);
  m.statistics.meanActiveContacts = static_cast<double>(counters.values[counterActive]) / steps;
  if (m.statistics.dangerousRebuilds > 0 && !m.warnedDangerous) {
    m.warnedDangerous = true; // once per system: a long run must not flood the log
    log(LogLevel::Warning,
        "polyhedra: a stone moved more than half the neighbour skin (" + std::to_string(d.skin) +
            " m) between list rebuilds; contacts may have been missed. Raise neighbourSkin or lower rebuildInterval "
            "(said once; StepStatistics::dangerousRebuilds counts every call)");
  }
  m.lastSteps = steps;
  m.time += steps * d.timeStep;
}

std::size_t PolyhedraSystem::stoneCount() const { return static_cast<std::size_t>(implementation_->data.stoneCount); }
std::size_t PolyhedraSystem::triangleCount() const {
  return static_cast<std::size_t>(implementation_->data.triangleCount());
}
double PolyhedraSystem::time() const { return implementation_->time; }
Backend PolyhedraSystem::activeBackend() const { return implementation_->active; }
const std::string& PolyhedraSystem::backendReason() const { return implementation_->reason; }
const StepStatistics& PolyhedraSystem::lastStatistics() const { return implementation_->statistics; }

double PolyhedraSystem::criticalTimeStep(double normalForce, double impactVelocity) const {
  const HostData& d = implementation_->data;
  if (d.shapes.empty()) fail("criticalTimeStep", "no shapes: add them first");
  if (!(normalForce > 0.0) && !(impactVelocity > 0.0))
    fail("criticalTimeStep", "give a contact force [N] or an impact speed [m/s] > 0");
  double step = INFINITY;
  for (const ShapeData& shape : d.shapes) {
    std::vector<kernels::ContactLaw> laws{d.stoneLaw};
    kernels::setContactGeometry(laws[0], 0.5 * shape.dilationRadius, 0.5 * shape.mass);
    for (int k = 0; k < d.wallLawCount; ++k) {
      laws.push_back(d.wallLaws[k]);
      kernels::setContactGeometry(laws.back(), shape.dilationRadius, shape.mass);
    }
    for (const kernels::ContactLaw& law : laws) {
      const kernels::HertzMindlinParams& p = law.params.hertzMindlin;
      if (normalForce > 0.0) step = std::min(step, kernels::hertzCriticalTimeStepAtForce(p, normalForce));
      if (impactVelocity > 0.0) step = std::min(step, kernels::hertzCriticalTimeStep(p, impactVelocity));
    }
  }
  return step;
}

std::vector<double> PolyhedraSystem::positions() const {
  implementation_->sync(downloadStones);
  return implementation_->inUserOrder(implementation_->data.position, 3);
}
std::vector<double> PolyhedraSystem::velocities() const {
  implementation_->sync(downloadStones);
  return implementation_->inUserOrder(implementation_->data.velocity, 3);
}
std::vector<double> PolyhedraSystem::orientations() const {
  Implementation& m = *implementation_;
  m.sync(downloadStones);
  std::vector<double> result(4 * m.data.rotation.size());
  for (std::size_t i = 0; i < m.data.rotation.size(); ++i) {
    const Quat& q = m.data.rotation[m.stored(i)].orientation;
    result[4 * i] = q.w, result[4 * i + 1] = q.x, result[4 * i + 2] = q.y, result[4 * i + 3] = q.z;
  }
  return result;
}
std::vector<double> PolyhedraSystem::angularVelocities() const {
  Implementation& m = *implementation_;
  m.sync(downloadStones);
  std::vector<double> result(3 * m.data.rotation.size());
  for (std::size_t i = 0; i < m.data.rotation.size(); ++i) {
    const Vec3& w = m.data.rotation[m.stored(i)].angularVelocity;
    result[3 * i] = w.x, result[3 * i + 1] = w.y, result[3 * i + 2] = w.z;
  }
  return result;
}
void PolyhedraSystem::stoneStates(const std::vector<std::int32_t>& stones, std::vector<double>& positions,
                                  std::vector<double>& orientations, std::vector<double>& velocities,
                                  std::vector<double>& angularVelocities) const {
  Implementation& m = *implementation_;
  std::vector<std::int32_t> storedStones(stones.size());
  for (std::size_t k = 0; k < stones.size(); ++k)
    storedStones[k] = static_cast<std::int32_t>(m.storedChecked("stoneStates", stones[k]));
  // Written into the host arrays at their places only: they are not marked current, a later sync() still
  // brings everything back.
  if (!m.hostCurrent && (m.partsCurrent & downloadStones) == 0) m.backend->downloadStonesAt(m.data, storedStones);
  positions.resize(3 * stones.size());
  velocities.resize(3 * stones.size());
  orientations.resize(4 * stones.size());
  angularVelocities.resize(3 * stones.size());
  for (std::size_t k = 0; k < stones.size(); ++k) {
    const std::size_t i = static_cast<std::size_t>(storedStones[k]);
    const auto& r = m.data.rotation[i];
    for (int c = 0; c < 3; ++c) {
      positions[3 * k + c] = m.data.position[3 * i + c];
      velocities[3 * k + c] = m.data.velocity[3 * i + c];
    }
    orientations[4 * k] = r.orientation.w, orientations[4 * k + 1] = r.orientation.x;
    orientations[4 * k + 2] = r.orientation.y, orientations[4 * k + 3] = r.orientation.z;
    angularVelocities[3 * k] = r.angularVelocity.x, angularVelocities[3 * k + 1] = r.angularVelocity.y;
    angularVelocities[3 * k + 2] = r.angularVelocity.z;
  }
}

std::vector<double> PolyhedraSystem::forces() const {
  implementation_->sync();
  return implementation_->inUserOrder(implementation_->data.force, 3);
}
std::vector<double> PolyhedraSystem::torques() const {
  implementation_->sync();
  return implementation_->inUserOrder(implementation_->data.torque, 3);
}

void PolyhedraSystem::setState(const std::vector<double>& positions, const std::vector<double>& orientations,
                               const std::vector<double>& velocities, const std::vector<double>& angularVelocities) {
  Implementation& m = *implementation_;
  HostData& d = m.data;
  const std::size_t n = static_cast<std::size_t>(d.stoneCount);
  if (positions.size() != 3 * n || orientations.size() != 4 * n || velocities.size() != 3 * n ||
      angularVelocities.size() != 3 * n)
    fail("setState", "expected 3/4/3/3 values per stone for " + std::to_string(n) + " stones");
  // Checked before anything changes: a refused call leaves the state as it was.
  for (std::size_t i = 0; i < n; ++i)
    checkStoneState("setState", i, &positions[3 * i], &orientations[4 * i], &velocities[3 * i],
                    &angularVelocities[3 * i]);
  m.sync();
  for (std::size_t i = 0; i < n; ++i) { // i: the user's index
    const std::size_t k = m.stored(i);
    for (std::size_t c = 0; c < 3; ++c) {
      d.position[3 * k + c] = positions[3 * i + c];
      d.velocity[3 * k + c] = velocities[3 * i + c];
    }
    const Quat q{orientations[4 * i], orientations[4 * i + 1], orientations[4 * i + 2], orientations[4 * i + 3]};
    const ShapeData& data = d.shapes[d.shape[k]];
    d.rotation[k] = kernels::makeRotationState(q, load3(angularVelocities.data(), static_cast<int>(i)),
                                               Vec3{data.inertia[0], data.inertia[1], data.inertia[2]});
  }
  d.forcesValid = false;
  if (m.started) m.backend->upload(d);
}

std::vector<double> PolyhedraSystem::triangleForces() const {
  Implementation& m = *implementation_;
  m.sync(downloadTriangles);
  std::vector<double> result(m.data.triangleForceSum.size(), 0.0);
  if (m.lastSteps > 0)
    for (std::size_t k = 0; k < result.size(); ++k) result[k] = m.data.triangleForceSum[k] / m.lastSteps;
  return result;
}

std::vector<double> PolyhedraSystem::triangleContactPoints() const {
  Implementation& m = *implementation_;
  m.sync(downloadTriangles);
  const HostData& d = m.data;
  const int t = d.triangleCount();
  std::vector<double> result(3 * static_cast<std::size_t>(t), 0.0);
  for (int k = 0; k < t; ++k) {
    const double w = k < static_cast<int>(d.triangleWeightSum.size()) ? d.triangleWeightSum[k] : 0.0;
    for (int c = 0; c < 3; ++c) {
      if (w > 0.0) {
        result[3 * k + c] = d.trianglePointSum[3 * k + c] / w;
      } else {
        result[3 * k + c] =
            (d.nodePosition[3 * d.triangles[3 * k] + c] + d.nodePosition[3 * d.triangles[3 * k + 1] + c] +
             d.nodePosition[3 * d.triangles[3 * k + 2] + c]) /
            3.0;
      }
    }
  }
  return result;
}

std::vector<ContactRecord> PolyhedraSystem::contacts() const { return implementation_->contacts({}); }

std::vector<ContactRecord> PolyhedraSystem::contacts(const std::vector<std::int32_t>& stones) const {
  Implementation& m = *implementation_;
  if (stones.empty()) return {}; // (an empty selection would read as "all" below)
  std::vector<std::uint8_t> selected(m.data.rotation.size(), 0);
  for (std::int32_t i : stones) selected[m.storedChecked("contacts", i)] = 1;
  return m.contacts(selected);
}

std::vector<ContactRecord> PolyhedraSystem::Implementation::contacts(const std::vector<std::uint8_t>& selected) {
  Implementation& m = *this;
  std::vector<ContactRecord> result;
  if (!m.started) return result;
  const std::vector<ActiveContact> active = m.backend->activeContacts(m.data, selected);
  result.reserve(active.size());
  for (const ActiveContact& a : active) {
    ContactRecord r;
    r.first = static_cast<std::int32_t>(m.user(a.stone));
    r.wall = a.wall != 0;
    r.second = r.wall ? a.partner : static_cast<std::int32_t>(m.user(a.partner));
    r.overlap = a.output.overlap;
    for (int c = 0; c < 3; ++c) {
      r.normal[c] = a.normal[c];
      r.point[c] = a.output.point[c];
      r.force[c] = a.output.force[c];
    }
    result.push_back(r);
  }
  return result;
}

namespace {
std::vector<StateHeader> stateHeader(const HostData& d, std::size_t shapeCount) {
  return {{"stones", static_cast<std::uint64_t>(d.stoneCount)},
          {"wall triangles", static_cast<std::uint64_t>(d.triangleCount())},
          {"surface nodes", static_cast<std::uint64_t>(d.nodeCount())},
          {"shape templates", shapeCount},
          {"maxNeighbours", static_cast<std::uint64_t>(d.maxPairs)},
          {"maxWallNeighbours", static_cast<std::uint64_t>(d.maxWalls)},
          {"bytes per contact slot", sizeof(ContactSlot)},
          {"bytes per rotation state", sizeof(kernels::RotationState)},
          {"bytes per normal history", sizeof(kernels::NormalHistory)},
          {"bytes per contact output", sizeof(ContactOutput)}};
}
} // namespace

void PolyhedraSystem::saveSnapshot() {
  Implementation& m = *implementation_;
  m.start();
  HostData& d = m.data;
  m.backend->saveSnapshot(d);
  Implementation::Snapshot& s = m.snapshot;
  s.time = m.time;
  s.lastSteps = m.lastSteps;
  s.forcesValid = d.forcesValid;
  s.statistics = m.statistics;
  s.nodeVelocity = d.nodeVelocity;
  s.saved = true;
}

void PolyhedraSystem::restoreSnapshot() {
  Implementation& m = *implementation_;
  const Implementation::Snapshot& s = m.snapshot;
  if (!s.saved) fail("restoreSnapshot", "no snapshot: call saveSnapshot first");
  HostData& d = m.data;
  m.backend->restoreSnapshot(d);
  m.time = s.time;
  m.lastSteps = s.lastSteps;
  d.forcesValid = s.forcesValid;
  m.statistics = s.statistics;
  d.nodeVelocity = s.nodeVelocity;
  m.hostCurrent = m.active == Backend::Cpu;
  m.partsCurrent = 0; // the CUDA backend restored its device buffers
}

bool PolyhedraSystem::hasSnapshot() const { return implementation_->snapshot.saved; }

void PolyhedraSystem::writeRestartState(railcosim::StateWriter& out) {
  std::ostringstream current;
  writeState(current);
  out.bytes(current.str());
  out.flag(hasSnapshot());
  if (hasSnapshot()) {
    std::ostringstream snapshot;
    restoreSnapshot();
    writeState(snapshot);
    std::istringstream back(current.str());
    readState(back);
    out.bytes(snapshot.str());
  }
}

void PolyhedraSystem::readRestartState(railcosim::StateReader& in) {
  const std::string current = in.bytes();
  if (in.flag()) { // the snapshot first, kept by the system; then the current state over it
    std::istringstream snapshot(in.bytes());
    readState(snapshot);
    saveSnapshot();
  }
  std::istringstream now(current);
  readState(now);
}

void PolyhedraSystem::writeState(std::ostream& out) const {
  Implementation& m = *implementation_;
  m.start();
  m.sync();
  const HostData& d = m.data;
  out.write(stateMagic, sizeof(stateMagic));
  writeValue(out, stateVersion);
  for (const StateHeader& field : stateHeader(d, m.properties.size())) writeValue(out, field.value);
  writeArray(out, m.userOf);
  writeArray(out, d.triangles);
  writeArray(out, d.shape);
  writeValue(out, m.time);
  writeValue<std::int64_t>(out, m.lastSteps);
  writeValue<std::uint8_t>(out, d.forcesValid ? 1 : 0);
  writeValue(out, m.statistics.steps);
  writeValue(out, m.statistics.neighbourRebuilds);
  writeValue(out, m.statistics.dangerousRebuilds);
  writeValue(out, m.statistics.coreOverlapFallbacks);
  writeValue(out, m.statistics.meanActiveContacts);
  // Some list entries no step reads: those past each stone's count (left from older lists: the slots and normal
  // histories are double-buffered, swapped at each rebuild) and the outputs of contacts that do not act (outputs are
  // written by acting contacts only). Their bytes depend on the buffers' history, which a restart does not have, so
  // they are written as fresh entries (canonicalList): a state is a function of the dynamics alone.
  visitStateArrays(d, [&](const char* name, const auto& array) {
    using Record = typename std::decay_t<decltype(array)>::value_type;
    if constexpr (std::is_same_v<Record, ContactSlot> || std::is_same_v<Record, kernels::NormalHistory> ||
                  std::is_same_v<Record, ContactOutput>) {
      const bool pairs = std::string(name).rfind("pair", 0) == 0;
      writeArray(out, canonicalList(array, pairs ? d.pairCount : d.wallCount, pairs ? d.maxPairs : d.maxWalls,
                                    pairs ? d.pairSlots : d.wallSlots));
    } else {
      writeArray(out, array);
    }
  });
  if (!out) fail("writeState", "the output stream failed (disk full, closed file?)");
}

void PolyhedraSystem::readState(std::istream& in) {
  Implementation& m = *implementation_;
  HostData& d = m.data;
  if (d.stoneCount == 0) fail("readState", "no stones: build the system (shapes, stones, walls) before reading a state");
  char magic[sizeof(stateMagic)] = {};
  in.read(magic, sizeof(magic));
  if (!in || std::memcmp(magic, stateMagic, sizeof(magic)) != 0)
    fail("readState", "the stream does not start with a polyhedra state (written by PolyhedraSystem::writeState)");
  const auto version = readValue<std::uint32_t>(in, "the format version");
  if (version != stateVersion)
    fail("readState", "state format version " + std::to_string(version) + ", this library reads version " +
                          std::to_string(stateVersion));
  for (const StateHeader& field : stateHeader(d, m.properties.size())) {
    const auto value = readValue<std::uint64_t>(in, std::string("the header (") + field.name + ")");
    if (value != field.value)
      fail("readState", std::string(field.name) + ": " + std::to_string(value) + " in the stream, " +
                            std::to_string(field.value) + " in this system");
  }
  const std::size_t n = static_cast<std::size_t>(d.stoneCount);
  const std::vector<std::int32_t> order = readArray<std::int32_t>(in, n, "the storage order");
  std::vector<char> seen(n, 0);
  for (std::int32_t k : order) {
    if (k < 0 || static_cast<std::size_t>(k) >= n || seen[k])
      fail("readState", "the storage order in the stream is not a permutation of the stones (corrupt stream)");
    seen[k] = 1;
  }
  if (readArray<std::int32_t>(in, d.triangles.size(), "the wall connectivity") != d.triangles)
    fail("readState", "the wall triangles differ from this system's (setWalls with another mesh)");
  const std::vector<std::int32_t> shapes = readArray<std::int32_t>(in, n, "the stones' shapes");
  // This system's shape of each stone, in the user's (addStone) order, against the stream's in its storage order.
  std::vector<std::int32_t> userShape(n);
  for (std::size_t i = 0; i < n; ++i) userShape[i] = d.shape[m.stored(i)];
  for (std::size_t k = 0; k < n; ++k)
    if (shapes[k] != userShape[order[k]])
      fail("readState", "stone " + std::to_string(order[k]) + " has shape " + std::to_string(userShape[order[k]]) +
                            " here and " + std::to_string(shapes[k]) + " in the stream (stones added in another order?)");
  const auto time = readValue<double>(in, "the time");
  const auto lastSteps = readValue<std::int64_t>(in, "the step count");
  const auto forcesValid = readValue<std::uint8_t>(in, "the force flag");
  StepStatistics statistics;
  statistics.steps = readValue<std::int64_t>(in, "the statistics");
  statistics.neighbourRebuilds = readValue<std::int64_t>(in, "the statistics");
  statistics.dangerousRebuilds = readValue<std::int64_t>(in, "the statistics");
  statistics.coreOverlapFallbacks = readValue<std::int64_t>(in, "the statistics");
  statistics.meanActiveContacts = readValue<double>(in, "the statistics");

  // Everything is read into a copy first: a refused stream leaves the system as it was.
  m.start();
  m.sync();
  HostData incoming = d;
  incoming.shape = shapes;
  visitStateArrays(incoming, [&](const char* name, auto& array) {
    using Record = typename std::decay_t<decltype(array)>::value_type;
    array = readArray<Record>(in, array.size(), std::string("the array '") + name + "'");
  });
  // A kept snapshot speaks this system's storage order; the order is fixed from the first step on, so a state of the
  // same system (a restart, or a state written between a snapshot and its restore) leaves the snapshot valid.
  const bool sameOrder = order == m.userOf;
  d = std::move(incoming);
  m.userOf = order;
  for (std::size_t k = 0; k < n; ++k) m.storedOf[order[k]] = static_cast<std::int32_t>(k);
  m.time = time;
  m.lastSteps = static_cast<int>(lastSteps);
  d.forcesValid = forcesValid != 0;
  m.statistics = statistics;
  if (!sameOrder) m.snapshot.saved = false;
  d.largeBodies = largeBodiesOf(d);
  m.backend->upload(d);
  m.hostCurrent = true;
}

} // namespace railcosim::polyhedra
