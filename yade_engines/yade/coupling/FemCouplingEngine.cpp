// FemCouplingEngine: gathers facet contact forces, exchanges them through the bridge, moves the facets.
#include "FemCouplingEngine.hpp"

#include "railcosim/Error.hpp"
#include "railcosim/ForceLumping.hpp"
#include "railcosim/ImplicitCoupling.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include "kernels/HertzMindlin.hpp"
#include "kernels/SurfaceContactMesh.hpp"

#include <core/Interaction.hpp>
#include <core/InteractionContainer.hpp>
#include <core/Scene.hpp>
#include <core/State.hpp>
#include <core/Aabb.hpp>
#include <lib/pyutil/gil.hpp>
#include <pkg/common/Facet.hpp>
#include <pkg/common/NormShearPhys.hpp>
#include <pkg/common/Sphere.hpp>
#include <pkg/dem/FrictPhys.hpp>
#include <pkg/dem/DemXDofGeom.hpp>

#include <boost/archive/binary_iarchive.hpp>
#include <boost/archive/binary_oarchive.hpp>
#include <boost/serialization/shared_ptr.hpp>
#include <boost/serialization/vector.hpp>

#include <chrono>
#include <cmath>
#include <sstream>

namespace yade {

YADE_PLUGIN((FemCouplingEngine));
CREATE_LOGGER(FemCouplingEngine);

namespace {
	using Clock = std::chrono::steady_clock;
	double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

