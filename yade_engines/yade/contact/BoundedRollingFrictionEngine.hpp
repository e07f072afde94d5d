// YADE engine applying bounded rolling friction (BROF) to spheres once all contact moments of the step are known.
#pragma once

#include <core/GlobalEngine.hpp>

namespace yade {

class BoundedRollingFrictionEngine : public GlobalEngine {
public:
  void action() override;
  // clang-format off
	YADE_CLASS_BASE_DOC_ATTRS(BoundedRollingFrictionEngine,GlobalEngine,"Bounded rolling friction (BROF, Irazábal 2017 §5.2.1 with eq. 5.4 corrected; railcosim). For every dynamic, standalone sphere it sums the rolling-resistance budget M_r = Σ e_c |F_n| [N m] over its :yref:`BallastPhys` contacts (each contact's :yref:`rollingResistance<BallastPhys.rollingResistance>` = e_c |F_n| from the contact law, e_c = :yref:`rollingArm<BallastPhys.rollingArm>`) and adds one torque that opposes T_stop = I ω/Δt + T (T: the torque already accumulated this step): −M_r T_stop/|T_stop| if |T_stop| > M_r, otherwise −T_stop, which stops the spin in this step but never reverses it. Place it after :yref:`InteractionLoop` and right before the integrator, which must advance the stored angular velocity by Δt·T/I (:yref:`NewtonIntegrator`, or railcosim's QuaternionIntegrator for spheres) with damping = 0: Cundall damping would amplify the opposing torque and push a stopped spin past zero, so the engine refuses to run with it. Clumps and their members get no rolling friction (as in the thesis).",
		((Real,lastMaxBudget,0.0,Attr::readonly,"Largest rolling-resistance budget M_r [N m] of any sphere in the last step (diagnostic)."))
	);
  // clang-format on
};
REGISTER_SERIALIZABLE(BoundedRollingFrictionEngine);

} // namespace yade
