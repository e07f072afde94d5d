// YADE ballast contact classes: material validation, Ip2 parameter mixing, and the gather → kernels → scatter Law2.
#include "BallastContact.hpp"

#include <core/Scene.hpp>
#include <pkg/common/Sphere.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace yade {

YADE_PLUGIN((BallastMat)(BallastPhys)(Ip2_BallastMat_BallastMat_BallastPhys)(Law2_ScGeom_BallastPhys_Ballast));

namespace {
namespace kernels = railcosim::kernels;

kernels::Vec3 toKernel(const Vector3r& v) { return kernels::Vec3{double(v[0]), double(v[1]), double(v[2])}; }
Vector3r fromKernel(const kernels::Vec3& v) { return Vector3r(v.x, v.y, v.z); }

const double infinity = std::numeric_limits<double>::infinity();

// Spheres contribute their radius; any other shape (wall, facet, box) is a flat surface.
double contactRadius(const Body& body) {
  const auto* sphere = dynamic_cast<const Sphere*>(body.shape.get());
  return sphere ? double(sphere->radius) : infinity;
}

// Translational inertia seen by the contact: a clump member moves with its whole clump.
double contactMass(const Body& body, const Scene* scene) {
  if (!body.isDynamic()) return infinity;
  if (body.isClumpMember()) {
    const shared_ptr<Body>& clump = Body::byId(body.clumpId, const_cast<Scene*>(scene));
    if (clump && clump->state->mass > 0) return double(clump->state->mass);
  }
  return body.state->mass > 0 ? double(body.state->mass) : infinity;
}
} // namespace

// Every attribute is checked here, on the Python side of the simulation, so that the parallel interaction
// loop never meets an invalid material (an exception there cannot be reported cleanly).
void BallastMat::postLoad(BallastMat&) {
  std::ostringstream problem;
  if (!(restitution >= 0 && restitution <= 1))
    problem << "restitution must be in [0, 1], got " << restitution;
  else if (!(rollingFriction >= 0))
    problem << "rollingFriction (η_r [-]) must be >= 0, got " << rollingFriction;
  else if (!(roughnessRms >= 0))
    problem << "roughnessRms [m] must be >= 0 (0 = smooth Hertz), got " << roughnessRms;
  else if (roughnessRms > 0 && !(roughnessFractalDim >= 2 && roughnessFractalDim < 3))
    problem << "roughnessFractalDim must be in [2, 3) when roughnessRms > 0, got " << roughnessFractalDim;
  else if (plasticUnloading && !(roughnessRms > 0))
    problem << "plasticUnloading needs a rough surface: set roughnessRms [m] > 0 and roughnessFractalDim";
  else if (!(frictionExponent <= 0))
    problem << "frictionExponent must be <= 0 (friction falls with stress), got " << frictionExponent;
  else if (!(maxContactStress >= 0))
    problem << "maxContactStress [Pa] must be >= 0 (0 disables it), got " << maxContactStress;
  else if (!(young > 0) || !(poisson > -1 && poisson < 0.5))
    problem << "young [Pa] must be > 0 and poisson in (-1, 0.5), got young=" << young << ", poisson=" << poisson;
  else
    return;
  throw std::invalid_argument("BallastMat '" + label + "': " + problem.str());
}

kernels::BallastContactParams BallastPhys::kernelParams() {
  kernels::BallastContactParams p{};
  p.normalModel = static_cast<kernels::NormalModel>(normalModel);
  p.hertzMindlin = kernels::HertzMindlinParams{double(effectiveYoungModulus), double(effectiveShearModulus),
                                               double(effectiveRadius), double(effectiveMass), double(dampingRatio)};
  if (normalModel != int(kernels::NormalModel::Hertz) && !pohrtPopovReady) {
    pohrtPopovCache = kernels::makePohrtPopovParams(double(effectiveYoungModulus), double(effectiveRadius),
                                                    double(fractalDimension), double(roughnessRms));
    pohrtPopovReady = true;
  }
  p.pohrtPopov = pohrtPopovCache;
  p.tangentialStiffnessRatio = double(tangentialStiffnessRatio);
  p.friction = kernels::StressDependentFrictionParams{double(tangensOfFrictionAngle), double(frictionExponent),
                                                      double(maxContactStress)};
  p.stressDependentFriction = stressDependentFriction;
  return p;
}

