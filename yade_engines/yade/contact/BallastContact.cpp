// YADE ballast contact classes: material validation, Ip2 through the contact law's mixing, and the gather → kernels →
// scatter Law2.
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

railcosim::kernels::ContactMaterial contactMaterialOf(const Material& material, const std::string& owner) {
  if (const auto* ballast = dynamic_cast<const BallastMat*>(&material)) {
    return kernels::ContactMaterial{double(ballast->young),
                                    double(ballast->poisson),
                                    double(ballast->restitution),
                                    double(math::tan(ballast->frictionAngle)),
                                    double(ballast->roughnessRms),
                                    double(ballast->roughnessFractalDim),
                                    ballast->plasticUnloading,
                                    double(ballast->frictionExponent),
                                    double(ballast->maxContactStress),
                                    double(ballast->rollingFriction)};
  }
  if (const auto* frict = dynamic_cast<const FrictMat*>(&material)) {
    return kernels::ContactMaterial{double(frict->young), double(frict->poisson), 1.0,
                                    double(math::tan(frict->frictionAngle))};
  }
  throw std::invalid_argument(owner + " needs a FrictMat or BallastMat material (moduli and friction), got a " +
                              material.getClassName());
}

// Every attribute is checked here, on the Python side of the simulation, so that the parallel interaction
// loop never meets an invalid material (an exception there cannot be reported cleanly). The contact law's own
// check of a material is the one used.
// Refused when set (from Python or a loaded file), not inside the parallel interaction loop, where a throw aborts.
void Ip2_BallastMat_BallastMat_BallastPhys::postLoad(Ip2_BallastMat_BallastMat_BallastPhys&) {
  if (!(fixedEffectiveRadius >= 0))
    throw std::invalid_argument("Ip2_BallastMat_BallastMat_BallastPhys.fixedEffectiveRadius must be >= 0 m (0: R* from "
                                "the bodies), got " + std::to_string(double(fixedEffectiveRadius)));
}

void BallastMat::postLoad(BallastMat&) {
  kernels::validate(contactMaterialOf(*this, "BallastMat"), "BallastMat '" + label + "'");
}

kernels::ContactLaw BallastPhys::contactLaw() {
  kernels::ContactLaw law{};
  law.config = kernels::ContactLawConfig{normalModel, dampingModel, tangentialModel, frictionModel, rollingModel};
  kernels::ContactParams& p = law.params;
  p.hertzMindlin = kernels::HertzMindlinParams{double(effectiveYoungModulus), double(effectiveShearModulus),
                                               double(effectiveRadius), double(effectiveMass), double(dampingRatio)};
  p.tangentialStiffnessRatio = double(tangentialStiffnessRatio);
  p.friction = kernels::StressDependentFrictionParams{double(tangensOfFrictionAngle), double(frictionExponent),
                                                      double(maxContactStress)};
  p.rollingFrictionCoefficient = double(rollingFriction);
  if (!normalModelPrepared) {
    p.pohrtPopov.fractalDimension = double(fractalDimension);
    p.pohrtPopov.roughnessRms = double(roughnessRms);
    kernels::prepareNormalModel(law);
    pohrtPopovCache = p.pohrtPopov;
    normalModelPrepared = true;
  }
  p.pohrtPopov = pohrtPopovCache;
  return law;
}

