// Set-ups of the rotation-scheme verification tests R1–R4 (Irazábal 2017 §5.3.2), shared by tests and benchmark.
//
// R1 torque-free precession and R2 sphere under T = 1e5·eᵗ are single bodies; R3/R4 are rigid fibres
// (chains of touching spheres) bouncing without dissipation in an elastic 1 m box. All use velocity Verlet
// for translation and the predict/correct rotation kernels, in the order of the thesis flowchart (§5.8).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "kernels/HertzMindlin.hpp"
#include "kernels/MathConstants.hpp"
#include "kernels/Quaternion.hpp"
#include "kernels/RotationIntegrators.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::rotationscenes {

using kernels::Quaternion;
using kernels::RotationScheme;
using kernels::RotationState;
using kernels::Vec3;

// ---------------------------------------------------------------------------------------------------
// R1: free precession of a symmetric body, I' = diag(2, 2, 1) (Munjiza's cylinder, L = 3r), ω0 = [0, 1, 100].
// Analytic body-frame solution (eq. 5.56 with erratum 15): ω'_x = sin 50t, ω'_y = cos 50t, ω'_z = 100.
// ---------------------------------------------------------------------------------------------------
struct PrecessionResult {
  double maxBodyOmegaError;         // max_t |ω'(t) − ω'_exact(t)| [rad/s]
  double maxMomentumDirectionError; // max_t |q(t) I' ω'_exact(t) q(t)* − H0| / |H0|: orientation error [-]
};

inline PrecessionResult runFreePrecession(RotationScheme scheme, double timeStep, double duration = 0.5) {
  const Vec3 inertia{2.0, 2.0, 1.0};
  const Vec3 omega0{0.0, 1.0, 100.0};
  const Vec3 momentum0 = kernels::componentProduct(inertia, omega0);      // q0 = identity: H0 = I' ω0
  const double precessionRate = (1.0 - inertia.z / inertia.x) * omega0.z; // 50 rad/s
  RotationState state = kernels::makeRotationState(kernels::identityQuaternion(), omega0, inertia);
  const Vec3 zeroTorque{0.0, 0.0, 0.0};
  PrecessionResult result{0.0, 0.0};
  const long steps = std::lround(duration / timeStep);
  for (long n = 1; n <= steps; ++n) {
    kernels::predictRotation(scheme, state, inertia, zeroTorque, timeStep);
    kernels::correctRotation(scheme, state, inertia, zeroTorque, timeStep);
    const double t = n * timeStep;
    const Vec3 exact{std::sin(precessionRate * t), std::cos(precessionRate * t), omega0.z};
    const Vec3 body = kernels::rotateInverse(state.orientation, state.angularVelocity);
    result.maxBodyOmegaError = std::max(result.maxBodyOmegaError, kernels::norm(body - exact));
    const Vec3 momentum = kernels::rotate(state.orientation, kernels::componentProduct(inertia, exact));
    result.maxMomentumDirectionError =
        std::max(result.maxMomentumDirectionError, kernels::norm(momentum - momentum0) / kernels::norm(momentum0));
  }
  return result;
}

// ---------------------------------------------------------------------------------------------------
// Tumbling asymmetric body (our addition to R1, which is axisymmetric): I' = diag(1, 2, 3), spun about
// the intermediate axis with a small perturbation, ω0 = [0.01, 10, 0.01]; it flips (ω'_y: 10 → −10 and
// back). Oracles: kinetic energy and the world angular momentum are invariants of torque-free motion.
// ---------------------------------------------------------------------------------------------------
struct TumblingResult {
  double maxRelativeEnergyError;   // max_t |E − E0|/E0 [-]
  double maxRelativeMomentumError; // max_t |H − H0|/|H0| [-]
  double minBodyOmegaY;            // min_t ω'_y [rad/s]: ≈ −10 when the flip happened
};