void Ip2_BallastMat_BallastMat_BallastPhys::go(const shared_ptr<Material>& material1,
                                               const shared_ptr<Material>& material2,
                                               const shared_ptr<Interaction>& interaction) {
  if (interaction->phys) return;
  const auto& mat1 = YADE_PTR_CAST<BallastMat>(material1);
  const auto& mat2 = YADE_PTR_CAST<BallastMat>(material2);
  const Body& body1 = *Body::byId(interaction->getId1(), scene);
  const Body& body2 = *Body::byId(interaction->getId2(), scene);

  auto phys = shared_ptr<BallastPhys>(new BallastPhys());
  // Equivalent properties, Irazábal eq. 3.27 (walls: infinite radius and mass).
  const double radius1 = contactRadius(body1);
  const double radius2 = contactRadius(body2);
  const double shear1 = kernels::shearModulus(mat1->young, mat1->poisson);
  const double shear2 = kernels::shearModulus(mat2->young, mat2->poisson);
  phys->effectiveYoungModulus = kernels::effectiveYoungModulus(mat1->young, mat1->poisson, mat2->young, mat2->poisson);
  phys->effectiveShearModulus = kernels::effectiveShearModulus(shear1, mat1->poisson, shear2, mat2->poisson);
  phys->effectiveRadius = kernels::effectiveRadius(radius1, radius2);
  phys->effectiveMass = kernels::effectiveMass(contactMass(body1, scene), contactMass(body2, scene));
  // Two non-dynamic bodies (e.g. a prescribed-motion test) have no dynamics to damp: m* = 0 → no dashpot.
  if (!std::isfinite(double(phys->effectiveMass))) phys->effectiveMass = 0;
  // γ_eq = (γ1 + γ2)/2 (eq. 3.27e), each from its material's restitution.
  phys->dampingRatio = 0.5 * (kernels::dampingRatioFromRestitution(mat1->restitution) +
                              kernels::dampingRatioFromRestitution(mat2->restitution));
  phys->tangensOfFrictionAngle = math::tan(math::min(mat1->frictionAngle, mat2->frictionAngle));
  phys->frictionCoeff = phys->tangensOfFrictionAngle;

  // Normal law: rough if either surface is rough (means over the rough ones), plastic if either asks.
  const int roughCount = int(mat1->roughnessRms > 0) + int(mat2->roughnessRms > 0);
  if (roughCount > 0) {
    phys->roughnessRms = (mat1->roughnessRms + mat2->roughnessRms) / roughCount;
    phys->fractalDimension = ((mat1->roughnessRms > 0 ? mat1->roughnessFractalDim : 0) +
                              (mat2->roughnessRms > 0 ? mat2->roughnessFractalDim : 0)) /
                             roughCount;
    const bool plastic =
        (mat1->plasticUnloading && mat1->roughnessRms > 0) || (mat2->plasticUnloading && mat2->roughnessRms > 0);
    phys->normalModel =
        int(plastic ? kernels::NormalModel::PohrtPopovElastoPlastic : kernels::NormalModel::PohrtPopovElastic);
  } else {
    phys->normalModel = int(kernels::NormalModel::Hertz);
  }
  // k_s/k_n = 4G*/E*, which is Tolomeo & McDowell eq. 7 for like materials.
  phys->tangentialStiffnessRatio = 4.0 * phys->effectiveShearModulus / phys->effectiveYoungModulus;

  // Stress-dependent friction between members of different clusters only (Irazábal §6.3.4).
  phys->frictionExponent = 0.5 * (mat1->frictionExponent + mat2->frictionExponent);
  phys->maxContactStress = 0.5 * (mat1->maxContactStress + mat2->maxContactStress);
  phys->stressDependentFriction = body1.isClumpMember() && body2.isClumpMember() && body1.clumpId != body2.clumpId &&
                                  phys->frictionExponent < 0 && phys->maxContactStress > 0;

  // Rolling arm e_c = η_r R1R2/(R1+R2) (eqs. 5.2–5.3), η_r the larger of the two materials.
  phys->rollingArm = kernels::rollingResistanceArm(
      kernels::BoundedRollingFrictionParams{double(math::max(mat1->rollingFriction, mat2->rollingFriction))}, radius1,
      radius2);
  interaction->phys = phys;
}

