// Test helper: one sphere on a triangulated surface, velocity Verlet + Hertz–Mindlin through the H² contact query.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "kernels/HertzMindlin.hpp"
#include "kernels/SurfaceContact.hpp"
#include "kernels/SurfaceContactMesh.hpp"

namespace railcosim::kernels::testing {

struct SphereProperties {
  double radius;       // [m]
  double density;      // [kg/m³]
  double youngModulus; // [Pa]
  double poissonRatio; // [-]
  double friction;     // Coulomb μ [-]
  double restitution;  // normal coefficient of restitution [-]

  double mass() const { return density * 4.0 / 3.0 * M_PI * radius * radius * radius; }
  double inertia() const { return 0.4 * mass() * radius * radius; } // I = 2/5 m R², eq. 3.30
};

// Contact law of a sphere against a rigid FE wall (Irazábal 2017 eq. 4.1: R_j, m_j, G_j → ∞).
inline HertzMindlinParams wallContactParams(const SphereProperties& sphere) {
  const double infinity = std::numeric_limits<double>::infinity();
  return HertzMindlinParams{
      effectiveYoungModulus(sphere.youngModulus, sphere.poissonRatio, infinity, 0.0),
      effectiveShearModulus(shearModulus(sphere.youngModulus, sphere.poissonRatio), sphere.poissonRatio, infinity, 0.0),
      effectiveRadius(sphere.radius, infinity), effectiveMass(sphere.mass(), infinity),
      dampingRatioFromRestitution(sphere.restitution)};
}

// Elastic energy stored in one Hertz contact, ∫0^δ (4/3)E*√R s^{3/2} ds = (8/15)E*√R δ^{5/2}. [J]
inline double hertzElasticEnergy(const HertzMindlinParams& p, double overlap) {
  return overlap > 0.0 ? 8.0 / 15.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius) * std::pow(overlap, 2.5)
                       : 0.0;
}

// Velocity Verlet exactly as Irazábal eqs. 3.44–3.53: forces at t_{n+1} use the half-step velocities.
// The surface is static unless a motion is set (the thesis' H² tests use fixed boundaries); a moving
// surface is refreshed at every force evaluation, as the coupling engine would do, and enters the contact
// law through the interpolated contact-point velocity.
class SphereOnSurface {
public:
  SphereOnSurface(const SphereProperties& sphere, const SurfaceTopology& topology, std::vector<double> nodePositions,
                  const Vec3& gravity, double timeStep, double gridCellSize)
      : sphere_(sphere),
        params_(wallContactParams(sphere)),
        topology_(topology),
        positions_(std::move(nodePositions)),
        surface_(topology_.view(positions_.data(), nullptr)),
        grid_(gridCellSize),
        gravity_(gravity),
        timeStep_(timeStep) {
    grid_.rebuild(surface_);
  }

  Vec3 position{0.0, 0.0, 0.0};
  Vec3 velocity{0.0, 0.0, 0.0};
  Vec3 angularVelocity{0.0, 0.0, 0.0};
  bool rotationFixed = false; // H2-04: "rotation fixed"
  double time = 0.0;

  // Node positions and velocities (3 per node, filled in place) at a given time.
  using SurfaceMotion =
      std::function<void(double time, std::vector<double>& positions, std::vector<double>& velocities)>;
  void setSurfaceMotion(SurfaceMotion motion) {
    motion_ = std::move(motion);
    velocities_.assign(positions_.size(), 0.0);
    surface_ = topology_.view(positions_.data(), velocities_.data());
  }

  // Forces at the initial state; call once after setting position and velocities.
  void start() { evaluateForces(time, velocity, angularVelocity); }

  void step() {
    const double h = timeStep_;
    const Vec3 halfVelocity = velocity + (0.5 * h / sphere_.mass()) * force_;
    const Vec3 halfAngularVelocity =
        rotationFixed ? Vec3{0.0, 0.0, 0.0} : angularVelocity + (0.5 * h / sphere_.inertia()) * torque_;
    position += h * halfVelocity;
    evaluateForces(time + h, halfVelocity, halfAngularVelocity);
    velocity = halfVelocity + (0.5 * h / sphere_.mass()) * force_;
    angularVelocity =
        rotationFixed ? Vec3{0.0, 0.0, 0.0} : halfAngularVelocity + (0.5 * h / sphere_.inertia()) * torque_;
    time += h;
  }

  // Kinetic + gravitational + Hertz elastic energy (tangential springs excluded: zero in normal impacts). [J]
  double energy() const {
    double elastic = 0.0;
    for (const Slot& slot : slots_) elastic += hertzElasticEnergy(params_, slot.contact.overlap);
    return 0.5 * sphere_.mass() * squaredNorm(velocity) + 0.5 * sphere_.inertia() * squaredNorm(angularVelocity) -
           sphere_.mass() * dot(gravity_, position) + elastic;
  }

