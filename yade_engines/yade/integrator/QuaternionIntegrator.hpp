// YADE engine QuaternionIntegrator: drop-in NewtonIntegrator replacement with the ZvW/RK4/direct rotation kernels.
#pragma once

#include <pkg/dem/NewtonIntegrator.hpp>

#include <string>
#include <vector>

#include "kernels/RotationIntegrators.hpp"

namespace railcosim {
class StateWriter;
class StateReader;
} // namespace railcosim

namespace yade {

/*! Velocity Verlet for translation and a predict/correct quaternion scheme for rotation (Irazábal 2017 §5.3).

YADE calls engines once per step after the contact forces F^n of configuration n are known, so one call does
the corrector of the previous step (second half kick, angular velocity at n) and the predictor of the next
(first half kick, drift, orientation q^{n+1}); between calls State::vel and State::angVel hold mid-step values,
as with NewtonIntegrator. Derives from NewtonIntegrator only so that InsertionSortCollider finds the maximum
displacement it needs; NewtonIntegrator's own rotation options (exactAsphericalRot, rotAlgorithm, ...) are
ignored. Periodic cells are not supported.
*/
class QuaternionIntegrator : public NewtonIntegrator {
public:
  // Per-body data that must survive from one call (predict) to the next (correct).
  struct BodySlot {
    bool predicted = false;
    Real timeStep = 0;
    railcosim::kernels::RotationState rotation{};
    Vector3r writtenPos{Vector3r::Zero()};
    Vector3r writtenVel{Vector3r::Zero()};
    Vector3r writtenAngVel{Vector3r::Zero()};
    Quaternionr writtenOri{Quaternionr::Identity()};
  };
  /// The per-body slots: what an engine that rolls the scene back to an earlier step (FemCouplingEngine, implicit
  /// scheme) saves and restores with the body states, so that the first step after a rollback is the corrector of
  /// the step before it, as in an uninterrupted run (restored body states alone would restart each body's scheme).
  std::vector<BodySlot> integrationState() const { return slots; }
  void restoreIntegrationState(std::vector<BodySlot> state) { slots = std::move(state); }
  /// The slots as a section of a state stream (restart checkpoints; FemCouplingEngine keeps a window's saved slots).
  static void writeSlots(railcosim::StateWriter& state, const std::vector<BodySlot>& bodySlots);
  static std::vector<BodySlot> readSlots(railcosim::StateReader& state);
  void action() override;

private:
  std::vector<BodySlot> slots;

  void integrateBody(const shared_ptr<Body>& b, railcosim::kernels::RotationScheme rotationScheme);

public:
  /// Restart checkpoints (railcosim.dem.CoupledDem): the per-body half-step data above, which no attribute holds;
  /// without it the first step after a restart would start every body afresh instead of correcting its last step.
  boost::python::object restartState() const;
  void restoreRestartState(const boost::python::object& state);
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS_CTOR_PY(QuaternionIntegrator,NewtonIntegrator,"Integrates the motion of spheres, clumps (sphere clusters) and facets like :yref:`NewtonIntegrator`, with velocity Verlet for translation and, for :yref:`aspherical<Body.aspherical>` bodies with free rotation, the Zhao–van Wachem quaternion predictor–corrector (default), quaternion RK4 with angular momentum as state, or the direct scheme (comparison only) — Irazábal 2017, §5.3.2. Bodies with any rotational DOF blocked, and non-aspherical bodies, rotate with the velocity-Verlet update of spheres. Clump forces and torques are assembled from members (eqs. 5.9–5.10), member torques (e.g. rolling friction) included. Attributes inherited from NewtonIntegrator other than gravity, damping, mask and kinSplit are not used.",
		((std::string,scheme,"zhaoVanWachem",,"Rotation scheme for aspherical bodies: ``'zhaoVanWachem'`` (recommended), ``'rk4'`` or ``'direct'`` (inaccurate; for comparison only)."))
		,
		/*ctor*/ damping = 0;
		,
		/*py*/
		.def("restartState", &QuaternionIntegrator::restartState, "The per-body half-step state (bytes) that no attribute holds, for a restart checkpoint.")
		.def("restoreRestartState", &QuaternionIntegrator::restoreRestartState, (py::arg("state")), "Put back what restartState() returned, in a rebuilt scene resumed from a restart checkpoint.")
	);
  // clang-format on
};
REGISTER_SERIALIZABLE(QuaternionIntegrator);

} // namespace yade
