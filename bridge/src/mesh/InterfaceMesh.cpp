// Validation of the interface mesh and of nodal kinematics: every error names the array and index.
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace railcosim {
namespace {

const char* componentName(std::size_t index) {
  static const char* names[3] = {"x", "y", "z"};
  return names[index % 3];
}

void checkFiniteArray(const std::vector<double>& values, const char* what, const char* owner) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      std::ostringstream message;
      message << owner << ": " << what << "[" << i << "] (node " << i / 3 << ", " << componentName(i) << ") is "
              << values[i] << "; every value must be finite";
      throw Error(message.str());
    }
  }
}

} // namespace

void InterfaceMesh::validate() const {
  std::ostringstream message;
  if (coordinates.size() % 3 != 0) {
    message << "InterfaceMesh: coordinates has " << coordinates.size()
            << " values, not a multiple of 3 (x,y,z per node)";
    throw Error(message.str());
  }
  if (triangles.size() % 3 != 0) {
    message << "InterfaceMesh: triangles has " << triangles.size()
            << " indices, not a multiple of 3 (3 nodes per triangle)";
    throw Error(message.str());
  }
  if (triangles.empty()) throw Error("InterfaceMesh: no triangles; the coupled surface needs at least one");
  checkFiniteArray(coordinates, "coordinates", "InterfaceMesh");
  const std::size_t nodes = nodeCount();
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nodes) {
      message << "InterfaceMesh: triangles[" << i << "] (triangle " << i / 3 << ", corner " << i % 3
              << ") = " << triangles[i] << " is out of range [0, " << nodes << ")";
      throw Error(message.str());
    }
  }
  for (std::size_t t = 0; t < triangleCount(); ++t) {
    const auto a = node(triangles[3 * t]);
    const auto b = node(triangles[3 * t + 1]);
    const auto c = node(triangles[3 * t + 2]);
    const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double cross[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                             ab[0] * ac[1] - ab[1] * ac[0]};
    const double twiceArea = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    const double longestSquared =
        std::max({ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2], ac[0] * ac[0] + ac[1] * ac[1] + ac[2] * ac[2]});
    // Relative test: the area compared with the squared edge length, so the unit of length does not matter.
    // 1e-12 is far below any usable element shape and above round-off of collinear points.
    if (!(twiceArea > 1e-12 * longestSquared)) {
      message << "InterfaceMesh: triangle " << t << " (nodes " << triangles[3 * t] << ", " << triangles[3 * t + 1]
              << ", " << triangles[3 * t + 2] << ") is degenerate (zero area); remove it or fix its nodes";
      throw Error(message.str());
    }
  }
}

void NodalKinematics::validate(std::size_t nodes) const {
  std::ostringstream message;
  if (!std::isfinite(time)) {
    message << "NodalKinematics: time is " << time << "; it must be finite";
    throw Error(message.str());
  }
  const std::size_t expected = 3 * nodes;
  auto checkSize = [&](const std::vector<double>& values, const char* what, bool mayBeEmpty) {
    if (mayBeEmpty && values.empty()) return;
    if (values.size() != expected) {
      std::ostringstream text;
      text << "NodalKinematics: " << what << " has " << values.size() << " values but the interface has " << nodes
           << " nodes (" << expected << " values expected" << (mayBeEmpty ? ", or none" : "") << ")";
      throw Error(text.str());
    }
  };
  checkSize(positions, "positions", false);
  checkSize(velocities, "velocities", true);
  checkSize(accelerations, "accelerations", true);
  checkFiniteArray(positions, "positions", "NodalKinematics");
  checkFiniteArray(velocities, "velocities", "NodalKinematics");
  checkFiniteArray(accelerations, "accelerations", "NodalKinematics");
}

} // namespace railcosim