  Vec3 contactForce() const { return contactForce_; }
  std::vector<SurfaceContact> contacts() const {
    std::vector<SurfaceContact> list;
    for (const Slot& slot : slots_) list.push_back(slot.contact);
    return list;
  }
  const HertzMindlinParams& params() const { return params_; }
  const SurfaceMeshView& surface() const { return surface_; }

private:
  struct Slot {
    SurfaceContact contact;
    Vec3 elasticTangentialForce;
  };

  void evaluateForces(double at, const Vec3& sphereVelocity, const Vec3& sphereAngularVelocity) {
    if (motion_) {
      motion_(at, positions_, velocities_);
      grid_.rebuild(surface_);
    }
    grid_.candidates(position, sphere_.radius, candidates_);
    buffer_.resize(candidates_.size());
    const SurfaceContactCount found = findSurfaceContacts(surface_, position, sphere_.radius, candidates_.data(),
                                                          static_cast<std::int32_t>(candidates_.size()), settings_,
                                                          buffer_.data(), static_cast<std::int32_t>(buffer_.size()));
    std::vector<SurfaceContact> previous;
    for (const Slot& slot : slots_) previous.push_back(slot.contact);
    std::vector<Slot> next;
    contactForce_ = Vec3{0.0, 0.0, 0.0};
    Vec3 torque{0.0, 0.0, 0.0};
    for (std::int32_t i = 0; i < found.count; ++i) {
      const SurfaceContact& c = buffer_[i];
      const Vec3 arm = c.point - position;
      const Vec3 relativeVelocity = sphereVelocity + cross(sphereAngularVelocity, arm) - c.velocity;
      const double overlapRate = -dot(relativeVelocity, c.normal);
      const double normalForce = hertzNormalForce(params_, c.overlap, overlapRate);
      // Tangential history continues when the contact patch moves to a neighbouring element.
      const std::int32_t match = findContinuingContact(c, previous.data(), static_cast<std::int32_t>(previous.size()),
                                                       hertzContactRadius(params_, c.overlap));
      const Vec3 history = match >= 0 ? slots_[match].elasticTangentialForce : Vec3{0.0, 0.0, 0.0};
      const double previousOverlap = match >= 0 ? slots_[match].contact.overlap : 0.0;
      const TangentialForceResult tangential =
          mindlinTangentialForce(params_, history, c.normal, c.overlap, previousOverlap, timeStep_ * relativeVelocity,
                                 relativeVelocity, sphere_.friction, normalForce);
      const Vec3 total = normalForce * c.normal + tangential.force;
      contactForce_ += total;
      torque += cross(arm, tangential.force);
      next.push_back(Slot{c, tangential.elasticForce});
    }
    slots_ = std::move(next);
    force_ = contactForce_ + sphere_.mass() * gravity_;
    torque_ = torque;
  }

  SphereProperties sphere_;
  HertzMindlinParams params_;
  const SurfaceTopology& topology_;
  std::vector<double> positions_;
  std::vector<double> velocities_;
  SurfaceMotion motion_;
  SurfaceMeshView surface_;
  SurfaceTriangleGrid grid_;
  SurfaceContactSettings settings_{};
  Vec3 gravity_;
  double timeStep_;
  std::vector<std::int32_t> candidates_;
  std::vector<SurfaceContact> buffer_;
  std::vector<Slot> slots_;
  Vec3 force_{0.0, 0.0, 0.0};
  Vec3 torque_{0.0, 0.0, 0.0};
  Vec3 contactForce_{0.0, 0.0, 0.0};
};

// Regular grid of nx × nz cells on [x0, x0 + nx·dx] × [z0, z0 + nz·dz] in the plane y = 0, each cell split
// along its diagonal into two triangles wound counter-clockwise seen from +y. Nodes row by row in x.
struct PlaneMesh {
  std::vector<double> positions;
  std::vector<std::int32_t> triangles;
};

inline PlaneMesh planeMesh(int nx, int nz, double x0, double z0, double dx, double dz) {
  PlaneMesh mesh;
  for (int j = 0; j <= nz; ++j)
    for (int i = 0; i <= nx; ++i) {
      mesh.positions.push_back(x0 + i * dx);
      mesh.positions.push_back(0.0);
      mesh.positions.push_back(z0 + j * dz);
    }
  auto node = [nx](int i, int j) { return static_cast<std::int32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < nx; ++i) {
      // Seen from +y with x right and z down the page, (x,z)→(x,z+dz)→(x+dx,z) is counter-clockwise.
      const std::int32_t a = node(i, j), b = node(i + 1, j), c = node(i + 1, j + 1), d = node(i, j + 1);
      mesh.triangles.insert(mesh.triangles.end(), {a, d, b});
      mesh.triangles.insert(mesh.triangles.end(), {b, d, c});
    }
  return mesh;
}

} // namespace railcosim::kernels::testing