inline TumblingResult runTumblingBody(RotationScheme scheme, double timeStep, double duration = 4.0) {
  const Vec3 inertia{1.0, 2.0, 3.0};
  const Vec3 omega0{0.01, 10.0, 0.01};
  RotationState state = kernels::makeRotationState(kernels::identityQuaternion(), omega0, inertia);
  const Vec3 momentum0 = state.angularMomentum;
  const double energy0 = kernels::rotationalKineticEnergy(state.orientation, inertia, omega0);
  const Vec3 zeroTorque{0.0, 0.0, 0.0};
  TumblingResult result{0.0, 0.0, omega0.y};
  const long steps = std::lround(duration / timeStep);
  for (long n = 0; n < steps; ++n) {
    kernels::predictRotation(scheme, state, inertia, zeroTorque, timeStep);
    kernels::correctRotation(scheme, state, inertia, zeroTorque, timeStep);
    const double energy = kernels::rotationalKineticEnergy(state.orientation, inertia, state.angularVelocity);
    const Vec3 momentum = kernels::applyRotatedDiagonal(state.orientation, inertia, state.angularVelocity);
    result.maxRelativeEnergyError = std::max(result.maxRelativeEnergyError, std::abs(energy - energy0) / energy0);
    result.maxRelativeMomentumError =
        std::max(result.maxRelativeMomentumError, kernels::norm(momentum - momentum0) / kernels::norm(momentum0));
    result.minBodyOmegaY =
        std::min(result.minBodyOmegaY, kernels::rotateInverse(state.orientation, state.angularVelocity).y);
  }
  return result;
}

// ---------------------------------------------------------------------------------------------------
// R2: sphere R = 1 m, ρ = 1100 kg/m³, translation fixed, T = [0, 1e5 eᵗ, 0] N·m.
// Analytic: θ_y = (1e5/I)(eᵗ − t − 1) (eq. 5.57).
// ---------------------------------------------------------------------------------------------------
struct SphereTorqueResult {
  double angleError;       // |Σ Δθ_y − θ_exact| at the end [rad] (accumulated angle: no 2π ambiguity)
  double orientationError; // min(|q − q_exact|, |q + q_exact|) at the end [-]
  double exactAngle;       // θ_exact at the end [rad]
};

inline SphereTorqueResult runSphereUnderExponentialTorque(RotationScheme scheme, double timeStep,
                                                          double duration = 1.0) {
  const double mass = 4.0 / 3.0 * kernels::pi * 1100.0; // R = 1 m
  const double moment = 0.4 * mass;                     // I = (2/5) m R² (eq. 3.30)
  const Vec3 inertia{moment, moment, moment};
  RotationState state = kernels::makeRotationState(kernels::identityQuaternion(), Vec3{0.0, 0.0, 0.0}, inertia);
  auto torqueAt = [](double t) { return Vec3{0.0, 1e5 * std::exp(t), 0.0}; };
  double accumulatedAngle = 0.0;
  const long steps = std::lround(duration / timeStep);
  for (long n = 0; n < steps; ++n) {
    kernels::predictRotation(scheme, state, inertia, torqueAt(n * timeStep), timeStep);
    accumulatedAngle += state.rotationIncrement.y;
    kernels::correctRotation(scheme, state, inertia, torqueAt((n + 1) * timeStep), timeStep);
  }
  const double t = steps * timeStep;
  const double exactAngle = 1e5 / moment * (std::exp(t) - t - 1.0);
  const Quaternion exact = kernels::quaternionFromAxisAngle(Vec3{0.0, 1.0, 0.0}, exactAngle);
  const Quaternion& q = state.orientation;
  const double plus = std::sqrt((q.w - exact.w) * (q.w - exact.w) + (q.x - exact.x) * (q.x - exact.x) +
                                (q.y - exact.y) * (q.y - exact.y) + (q.z - exact.z) * (q.z - exact.z));
  const double minus = std::sqrt((q.w + exact.w) * (q.w + exact.w) + (q.x + exact.x) * (q.x + exact.x) +
                                 (q.y + exact.y) * (q.y + exact.y) + (q.z + exact.z) * (q.z + exact.z));
  return SphereTorqueResult{std::abs(accumulatedAngle - exactAngle), std::min(plus, minus), exactAngle};
}

