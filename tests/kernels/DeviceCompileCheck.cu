// Compile-only check that every kernel header is usable from CUDA device code (run by nvcc in CTest).
#include "kernels/BoundedRollingFriction.hpp"
#include "kernels/ContactLaw.hpp"
#include "kernels/CriticalTimeStep.hpp"
#include "kernels/HertzMindlin.hpp"
#include "kernels/PohrtPopov.hpp"
#include "kernels/StressDependentFriction.hpp"
#include "kernels/SubModelRegistry.hpp"
#include "railcosim/TriangleGeometry.hpp"

using namespace railcosim::kernels;

// The law arrives as a kernel argument, configured on the host (every row of every kind is instantiated for the
// device by the composition's dispatch).
__global__ void evaluateEveryKernel(ContactLaw law, double* out) {
  const HertzMindlinParams hertz{effectiveYoungModulus(1e9, 0.3, 1e9, 0.3),
                                 effectiveShearModulus(shearModulus(1e9, 0.3), 0.3, shearModulus(1e9, 0.3), 0.3),
                                 effectiveRadius(0.01, 0.01), effectiveMass(1.0, 1.0),
                                 dampingRatioFromRestitution(0.5)};
  setContactGeometry(law, 0.01, 0.01, 1.0, 1.0);
  const ContactLawResult r = contactLawForces(
      law, ContactHistory{}, ContactKinematics{1e-5, 0.0, Vec3{0, 0, 1}, Vec3{1e-7, 0, 0}, Vec3{0, 0, 0}});
  const Vec3 rolling =
      boundedRollingTorque(Vec3{1, 0, 0}, 1.0, 1e-5, Vec3{0, 0, 0},
                           rollingResistanceMoment(rollingResistanceArm({0.2}, 0.01, 0.01), r.normalForce));
  const TangentialForceResult t = mindlinTangentialForce(hertz, Vec3{0, 0, 0}, Vec3{0, 0, 1}, 1e-5, 1.1e-5,
                                                         Vec3{1e-7, 0, 0}, Vec3{0, 0, 0}, 0.5, 1.0);
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0}, p{0.2, 0.3, 0.5};
  const railcosim::BarycentricWeights w = railcosim::closestPointWeights(p, a, b, c);
  out[threadIdx.x] =
      r.normalForce + norm(r.shearForce) + rolling.x + t.force.x + hertzCriticalTimeStep(hertz, 1.0) +
      rayleighTimeStep(0.01, 2600.0, 1e9, 0.25) + maxContactStressFromParticleWeight(1e-5, 2600.0, 9.81, 1e9, 0.005) +
      hertzNormalForce(hertz, 1e-5, 0.1) + normalHistorySlots(law.config) + rollingArm(law) + w[1] +
      railcosim::lumpedShare(w, Vec3{0, 0, 1}, 2).z + railcosim::planeWeights(p, a, b, c, Vec3{0, 0, 1})[0];
}
