// The one registry of contact sub-models: each row is a keyword, its kind, the function(s) the composition calls and
// its documentation (parameters with units, history, source, test).
#pragma once

#include <array>
#include <cstddef>
#include <cstring>
#include <type_traits>

#include "kernels/BoundedRollingFriction.hpp"
#include "kernels/HertzMindlin.hpp"
#include "kernels/PohrtPopov.hpp"
#include "kernels/StressDependentFriction.hpp"
#include "railcosim/HostDevice.hpp"

namespace railcosim::kernels {

enum class SubModelKind { Normal, Damping, Tangential, FrictionCoefficient, Rolling, TimeStep };

struct SubModelInfo {
  const char* keyword; // name used in configuration and docs/contact-models.md
  SubModelKind kind;
  const char* kernel;     // header and entry function
  const char* parameters; // named parameters with units
  const char* history;    // per-contact (or per-particle) history slots, "none" if stateless
  const char* reference;  // equation source
  const char* verifiedBy; // test file under tests/kernels/
};

// ---------------------------------------------------------------------------------------------------
// What the rows read and return. The numbers of one contact are set up once (ContactLaw.hpp: mixContactLaw for the
// materials, setContactGeometry for R* and m*); a row reads only the fields its documentation names.
// ---------------------------------------------------------------------------------------------------
struct ContactParams {
  HertzMindlinParams hertzMindlin;        // E*, G*, R*, m*, damping ratio γ
  PohrtPopovParams pohrtPopov;            // D_f, h and the constants derived for R* (Pohrt–Popov rows only)
  double tangentialStiffnessRatio;        // k_t/k_n [-] (stiffness_ratio)
  StressDependentFrictionParams friction; // μ0 [-] always; γ_μ [-] and σ_c,max [Pa] for stress_dependent
  double rollingFrictionCoefficient;      // η_r [-] (brof)
};

// History of the normal sub-model, zero for a fresh contact; rows that declare no history slots pass it through.
struct NormalHistory {
  double maxNormalForce; // F_max [N] (pohrt_popov_plastic)
  double plasticOverlap; // δ_p [m] (pohrt_popov_plastic)
};

struct NormalEvaluation {
  double force;          // elastic normal force F_ne ≥ 0 [N]
  double stiffness;      // tangent dF/dδ of the active branch [N/m] (dashpot, tangential spring, time step)
  NormalHistory history; // to keep for the next step
  // True on a branch only a growing overlap travels (the elasto-plastic law's virgin curve, where F_max rises): there
  // a falling tangent stiffness is the branch's, not a shrinking contact area (HertzMindlin.hpp, Mindlin's correction).
  bool virginLoading = false;
};

// ---------------------------------------------------------------------------------------------------
// The rows. One struct per sub-model: `info` and the function of its kind, all with the same signature per kind:
//   normal      historySlots (NormalHistory doubles it keeps), prepare(params) once per R*, evaluate(params,
//               history, δ) → NormalEvaluation
//   damping     coefficient(params, stiffness) → c [N s/m]
//   tangential  stiffness(params, δ, normal evaluation) → k_t [N/m] (the incremental spring with its Coulomb cap is
//               common to all: HertzMindlin.hpp, incrementalTangentialForce)
//   friction    coefficient(params, δ, F_n) → μ [-]
//   rolling     arm(params) → e_c [m], the contact's share of the particle's BROF budget per newton of F_n
//   time step   documentation only: the estimators are called by name where a time step is chosen
// ---------------------------------------------------------------------------------------------------
struct HertzNormalModel {
  static constexpr SubModelInfo info{"hertz",
                                     SubModelKind::Normal,
                                     "HertzMindlin.hpp: hertzElasticNormalForce, hertzNormalStiffness",
                                     "E* [Pa], R* [m]",
                                     "none",
                                     "Irazábal 2017 eqs. 3.13, 3.25a, 3.27 (Thornton's simplification)",
                                     "TestHertzMindlin.cpp"};
  static constexpr int historySlots = 0;
  RAILCOSIM_HOST_DEVICE static void prepare(ContactParams&) {}
  RAILCOSIM_HOST_DEVICE static NormalEvaluation evaluate(const ContactParams& p, const NormalHistory& history,
                                                         double overlap) {
    return NormalEvaluation{hertzElasticNormalForce(p.hertzMindlin, overlap),
                            hertzNormalStiffness(p.hertzMindlin, overlap), history};
  }
};

// The Pohrt–Popov constants depend on E* and R*: computed once per contact geometry.
RAILCOSIM_HOST_DEVICE inline void preparePohrtPopov(ContactParams& p) {
  p.pohrtPopov = makePohrtPopovParams(p.hertzMindlin.effectiveYoungModulus, p.hertzMindlin.effectiveRadius,
                                      p.pohrtPopov.fractalDimension, p.pohrtPopov.roughnessRms);
}

struct PohrtPopovNormalModel {
  static constexpr SubModelInfo info{
      "pohrt_popov",
      SubModelKind::Normal,
      "PohrtPopov.hpp: pohrtPopovElasticForce, pohrtPopovElasticStiffness",
      "E* [Pa], R* [m], D_f [-], h (rms roughness) [m]",
      "none",
      "Tolomeo & McDowell 2022 eqs. 1-5 (eq. 5 exponent corrected), closed form from F = 0",
      "TestPohrtPopov.cpp"};
  static constexpr int historySlots = 0;
  RAILCOSIM_HOST_DEVICE static void prepare(ContactParams& p) { preparePohrtPopov(p); }
  RAILCOSIM_HOST_DEVICE static NormalEvaluation evaluate(const ContactParams& p, const NormalHistory& history,
                                                         double overlap) {
    return NormalEvaluation{pohrtPopovElasticForce(p.pohrtPopov, overlap),
                            pohrtPopovElasticStiffness(p.pohrtPopov, overlap), history};
  }
};

struct PohrtPopovPlasticNormalModel {
  static constexpr SubModelInfo info{"pohrt_popov_plastic",
                                     SubModelKind::Normal,
                                     "PohrtPopov.hpp: pohrtPopovElastoPlasticForce",
                                     "E* [Pa], R* [m], D_f [-], h (rms roughness) [m]",
                                     "maxNormalForce F_max [N], plasticOverlap delta_p [m]",
                                     "Tolomeo & McDowell 2022 eq. 6, written in overlap",
                                     "TestPohrtPopov.cpp"};
  static constexpr int historySlots = 2;
  RAILCOSIM_HOST_DEVICE static void prepare(ContactParams& p) { preparePohrtPopov(p); }
  RAILCOSIM_HOST_DEVICE static NormalEvaluation evaluate(const ContactParams& p, const NormalHistory& history,
                                                         double overlap) {
    const PlasticNormalResult plastic =
        pohrtPopovElastoPlasticForce(p.pohrtPopov, overlap, history.maxNormalForce, history.plasticOverlap);
    return NormalEvaluation{plastic.force, plastic.stiffness,
                            NormalHistory{plastic.maxNormalForce, plastic.plasticOverlap},
                            plastic.virginLoading};
  }
};

struct ViscousRestitutionDampingModel {
  static constexpr SubModelInfo info{
      "viscous_restitution",
      SubModelKind::Damping,
      "HertzMindlin.hpp: dampingRatioFromRestitution, viscousDampingCoefficient",
      "e (restitution) [-] -> gamma [-], m* [kg], current tangent stiffness [N/m]",
      "none",
      "Irazábal 2017 eqs. 3.14-3.15, 3.26b; gamma(e) fit of Thornton, Cummins & Cleary 2013 for Hertz",
      "TestHertzMindlin.cpp"};
  RAILCOSIM_HOST_DEVICE static double coefficient(const ContactParams& p, double stiffness) {
    return viscousDampingCoefficient(p.hertzMindlin.dampingRatio, p.hertzMindlin.effectiveMass, stiffness);
  }
};

struct MindlinTangentialModel {
  static constexpr SubModelInfo info{"mindlin_incremental",
                                     SubModelKind::Tangential,
                                     "HertzMindlin.hpp: mindlinTangentialStiffness, incrementalTangentialForce",
                                     "G* [Pa], R* [m], gamma [-], m* [kg], mu [-]",
                                     "elasticShearForce F_te [N] (3), previous k_t [N/m]",
                                     "Irazábal 2017 eqs. 3.20-3.24, 3.25b",
                                     "TestHertzMindlin.cpp"};
  RAILCOSIM_HOST_DEVICE static double stiffness(const ContactParams& p, double overlap, const NormalEvaluation&) {
    return mindlinTangentialStiffness(p.hertzMindlin, overlap);
  }
};

struct StiffnessRatioTangentialModel {
  static constexpr SubModelInfo info{
      "stiffness_ratio",
      SubModelKind::Tangential,
      "PohrtPopov.hpp: tangentialToNormalStiffnessRatio; HertzMindlin.hpp: incrementalTangentialForce",
      "nu [-] -> k_t/k_n [-], gamma [-], m* [kg], mu [-]",
      "elasticShearForce F_te [N] (3), previous k_t [N/m]",
      "Tolomeo & McDowell 2022 eq. 7",
      "TestPohrtPopov.cpp"};
  RAILCOSIM_HOST_DEVICE static double stiffness(const ContactParams& p, double, const NormalEvaluation& normal) {
    return p.tangentialStiffnessRatio * normal.stiffness;
  }
};

struct CoulombFrictionModel {
  static constexpr SubModelInfo info{"coulomb",
                                     SubModelKind::FrictionCoefficient,
                                     "ContactLaw.hpp: contactLawForces (Coulomb cap of incrementalTangentialForce)",
                                     "mu0 [-]",
                                     "none",
                                     "Irazábal 2017 eq. 3.24",
                                     "TestContactLaw.cpp"};
  RAILCOSIM_HOST_DEVICE static double coefficient(const ContactParams& p, double, double) {
    return p.friction.baseFrictionCoefficient;
  }
};

struct StressDependentFrictionModel {
  static constexpr SubModelInfo info{"stress_dependent",
                                     SubModelKind::FrictionCoefficient,
                                     "StressDependentFriction.hpp: stressDependentFrictionCoefficient",
                                     "mu0 [-], gamma_mu (exponent, <= 0) [-], sigma_c,max [Pa]",
                                     "none",
                                     "Irazábal 2017 eqs. 6.3-6.9 (clusters of different particles only)",
                                     "TestStressDependentFriction.cpp"};
  RAILCOSIM_HOST_DEVICE static double coefficient(const ContactParams& p, double overlap, double normalForce) {
    return stressDependentFrictionCoefficient(p.friction, p.hertzMindlin.effectiveRadius, overlap, normalForce);
  }
};

struct NoRollingModel {
  static constexpr SubModelInfo info{"none",
                                     SubModelKind::Rolling,
                                     "ContactLaw.hpp: contactLawForces (zero rolling arm)",
                                     "none",
                                     "none",
                                     "no rolling resistance: bodies that are not spheres (clusters, polyhedra)",
                                     "TestContactLaw.cpp"};
  RAILCOSIM_HOST_DEVICE static double arm(const ContactParams&) { return 0.0; }
};

struct BoundedRollingFrictionModel {
  static constexpr SubModelInfo info{
      "brof",
      SubModelKind::Rolling,
      "BoundedRollingFriction.hpp: rollingResistanceArm, boundedRollingTorque",
      "eta_r [-] (particle-particle and particle-wall values), R1, R2 [m], I [kg m^2], h [s]",
      "none per contact; per particle the summed budget M_r [N m] of the current step",
      "Irazábal 2017 eqs. 5.2-5.5 with eq. 5.4 corrected (I w/h + sum r x F)",
      "TestBoundedRollingFriction.cpp"};
  RAILCOSIM_HOST_DEVICE static double arm(const ContactParams& p) {
    return rollingResistanceArm(BoundedRollingFrictionParams{p.rollingFrictionCoefficient},
                                p.hertzMindlin.effectiveRadius);
  }
};

struct RayleighTimeStepModel {
  static constexpr SubModelInfo info{"rayleigh",
                                     SubModelKind::TimeStep,
                                     "CriticalTimeStep.hpp: rayleighTimeStep",
                                     "R [m], rho [kg/m^3], G [Pa], nu [-]",
                                     "none",
                                     "O'Sullivan & Bray 2004",
                                     "TestCriticalTimeStep.cpp"};
};

struct ContactOscillatorTimeStepModel {
  static constexpr SubModelInfo info{"contact_oscillator",
                                     SubModelKind::TimeStep,
                                     "CriticalTimeStep.hpp: springCriticalTimeStep, hertzCriticalTimeStep, hertzCriticalTimeStepAtForce",
                                     "m* [kg], k [N/m], gamma [-], impact speed [m/s] or contact force [N]",
                                     "none",
                                     "Belytschko, Liu & Moran 2000 (central-difference stability with damping)",
                                     "TestCriticalTimeStep.cpp"};
};

// ---------------------------------------------------------------------------------------------------
// The table: one list of rows per kind. A row's index in its list is the number ContactLawConfig stores.
// Adding a sub-model: its kernel, its row above, its name in the list of its kind, one analytic test and one line
// in docs/contact-models.md (TestSubModelRegistry checks that the docs and the test files name every row).
// ---------------------------------------------------------------------------------------------------
template <class... Rows>
struct SubModelList {
  static constexpr int size = static_cast<int>(sizeof...(Rows));
};

using NormalModels = SubModelList<HertzNormalModel, PohrtPopovNormalModel, PohrtPopovPlasticNormalModel>;
using DampingModels = SubModelList<ViscousRestitutionDampingModel>;
using TangentialModels = SubModelList<MindlinTangentialModel, StiffnessRatioTangentialModel>;
using FrictionModels = SubModelList<CoulombFrictionModel, StressDependentFrictionModel>;
using RollingModels = SubModelList<NoRollingModel, BoundedRollingFrictionModel>;
using TimeStepModels = SubModelList<RayleighTimeStepModel, ContactOscillatorTimeStepModel>;

template <class... Rows>
constexpr bool allOfKind(SubModelList<Rows...>, SubModelKind kind) {
  return ((Rows::info.kind == kind) && ...);
}
static_assert(allOfKind(NormalModels{}, SubModelKind::Normal), "a row of NormalModels is not a normal model");
static_assert(allOfKind(DampingModels{}, SubModelKind::Damping), "a row of DampingModels is not a damping model");
static_assert(allOfKind(TangentialModels{}, SubModelKind::Tangential), "a row of TangentialModels is misfiled");
static_assert(allOfKind(FrictionModels{}, SubModelKind::FrictionCoefficient), "a row of FrictionModels is misfiled");
static_assert(allOfKind(RollingModels{}, SubModelKind::Rolling), "a row of RollingModels is misfiled");
static_assert(allOfKind(TimeStepModels{}, SubModelKind::TimeStep), "a row of TimeStepModels is misfiled");

namespace detail {
template <int Index, class Row, class... Rest, class Visitor>
RAILCOSIM_HOST_DEVICE inline auto visitRow(int index, Visitor& visitor) {
  if constexpr (sizeof...(Rest) == 0) {
    return visitor(Row{}); // the last row; indices are checked when the configuration is made
  } else {
    if (index == Index) return visitor(Row{});
    return visitRow<Index + 1, Rest...>(index, visitor);
  }
}
} // namespace detail

// Calls visitor(Row{}) for the row at `index` of a list. The compiler unrolls the list into a chain of compares, so
// host and device code reach the selected row's functions inline: no function pointer (which a device cannot call
// across the host boundary), no virtual call, no hand-written switch beside the table.
template <class... Rows, class Visitor>
RAILCOSIM_HOST_DEVICE inline auto visitSubModel(SubModelList<Rows...>, int index, Visitor&& visitor) {
  return detail::visitRow<0, Rows...>(index, visitor);
}

// Index of the row with this keyword in a list, or −1. Host only (set-up time).
template <class... Rows>
inline int findSubModel(SubModelList<Rows...>, const char* keyword) {
  const char* const keywords[] = {Rows::info.keyword...};
  for (int i = 0; i < static_cast<int>(sizeof...(Rows)); ++i)
    if (std::strcmp(keywords[i], keyword) == 0) return i;
  return -1;
}

// Index of a row type in a list, at compile time (−1 if absent).
template <class Row, class... Rows>
constexpr int subModelIndex(SubModelList<Rows...>) {
  constexpr bool match[] = {std::is_same_v<Row, Rows>...};
  for (int i = 0; i < static_cast<int>(sizeof...(Rows)); ++i)
    if (match[i]) return i;
  return -1;
}

namespace detail {
template <class... Lists>
struct JoinedLists;
template <class List>
struct JoinedLists<List> {
  using type = List;
};
template <class... A, class... B, class... Rest>
struct JoinedLists<SubModelList<A...>, SubModelList<B...>, Rest...> {
  using type = typename JoinedLists<SubModelList<A..., B...>, Rest...>::type;
};
template <class... Rows>
constexpr std::array<SubModelInfo, sizeof...(Rows)> infoTable(SubModelList<Rows...>) {
  return {{Rows::info...}};
}
} // namespace detail

using AllSubModels = detail::JoinedLists<NormalModels, DampingModels, TangentialModels, FrictionModels, RollingModels,
                                         TimeStepModels>::type;

// Every row's documentation, generated from the lists above (docs and tests iterate over it).
inline constexpr auto subModelRegistry = detail::infoTable(AllSubModels{});
inline constexpr std::size_t subModelCount = subModelRegistry.size();

inline const char* toString(SubModelKind kind) {
  switch (kind) {
    case SubModelKind::Normal:
      return "normal";
    case SubModelKind::Damping:
      return "damping";
    case SubModelKind::Tangential:
      return "tangential";
    case SubModelKind::FrictionCoefficient:
      return "friction";
    case SubModelKind::Rolling:
      return "rolling";
    case SubModelKind::TimeStep:
      return "timestep";
  }
  return "unknown";
}

} // namespace railcosim::kernels
