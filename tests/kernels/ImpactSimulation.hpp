// Test helper: head-on two-sphere impact integrated with the same leapfrog update as YADE's NewtonIntegrator.
#pragma once

#include <functional>

namespace railcosim::kernels::testing {

struct ImpactOutcome {
  double reboundSpeed;   // relative separation speed once the overlap is back to zero [m/s]
  double contactTime;    // time from first touch to separation [s]
  double maximumOverlap; // largest overlap reached [m]
};

// Relative (one-dimensional) motion of two bodies of effective mass m*: d²δ/dt² = −F(δ, dδ/dt)/m*.
// The force law is passed as a callable so the same integrator drives every normal model. Velocities
// live at half steps (leapfrog), and the force uses the latest known velocity, as in YADE.
inline ImpactOutcome simulateHeadOnImpact(double effectiveMass, double approachSpeed, double timeStep,
                                          const std::function<double(double, double)>& normalForce) {
  double overlap = 0.0;
  double overlapRate = approachSpeed;
  ImpactOutcome outcome{0.0, 0.0, 0.0};
  double time = 0.0;
  // a hard cap on steps keeps a wrong force law from hanging the test
  for (long step = 0; step < 100000000L; ++step) {
    const double force = overlap > 0.0 ? normalForce(overlap, overlapRate) : 0.0;
    overlapRate -= timeStep * force / effectiveMass;
    overlap += timeStep * overlapRate;
    time += timeStep;
    if (overlap > outcome.maximumOverlap) outcome.maximumOverlap = overlap;
    if (overlap <= 0.0 && overlapRate < 0.0) {
      // interpolate the crossing of δ = 0 inside the last step for the contact time
      outcome.contactTime = time - (-overlap / -overlapRate);
      outcome.reboundSpeed = -overlapRate;
      return outcome;
    }
  }
  return outcome;
}

} // namespace railcosim::kernels::testing
