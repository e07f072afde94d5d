// Pohrt–Popov rough-surface normal laws (elastic and elasto-plastic) after Tolomeo & McDowell (2022).
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "railcosim/HostDevice.hpp"
#include "kernels/MathConstants.hpp"

namespace railcosim::kernels {

// Per-contact parameters. The four inputs come from the materials and the contact geometry; the derived
// fields are filled once by makePohrtPopovParams (they all depend on R*, so on the particle pair).
struct PohrtPopovParams {
  // inputs
  double effectiveYoungModulus; // E* [Pa]; Tolomeo & McDowell: 1/E* = 2(1 − ν²)/E for like grains
  double effectiveRadius;       // R* [m], radius of curvature 1/R* = 1/R1 + 1/R2 (their Table 1 "R*")
  double fractalDimension;      // D_f [-], 2 ≤ D_f < 3
  double roughnessRms;          // h [m], root-mean-square roughness height
  // derived (makePohrtPopovParams)
  double stiffnessExponent;  // γ_PP = 0.2567 D_f [-] (exponent of F in eq. 1)
  double stiffnessPrefactor; // C [N^(1−γ)/m] so that k_n = C F^γ on the rough branch (eq. 1)
  double fullContactArea;    // A0 [m²], eq. 5
  double transitionForce;    // F(A0) [N], eq. 4
  double transitionOverlap;  // δ at which the rough branch reaches F(A0) [m]
  double hertzOverlapShift;  // Δ [m]: above F(A0) the law is Hertz in (δ − Δ)
};

// Hertz overlap that carries force F: δ_H = (3F / (4E*√R*))^{2/3}. [m]
RAILCOSIM_HOST_DEVICE inline double hertzOverlapFromForce(double effectiveYoungModulus, double effectiveRadius,
                                                          double force) {
  if (force <= 0.0) return 0.0;
  return std::pow(3.0 * force / (4.0 * effectiveYoungModulus * std::sqrt(effectiveRadius)), 2.0 / 3.0);
}

// Hertz force at overlap δ: F = (4/3) E* √R* δ^{3/2}. [N]
RAILCOSIM_HOST_DEVICE inline double hertzForceFromOverlap(double effectiveYoungModulus, double effectiveRadius,
                                                          double overlap) {
  if (overlap <= 0.0) return 0.0;
  return (4.0 / 3.0) * effectiveYoungModulus * std::sqrt(effectiveRadius) * overlap * std::sqrt(overlap);
}

// Hertz tangent stiffness at force F: k = (6 E*² F R*)^{1/3} (Tolomeo & McDowell eq. 1, second branch). [N/m]
RAILCOSIM_HOST_DEVICE inline double hertzStiffnessFromForce(double effectiveYoungModulus, double effectiveRadius,
                                                            double force) {
  if (force <= 0.0) return 0.0;
  return std::cbrt(6.0 * effectiveYoungModulus * effectiveYoungModulus * force * effectiveRadius);
}

// Fills the derived fields. Equations of Tolomeo & McDowell (2022) with the exponent of eq. 5 as
// corrected to 1/(0.2567 D_f) (the printed exponent does not reproduce the paper's own curves):
//   eq. 5  A0 = (3/4) π^{3/2} R h (20 / (π^{3/2} D_f))^{1/(0.2567 D_f)}
//   eq. 4  F(A0) = (4E*/(3R)) (A0/π)^{3/2}
//   eq. 1  k_n = (π/10) D_f E* √A0 (F/(h E* √A0))^{0.2567 D_f} = C F^γ
// The rough branch is integrated in closed form from F = 0 at δ = 0 (dF/dδ = C F^γ):
//   F(δ) = [(1 − γ) C δ]^{1/(1−γ)}, reaching F(A0) at δ_A0 = F(A0)^{1−γ} / ((1 − γ) C);
// above it the law is Hertz shifted by Δ = δ_A0 − δ_H(F(A0)) so force and stiffness are continuous there.
RAILCOSIM_HOST_DEVICE inline PohrtPopovParams makePohrtPopovParams(double effectiveYoungModulus, double effectiveRadius,
                                                                   double fractalDimension, double roughnessRms) {
  PohrtPopovParams p{effectiveYoungModulus, effectiveRadius, fractalDimension, roughnessRms, 0, 0, 0, 0, 0, 0};
  const double piPow = std::pow(pi, 1.5);
  const double gamma = 0.2567 * fractalDimension;
  p.stiffnessExponent = gamma;
  p.fullContactArea =
      0.75 * piPow * effectiveRadius * roughnessRms * std::pow(20.0 / (piPow * fractalDimension), 1.0 / gamma);
  const double contactPatchRadius = std::sqrt(p.fullContactArea / pi);
  p.transitionForce = 4.0 * effectiveYoungModulus / (3.0 * effectiveRadius) * contactPatchRadius * contactPatchRadius *
                      contactPatchRadius;
  const double sqrtArea = std::sqrt(p.fullContactArea);
  p.stiffnessPrefactor = (pi / 10.0) * fractalDimension * effectiveYoungModulus * sqrtArea /
                         std::pow(roughnessRms * effectiveYoungModulus * sqrtArea, gamma);
  p.transitionOverlap = std::pow(p.transitionForce, 1.0 - gamma) / ((1.0 - gamma) * p.stiffnessPrefactor);
  p.hertzOverlapShift =
      p.transitionOverlap - hertzOverlapFromForce(effectiveYoungModulus, effectiveRadius, p.transitionForce);
  return p;
}

// Rough-branch tangent stiffness at force F, k = C F^γ (eq. 1, first branch). [N/m]
RAILCOSIM_HOST_DEVICE inline double pohrtPopovRoughStiffnessFromForce(const PohrtPopovParams& p, double force) {
  if (force <= 0.0) return 0.0;
  return p.stiffnessPrefactor * std::pow(force, p.stiffnessExponent);
}

// Elastic Pohrt–Popov law (the virgin curve of the elasto-plastic law). [N], repulsive positive.
RAILCOSIM_HOST_DEVICE inline double pohrtPopovElasticForce(const PohrtPopovParams& p, double overlap) {
  if (overlap <= 0.0) return 0.0;
  if (overlap < p.transitionOverlap) {
    return std::pow((1.0 - p.stiffnessExponent) * p.stiffnessPrefactor * overlap, 1.0 / (1.0 - p.stiffnessExponent));
  }
  return hertzForceFromOverlap(p.effectiveYoungModulus, p.effectiveRadius, overlap - p.hertzOverlapShift);
}

// Tangent stiffness dF/dδ of the elastic law. [N/m]
RAILCOSIM_HOST_DEVICE inline double pohrtPopovElasticStiffness(const PohrtPopovParams& p, double overlap) {
  if (overlap <= 0.0) return 0.0;
  if (overlap < p.transitionOverlap) return pohrtPopovRoughStiffnessFromForce(p, pohrtPopovElasticForce(p, overlap));
  return 2.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius * (overlap - p.hertzOverlapShift));
}

