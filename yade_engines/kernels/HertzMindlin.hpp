// Hertz–Mindlin contact kernels as simplified by Thornton (Irazábal 2017 §3.2.3): normal, damping, tangential.
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "railcosim/HostDevice.hpp"
#include "kernels/Vector3.hpp"

namespace railcosim::kernels {

// ---------------------------------------------------------------------------------------------------
// Equivalent (two-body) properties. A rigid wall is passed as radius or mass = INFINITY (1/inf = 0 in
// IEEE arithmetic, which reduces these to the one-body values of Irazábal eq. 4.1).
// ---------------------------------------------------------------------------------------------------

// G = E / (2 (1 + ν)), Irazábal 2017 eq. 3.28. [Pa]
RAILCOSIM_HOST_DEVICE inline double shearModulus(double youngModulus, double poissonRatio) {
  return youngModulus / (2.0 * (1.0 + poissonRatio));
}

// R* = R1 R2 / (R1 + R2), eq. 3.27a. [m]
RAILCOSIM_HOST_DEVICE inline double effectiveRadius(double radius1, double radius2) {
  return 1.0 / (1.0 / radius1 + 1.0 / radius2);
}

// m* = m1 m2 / (m1 + m2), eq. 3.27b. [kg]
RAILCOSIM_HOST_DEVICE inline double effectiveMass(double mass1, double mass2) {
  return 1.0 / (1.0 / mass1 + 1.0 / mass2);
}

// E* = [(1 − ν1²)/E1 + (1 − ν2²)/E2]⁻¹, eq. 3.27c. [Pa]
RAILCOSIM_HOST_DEVICE inline double effectiveYoungModulus(double youngModulus1, double poissonRatio1,
                                                          double youngModulus2, double poissonRatio2) {
  return 1.0 / ((1.0 - poissonRatio1 * poissonRatio1) / youngModulus1 +
                (1.0 - poissonRatio2 * poissonRatio2) / youngModulus2);
}

// G* = [(2 − ν1)/G1 + (2 − ν2)/G2]⁻¹, eq. 3.27d (Mindlin's tangential compliance). [Pa]
RAILCOSIM_HOST_DEVICE inline double effectiveShearModulus(double shearModulus1, double poissonRatio1,
                                                          double shearModulus2, double poissonRatio2) {
  return 1.0 / ((2.0 - poissonRatio1) / shearModulus1 + (2.0 - poissonRatio2) / shearModulus2);
}

// ---------------------------------------------------------------------------------------------------
// Per-contact parameters of the Hertz–Mindlin (Thornton) law. Built once when the contact is created.
// ---------------------------------------------------------------------------------------------------
struct HertzMindlinParams {
  double effectiveYoungModulus; // E* [Pa], eq. 3.27c
  double effectiveShearModulus; // G* [Pa], eq. 3.27d
  double effectiveRadius;       // R* [m], eq. 3.27a
  double effectiveMass;         // m* [kg], eq. 3.27b
  double dampingRatio;          // γ [-], fraction of critical damping; see dampingRatioFromRestitution
};

// Hertz contact radius a = sqrt(R* δ) (eq. 3.25a). Zero for no overlap. [m]
RAILCOSIM_HOST_DEVICE inline double hertzContactRadius(const HertzMindlinParams& p, double overlap) {
  return overlap > 0.0 ? std::sqrt(p.effectiveRadius * overlap) : 0.0;
}

// Tangent normal stiffness k_n = dF/dδ = 2 E* a (eq. 3.25a). [N/m]
RAILCOSIM_HOST_DEVICE inline double hertzNormalStiffness(const HertzMindlinParams& p, double overlap) {
  return 2.0 * p.effectiveYoungModulus * hertzContactRadius(p, overlap);
}

// Tangential stiffness k_t = 8 G* a (eq. 3.25b). [N/m]
RAILCOSIM_HOST_DEVICE inline double mindlinTangentialStiffness(const HertzMindlinParams& p, double overlap) {
  return 8.0 * p.effectiveShearModulus * hertzContactRadius(p, overlap);
}

// Elastic normal force F_ne = (2/3) k_n δ = (4/3) E* sqrt(R*) δ^{3/2} (eqs. 3.13, 3.25a). [N]
RAILCOSIM_HOST_DEVICE inline double hertzElasticNormalForce(const HertzMindlinParams& p, double overlap) {
  return overlap > 0.0 ? (2.0 / 3.0) * hertzNormalStiffness(p, overlap) * overlap : 0.0;
}

// Viscous coefficient c = 2 γ sqrt(m* k) (eqs. 3.15 and 3.26b; pass k_n for normal, k_t for tangential —
// eq. 3.22's text and formula disagree; read in favour of k_t). [N s/m]
// An undamped contact returns exactly 0 even when m* is infinite (two non-dynamic bodies), instead of 0·∞.
RAILCOSIM_HOST_DEVICE inline double viscousDampingCoefficient(double dampingRatio, double effectiveMass,
                                                              double stiffness) {
  if (dampingRatio == 0.0) return 0.0;
  return 2.0 * dampingRatio * std::sqrt(effectiveMass * stiffness);
}

// Damping ratio γ from the normal coefficient of restitution e for the HERTZIAN spring with the
// stiffness-proportional dashpot c_n = 2γ sqrt(m* k_n(δ)) and a non-attractive total force (F_n ≥ 0).
// With k_n ∝ δ^{1/2} the achieved restitution depends on γ only (not on impact velocity), but the
// linear spring–dashpot closed form (Irazábal eq. 3.17) does not apply: it is ≈10 % off in γ.
// Relation used: the polynomial fit of Thornton, Cummins & Cleary (2013, Powder Technol. 233, 30–46)
// for this Hertzian model, γ = sqrt(1/(1 − (1+e)² exp(α)) − 1), α = e(h1 + e(h2 + … + e h10))
// (coefficients as given by Irazábal 2017, §3.3). Verified against a simulated two-sphere
// impact in tests/kernels/TestHertzMindlin.cpp. e is clamped to [0.001, 0.999] where the fit is valid;
// e ≥ 0.999 gives γ = 0 (elastic). e = 0 therefore maps to γ(0.001) ≈ 14.2 (strongly overdamped).
RAILCOSIM_HOST_DEVICE inline double dampingRatioFromRestitution(double restitution) {
  if (restitution >= 0.999) return 0.0;
  const double e = restitution < 0.001 ? 0.001 : restitution;
  // h1..h10 of the fit, applied in Horner form from h10 down.
  const double h[10] = {-6.918798, -16.41105, 146.8049,  -796.4559, 2928.711,
                        -7206.864, 11494.29,  -11342.18, 6276.757,  -1489.915};
  double alpha = h[9];
  for (int i = 8; i >= 0; --i) alpha = h[i] + e * alpha;
  alpha *= e;
  return std::sqrt(1.0 / (1.0 - (1.0 + e) * (1.0 + e) * std::exp(alpha)) - 1.0);
}

// Total normal force F_n = max(0, F_ne + c_n δ̇) (eqs. 3.12–3.15); the clamp forbids attraction from the
// dashpot during rebound. overlapRate = dδ/dt > 0 while approaching. [N], repulsive positive.
RAILCOSIM_HOST_DEVICE inline double hertzNormalForce(const HertzMindlinParams& p, double overlap, double overlapRate) {
  if (overlap <= 0.0) return 0.0;
  const double stiffness = hertzNormalStiffness(p, overlap);
  const double damping = viscousDampingCoefficient(p.dampingRatio, p.effectiveMass, stiffness);
  const double force = (2.0 / 3.0) * stiffness * overlap + damping * overlapRate;
  return force > 0.0 ? force : 0.0;
}

// ---------------------------------------------------------------------------------------------------
// Tangential force: incremental elastic spring with unloading correction, dashpot and Coulomb cap.
// History slot: the elastic tangential force vector F_te (3 doubles) and the tangential stiffness or
// overlap of the previous step (1 double).
// ---------------------------------------------------------------------------------------------------
struct TangentialForceResult {
  Vec3 elasticForce; // new elastic history F_te, to store for the next step [N]
  Vec3 force;        // total tangential force F_t (elastic + viscous, capped) [N]
  bool sliding;      // true when the Coulomb cap was active this step
};

// Generic incremental update, valid for any normal law that provides a tangential stiffness
// (eqs. 3.20, 3.23, 3.24). Conventions: the returned force acts on the body whose relative tangential
// displacement increment is `tangentialDisplacementIncrement` and whose relative tangential velocity is
// `tangentialVelocity` (so F opposes both). Steps:
//  1. the stored force is rotated into the current tangent plane keeping its magnitude (contact frames
//     turn with the particles);
//  2. unloading (k_t < k_t,prev where the area may shrink) scales it by k_t/k_t,prev (for Hertz = sqrt(δ/δ_prev),
//     eq. 3.20) so the spring unloads along the shrinking contact area instead of storing energy it cannot hold.
//     Only a falling overlap shrinks the area: a k_t that drops while the overlap grows (the elasto-plastic
//     Pohrt–Popov law passing from its stiffer reloading branch to the virgin one at F_max) keeps the force, so
//     the caller says whether the area may shrink (`areaMayShrink`);
//  3. F_te ← F_te − k_t Δs;  F_trial = F_te − c_t v_t;
//  4. if |F_trial| > μ F_n: F_t = μ F_n F_trial/|F_trial| and the elastic history is set to that capped
//     force (the dashpot does no work while sliding; on reversal the spring unloads from the friction
//     level). This resolves the thesis' ambiguity on how the cap splits between spring and dashpot.
RAILCOSIM_HOST_DEVICE inline TangentialForceResult incrementalTangentialForce(
    const Vec3& elasticForceHistory, const Vec3& unitNormal, double tangentialStiffness,
    double previousTangentialStiffness, const Vec3& tangentialDisplacementIncrement, const Vec3& tangentialVelocity,
    double tangentialDampingCoefficient, double frictionCoefficient, double normalForce, bool areaMayShrink) {
  // 1. rotate the history into the current tangent plane, preserving its magnitude
  Vec3 elastic = tangentialPart(elasticForceHistory, unitNormal);
  const double oldMagnitude = norm(elasticForceHistory);
  const double projectedMagnitude = norm(elastic);
  if (projectedMagnitude > 0.0) elastic = elastic * (oldMagnitude / projectedMagnitude);
  // 2. unloading correction
  if (areaMayShrink && previousTangentialStiffness > 0.0 && tangentialStiffness < previousTangentialStiffness) {
    elastic = elastic * (tangentialStiffness / previousTangentialStiffness);
  }
  // 3. spring increment and dashpot (only tangential parts of the kinematic inputs count)
  elastic -= tangentialStiffness * tangentialPart(tangentialDisplacementIncrement, unitNormal);
  const Vec3 trial = elastic - tangentialDampingCoefficient * tangentialPart(tangentialVelocity, unitNormal);
  // 4. Coulomb cap
  const double limit = normalForce > 0.0 && frictionCoefficient > 0.0 ? frictionCoefficient * normalForce : 0.0;
  const double trialMagnitude = norm(trial);
  TangentialForceResult result{elastic, trial, false};
  if (trialMagnitude > limit) {
    const Vec3 capped = trialMagnitude > 0.0 ? trial * (limit / trialMagnitude) : Vec3{0.0, 0.0, 0.0};
    result.elasticForce = capped;
    result.force = capped;
    result.sliding = true;
  }
  return result;
}

// Hertz–Mindlin tangential force: k_t = 8 G* a at the current and previous overlap, c_t = 2γ sqrt(m* k_t).
RAILCOSIM_HOST_DEVICE inline TangentialForceResult mindlinTangentialForce(
    const HertzMindlinParams& p, const Vec3& elasticForceHistory, const Vec3& unitNormal, double overlap,
    double previousOverlap, const Vec3& tangentialDisplacementIncrement, const Vec3& tangentialVelocity,
    double frictionCoefficient, double normalForce) {
  const double stiffness = mindlinTangentialStiffness(p, overlap);
  const double previousStiffness = mindlinTangentialStiffness(p, previousOverlap);
  const double damping = viscousDampingCoefficient(p.dampingRatio, p.effectiveMass, stiffness);
  return incrementalTangentialForce(elasticForceHistory, unitNormal, stiffness, previousStiffness,
                                    tangentialDisplacementIncrement, tangentialVelocity, damping, frictionCoefficient,
                                    normalForce, true); // Hertz has one branch: k_t falls only with the overlap
}

// ---------------------------------------------------------------------------------------------------
// Host-only validation (throws; never called from device code).
// ---------------------------------------------------------------------------------------------------
namespace detail {
inline void requirePositiveFinite(double value, const char* name, const char* where) {
  if (!(value > 0.0) || std::isnan(value)) {
    std::ostringstream message;
    message << where << ": " << name << " must be positive, got " << value
            << "; check the material or contact parameters";
    throw std::invalid_argument(message.str());
  }
}
} // namespace detail

// Restitution must lie in [0, 1]; anything else is a unit or input error.
inline void validateRestitution(double restitution, const char* where = "dampingRatioFromRestitution") {
  if (!(restitution >= 0.0 && restitution <= 1.0)) {
    std::ostringstream message;
    message << where << ": coefficient of restitution must be in [0, 1], got " << restitution;
    throw std::invalid_argument(message.str());
  }
}

inline void validate(const HertzMindlinParams& p, const char* where = "HertzMindlinParams") {
  detail::requirePositiveFinite(p.effectiveYoungModulus, "effectiveYoungModulus [Pa]", where);
  detail::requirePositiveFinite(p.effectiveShearModulus, "effectiveShearModulus [Pa]", where);
  detail::requirePositiveFinite(p.effectiveRadius, "effectiveRadius [m]", where);
  detail::requirePositiveFinite(p.effectiveMass, "effectiveMass [kg]", where);
  if (!(p.dampingRatio >= 0.0) || std::isinf(p.dampingRatio)) {
    std::ostringstream message;
    message << where << ": dampingRatio must be finite and ≥ 0, got " << p.dampingRatio;
    throw std::invalid_argument(message.str());
  }
}

} // namespace railcosim::kernels
