// Composition of the ballast contact law per contact: normal + damping + tangential + friction coefficient.
#pragma once

#include "kernels/HertzMindlin.hpp"
#include "kernels/HostDevice.hpp"
#include "kernels/PohrtPopov.hpp"
#include "kernels/StressDependentFriction.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::kernels {

// Normal sub-model keywords of SubModelRegistry.hpp: "hertz", "pohrt_popov", "pohrt_popov_plastic".
enum class NormalModel : int { Hertz = 0, PohrtPopovElastic = 1, PohrtPopovElastoPlastic = 2 };

// Everything one contact needs; built once per contact (YADE: the Ip2 functor; GPU: per pair type).
struct BallastContactParams {
  NormalModel normalModel;
  HertzMindlinParams hertzMindlin;        // E*, G*, R*, m*, damping ratio γ (all normal models)
  PohrtPopovParams pohrtPopov;            // only read by the Pohrt–Popov normal models
  double tangentialStiffnessRatio;        // k_t/k_n [-] for the Pohrt–Popov models (eq. 7); Hertz uses 8G*a
  StressDependentFrictionParams friction; // μ0 always; the stress reduction only if stressDependentFriction
  bool stressDependentFriction;           // true between members of different clusters only
};

// History slots stored per contact (all zero for a fresh contact).
struct BallastContactHistory {
  Vec3 elasticShearForce;             // elastic tangential force F_te [N]
  double previousTangentialStiffness; // k_t of the previous step [N/m] (unloading correction)
  double maxNormalForce;              // F_max [N] (elasto-plastic Pohrt–Popov only)
  double plasticOverlap;              // δ_p [m] (elasto-plastic Pohrt–Popov only)
};

// Contact kinematics gathered by the caller. Sign conventions: overlap > 0 in contact; overlapRate > 0
// while approaching; shearIncrement and shearVelocity are the displacement increment and velocity of
// body 2 relative to body 1 at the contact point; unitNormal points from body 1 to body 2.
struct ContactKinematics {
  double overlap;      // δ [m]
  double overlapRate;  // dδ/dt [m/s]
  Vec3 unitNormal;     // n [-]
  Vec3 shearIncrement; // Δs [m]
  Vec3 shearVelocity;  // v_t [m/s]
};

struct BallastContactResult {
  double normalForce;            // |F_n| ≥ 0 [N]; the force on body 2 is +normalForce·n (repulsion)
  Vec3 shearForce;               // tangential force on body 2 [N]; body 1 receives the opposite
  double normalStiffness;        // tangent k_n of the active branch [N/m]
  double tangentialStiffness;    // k_t [N/m]
  double frictionCoefficient;    // μ used for the Coulomb cap [-]
  bool sliding;                  // Coulomb cap active this step
  BallastContactHistory history; // to store for the next step
};

// One evaluation of the composed law. Normal: the selected elastic law plus the dashpot
// c_n = 2γ sqrt(m* k_n), total clamped at ≥ 0. Tangential: incremental with unloading correction,
// dashpot c_t = 2γ sqrt(m* k_t), Coulomb cap with μ (stress-dependent if enabled).
RAILCOSIM_HOST_DEVICE inline BallastContactResult ballastContactForces(const BallastContactParams& p,
                                                                       const BallastContactHistory& history,
                                                                       const ContactKinematics& k) {
  BallastContactResult r{};
  r.history = history;
  double elasticForce = 0.0;
  switch (p.normalModel) {
    case NormalModel::Hertz:
      elasticForce = hertzElasticNormalForce(p.hertzMindlin, k.overlap);
      r.normalStiffness = hertzNormalStiffness(p.hertzMindlin, k.overlap);
      r.tangentialStiffness = mindlinTangentialStiffness(p.hertzMindlin, k.overlap);
      break;
    case NormalModel::PohrtPopovElastic:
      elasticForce = pohrtPopovElasticForce(p.pohrtPopov, k.overlap);
      r.normalStiffness = pohrtPopovElasticStiffness(p.pohrtPopov, k.overlap);
      r.tangentialStiffness = p.tangentialStiffnessRatio * r.normalStiffness;
      break;
    case NormalModel::PohrtPopovElastoPlastic: {
      const PlasticNormalResult plastic =
          pohrtPopovElastoPlasticForce(p.pohrtPopov, k.overlap, history.maxNormalForce, history.plasticOverlap);
      elasticForce = plastic.force;
      r.normalStiffness = plastic.stiffness;
      r.tangentialStiffness = p.tangentialStiffnessRatio * r.normalStiffness;
      r.history.maxNormalForce = plastic.maxNormalForce;
      r.history.plasticOverlap = plastic.plasticOverlap;
      break;
    }
  }
  const double normalDamping =
      viscousDampingCoefficient(p.hertzMindlin.dampingRatio, p.hertzMindlin.effectiveMass, r.normalStiffness);
  const double normalForce = elasticForce + normalDamping * k.overlapRate;
  r.normalForce = normalForce > 0.0 ? normalForce : 0.0;

  r.frictionCoefficient =
      p.stressDependentFriction
          ? stressDependentFrictionCoefficient(p.friction, p.hertzMindlin.effectiveRadius, k.overlap, r.normalForce)
          : p.friction.baseFrictionCoefficient;

  const double tangentialDamping =
      viscousDampingCoefficient(p.hertzMindlin.dampingRatio, p.hertzMindlin.effectiveMass, r.tangentialStiffness);
  const TangentialForceResult tangential = incrementalTangentialForce(
      history.elasticShearForce, k.unitNormal, r.tangentialStiffness, history.previousTangentialStiffness,
      k.shearIncrement, k.shearVelocity, tangentialDamping, r.frictionCoefficient, r.normalForce);
  r.shearForce = tangential.force;
  r.sliding = tangential.sliding;
  r.history.elasticShearForce = tangential.elasticForce;
  r.history.previousTangentialStiffness = r.tangentialStiffness;
  return r;
}

} // namespace railcosim::kernels