// Elasto-plastic Pohrt–Popov (Tolomeo & McDowell eq. 6) written in overlap:
//  - virgin loading (overlap beyond the largest reached): the elastic Pohrt–Popov curve;
//  - unloading and reloading: Hertz from the stored maximum, F = (4/3)E*√R* (δ − δ_p)^{3/2}, with the
//    plastic overlap δ_p = δ_max − δ_H(F_max); no tension (F = 0 for δ ≤ δ_p);
//  - reloading rejoins the virgin curve exactly at F_max (both curves pass through (δ_max, F_max)).
// History slots: maxNormalForce F_max [N] and plasticOverlap δ_p [m], both 0 for a fresh contact.
struct PlasticNormalResult {
  double force;          // F_n [N]
  double stiffness;      // tangent dF/dδ of the active branch [N/m] (for tangential stiffness, time step)
  double maxNormalForce; // updated F_max [N]
  double plasticOverlap; // updated δ_p [m]
  bool virginLoading;    // true on the virgin (Pohrt–Popov) branch
};

RAILCOSIM_HOST_DEVICE inline PlasticNormalResult pohrtPopovElastoPlasticForce(const PohrtPopovParams& p, double overlap,
                                                                              double maxNormalForce,
                                                                              double plasticOverlap) {
  PlasticNormalResult result{0.0, 0.0, maxNormalForce, plasticOverlap, false};
  if (overlap <= 0.0) return result;
  const double elasticOverlap = overlap - plasticOverlap;
  const double reloadForce = hertzForceFromOverlap(p.effectiveYoungModulus, p.effectiveRadius, elasticOverlap);
  // The Hertz reloading curve is stiffer than the virgin curve, so it exceeds F_max exactly when the
  // overlap passes δ_max: that is where the virgin curve takes over.
  if (reloadForce >= maxNormalForce) {
    result.force = pohrtPopovElasticForce(p, overlap);
    result.stiffness = pohrtPopovElasticStiffness(p, overlap);
    result.maxNormalForce = result.force;
    const double plastic = overlap - hertzOverlapFromForce(p.effectiveYoungModulus, p.effectiveRadius, result.force);
    result.plasticOverlap = plastic > plasticOverlap ? plastic : plasticOverlap; // never heals
    result.virginLoading = true;
    return result;
  }
  result.force = reloadForce;
  result.stiffness =
      elasticOverlap > 0.0 ? 2.0 * p.effectiveYoungModulus * std::sqrt(p.effectiveRadius * elasticOverlap) : 0.0;
  return result;
}

// Constant tangential/normal stiffness ratio of Tolomeo & McDowell eq. 7, k_s/k_n = 2(1 − ν)/(2 − ν)
// (the ratio of the initial Mindlin and Hertz tangents for like materials; equals 4G*/E*). [-]
RAILCOSIM_HOST_DEVICE inline double tangentialToNormalStiffnessRatio(double poissonRatio) {
  return 2.0 * (1.0 - poissonRatio) / (2.0 - poissonRatio);
}

// Host-only validation of the inputs (throws std::invalid_argument with the offending value).
inline void validate(const PohrtPopovParams& p, const char* where = "PohrtPopovParams") {
  std::ostringstream message;
  if (!(p.effectiveYoungModulus > 0.0))
    message << "effectiveYoungModulus must be > 0 Pa, got " << p.effectiveYoungModulus;
  else if (!(p.effectiveRadius > 0.0) || std::isinf(p.effectiveRadius))
    message << "effectiveRadius must be finite and > 0 m, got " << p.effectiveRadius;
  else if (!(p.fractalDimension >= 2.0 && p.fractalDimension < 3.0))
    message << "fractalDimension must be in [2, 3) for a rough surface, got " << p.fractalDimension;
  else if (!(p.roughnessRms > 0.0))
    message << "roughnessRms must be > 0 m, got " << p.roughnessRms;
  else
    return;
  throw std::invalid_argument(std::string(where) + ": " + message.str() + "; check the BallastMat roughness inputs");
}

} // namespace railcosim::kernels