void BallastPhys::setContactLaw(const kernels::ContactLaw& law) {
  const kernels::ContactParams& p = law.params;
  normalModel = law.config.normal;
  dampingModel = law.config.damping;
  tangentialModel = law.config.tangential;
  frictionModel = law.config.friction;
  rollingModel = law.config.rolling;
  effectiveYoungModulus = p.hertzMindlin.effectiveYoungModulus;
  effectiveShearModulus = p.hertzMindlin.effectiveShearModulus;
  effectiveRadius = p.hertzMindlin.effectiveRadius;
  effectiveMass = p.hertzMindlin.effectiveMass;
  dampingRatio = p.hertzMindlin.dampingRatio;
  fractalDimension = p.pohrtPopov.fractalDimension;
  roughnessRms = p.pohrtPopov.roughnessRms;
  tangentialStiffnessRatio = p.tangentialStiffnessRatio;
  tangensOfFrictionAngle = p.friction.baseFrictionCoefficient;
  frictionCoeff = tangensOfFrictionAngle;
  frictionExponent = p.friction.frictionExponent;
  maxContactStress = p.friction.maxContactStress;
  rollingFriction = p.rollingFrictionCoefficient;
  rollingArm = kernels::rollingArm(law);
  pohrtPopovCache = p.pohrtPopov;
  normalModelPrepared = true;
}

std::string BallastPhys::contactLawKeywords() const {
  return kernels::describe(
      kernels::ContactLawConfig{normalModel, dampingModel, tangentialModel, frictionModel, rollingModel});
}

void Ip2_BallastMat_BallastMat_BallastPhys::go(const shared_ptr<Material>& material1,
                                               const shared_ptr<Material>& material2,
                                               const shared_ptr<Interaction>& interaction) {
  if (interaction->phys) return;
  const Body& body1 = *Body::byId(interaction->getId1(), scene);
  const Body& body2 = *Body::byId(interaction->getId2(), scene);
  // The contact law's mixing rule (Irazábal eq. 3.27 and docs/contact-models.md): stress-dependent friction between
  // members of different clusters only (§6.3.4); bounded rolling friction wherever a body is a sphere, which
  // BoundedRollingFrictionEngine then applies to the standalone dynamic spheres.
  const kernels::ContactPairOptions options{
      body1.isClumpMember() && body2.isClumpMember() && body1.clumpId != body2.clumpId, true};
  kernels::ContactLaw law = kernels::mixContactLaw(contactMaterialOf(*material1, "Ip2 body 1"),
                                                   contactMaterialOf(*material2, "Ip2 body 2"), options);
  // Walls: infinite radius and mass.
  const double radius = fixedEffectiveRadius > 0 ? double(fixedEffectiveRadius)
                                                 : kernels::effectiveRadius(contactRadius(body1), contactRadius(body2));
  const double mass = kernels::effectiveMass(contactMass(body1, scene), contactMass(body2, scene));
  kernels::setContactGeometry(law, radius, mass);
  auto phys = shared_ptr<BallastPhys>(new BallastPhys());
  phys->setContactLaw(law);
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
    phys->rollingResistance = 0;
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
  const railcosim::kernels::ContactHistory history{
      toKernel(phys->elasticShearForce), double(phys->previousShearStiffness),
      railcosim::kernels::NormalHistory{double(phys->maxNormalForce), double(phys->plasticOverlap)}};
  // Kernels.
  const railcosim::kernels::ContactLawResult result =
      railcosim::kernels::contactLawForces(phys->contactLaw(), history, kinematics);

  // Scatter: forces on body 2 (+) and body 1 (−), stiffnesses for time steppers, history.
  phys->normalForce = result.normalForce * normal;
  phys->shearForce = fromKernel(result.shearForce);
  phys->kn = result.normalStiffness;
  phys->ks = result.tangentialStiffness;
  phys->frictionCoeff = result.frictionCoefficient;
  phys->isSliding = result.sliding;
  phys->rollingResistance = result.rollingResistanceMoment;
  phys->elasticShearForce = fromKernel(result.history.elasticShearForce);
  phys->previousShearStiffness = result.history.previousTangentialStiffness;
  phys->maxNormalForce = result.history.normal.maxNormalForce;
  phys->plasticOverlap = result.history.normal.plasticOverlap;
  applyForceAtContactPoint(-phys->normalForce - phys->shearForce, geom->contactPoint, id1, state1->se3.position, id2,
                           state2->se3.position + shift2);
  return true;
}

} // namespace yade