bool Law2_ScGeom_BallastPhys_Ballast::go(shared_ptr<IGeom>& geometry, shared_ptr<IPhys>& physics,
                                         Interaction* interaction) {
  auto* geom = static_cast<ScGeom*>(geometry.get());
  auto* phys = static_cast<BallastPhys*>(physics.get());
  const Body::id_t id1 = interaction->getId1();
  const Body::id_t id2 = interaction->getId2();
  if (geom->penetrationDepth < 0) {
    if (!neverErase) return false;
    phys->normalForce = phys->shearForce = Vector3r::Zero();
    return true;
  }
  // Gather: kinematics of body 2 relative to body 1 at the contact point.
  const State* state1 = Body::byId(id1, scene)->state.get();
  const State* state2 = Body::byId(id2, scene)->state.get();
  const Vector3r shift2 =
      scene->isPeriodic ? Vector3r(scene->cell->hSize * interaction->cellDist.cast<Real>()) : Vector3r::Zero();
  const Vector3r shiftVel = scene->isPeriodic ? scene->cell->intrShiftVel(interaction->cellDist) : Vector3r::Zero();
  const Vector3r relativeVelocity =
      geom->getIncidentVel(state1, state2, scene->dt, shift2, shiftVel, /*avoidGranularRatcheting*/ false);
  const Vector3r& normal = geom->normal;
  geom->rotate(phys->elasticShearForce); // follow the contact frame as it turns (the kernel re-projects it)

  const railcosim::kernels::ContactKinematics kinematics{
      double(geom->penetrationDepth), double(-normal.dot(relativeVelocity)), toKernel(normal),
      toKernel(geom->shearIncrement()), toKernel(relativeVelocity - normal.dot(relativeVelocity) * normal)};
  const railcosim::kernels::BallastContactHistory history{toKernel(phys->elasticShearForce),
                                                          double(phys->previousShearStiffness),
                                                          double(phys->maxNormalForce), double(phys->plasticOverlap)};
  // Kernels.
  const railcosim::kernels::BallastContactResult result =
      railcosim::kernels::ballastContactForces(phys->kernelParams(), history, kinematics);

  // Scatter: forces on body 2 (+) and body 1 (−), stiffnesses for time steppers, history.
  phys->normalForce = result.normalForce * normal;
  phys->shearForce = fromKernel(result.shearForce);
  phys->kn = result.normalStiffness;
  phys->ks = result.tangentialStiffness;
  phys->frictionCoeff = result.frictionCoefficient;
  phys->isSliding = result.sliding;
  phys->elasticShearForce = fromKernel(result.history.elasticShearForce);
  phys->previousShearStiffness = result.history.previousTangentialStiffness;
  phys->maxNormalForce = result.history.maxNormalForce;
  phys->plasticOverlap = result.history.plasticOverlap;
  applyForceAtContactPoint(-phys->normalForce - phys->shearForce, geom->contactPoint, id1, state1->se3.position, id2,
                           state2->se3.position + shift2);
  return true;
}

} // namespace yade