// ---------------------------------------------------------------------------------------------------
// R3/R4: rigid fibres bouncing in an elastic box, no friction, no damping (Table 5.3 materials).
// The thesis leaves out the fibre geometry, density and gravity axis (erratum 16); our choices:
//  * fibre = 5 touching spheres of radius 0.02 m along the body x' axis (length 0.2 m, aspect ratio 5),
//    density 1000 kg/m³. Touching (not overlapping) spheres make the mass properties exact sums.
//  * box [0, 1]³ m, gravity along −y (so the 30° tilt of R3 makes one end land first and the fibre spin).
//  * Hertz normal force on every sphere–wall and sphere–sphere overlap (kernels/HertzMindlin.hpp),
//    elastic energy (2/5) F δ (the integral of F ∝ δ^{3/2}).
// ---------------------------------------------------------------------------------------------------
struct FibreSceneParams {
  int spheresPerFibre = 5;
  double sphereRadius = 0.02;      // [m]
  double density = 1000.0;         // [kg/m³]
  double fibreYoungModulus = 5e7;  // [Pa] Table 5.3
  double fibrePoissonRatio = 0.35; // [-]
  double wallYoungModulus = 5e7;   // [Pa]
  double wallPoissonRatio = 0.23;  // [-]
  double gravity = 9.81;           // [m/s²], acting along −y
  double boxSize = 1.0;            // [m], box [0, boxSize]³
};

struct Fibre {
  Vec3 position; // centre of mass, world [m]
  Vec3 velocity; // [m/s]
  Vec3 force;    // [N]
  Vec3 torque;   // about the centre of mass, world [N·m]
  RotationState rotation;
};

class FibreBox {
public:
  FibreBox(const FibreSceneParams& params, RotationScheme scheme, double timeStep)
      : params_(params), scheme_(scheme), timeStep_(timeStep) {
    const double r = params.sphereRadius;
    sphereMass_ = params.density * 4.0 / 3.0 * kernels::pi * r * r * r;
    mass_ = params.spheresPerFibre * sphereMass_;
    double sumSquaredOffsets = 0.0;
    for (int i = 0; i < params.spheresPerFibre; ++i) {
      const double offset = (i - 0.5 * (params.spheresPerFibre - 1)) * 2.0 * r;
      memberOffsets_.push_back(offset);
      sumSquaredOffsets += offset * offset;
    }
    const double axial = params.spheresPerFibre * 0.4 * sphereMass_ * r * r;
    inertia_ = Vec3{axial, axial + sphereMass_ * sumSquaredOffsets, axial + sphereMass_ * sumSquaredOffsets};
    halfLength_ = memberOffsets_.back() + r;
    wallContact_ =
        kernels::HertzMindlinParams{kernels::effectiveYoungModulus(params.fibreYoungModulus, params.fibrePoissonRatio,
                                                                   params.wallYoungModulus, params.wallPoissonRatio),
                                    0.0, r, 0.0, 0.0};
    sphereContact_ =
        kernels::HertzMindlinParams{kernels::effectiveYoungModulus(params.fibreYoungModulus, params.fibrePoissonRatio,
                                                                   params.fibreYoungModulus, params.fibrePoissonRatio),
                                    0.0, kernels::effectiveRadius(r, r), 0.0, 0.0};
  }

  // Adds a fibre whose body x' axis points along `axis` (unit), at rest or moving with `velocity`.
  void addFibre(const Vec3& position, const Vec3& axis, const Vec3& velocity) {
    // Shortest rotation taking e_x to `axis` (axis ⟂ e_z here, but keep it general).
    const Vec3 ex{1.0, 0.0, 0.0};
    const Vec3 rotationAxis = kernels::cross(ex, axis);
    const double sinAngle = kernels::norm(rotationAxis);
    const double angle = std::atan2(sinAngle, kernels::dot(ex, axis));
    const Quaternion q = sinAngle > 1e-15 ? kernels::quaternionFromAxisAngle(rotationAxis / sinAngle, angle)
                                          : kernels::identityQuaternion();
    Fibre fibre{position, velocity, Vec3{0, 0, 0}, Vec3{0, 0, 0},
                kernels::makeRotationState(q, Vec3{0.0, 0.0, 0.0}, inertia_)};
    fibres_.push_back(fibre);
  }