	Vector3r node(const std::vector<double>& xyz, int i) { return Vector3r(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }

	// Facet bodies must sit at the centre of the inscribed circle: YADE's facet contact geometry relies on it.
	Vector3r inscribedCircleCentre(const Vector3r& a, const Vector3r& b, const Vector3r& c)
	{
		const Real la = (b - c).norm(), lb = (c - a).norm(), lc = (a - b).norm();
		return (la * a + lb * b + lc * c) / (la + lb + lc);
	}
}

// What the implicit scheme restores when it repeats a window: body states and interactions (serialized
// with YADE's own archives, so every contact law's history comes back), the summed forces of the step
// the window started in, the clock, the audit sums and the hierarchy model's contact history.
struct FemCouplingEngine::Checkpoint {
	std::string                                                       archive;
	std::vector<Vector3r>                                             force, torque;
	Real                                                              time = 0;
	long                                                              iter = 0;
	Real                                                              workDem = 0, workFem = 0;
	std::shared_ptr<std::map<Body::id_t, std::vector<ContactHistory>>> history;
};

struct FemCouplingEngine::ContactHistory {
	railcosim::kernels::SurfaceContact contact;      // where the contact was at the previous step
	railcosim::kernels::Vec3           elasticForce; // tangential spring force carried to the next step [N]
	double                             overlap;      // overlap at the previous step [m] (unloading correction)
};

namespace {
	railcosim::kernels::Vec3 vec(const Vector3r& v) { return { v[0], v[1], v[2] }; }
	Vector3r                 vec(const railcosim::kernels::Vec3& v) { return Vector3r(v.x, v.y, v.z); }
	const FrictMat&          frictionMaterial(const shared_ptr<Material>& material, const std::string& owner)
	{
		const auto* frict = dynamic_cast<const FrictMat*>(material.get());
		if (!frict)
			throw std::invalid_argument(
			        "FemCouplingEngine (contactModel='hierarchy'): " + owner + " needs a FrictMat (or derived) material for its moduli and friction.");
		return *frict;
	}
}

bool FemCouplingEngine::useHierarchy() const
{
	if (contactModel == "hierarchy") return true;
	if (contactModel == "facets") return false;
	throw std::invalid_argument("FemCouplingEngine: contactModel='" + contactModel + "' is not known; use 'facets' or 'hierarchy'.");
}

FemCouplingEngine::~FemCouplingEngine()
{
	try {
		finalize();
	} catch (...) {
		// Destructors must not throw; the peer notices the closed connection anyway.
	}
}

void FemCouplingEngine::connect()
{
	if (connected) return;
	if (endpoint.empty()) throw std::invalid_argument("FemCouplingEngine: 'endpoint' is empty; set it to the FEM participant's ZeroMQ endpoint.");
	if (!material) throw std::invalid_argument("FemCouplingEngine: 'material' is not set; give the facets a material, e.g. material=O.materials[0].");
	predictive            = (railcosim::parseCouplingScheme(scheme) == railcosim::CouplingScheme::Predictive);
	railcosim::ImplicitSettings implicitSettings;
	implicitSettings.tolerance         = implicitTolerance;
	implicitSettings.absoluteTolerance = implicitAbsoluteTolerance;
	implicitSettings.maxIterations     = implicitMaxIterations;
	implicitSettings.relaxation        = implicitRelaxation;
	implicitSettings.aitken            = aitken;
	if (isImplicit()) {
		try {
			implicitSettings.validate();
		} catch (const railcosim::Error& e) {
			throw std::invalid_argument(std::string("FemCouplingEngine: ") + e.what() + " (attributes implicitTolerance, implicitAbsoluteTolerance, implicitMaxIterations, implicitRelaxation)");
		}
	}
	const bool hierarchy  = useHierarchy();
	if (hierarchy) frictionMaterial(material, "the surface 'material'");
	if (!(restitution >= 0 && restitution <= 1)) throw std::invalid_argument("FemCouplingEngine: restitution must be in [0, 1], got " + std::to_string(restitution));

	railcosim::ParticipantConfig config;
	config.name             = participantName;
	config.endpoint         = endpoint;
	config.timeoutSeconds   = timeout;
	config.heartbeatSeconds = heartbeat;
	config.couplingScheme   = railcosim::toString(railcosim::parseCouplingScheme(scheme));
	participant             = std::make_shared<railcosim::DemParticipant>(config);
	const auto waitStart    = Clock::now();
	railcosim::InterfaceSetup setup = participant->initialize();
	waitTime += secondsSince(waitStart);

	femDt = setup.femTimeStep;
	if (!(femDt > 0)) throw std::runtime_error("FemCouplingEngine: the FEM participant announced a non-positive time step.");
	if (subcycles <= 0) {
		if (!(scene->dt > 0)) throw std::invalid_argument("FemCouplingEngine: subcycles=0 needs a positive O.dt to derive the sub-cycling ratio; set O.dt or subcycles.");
		subcycles = std::max(1, static_cast<int>(std::ceil(femDt / scene->dt - 1e-9)));
	}
	scene->dt = femDt / subcycles;
	LOG_INFO("Coupled with '" << setup.peerName << "': " << setup.mesh.nodeCount() << " nodes, " << setup.mesh.triangleCount()
	                          << " triangles, femDt=" << femDt << " s, " << subcycles << " DEM steps per window, O.dt=" << scene->dt);

	connectivity = setup.mesh.triangles;
	triangles.clear();
	for (size_t t = 0; t < setup.mesh.triangleCount(); ++t)
		triangles.push_back(Vector3i(connectivity[3 * t], connectivity[3 * t + 1], connectivity[3 * t + 2]));

	facetIds.clear();
	if (hierarchy) {
		topology = std::make_shared<railcosim::kernels::SurfaceTopology>(connectivity, static_cast<int32_t>(setup.mesh.nodeCount()));
		// Grid cells about one mean edge long: a sphere query then visits a handful of cells.
		double edgeSum = 0;
		for (const Vector3i& tri : triangles)
			for (int k = 0; k < 3; ++k)
				edgeSum += (node(setup.mesh.coordinates, tri[k]) - node(setup.mesh.coordinates, tri[(k + 1) % 3])).norm();
		grid    = std::make_shared<railcosim::kernels::SurfaceTriangleGrid>(edgeSum / (3.0 * triangles.size()));
		history = std::make_shared<std::map<Body::id_t, std::vector<ContactHistory>>>();
	}
	for (size_t t = 0; t < (hierarchy ? 0 : triangles.size()); ++t) {
		auto facet = shared_ptr<Facet>(new Facet);
		facet->color = Vector3r(0.6, 0.6, 0.7);
		auto body    = shared_ptr<Body>(new Body);
		body->shape  = facet;
		body->bound  = shared_ptr<Aabb>(new Aabb);
		body->material = material;
		body->groupMask = mask;
		body->setDynamic(false);
		body->state->blockedDOFs = State::DOF_ALL;
		body->state->ori = body->state->refOri = Quaternionr::Identity();
		facetIds.push_back(scene->bodies->insert(body));
	}

	if (predictive) {
		// FEM first: the FEM has already stepped to t1 with zero interface force and sent that state.
		const auto waitKin = Clock::now();
		railcosim::NodalKinematics end = participant->receiveKinematics(0);
		waitTime += secondsSince(waitKin);
		lastReceived = std::make_shared<railcosim::NodalKinematics>(end);
		windowStart  = std::make_shared<railcosim::NodalKinematics>(railcosim::predictiveStart(setup.initial, end, femDt));
	} else if (isImplicit()) {
		implicitWindow = std::make_shared<railcosim::ImplicitWindowIteration>(implicitSettings, setup.mesh.coordinates, femDt);
		accepted       = std::make_shared<railcosim::NodalKinematics>(setup.initial);
		implicitWindow->startWindow(*accepted);
		windowStart = std::make_shared<railcosim::NodalKinematics>(implicitWindow->surfaceStart());
	} else {
		windowStart = std::make_shared<railcosim::NodalKinematics>(setup.initial);
	}
	forceSum.assign(3 * setup.mesh.nodeCount(), 0.0);
	nodalForces.assign(setup.mesh.nodeCount(), Vector3r::Zero());
	stepsInWindow = 0;
	window        = 0;
	connected     = true;
	placeSurface(0, false);
}

void FemCouplingEngine::placeSurface(Real tau, bool beforeIntegrator)
{
	std::vector<double>& positions  = surfacePositions;
	std::vector<double>& velocities = surfaceVelocities;
	railcosim::extrapolateSurface(*windowStart, tau, positions, velocities);
	const size_t nodes = positions.size() / 3;
	nodePositions.resize(nodes);
	nodeVelocities.resize(nodes);
	for (size_t i = 0; i < nodes; ++i) {
		nodePositions[i]  = node(positions, i);
		nodeVelocities[i] = node(velocities, i);
	}
	for (size_t t = 0; t < facetIds.size(); ++t) {
		const Body::id_t id = facetIds[t];
		const auto&      b  = (*scene->bodies)[id];
		if (!b) throw std::runtime_error("FemCouplingEngine: coupled facet body #" + std::to_string(id) + " was erased from the scene.");
		const Vector3i& tri   = triangles[t];
		const Vector3r  v[3]  = { nodePositions[tri[0]], nodePositions[tri[1]], nodePositions[tri[2]] };
		const Vector3r  centre = inscribedCircleCentre(v[0], v[1], v[2]);
		auto*           facet = static_cast<Facet*>(b->shape.get());
		for (int j = 0; j < 3; ++j)
			facet->vertices[j] = v[j] - centre;
		facet->postLoad(*facet);
		// Rigid-body velocity of the facet: mean of its vertices (in-plane stretching is not represented).
		const Vector3r velocity = (nodeVelocities[tri[0]] + nodeVelocities[tri[1]] + nodeVelocities[tri[2]]) / 3.;
		b->state->vel           = velocity;
		b->state->angVel        = Vector3r::Zero();
		// The integrator that runs after this engine moves non-dynamic bodies by vel*dt: pre-compensate so that
		// the facet sits exactly at the interpolated position when the next contact evaluation happens.
		b->state->pos = beforeIntegrator ? Vector3r(centre - velocity * scene->dt) : centre;
	}
}

void FemCouplingEngine::collectForces(std::vector<double>& nodal) const
{
	nodal.assign(3 * nodePositions.size(), 0.0);
	const std::vector<double>& positions = surfacePositions; // set with nodePositions by placeSurface
	// Only the facets' own interaction maps are visited: the cost follows the contacts on the surface.
	for (size_t t = 0; t < facetIds.size(); ++t) {
		const Body::id_t id = facetIds[t];
		const auto&      b  = (*scene->bodies)[id];
		for (const auto& entry : b->intrs) {
			const shared_ptr<Interaction>& I = entry.second;
			if (!I->isReal()) continue;
			const auto* geom = dynamic_cast<const GenericSpheresContact*>(I->geom.get());
			const auto* phys = dynamic_cast<const NormShearPhys*>(I->phys.get());
			if (!geom || !phys) continue;
			// The law applies -(Fn+Fs) to body 1 and +(Fn+Fs) to body 2.
			const Vector3r  onSecond = phys->normalForce + phys->shearForce;
			const Vector3r  force    = (I->getId1() == id) ? Vector3r(-onSecond) : onSecond;
			const Vector3r& cp       = geom->contactPoint;
			railcosim::lumpPointForce(positions, connectivity, t, { cp[0], cp[1], cp[2] }, { force[0], force[1], force[2] }, nodal);
		}
	}
}

bool FemCouplingEngine::isImplicit() const { return railcosim::parseCouplingScheme(scheme) == railcosim::CouplingScheme::Implicit; }

void FemCouplingEngine::saveCheckpoint()
{
	const auto start = Clock::now();
	// YADE objects touch Python while they are (de)serialized, and objects made in Python scripts (states
	// of bodies created there) must be released with the GIL held.
	gilLock python;
	if (!checkpoint) checkpoint = std::make_shared<Checkpoint>();
	Checkpoint& c = *checkpoint;
	std::vector<shared_ptr<State>> states(scene->bodies->size());
	for (const auto& b : *scene->bodies)
		if (b) states[b->id] = b->state;
	std::ostringstream out;
	{
		boost::archive::binary_oarchive archive(out);
		archive << states;
		archive << scene->interactions;
	}
	c.archive = out.str();
	scene->forces.sync();
	c.force.resize(states.size());
	c.torque.resize(states.size());
	for (size_t id = 0; id < states.size(); ++id) {
		c.force[id]  = states[id] ? scene->forces.getForce(id) : Vector3r::Zero();
		c.torque[id] = states[id] ? scene->forces.getTorque(id) : Vector3r::Zero();
	}
	c.time    = scene->time;
	c.iter    = scene->iter;
	c.workDem = interfaceWorkDem;
	c.workFem = interfaceWorkFem;
	c.history = history;
	checkpointTime += secondsSince(start);
}

void FemCouplingEngine::restoreCheckpoint()
{
	const auto        start = Clock::now();
	if (!checkpoint) throw std::logic_error("FemCouplingEngine (implicit): no checkpoint to repeat the window from (internal error).");
	gilLock           python; // see saveCheckpoint()
	const Checkpoint& c     = *checkpoint;
	std::vector<shared_ptr<State>>  states;
	shared_ptr<InteractionContainer> interactions;
	{
		std::istringstream              in(c.archive);
		boost::archive::binary_iarchive archive(in);
		archive >> states;
		archive >> interactions;
	}
	if (states.size() != scene->bodies->size())
		throw std::runtime_error("FemCouplingEngine (implicit): bodies were added or erased during a coupling window (" + std::to_string(states.size())
		                         + " then, " + std::to_string(scene->bodies->size()) + " now); the window cannot be repeated.");
	for (const auto& b : *scene->bodies) {
		if (!b) continue;
		if (!states[b->id])
			throw std::runtime_error("FemCouplingEngine (implicit): body #" + std::to_string(b->id) + " appeared during a coupling window; the window cannot be repeated.");
		b->state = states[b->id];
	}
	// Interactions as they were; the collider rebuilds its sorted bounds from scratch (dirty flag).
	interactions->postLoad__calledFromScene(scene->bodies); // binds the loaded copy to this scene's bodies
	scene->interactions->clear();
	for (const auto& I : *interactions)
		scene->interactions->insert(I);
	scene->interactions->dirty = true;
	// Summed forces of the step the window started in: the integrator that runs next applies them again.
	// Read every current sum first: an addition marks the container unsynchronised for further reads.
	scene->forces.sync();
	std::vector<Vector3r> forceChange(c.force.size()), torqueChange(c.force.size());
	for (size_t id = 0; id < c.force.size(); ++id) {
		if (!states[id]) continue;
		forceChange[id]  = c.force[id] - scene->forces.getForce(id);
		torqueChange[id] = c.torque[id] - scene->forces.getTorque(id);
	}
	for (size_t id = 0; id < c.force.size(); ++id) {
		if (!states[id]) continue;
		scene->forces.addForce(id, forceChange[id]);
		scene->forces.addTorque(id, torqueChange[id]);
	}
	scene->time      = c.time;
	scene->iter      = c.iter;
	interfaceWorkDem = c.workDem;
	interfaceWorkFem = c.workFem;
	history          = c.history;
	checkpointTime += secondsSince(start);
}

void FemCouplingEngine::accumulateStep()
{
	if (!surfaceTouched)
		for (double f : stepForces)
			if (f != 0) {
				surfaceTouched = true;
				break;
			}
	if (averageForces)
		for (size_t k = 0; k < stepForces.size(); ++k)
			forceSum[k] += stepForces[k];
	if (auditEnergy) {
		Real power = 0;
		for (size_t i = 0; i < nodeVelocities.size(); ++i)
			power += node(stepForces, i).dot(nodeVelocities[i]);
		interfaceWorkDem += power * scene->dt;
	}
}

void FemCouplingEngine::hierarchyContacts(std::vector<double>& nodal)
{
	namespace k = railcosim::kernels;
	const size_t        nodes = nodePositions.size();
	nodal.assign(3 * nodes, 0.0);
	const k::SurfaceMeshView view = topology->view(surfacePositions, surfaceVelocities);
	grid->rebuild(view);
	const FrictMat& surface        = frictionMaterial(material, "the surface 'material'");
	const double    surfaceShear   = k::shearModulus(surface.young, surface.poisson);
	const double    dampingRatio   = k::dampingRatioFromRestitution(restitution);
	const double    dt             = scene->dt;
	auto            next           = std::make_shared<std::map<Body::id_t, std::vector<ContactHistory>>>();
	std::vector<int32_t> candidates;
	long                 count = 0;
	for (const auto& b : *scene->bodies) {
		if (!b || b->isClump()) continue;
		const auto* sphere = dynamic_cast<const Sphere*>(b->shape.get());
		if (!sphere) continue;
		const State&   state  = *b->state;
		const k::Vec3  centre = vec(state.pos);
		const double   radius = sphere->radius;
		grid->candidates(centre, radius, candidates);
		if (candidates.empty()) continue;
		const std::vector<k::SurfaceContact> contacts = k::findSurfaceContacts(view, centre, radius, candidates);
		if (contacts.empty()) continue;

		const FrictMat& particle = frictionMaterial(b->material, "particle #" + std::to_string(b->id));
		// A clump member resists with the whole clump's inertia.
		const double mass = b->isClumpMember() ? (*scene->bodies)[b->clumpId]->state->mass : state.mass;
		const k::HertzMindlinParams params { k::effectiveYoungModulus(particle.young, particle.poisson, surface.young, surface.poisson),
			                             k::effectiveShearModulus(
			                                     k::shearModulus(particle.young, particle.poisson), particle.poisson, surfaceShear, surface.poisson),
			                             radius, mass, dampingRatio };
		const double friction = std::min(std::tan(particle.frictionAngle), std::tan(surface.frictionAngle));
		const auto   found    = history->find(b->id);
		std::vector<k::SurfaceContact> previousContacts;
		if (found != history->end())
			for (const ContactHistory& h : found->second)
				previousContacts.push_back(h.contact);
		std::vector<ContactHistory>& kept = (*next)[b->id];
		for (const k::SurfaceContact& c : contacts) {
			const k::Vec3 branch       = c.point - centre;
			const k::Vec3 pointVel     = vec(state.vel) + cross(vec(state.angVel), branch);
			const k::Vec3 relative     = pointVel - c.velocity; // particle relative to the surface at the contact
			const double  overlapRate  = -dot(relative, c.normal);
			const double  normalForce  = k::hertzNormalForce(params, c.overlap, overlapRate);
			const int32_t continued    = previousContacts.empty()
			           ? -1
			           : k::findContinuingContact(c, previousContacts.data(), static_cast<int32_t>(previousContacts.size()), k::hertzContactRadius(params, c.overlap));
			const k::Vec3 elastic      = continued >= 0 ? found->second[continued].elasticForce : k::Vec3 { 0, 0, 0 };
			const double  lastOverlap  = continued >= 0 ? found->second[continued].overlap : c.overlap;
			const k::TangentialForceResult tangential
			        = k::mindlinTangentialForce(params, elastic, c.normal, c.overlap, lastOverlap, relative * dt, relative, friction, normalForce);
			const k::Vec3 force = normalForce * c.normal + tangential.force; // on the particle
			scene->forces.addForce(b->id, vec(force));
			scene->forces.addTorque(b->id, vec(cross(branch, force)));
			k::lumpContactForce(c, -1.0 * force, nodal.data());
			kept.push_back({ c, tangential.elasticForce, c.overlap });
			++count;
		}
	}
	history         = next;
	surfaceContacts = count;
}

bool FemCouplingEngine::exchange()
{
	railcosim::ForceMessage message;
	message.window    = window;
	message.iteration = implicitWindow ? implicitWindow->iteration() : 0;
	message.time      = scene->time;
	if (averageForces) {
		message.forces = forceSum;
		for (double& f : message.forces)
			f /= stepsInWindow;
	} else if (auditEnergy || useHierarchy() || implicitWindow) {
		message.forces = stepForces; // already gathered for this step
	} else {
		collectForces(message.forces);
	}
	const size_t nodes = message.forces.size() / 3;
	totalForce         = Vector3r::Zero();
	for (size_t i = 0; i < nodes; ++i) {
		nodalForces[i] = node(message.forces, i);
		totalForce += nodalForces[i];
	}
	const double before = participant->statistics().waitSeconds;
	participant->sendForces(message);
	railcosim::NodalKinematics received = participant->receiveKinematics(predictive ? window + 1 : window);
	waitTime += participant->statistics().waitSeconds - before;
	std::fill(forceSum.begin(), forceSum.end(), 0.0); // the window's sum is in the message
	if (implicitWindow) {
		const auto outcome = implicitWindow->judge(received, surfaceTouched);
		surfaceTouched     = false;
		++implicitPasses;
		lastResidual = implicitWindow->residualNorm();
		if (outcome == railcosim::ImplicitWindowIteration::Outcome::Repeat) {
			windowStart = std::make_shared<railcosim::NodalKinematics>(implicitWindow->surfaceStart());
			return false;
		}
		lastWindowPasses = implicitWindow->iteration() + 1;
		maxWindowPasses  = std::max(maxWindowPasses, lastWindowPasses);
		if (outcome == railcosim::ImplicitWindowIteration::Outcome::GaveUp) {
			if (unconvergedWindows == 0)
				LOG_WARN("implicit coupling: window " << window << " did not converge in " << implicitMaxIterations << " passes (residual " << lastResidual
				                                      << " m, limit " << implicitWindow->convergenceLimit()
				                                      << " m); its last pass is accepted. Counted in unconvergedWindows; reported once.");
			++unconvergedWindows;
		}
	}
	if (auditEnergy) {
		// The FEM applies the sent forces over the step that produced `received`; its displacement over
		// that step starts from its previous state (JIT: window start; predictive: last received; implicit:
		// the accepted state at the window start).
		const std::vector<double>& from
		        = implicitWindow ? accepted->positions : (predictive ? lastReceived->positions : windowStart->positions);
		for (size_t k = 0; k < message.forces.size(); ++k)
			interfaceWorkFem += message.forces[k] * (received.positions[k] - from[k]);
	}
	if (implicitWindow) {
		accepted = std::make_shared<railcosim::NodalKinematics>(std::move(received));
		implicitWindow->startWindow(*accepted);
		windowStart = std::make_shared<railcosim::NodalKinematics>(implicitWindow->surfaceStart());
	} else if (predictive) {
		windowStart  = std::make_shared<railcosim::NodalKinematics>(railcosim::predictiveStart(*lastReceived, received, femDt));
		lastReceived = std::make_shared<railcosim::NodalKinematics>(std::move(received));
	} else {
		windowStart = std::make_shared<railcosim::NodalKinematics>(std::move(received));
	}
	++window;
	++exchanges;
	return true;
}

void FemCouplingEngine::action()
{
	try {
		// Connecting here means the facets missed this step's contact evaluation; the window starts now.
		bool windowStarts = false;
		if (!connected) {
			connect();
			windowStarts = true;
		}
		// Forces of this step's contact evaluation belong to the configuration at t_i + stepsInWindow*dt.
		const bool everyStep = averageForces || auditEnergy || implicitWindow;
		if (useHierarchy()) hierarchyContacts(stepForces);
		else if (stepsInWindow > 0 && everyStep) {
			const auto mapping = Clock::now();
			collectForces(stepForces);
			mappingTime += secondsSince(mapping);
		}
		if (stepsInWindow > 0 && everyStep) accumulateStep();
		if (stepsInWindow == subcycles) {
			const auto   start      = Clock::now();
			const double waitBefore = waitTime;
			windowStarts            = exchange();
			bridgeTime += secondsSince(start) - (waitTime - waitBefore);
			stepsInWindow = 0;
			// Implicit: back to the window's start (states, contacts, forces, clock) for another pass.
			if (!windowStarts) restoreCheckpoint();
		}
		// connect() may have run from Python before the first step: the first window then starts here.
		if (implicitWindow && (windowStarts || !checkpoint)) saveCheckpoint();
		++stepsInWindow;
		placeSurface(stepsInWindow * scene->dt, true);
	} catch (const railcosim::Error& e) {
		std::ostringstream context;
		context << "FemCouplingEngine at iteration " << scene->iter << " (t=" << scene->time << " s, window " << window << "): " << e.what();
		throw std::runtime_error(context.str());
	}
}

void FemCouplingEngine::finalize()
{
	if (participant) participant->finalize();
}

} // namespace yade
