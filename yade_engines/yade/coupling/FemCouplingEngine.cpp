// FemCouplingEngine: gathers facet contact forces, exchanges them through the bridge, moves the facets.
#include "FemCouplingEngine.hpp"

#include "railcosim/Error.hpp"
#include "railcosim/ForceLumping.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/WindowInterpolation.hpp"

#include <core/Interaction.hpp>
#include <core/InteractionContainer.hpp>
#include <core/Scene.hpp>
#include <core/State.hpp>
#include <pkg/common/Aabb.hpp>
#include <pkg/common/Facet.hpp>
#include <pkg/common/NormShearPhys.hpp>
#include <pkg/dem/ScGeom.hpp>

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
	predictive = (railcosim::parseCouplingScheme(scheme) == railcosim::CouplingScheme::Predictive);

	railcosim::ParticipantConfig config;
	config.name             = participantName;
	config.endpoint         = endpoint;
	config.timeoutSeconds   = timeout;
	config.heartbeatSeconds = heartbeat;
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
	for (size_t t = 0; t < triangles.size(); ++t) {
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
	std::vector<double> positions, velocities;
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
	std::vector<double> positions(3 * nodePositions.size());
	for (size_t i = 0; i < nodePositions.size(); ++i)
		for (int k = 0; k < 3; ++k)
			positions[3 * i + k] = nodePositions[i][k];
	// Map body id -> triangle index once per call; facet ids are few compared with interactions.
	const Body::id_t firstId = facetIds.empty() ? 0 : *std::min_element(facetIds.begin(), facetIds.end());
	const Body::id_t lastId  = facetIds.empty() ? -1 : *std::max_element(facetIds.begin(), facetIds.end());
	std::vector<int> triangleOf(lastId - firstId + 1, -1);
	for (size_t t = 0; t < facetIds.size(); ++t)
		triangleOf[facetIds[t] - firstId] = static_cast<int>(t);
	auto triangleIndex = [&](Body::id_t id) { return (id < firstId || id > lastId) ? -1 : triangleOf[id - firstId]; };

	for (const auto& I : *scene->interactions) {
		if (!I->isReal()) continue;
		const int t1 = triangleIndex(I->getId1()), t2 = triangleIndex(I->getId2());
		if (t1 < 0 && t2 < 0) continue;
		const auto* geom = dynamic_cast<const GenericSpheresContact*>(I->geom.get());
		const auto* phys = dynamic_cast<const NormShearPhys*>(I->phys.get());
		if (!geom || !phys) continue;
		// The law applies -(Fn+Fs) to body 1 and +(Fn+Fs) to body 2.
		const Vector3r onSecond = phys->normalForce + phys->shearForce;
		const Vector3r force    = (t1 >= 0) ? Vector3r(-onSecond) : onSecond;
		const int      t        = (t1 >= 0) ? t1 : t2;
		const Vector3r& cp      = geom->contactPoint;
		railcosim::lumpPointForce(positions, connectivity, t, { cp[0], cp[1], cp[2] }, { force[0], force[1], force[2] }, nodal);
	}
}

void FemCouplingEngine::exchange()
{
	railcosim::ForceMessage message;
	message.window = window;
	message.time   = scene->time;
	if (averageForces) {
		message.forces = forceSum;
		for (double& f : message.forces)
			f /= stepsInWindow;
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
	if (predictive) {
		windowStart  = std::make_shared<railcosim::NodalKinematics>(railcosim::predictiveStart(*lastReceived, received, femDt));
		lastReceived = std::make_shared<railcosim::NodalKinematics>(std::move(received));
	} else {
		windowStart = std::make_shared<railcosim::NodalKinematics>(std::move(received));
	}
	std::fill(forceSum.begin(), forceSum.end(), 0.0);
	++window;
	++exchanges;
}

void FemCouplingEngine::action()
{
	try {
		// Connecting here means the facets missed this step's contact evaluation; the window starts now.
		if (!connected) connect();
		const auto start = Clock::now();
		const double waitBefore = waitTime;
		// Forces of this step's contact evaluation belong to the configuration at t_i + stepsInWindow*dt.
		if (stepsInWindow > 0 && averageForces) {
			std::vector<double> nodal;
			collectForces(nodal);
			for (size_t k = 0; k < nodal.size(); ++k)
				forceSum[k] += nodal[k];
		}
		if (stepsInWindow == subcycles) {
			exchange();
			stepsInWindow = 0;
		}
		++stepsInWindow;
		placeSurface(stepsInWindow * scene->dt, true);
		bridgeTime += secondsSince(start) - (waitTime - waitBefore);
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
