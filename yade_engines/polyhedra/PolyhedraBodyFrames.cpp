// Body frames <-> principal frames of the polyhedra system's stones (PolyhedraBodyFrames.hpp).
#include "polyhedra/PolyhedraBodyFrames.hpp"

#include <Eigen/Geometry>

#include "polyhedra/PolyhedraShapes.hpp"

namespace railcosim::polyhedra {

namespace {
Eigen::Quaterniond quaternion(const double* wxyz) { return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]); }
Eigen::Vector3d vector(const double* xyz) { return Eigen::Vector3d(xyz[0], xyz[1], xyz[2]); }
} // namespace

void BodyFrameStones::clear() {
  templateOf_.clear();
  principalToBody_.clear();
  centroidInBody_.clear();
  mass_.clear();
}

int BodyFrameStones::add(PolyhedraSystem& system, const std::vector<double>& vertices, double dilationRadius,
                         double density, const std::array<double, 3>& position, const std::array<double, 4>& orientation,
                         const std::array<double, 3>& velocity, const std::array<double, 3>& angularVelocity) {
  std::vector<double> key = vertices;
  key.push_back(dilationRadius);
  auto found = templateOf_.find(key);
  if (found == templateOf_.end()) {
    // One vertex: a sphere of radius dilationRadius (a point core has no hull; the system takes it as it is).
    const ShapeTemplate shape = vertices.size() == 3 ? ShapeTemplate{vertices, {}, dilationRadius, density}
                                                     : convexHullTemplate(vertices, dilationRadius, density);
    found = templateOf_.emplace(key, system.addShape(shape)).first;
  }
  const ShapeProperties& props = system.shapeProperties(found->second);
  const Eigen::Quaterniond toBody = quaternion(props.principalToGiven.data());
  const Eigen::Vector3d centroid(props.centroid[0], props.centroid[1], props.centroid[2]);
  const Eigen::Vector3d origin = vector(position.data()), omega = vector(angularVelocity.data());
  const Eigen::Quaterniond bodyOri = quaternion(orientation.data());
  // The principal frame sits at the centroid; the centroid moves with the body frame's origin plus omega x lever.
  const Eigen::Vector3d centre = origin + bodyOri * centroid;
  const Eigen::Quaterniond ori = bodyOri * toBody;
  const Eigen::Vector3d v = vector(velocity.data()) + omega.cross(centre - origin);
  const int index = system.addStone(found->second, {centre[0], centre[1], centre[2]}, {ori.w(), ori.x(), ori.y(), ori.z()},
                                    {v[0], v[1], v[2]}, angularVelocity);
  principalToBody_.push_back(props.principalToGiven);
  centroidInBody_.push_back(props.centroid);
  mass_.push_back(props.mass);
  return index;
}

void BodyFrameStones::bodyState(std::size_t i, std::size_t k, const std::vector<double>& positions,
                                const std::vector<double>& orientations, const std::vector<double>& velocities,
                                const std::vector<double>& angularVelocities, std::array<double, 3>& position,
                                std::array<double, 4>& orientation, std::array<double, 3>& velocity,
                                std::array<double, 3>& angularVelocity) const {
  const Eigen::Vector3d centre = vector(&positions[3 * k]);
  const Eigen::Vector3d omega = vector(&angularVelocities[3 * k]);
  const Eigen::Quaterniond ori =
      (quaternion(&orientations[4 * k]) * quaternion(principalToBody_[i].data()).conjugate()).normalized();
  const Eigen::Vector3d origin = centre - ori * vector(centroidInBody_[i].data());
  const Eigen::Vector3d v = vector(&velocities[3 * k]) + omega.cross(origin - centre);
  position = {origin[0], origin[1], origin[2]};
  orientation = {ori.w(), ori.x(), ori.y(), ori.z()};
  velocity = {v[0], v[1], v[2]};
  angularVelocity = {omega[0], omega[1], omega[2]};
}

} // namespace railcosim::polyhedra