  void initialise() { computeForces(); }

  // One velocity-Verlet step with the predict/correct rotation scheme around the force evaluation.
  void step() {
    for (Fibre& f : fibres_) {
      kernels::velocityVerletHalfKick(f.velocity, f.force, mass_, timeStep_);
      kernels::velocityVerletDrift(f.position, f.velocity, timeStep_);
      kernels::predictRotation(scheme_, f.rotation, inertia_, f.torque, timeStep_);
    }
    computeForces();
    for (Fibre& f : fibres_) {
      kernels::velocityVerletHalfKick(f.velocity, f.force, mass_, timeStep_);
      kernels::correctRotation(scheme_, f.rotation, inertia_, f.torque, timeStep_);
    }
  }

  // Kinetic + gravitational (reference y = 0, the floor) + elastic energy [J].
  double totalEnergy() const {
    double energy = elasticEnergy_;
    for (const Fibre& f : fibres_) {
      energy += 0.5 * mass_ * kernels::squaredNorm(f.velocity) + mass_ * params_.gravity * f.position.y +
                kernels::rotationalKineticEnergy(f.rotation.orientation, inertia_, f.rotation.angularVelocity);
    }
    return energy;
  }

  double elasticEnergy() const { return elasticEnergy_; }
  long sphereSphereContactSteps() const { return sphereSphereContactSteps_; }
  const std::vector<Fibre>& fibres() const { return fibres_; }

private:
  Vec3 memberCentre(const Fibre& f, int i) const {
    return f.position + kernels::rotate(f.rotation.orientation, Vec3{memberOffsets_[i], 0.0, 0.0});
  }

  void applyContact(Fibre& f, const Vec3& contactCentre, const Vec3& force) {
    f.force += force;
    f.torque += kernels::cross(contactCentre - f.position, force); // eq. 5.10; no sphere torques (μ = 0)
  }

  void computeForces() {
    elasticEnergy_ = 0.0;
    const double r = params_.sphereRadius;
    for (Fibre& f : fibres_) {
      f.force = Vec3{0.0, -mass_ * params_.gravity, 0.0};
      f.torque = Vec3{0.0, 0.0, 0.0};
    }
    bool anySphereContact = false;
    for (Fibre& f : fibres_) {
      for (int i = 0; i < params_.spheresPerFibre; ++i) {
        const Vec3 c = memberCentre(f, i);
        const double coordinates[3] = {c.x, c.y, c.z};
        for (int axis = 0; axis < 3; ++axis) {
          for (int side = 0; side < 2; ++side) {
            const double gap = side == 0 ? coordinates[axis] : params_.boxSize - coordinates[axis];
            const double overlap = r - gap;
            if (overlap <= 0.0) continue;
            const double magnitude = kernels::hertzElasticNormalForce(wallContact_, overlap);
            Vec3 normal{0.0, 0.0, 0.0}; // into the box
            (axis == 0 ? normal.x : axis == 1 ? normal.y : normal.z) = side == 0 ? 1.0 : -1.0;
            applyContact(f, c, magnitude * normal);
            elasticEnergy_ += 0.4 * magnitude * overlap;
          }
        }
      }
    }
    for (std::size_t a = 0; a < fibres_.size(); ++a) {
      for (std::size_t b = a + 1; b < fibres_.size(); ++b) {
        Fibre& fa = fibres_[a];
        Fibre& fb = fibres_[b];
        if (kernels::norm(fa.position - fb.position) >= 2.0 * halfLength_) continue; // bounding spheres
        for (int i = 0; i < params_.spheresPerFibre; ++i) {
          const Vec3 ca = memberCentre(fa, i);
          for (int j = 0; j < params_.spheresPerFibre; ++j) {
            const Vec3 cb = memberCentre(fb, j);
            const Vec3 branch = ca - cb;
            const double distance = kernels::norm(branch);
            const double overlap = 2.0 * r - distance;
            if (overlap <= 0.0) continue;
            anySphereContact = true;
            const double magnitude = kernels::hertzElasticNormalForce(sphereContact_, overlap);
            const Vec3 force = (magnitude / distance) * branch; // on a, along n = (C_a − C_b)/|·| (3.6)
            const Vec3 contactPoint = 0.5 * (ca + cb);
            applyContact(fa, contactPoint, force);
            applyContact(fb, contactPoint, -force);
            elasticEnergy_ += 0.4 * magnitude * overlap;
          }
        }
      }
    }
    if (anySphereContact) ++sphereSphereContactSteps_;
  }

