// The one table of contact sub-models: keyword, kind, parameters with units, history, source, test.
#pragma once

#include <cstddef>

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

// Adding a sub-model: its kernel, one row here, one analytic test, one entry in docs/contact-models.md
// (TestSubModelRegistry checks that the docs and the test files name every row).
inline constexpr SubModelInfo subModelRegistry[] = {
    {"hertz", SubModelKind::Normal, "HertzMindlin.hpp: hertzElasticNormalForce, hertzNormalStiffness",
     "E* [Pa], R* [m]", "none", "Irazábal 2017 eqs. 3.13, 3.25a, 3.27 (Thornton's simplification)",
     "TestHertzMindlin.cpp"},
    {"pohrt_popov", SubModelKind::Normal, "PohrtPopov.hpp: pohrtPopovElasticForce, pohrtPopovElasticStiffness",
     "E* [Pa], R* [m], D_f [-], h (rms roughness) [m]", "none",
     "Tolomeo & McDowell 2022 eqs. 1-5 (eq. 5 exponent corrected), closed form from F = 0", "TestPohrtPopov.cpp"},
    {"pohrt_popov_plastic", SubModelKind::Normal, "PohrtPopov.hpp: pohrtPopovElastoPlasticForce",
     "E* [Pa], R* [m], D_f [-], h (rms roughness) [m]", "maxNormalForce F_max [N], plasticOverlap delta_p [m]",
     "Tolomeo & McDowell 2022 eq. 6, written in overlap", "TestPohrtPopov.cpp"},
    {"viscous_restitution", SubModelKind::Damping,
     "HertzMindlin.hpp: dampingRatioFromRestitution, viscousDampingCoefficient, hertzNormalForce",
     "e (restitution) [-] -> gamma [-], m* [kg], current tangent stiffness [N/m]", "none",
     "Irazábal 2017 eqs. 3.14-3.15, 3.26b; gamma(e) fit of Thornton, Cummins & Cleary 2013 for Hertz",
     "TestHertzMindlin.cpp"},
    {"mindlin_incremental", SubModelKind::Tangential, "HertzMindlin.hpp: mindlinTangentialForce",
     "G* [Pa], R* [m], gamma [-], m* [kg], mu [-]",
     "elasticShearForce F_te [N] (3), previous k_t [N/m] or previous overlap [m]",
     "Irazábal 2017 eqs. 3.20-3.24, 3.25b", "TestHertzMindlin.cpp"},
    {"stiffness_ratio", SubModelKind::Tangential,
     "PohrtPopov.hpp: tangentialToNormalStiffnessRatio; HertzMindlin.hpp: incrementalTangentialForce",
     "nu [-] -> k_t/k_n [-], gamma [-], m* [kg], mu [-]", "elasticShearForce F_te [N] (3), previous k_t [N/m]",
     "Tolomeo & McDowell 2022 eq. 7", "TestPohrtPopov.cpp"},
    {"coulomb", SubModelKind::FrictionCoefficient, "BallastContact.hpp: ballastContactForces", "mu0 [-]", "none",
     "Irazábal 2017 eq. 3.24", "TestBallastContact.cpp"},
    {"stress_dependent", SubModelKind::FrictionCoefficient,
     "StressDependentFriction.hpp: stressDependentFrictionCoefficient",
     "mu0 [-], gamma_mu (exponent, <= 0) [-], sigma_c,max [Pa]", "none",
     "Irazábal 2017 eqs. 6.3-6.9 (clusters of different particles only)", "TestStressDependentFriction.cpp"},
    {"brof", SubModelKind::Rolling, "BoundedRollingFriction.hpp: rollingResistanceArm, boundedRollingTorque",
     "eta_r [-] (particle-particle and particle-wall values), R1, R2 [m], I [kg m^2], h [s]",
     "none per contact; per particle the summed budget M_r [N m] of the current step",
     "Irazábal 2017 eqs. 5.2-5.5 with eq. 5.4 corrected (I w/h + sum r x F)", "TestBoundedRollingFriction.cpp"},
    {"rayleigh", SubModelKind::TimeStep, "CriticalTimeStep.hpp: rayleighTimeStep",
     "R [m], rho [kg/m^3], G [Pa], nu [-]", "none", "O'Sullivan & Bray 2004", "TestCriticalTimeStep.cpp"},
    {"contact_oscillator", SubModelKind::TimeStep,
     "CriticalTimeStep.hpp: springCriticalTimeStep, hertzCriticalTimeStep",
     "m* [kg], k [N/m], gamma [-], impact speed [m/s]", "none",
     "Belytschko, Liu & Moran 2000 (central-difference stability with damping)", "TestCriticalTimeStep.cpp"},
};

inline constexpr std::size_t subModelCount = sizeof(subModelRegistry) / sizeof(subModelRegistry[0]);

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
