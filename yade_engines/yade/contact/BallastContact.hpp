// YADE classes of the ballast contact law: BallastMat, BallastPhys, their Ip2 and the thin Law2 over the kernels.
#pragma once

#include <core/Dispatching.hpp>
#include <pkg/common/ElastMat.hpp>
#include <pkg/dem/FrictPhys.hpp>
#include <pkg/dem/ScGeom.hpp>

#include "kernels/ContactLaw.hpp"

#include <string>

namespace yade {

/*! Ballast grain material: the contact law of kernels/ContactLaw.hpp (Hertz–Mindlin, or the rough-surface
Pohrt–Popov normal laws, stress-dependent friction between clusters, bounded rolling friction) with the sub-models
its attributes select. Equations: docs/contact-models.md. */
class BallastMat : public FrictMat {
public:
  virtual ~BallastMat() = default;
  void postLoad(BallastMat&);
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR(BallastMat,FrictMat,"Ballast grain material for :yref:`Law2_ScGeom_BallastPhys_Ballast` (railcosim). Inherits :yref:`young<ElastMat.young>` [Pa], :yref:`poisson<ElastMat.poisson>` [-], :yref:`density<Material.density>` [kg/m³] and :yref:`frictionAngle<FrictMat.frictionAngle>` [rad] (the contact uses tan of the smaller angle of the pair as μ0). Equations and sources: docs/contact-models.md.",
		((Real,restitution,0.5,Attr::triggerPostLoad,"Normal coefficient of restitution e [-], 0 ≤ e ≤ 1, turned into the Hertzian damping ratio of Thornton et al. (2013); the pair uses the mean of the two damping ratios (Irazábal eq. 3.27e)."))
		((Real,rollingFriction,0.0,Attr::triggerPostLoad,"Bounded rolling friction coefficient η_r [-] (dimensionless; rolling arm η_r·R1R2/(R1+R2)). The pair uses the larger value of the two materials, so a wall material with η_r = 1 stops grains rolling on it as in Irazábal §6.2. Applied by :yref:`BoundedRollingFrictionEngine` to spheres only."))
		((Real,roughnessFractalDim,0.0,Attr::triggerPostLoad,"Fractal dimension D_f [-] of the surface, 2 ≤ D_f < 3, used with :yref:`roughnessRms<BallastMat.roughnessRms>` > 0 (Pohrt–Popov law; Tolomeo & McDowell 2022 use 2.13)."))
		((Real,roughnessRms,0.0,Attr::triggerPostLoad,"Root-mean-square roughness h [m]; 0 selects the smooth Hertz normal law, > 0 the Pohrt–Popov rough-surface law (Tolomeo & McDowell 2022: 2.61e-5 m). If both materials are rough the pair uses the means of D_f and h."))
		((bool,plasticUnloading,false,Attr::triggerPostLoad,"Use the elasto-plastic Pohrt–Popov law (virgin loading rough, Hertzian unloading/reloading from the stored maximum, no tension) instead of the elastic one; needs roughnessRms > 0. Either material of the pair can request it."))
		((Real,frictionExponent,0.0,Attr::triggerPostLoad,"Exponent γ [-] ≤ 0 of the stress-dependent friction μ = μ0 (F_n/F_n,c)^γ (Irazábal §6.3.4: −0.15); 0 disables it. Applied only between members of different clumps; the pair uses the mean of the two materials."))
		((Real,maxContactStress,0.0,Attr::triggerPostLoad,"Critical peak contact pressure σ_c,max [Pa] of the stress-dependent friction (Irazábal: 5.17e6 Pa for E = 0.24 GPa); 0 disables it. The pair uses the mean of the two materials."))
		,
		createIndex();
	);
  // clang-format on
  REGISTER_CLASS_INDEX(BallastMat, FrictMat);
};
REGISTER_SERIALIZABLE(BallastMat);

/*! Per-contact parameters (set by the Ip2) and history (kept by the Law2) of the ballast contact law. */
class BallastPhys : public FrictPhys {
  // Derived Pohrt–Popov constants (A0, F(A0), ...) are rebuilt from the serialized inputs after loading.
  bool normalModelPrepared = false;
  railcosim::kernels::PohrtPopovParams pohrtPopovCache{};

public:
  virtual ~BallastPhys() = default;
  //! The contact law assembled from the attributes (prepares the normal model's constants on first use).
  railcosim::kernels::ContactLaw contactLaw();
  //! Stores a law made by the Ip2 in the attributes.
  void setContactLaw(const railcosim::kernels::ContactLaw& law);
  //! The selected sub-models' keywords.
  std::string contactLawKeywords() const;
  //! Former attribute, now derived from frictionModel (row 1 is ``stress_dependent``).
  bool stressDependentFriction() const { return frictionModel == 1; }
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(BallastPhys,FrictPhys,"Interaction physics of :yref:`Law2_ScGeom_BallastPhys_Ballast` (railcosim). Inherits :yref:`normalForce<NormShearPhys.normalForce>` and :yref:`shearForce<NormShearPhys.shearForce>` [N] (forces on body 2), :yref:`kn<NormPhys.kn>` and :yref:`ks<NormShearPhys.ks>` [N/m] (current tangent stiffnesses, used by time steppers) and :yref:`tangensOfFrictionAngle<FrictPhys.tangensOfFrictionAngle>` (μ0 [-]). The sub-models are rows of the contact-law registry (docs/contact-models.md); :yref:`contactLaw<BallastPhys.contactLaw>` names them.",
		((Real,frictionCoeff,0.0,,"Friction coefficient μ [-] used in the last step (μ0, or reduced by stress-dependent friction)."))
		((Real,maxNormalForce,0.0,,"Largest normal force F_max [N] reached (elasto-plastic Pohrt–Popov history)."))
		((Real,plasticOverlap,0.0,,"Plastic (permanent) overlap δ_p [m] (elasto-plastic Pohrt–Popov history)."))
		((Vector3r,elasticShearForce,Vector3r::Zero(),,"Elastic part of the tangential force [N] (history of the incremental tangential spring)."))
		((Real,previousShearStiffness,0.0,,"Tangential stiffness of the previous step [N/m] (history for the unloading correction)."))
		((bool,isSliding,false,,"Whether the Coulomb limit was reached in the last step."))
		((int,normalModel,0,,"Normal sub-model, index in the registry's normal rows: 0 ``hertz``, 1 ``pohrt_popov``, 2 ``pohrt_popov_plastic``."))
		((int,dampingModel,0,,"Damping sub-model, index in the registry's damping rows: 0 ``viscous_restitution``."))
		((int,tangentialModel,0,,"Tangential sub-model, index in the registry's tangential rows: 0 ``mindlin_incremental``, 1 ``stiffness_ratio``."))
		((int,frictionModel,0,,"Friction-coefficient sub-model, index in the registry's friction rows: 0 ``coulomb``, 1 ``stress_dependent`` (members of different clumps with frictionExponent < 0 and maxContactStress > 0)."))
		((int,rollingModel,0,,"Rolling sub-model, index in the registry's rolling rows: 0 ``none``, 1 ``brof``."))
		((Real,effectiveYoungModulus,0.0,,"E* [Pa] of the pair."))
		((Real,effectiveShearModulus,0.0,,"G* [Pa] of the pair."))
		((Real,effectiveRadius,0.0,,"R* [m] of the pair (a wall counts as infinite radius)."))
		((Real,effectiveMass,0.0,,"m* [kg] of the pair (clump members count with their clump's mass, a non-dynamic body as infinite mass; 0 if both are non-dynamic, which disables the dashpot)."))
		((Real,dampingRatio,0.0,,"Viscous damping ratio γ [-] (fraction of critical)."))
		((Real,fractalDimension,0.0,,"D_f [-] of the pair (Pohrt–Popov laws)."))
		((Real,roughnessRms,0.0,,"h [m] of the pair (Pohrt–Popov laws)."))
		((Real,tangentialStiffnessRatio,0.0,,"k_s/k_n [-] for the ``stiffness_ratio`` tangential model (4G*/E*, = 2(1−ν)/(2−ν) for like materials)."))
		((Real,frictionExponent,0.0,,"Exponent γ [-] of the stress-dependent friction."))
		((Real,maxContactStress,0.0,,"σ_c,max [Pa] of the stress-dependent friction."))
		((Real,rollingFriction,0.0,,"Bounded rolling friction coefficient η_r [-] of the pair (the larger of the two materials)."))
		((Real,rollingArm,0.0,,"Rolling-resistance arm e_c = η_r R1R2/(R1+R2) [m] (0 unless the ``brof`` rolling model is selected)."))
		((Real,rollingResistance,0.0,,"This contact's share e_c |F_n| [N m] of each body's rolling-resistance budget in the last step (summed by :yref:`BoundedRollingFrictionEngine`)."))
		,
		createIndex();
		,
		.add_property("contactLaw",&BallastPhys::contactLawKeywords,"Keywords of the selected sub-models: normal + damping + tangential + friction + rolling (read-only).")
		.add_property("stressDependentFriction",&BallastPhys::stressDependentFriction,"Whether stress-dependent friction applies (read-only; kept for scripts written before :yref:`frictionModel<BallastPhys.frictionModel>`, which it reads: ``frictionModel == 1``).")
	);
  // clang-format on
  REGISTER_CLASS_INDEX(BallastPhys, FrictPhys);
};
REGISTER_SERIALIZABLE(BallastPhys);

//! The contact properties of a body's material for the contact law: every attribute of a BallastMat; for a plain
//! FrictMat its moduli and friction, with restitution 1 (no dashpot) unless the caller sets another. Throws
//! std::invalid_argument naming `owner` for any other material.
railcosim::kernels::ContactMaterial contactMaterialOf(const Material& material, const std::string& owner);

class Ip2_BallastMat_BallastMat_BallastPhys : public IPhysFunctor {
public:
  void go(const shared_ptr<Material>& material1, const shared_ptr<Material>& material2,
          const shared_ptr<Interaction>& interaction) override;
  void postLoad(Ip2_BallastMat_BallastMat_BallastPhys&);
  FUNCTOR2D(BallastMat, BallastMat);
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS(Ip2_BallastMat_BallastMat_BallastPhys,IPhysFunctor,"Creates :yref:`BallastPhys` from two :yref:`BallastMat` (railcosim) with the contact law's one mixing rule (docs/contact-models.md): equivalent properties (Irazábal eq. 3.27; spheres use their radius, other shapes count as flat walls; clump members use their clump's mass), damping ratio from restitution, the normal sub-model from the roughness attributes, μ0 = tan(min friction angle), stress-dependent friction for members of different clumps, and bounded rolling friction.",
		((Real,fixedEffectiveRadius,0.0,Attr::triggerPostLoad,"R* [m] given to every contact instead of R1R2/(R1+R2) when > 0 (0: from the bodies). For studies of a paper that gives one contact radius for all contacts of its clumps, e.g. Tolomeo & McDowell 2022 Table 1, R* = 2.36 mm."))
	);
  // clang-format on
};
REGISTER_SERIALIZABLE(Ip2_BallastMat_BallastMat_BallastPhys);

class Law2_ScGeom_BallastPhys_Ballast : public LawFunctor {
public:
  bool go(shared_ptr<IGeom>& geometry, shared_ptr<IPhys>& physics, Interaction* interaction) override;
  FUNCTOR2D(ScGeom, BallastPhys);
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS(Law2_ScGeom_BallastPhys_Ballast,LawFunctor,"Ballast contact law (railcosim): gathers the contact kinematics from :yref:`ScGeom`, evaluates the composed contact law of the header-only kernels with the sub-models its :yref:`BallastPhys` selects (normal law + viscous damping + incremental tangential force with unloading correction + Coulomb cap with constant or stress-dependent μ + the rolling-resistance budget; docs/contact-models.md) and applies the forces. No attractive normal force.",
		((bool,neverErase,false,,"Keep interactions whose overlap became negative (forces set to zero) instead of erasing them, e.g. when another law still needs them."))
	);
  // clang-format on
};
REGISTER_SERIALIZABLE(Law2_ScGeom_BallastPhys_Ballast);

} // namespace yade