  FibreSceneParams params_;
  RotationScheme scheme_;
  double timeStep_;
  double sphereMass_ = 0.0;
  double mass_ = 0.0;
  double halfLength_ = 0.0;
  Vec3 inertia_{0.0, 0.0, 0.0};
  std::vector<double> memberOffsets_;
  kernels::HertzMindlinParams wallContact_{};
  kernels::HertzMindlinParams sphereContact_{};
  std::vector<Fibre> fibres_;
  double elasticEnergy_ = 0.0;
  long sphereSphereContactSteps_ = 0;
};

struct BounceResult {
  double maxRelativeEnergyError; // max_t |E(t) − E(0)| / E(0) [-]
  double initialEnergy;          // [J]
  long sphereSphereContactSteps; // steps with at least one fibre–fibre contact (R4 must have some)
  double maxAngularSpeed;        // max_t over fibres of |ω| [rad/s] (shows that the fibres rotate)
};

inline BounceResult runBounce(FibreBox& box, double timeStep, double duration, int sampleEvery = 20) {
  box.initialise();
  const double initialEnergy = box.totalEnergy();
  BounceResult result{0.0, initialEnergy, 0, 0.0};
  const long steps = std::lround(duration / timeStep);
  for (long n = 1; n <= steps; ++n) {
    box.step();
    if (n % sampleEvery == 0 || n == steps) {
      result.maxRelativeEnergyError =
          std::max(result.maxRelativeEnergyError, std::abs(box.totalEnergy() - initialEnergy) / initialEnergy);
      for (const Fibre& f : box.fibres()) {
        result.maxAngularSpeed = std::max(result.maxAngularSpeed, kernels::norm(f.rotation.angularVelocity));
      }
    }
  }
  result.sphereSphereContactSteps = box.sphereSphereContactSteps();
  return result;
}

// R3: one fibre at the box centre, at rest, x' along [0.86603, −0.5, 0] (−30° about z).
inline BounceResult runSingleFibre(RotationScheme scheme, double timeStep, double duration) {
  FibreBox box(FibreSceneParams{}, scheme, timeStep);
  box.addFibre(Vec3{0.5, 0.5, 0.5}, Vec3{0.86603, -0.5, 0.0} / kernels::norm(Vec3{0.86603, -0.5, 0.0}),
               Vec3{0.0, 0.0, 0.0});
  return runBounce(box, timeStep, duration);
}

// R4: nine fibres spread evenly along x on the mid-plane z = 0.5 at mid-height y = 0.5, v0 = [1, 0, −1] m/s,
// x' along [0.25882, −0.96593, 0] (−75° about z).
inline BounceResult runNineFibres(RotationScheme scheme, double timeStep, double duration) {
  FibreBox box(FibreSceneParams{}, scheme, timeStep);
  const Vec3 axis = Vec3{0.25882, -0.96593, 0.0} / kernels::norm(Vec3{0.25882, -0.96593, 0.0});
  for (int i = 0; i < 9; ++i) {
    box.addFibre(Vec3{0.1 + 0.1 * i, 0.5, 0.5}, axis, Vec3{1.0, 0.0, -1.0});
  }
  return runBounce(box, timeStep, duration);
}

} // namespace railcosim::rotationscenes
