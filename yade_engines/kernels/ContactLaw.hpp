// The one contact law: sub-models chosen by keyword from SubModelRegistry.hpp and composed per contact, with the one
// parameter mixing for a pair; called by the YADE pairs, the sphere–FE-surface contacts and the polyhedra step.
#pragma once

#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "kernels/SubModelRegistry.hpp"
#include "kernels/Vector3.hpp"
#include "railcosim/HostDevice.hpp"

namespace railcosim::kernels {

// ---------------------------------------------------------------------------------------------------
// Selection: which row of each kind the composition calls. Made once from keywords (selectContactLaw), then read by
// the hot loops; plain data, so it travels into CUDA kernel arguments as it is.
// ---------------------------------------------------------------------------------------------------
struct ContactLawConfig {
  std::int32_t normal;     // index in NormalModels
  std::int32_t damping;    // index in DampingModels
  std::int32_t tangential; // index in TangentialModels
  std::int32_t friction;   // index in FrictionModels
  std::int32_t rolling;    // index in RollingModels
};

struct ContactLawKeywords {
  std::string normal = "hertz";
  std::string damping = "viscous_restitution";
  std::string tangential = "mindlin_incremental";
  std::string friction = "coulomb";
  std::string rolling = "none";
};

namespace detail {
template <class... Rows>
std::int32_t selectRow(SubModelList<Rows...> list, SubModelKind kind, const std::string& keyword) {
  const int index = findSubModel(list, keyword.c_str());
  if (index >= 0) return index;
  std::ostringstream message;
  message << "contact law: '" << keyword << "' is not a " << toString(kind) << " sub-model; known:";
  const char* const keywords[] = {Rows::info.keyword...};
  for (const char* known : keywords) message << " '" << known << "'";
  message << " (docs/contact-models.md)";
  throw std::invalid_argument(message.str());
}
template <class... Rows>
const char* rowKeyword(SubModelList<Rows...>, int index) {
  const char* const keywords[] = {Rows::info.keyword...};
  return index >= 0 && index < static_cast<int>(sizeof...(Rows)) ? keywords[index] : "?";
}
} // namespace detail

// Throws std::invalid_argument naming an unknown keyword and the known ones of its kind.
inline ContactLawConfig selectContactLaw(const ContactLawKeywords& keywords) {
  return ContactLawConfig{detail::selectRow(NormalModels{}, SubModelKind::Normal, keywords.normal),
                          detail::selectRow(DampingModels{}, SubModelKind::Damping, keywords.damping),
                          detail::selectRow(TangentialModels{}, SubModelKind::Tangential, keywords.tangential),
                          detail::selectRow(FrictionModels{}, SubModelKind::FrictionCoefficient, keywords.friction),
                          detail::selectRow(RollingModels{}, SubModelKind::Rolling, keywords.rolling)};
}

// The keywords of a configuration, e.g. "hertz + viscous_restitution + mindlin_incremental + coulomb + none".
inline std::string describe(const ContactLawConfig& c) {
  return std::string(detail::rowKeyword(NormalModels{}, c.normal)) + " + " +
         detail::rowKeyword(DampingModels{}, c.damping) + " + " + detail::rowKeyword(TangentialModels{}, c.tangential) +
         " + " + detail::rowKeyword(FrictionModels{}, c.friction) + " + " +
         detail::rowKeyword(RollingModels{}, c.rolling);
}

// NormalHistory doubles the selected normal model keeps per contact (0: the caller need not store any).
RAILCOSIM_HOST_DEVICE inline int normalHistorySlots(const ContactLawConfig& c) {
  return visitSubModel(NormalModels{}, c.normal, [](auto row) { return decltype(row)::historySlots; });
}

// The selection and the numbers of one contact.
struct ContactLaw {
  ContactLawConfig config;
  ContactParams params;
};

// ---------------------------------------------------------------------------------------------------
// Parameter mixing: one rule for a pair of particles and for a particle against a wall or an FE surface.
// ---------------------------------------------------------------------------------------------------

// The contact properties of one body's material.
struct ContactMaterial {
  double youngModulus;           // E [Pa]
  double poissonRatio;           // ν [-]
  double restitution;            // e [-], normal coefficient of restitution
  double frictionCoefficient;    // μ [-]
  double roughnessRms = 0.0;     // h [m]; 0: smooth (Hertz), > 0: rough (Pohrt–Popov)
  double fractalDimension = 0.0; // D_f [-], 2 ≤ D_f < 3 for a rough surface
  bool plasticUnloading = false; // elasto-plastic Pohrt–Popov (rough surfaces only)
  double frictionExponent = 0.0; // γ_μ ≤ 0 [-] of the stress-dependent friction; 0 disables it
  double maxContactStress = 0.0; // σ_c,max [Pa] of the stress-dependent friction; 0 disables it
  double rollingFriction = 0.0;  // η_r [-] of bounded rolling friction; 0 disables it
};

struct ContactPairOptions {
  // Stress-dependent friction acts between members of different clusters only (Irazábal 2017 §6.3.4).
  bool differentClusters = false;
  // Bounded rolling friction acts where a body is a sphere (Irazábal 2017 §5.2.1); the caller knows the shapes.
  bool rollingResistance = false;
};

// Host-only: throws std::invalid_argument naming the offending value.
inline void validate(const ContactMaterial& m, const std::string& where = "ContactMaterial") {
  std::ostringstream problem;
  if (!(m.youngModulus > 0.0) || !(m.poissonRatio > -1.0 && m.poissonRatio < 0.5))
    problem << "young [Pa] must be > 0 and poisson in (-1, 0.5), got young=" << m.youngModulus
            << ", poisson=" << m.poissonRatio;
  else if (!(m.restitution >= 0.0 && m.restitution <= 1.0))
    problem << "restitution must be in [0, 1], got " << m.restitution;
  else if (!(m.frictionCoefficient >= 0.0) || std::isinf(m.frictionCoefficient))
    problem << "friction coefficient must be finite and >= 0, got " << m.frictionCoefficient;
  else if (!(m.roughnessRms >= 0.0))
    problem << "roughnessRms [m] must be >= 0 (0 = smooth Hertz), got " << m.roughnessRms;
  else if (m.roughnessRms > 0.0 && !(m.fractalDimension >= 2.0 && m.fractalDimension < 3.0))
    problem << "fractal dimension must be in [2, 3) when roughnessRms > 0, got " << m.fractalDimension;
  else if (m.plasticUnloading && !(m.roughnessRms > 0.0))
    problem << "plastic unloading needs a rough surface: set roughnessRms [m] > 0 and the fractal dimension";
  else if (!(m.frictionExponent <= 0.0))
    problem << "frictionExponent must be <= 0 (friction falls with stress), got " << m.frictionExponent;
  else if (!(m.maxContactStress >= 0.0))
    problem << "maxContactStress [Pa] must be >= 0 (0 disables it), got " << m.maxContactStress;
  else if (!(m.rollingFriction >= 0.0) || std::isinf(m.rollingFriction))
    problem << "rolling friction (η_r [-]) must be finite and >= 0, got " << m.rollingFriction;
  else
    return;
  throw std::invalid_argument(where + ": " + problem.str());
}

// The law of a pair of materials, geometry still to come (setContactGeometry). Rules:
//  - E*, G*: Irazábal 2017 eq. 3.27c–d;
//  - damping ratio: the mean of the two γ(e) (eq. 3.27e);
//  - μ0: the smaller coefficient (YADE's FrictPhys: tan of the smaller friction angle);
//  - normal law: Pohrt–Popov if either surface is rough, with the means of D_f and h over the rough ones,
//    elasto-plastic if a rough one asks for it; Hertz otherwise. Tangential: Mindlin for Hertz, the stiffness ratio
//    k_t/k_n = 4G*/E* for the Pohrt–Popov laws (Tolomeo & McDowell 2022 eq. 7 for like materials);
//  - stress-dependent friction with the means of γ_μ and σ_c,max, where options.differentClusters and both are set;
//  - rolling: η_r the larger of the two (a wall material with η_r = 1 stops grains rolling on it, Irazábal §6.2),
//    where options.rollingResistance.
inline ContactLaw mixContactLaw(const ContactMaterial& a, const ContactMaterial& b,
                                const ContactPairOptions& options = ContactPairOptions{}) {
  validate(a, "contact law, first material");
  validate(b, "contact law, second material");
  ContactLaw law{};
  ContactLawKeywords keywords;
  ContactParams& p = law.params;
  p.hertzMindlin.effectiveYoungModulus =
      effectiveYoungModulus(a.youngModulus, a.poissonRatio, b.youngModulus, b.poissonRatio);
  p.hertzMindlin.effectiveShearModulus =
      effectiveShearModulus(shearModulus(a.youngModulus, a.poissonRatio), a.poissonRatio,
                            shearModulus(b.youngModulus, b.poissonRatio), b.poissonRatio);
  p.hertzMindlin.dampingRatio =
      0.5 * (dampingRatioFromRestitution(a.restitution) + dampingRatioFromRestitution(b.restitution));
  p.tangentialStiffnessRatio = 4.0 * p.hertzMindlin.effectiveShearModulus / p.hertzMindlin.effectiveYoungModulus;
  p.friction = StressDependentFrictionParams{
      a.frictionCoefficient < b.frictionCoefficient ? a.frictionCoefficient : b.frictionCoefficient,
      0.5 * (a.frictionExponent + b.frictionExponent), 0.5 * (a.maxContactStress + b.maxContactStress)};
  p.rollingFrictionCoefficient = a.rollingFriction > b.rollingFriction ? a.rollingFriction : b.rollingFriction;

  const int roughCount = int(a.roughnessRms > 0.0) + int(b.roughnessRms > 0.0);
  if (roughCount > 0) {
    p.pohrtPopov.roughnessRms = (a.roughnessRms + b.roughnessRms) / roughCount;
    p.pohrtPopov.fractalDimension =
        ((a.roughnessRms > 0.0 ? a.fractalDimension : 0.0) + (b.roughnessRms > 0.0 ? b.fractalDimension : 0.0)) /
        roughCount;
    const bool plastic = (a.plasticUnloading && a.roughnessRms > 0.0) || (b.plasticUnloading && b.roughnessRms > 0.0);
    keywords.normal = plastic ? "pohrt_popov_plastic" : "pohrt_popov";
    keywords.tangential = "stiffness_ratio";
  }
  if (options.differentClusters && p.friction.frictionExponent < 0.0 && p.friction.maxContactStress > 0.0)
    keywords.friction = "stress_dependent";
  if (options.rollingResistance && p.rollingFrictionCoefficient > 0.0) keywords.rolling = "brof";
  law.config = selectContactLaw(keywords);
  return law;
}

// The selected normal model's constants for the current E* and R* (the Pohrt–Popov ones; nothing for Hertz).
RAILCOSIM_HOST_DEVICE inline void prepareNormalModel(ContactLaw& law) {
  visitSubModel(NormalModels{}, law.config.normal, [&](auto row) {
    decltype(row)::prepare(law.params);
    return 0;
  });
}

// Geometry of one contact: R* [m] and m* [kg], then the normal model's constants for that R*. An infinite m* (two
// bodies of prescribed motion) becomes 0, which switches the dashpot off: there is no dynamics to damp.
RAILCOSIM_HOST_DEVICE inline void setContactGeometry(ContactLaw& law, double effectiveRadius, double effectiveMass) {
  law.params.hertzMindlin.effectiveRadius = effectiveRadius;
  law.params.hertzMindlin.effectiveMass = effectiveMass < INFINITY ? effectiveMass : 0.0;
  prepareNormalModel(law);
}

// The same from the two bodies: R* = R1R2/(R1 + R2), m* = m1m2/(m1 + m2) (eq. 3.27a–b). A flat wall or surface is
// radius INFINITY, a wall or a body of prescribed motion mass INFINITY (1/∞ = 0 gives the one-body values, eq. 4.1).
RAILCOSIM_HOST_DEVICE inline void setContactGeometry(ContactLaw& law, double radius1, double radius2, double mass1,
                                                     double mass2) {
  setContactGeometry(law, effectiveRadius(radius1, radius2), effectiveMass(mass1, mass2));
}

// The contact's rolling-resistance arm e_c [m] (0 unless brof is selected).
RAILCOSIM_HOST_DEVICE inline double rollingArm(const ContactLaw& law) {
  return visitSubModel(RollingModels{}, law.config.rolling, [&](auto row) { return decltype(row)::arm(law.params); });
}

// ---------------------------------------------------------------------------------------------------
// Composition per contact.
// ---------------------------------------------------------------------------------------------------

// History slots stored per contact (all zero for a fresh contact).
struct ContactHistory {
  Vec3 elasticShearForce;             // elastic tangential force F_te [N]
  double previousTangentialStiffness; // k_t of the previous step [N/m] (unloading correction)
  NormalHistory normal;               // the normal model's own (elasto-plastic Pohrt–Popov: F_max, δ_p)
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

struct ContactLawResult {
  double normalForce;             // |F_n| ≥ 0 [N]; the force on body 2 is +normalForce·n (repulsion)
  Vec3 shearForce;                // tangential force on body 2 [N]; body 1 receives the opposite
  double normalStiffness;         // tangent k_n of the active branch [N/m]
  double tangentialStiffness;     // k_t [N/m]
  double frictionCoefficient;     // μ used for the Coulomb cap [-]
  double rollingResistanceMoment; // e_c |F_n| [N m], this contact's share of each body's BROF budget
  bool sliding;                   // Coulomb cap active this step
  ContactHistory history;         // to store for the next step
};

// First half of the composition: the selected normal model at δ and the selected tangential stiffness it implies.
// Split off so that a caller storing the previous k_t in reduced precision can compare it with this one first.
struct ContactStiffness {
  NormalEvaluation normal; // elastic force, tangent k_n, new normal history
  double tangential;       // k_t [N/m]
};

RAILCOSIM_HOST_DEVICE inline ContactStiffness contactStiffness(const ContactLaw& law, const NormalHistory& history,
                                                               double overlap) {
  const ContactParams& p = law.params;
  ContactStiffness s{};
  s.normal = visitSubModel(NormalModels{}, law.config.normal,
                           [&](auto row) { return decltype(row)::evaluate(p, history, overlap); });
  s.tangential = visitSubModel(TangentialModels{}, law.config.tangential,
                               [&](auto row) { return decltype(row)::stiffness(p, overlap, s.normal); });
  return s;
}

// One evaluation of the composed law, given its first half. Normal: the selected elastic law plus the selected
// dashpot on its tangent stiffness, total clamped at ≥ 0. Tangential: the selected stiffness in the incremental
// spring with unloading correction, the dashpot on k_t, Coulomb cap with the selected μ. Rolling: the contact's
// BROF budget share.
RAILCOSIM_HOST_DEVICE inline ContactLawResult contactLawForces(const ContactLaw& law, const ContactHistory& history,
                                                               const ContactKinematics& k,
                                                               const ContactStiffness& stiffness) {
  const ContactLawConfig& c = law.config;
  const ContactParams& p = law.params;
  ContactLawResult r{};
  const double normalDamping = visitSubModel(
      DampingModels{}, c.damping, [&](auto row) { return decltype(row)::coefficient(p, stiffness.normal.stiffness); });
  const double normalForce = stiffness.normal.force + normalDamping * k.overlapRate;
  r.normalForce = normalForce > 0.0 ? normalForce : 0.0;
  r.normalStiffness = stiffness.normal.stiffness;
  r.frictionCoefficient = visitSubModel(
      FrictionModels{}, c.friction, [&](auto row) { return decltype(row)::coefficient(p, k.overlap, r.normalForce); });
  r.tangentialStiffness = stiffness.tangential;
  const double tangentialDamping = visitSubModel(
      DampingModels{}, c.damping, [&](auto row) { return decltype(row)::coefficient(p, r.tangentialStiffness); });
  const TangentialForceResult tangential = incrementalTangentialForce(
      history.elasticShearForce, k.unitNormal, r.tangentialStiffness, history.previousTangentialStiffness,
      k.shearIncrement, k.shearVelocity, tangentialDamping, r.frictionCoefficient, r.normalForce,
      !stiffness.normal.virginLoading);
  r.shearForce = tangential.force;
  r.sliding = tangential.sliding;
  r.rollingResistanceMoment = rollingResistanceMoment(rollingArm(law), r.normalForce);
  r.history = ContactHistory{tangential.elasticForce, r.tangentialStiffness, stiffness.normal.history};
  return r;
}

// The whole composition for one contact.
RAILCOSIM_HOST_DEVICE inline ContactLawResult contactLawForces(const ContactLaw& law, const ContactHistory& history,
                                                               const ContactKinematics& k) {
  return contactLawForces(law, history, k, contactStiffness(law, history.normal, k.overlap));
}

} // namespace railcosim::kernels
