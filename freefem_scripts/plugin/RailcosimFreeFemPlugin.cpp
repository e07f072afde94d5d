// FreeFEM plugin exposing the bridge's FemParticipant to .edp scripts (load "railcosim_bridge").
//
// Functions added to the FreeFEM language (one participant per FreeFem++ process):
//
//   long railcosimConnect(string endpoint, string name, real timeoutSeconds)
//   long railcosimConnect(string endpoint, string name, real timeoutSeconds, string scheme)
//       Creates the FEM participant; the FEM side binds `endpoint` (ZeroMQ, e.g. "ipc:///tmp/x.sock").
//       `scheme` ("justInTime", "predictive", "implicit") is checked against the DEM side's at the handshake.
//   long railcosimInitialize(real[int] coordinates, int[int] triangles, real femTimeStep,
//                            real[int] velocities, real[int] accelerations)
//       Handshake: sends the interface mesh (coordinates x0,y0,z0,x1,... [m]; triangles i0,j0,k0,...
//       zero-based, counter-clockwise seen from outside), the window length [s] and the kinematics at
//       t = 0 (positions = coordinates; velocities [m/s] and accelerations [m/s^2], 3 per node).
//       Returns the number of interface nodes.
// The time loop, scheme-agnostic (the coupling scheme agreed at the handshake orders the messages):
//   long railcosimBeginStep(real[int] forces)
//       Waits, if the scheme orders it, for the nodal forces [N] that load the next step (3 per node,
//       resized if needed). Returns 1, or 0 once the DEM side has ended the run.
//   long railcosimWriteCheckpoint()  1: save the solver state (u, v, a, t) before solving this step.
//   long railcosimReadCheckpoint()   1: restore the saved state before solving (the window is repeated).
//   long railcosimEndStep(real time, real[int] positions, real[int] velocities, real[int] accelerations)
//       Sends the interface kinematics at the end of the step just solved (time t_i+1 [s]).
//   long railcosimStepAccepted()     1 once per solved step that became final (record it then); ask after
//                                    railcosimBeginStep and after railcosimEndStep.
//   long railcosimStepWindow()       Window index of the step being solved.
// Low-level calls (a script that orders the messages itself; not mixed with the calls above):
//   long railcosimReceiveForces(real[int] forces)
//       Waits for the next window's nodal forces [N] (3 per node, resized if needed). Returns 1, or 0
//       once the DEM side has finished (forces untouched).
//   long railcosimSendKinematics(int window, real time, real[int] positions, real[int] velocities,
//                                real[int] accelerations)
//       Sends the interface kinematics at the end of window `window` (time t_i+1 [s]).
//   long railcosimFinalize()        Ends the run normally (idempotent); statistics stay readable.
//   long railcosimAbort(string why) Tells the DEM side this side failed, with the reason.
//   real railcosimForceTime()       Time [s] the last received forces refer to.
//   long railcosimForceWindow()     Window index of the last received forces.
//   long railcosimForceIteration()  Implicit scheme: pass k of the last received forces. 0 opens a new
//                                   window (the previous pass is accepted); k > 0 repeats the same window,
//                                   to be solved again from the state saved at its start.
//   real railcosimBridgeSeconds()   Seconds spent packing/unpacking and inside ZeroMQ calls.
//   real railcosimWaitSeconds()     Seconds spent waiting for the DEM side (its compute time).
//   long railcosimExchanges()       Messages sent + received after the handshake.
//
// Every railcosim::Error becomes a FreeFEM execution error carrying the full message (FreeFem++ then
// stops with a non-zero exit status); before that the peer is told why, so it does not hang.

#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Participant.hpp"

#include <cstdint>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

// FreeFEM's headers come last: they define macros and pull names into the global namespace.
#include <ff++.hpp>
#include <AFunction_ext.hpp>

namespace {

struct PluginState {
  std::unique_ptr<railcosim::FemParticipant> participant;
  std::unique_ptr<railcosim::FemCouplingScheme> scheme; // made by the first railcosimBeginStep
  std::string name = "fem";
  std::size_t nodeCount = 0;
  bool initialized = false;
  bool finalized = false;
  railcosim::BridgeStatistics finalStatistics; // kept after the participant is released
  double lastForceTime = 0.0;
  long lastForceWindow = -1;
  long lastForceIteration = 0;
};

PluginState& state() {
  static PluginState instance;
  return instance;
}

// Reports a failure to the peer (best effort) and raises a FreeFEM execution error with `message`.
[[noreturn]] void fail(const std::string& function, const std::string& message) {
  PluginState& s = state();
  const std::string full = "railcosim plugin, " + function + ": " + message;
  if (s.participant && !s.finalized) {
    try {
      s.participant->abort(full);
    } catch (...) {
      // The peer may already be gone; the original error is the one worth reporting.
    }
    s.finalStatistics = s.participant->statistics();
    s.scheme.reset();
    s.participant.reset();
    s.finalized = true;
  }
  ExecError(full);
  throw std::logic_error(full); // not reached: ExecError throws
}

// Runs `body`, converting every C++ exception into a FreeFEM error that names the function.
template <class Body>
auto guarded(const char* function, Body body) -> decltype(body()) {
  try {
    return body();
  } catch (const ::Error&) {
    throw; // already a FreeFEM error (raised by fail()), message complete
  } catch (const railcosim::Error& error) {
    fail(function, error.what());
  } catch (const std::bad_alloc&) {
    fail(function, "out of memory");
  } catch (const std::exception& error) {
    fail(function, error.what());
  }
}

railcosim::FemParticipant& requireParticipant(const char* function, bool mustBeInitialized) {
  PluginState& s = state();
  if (s.finalized) fail(function, "the participant was already finalized; a run uses one participant per process");
  if (!s.participant) fail(function, "no participant: call railcosimConnect(endpoint, name, timeout) first");
  if (mustBeInitialized && !s.initialized)
    fail(function, "the interface is not initialized: call railcosimInitialize(...) first");
  return *s.participant;
}

std::vector<double> toVector(const KN<double>& array) {
  std::vector<double> values(array.N());
  for (long i = 0; i < array.N(); ++i) values[i] = array[i];
  return values;
}

// Checks that an .edp array holds 3 values per interface node.
void requireNodalSize(const char* function, const char* what, const KN<double>& array, std::size_t nodes) {
  if (static_cast<std::size_t>(array.N()) != 3 * nodes) {
    std::ostringstream message;
    message << what << " has " << array.N() << " values but the interface has " << nodes
            << " nodes: pass 3 values per node (x,y,z interleaved)";
    fail(function, message.str());
  }
}

// The kinematics an .edp script passes at a step's end, checked for 3 values per interface node.
railcosim::NodalKinematics kinematicsFrom(const char* function, double time, const KN<double>& positions,
                                          const KN<double>& velocities, const KN<double>& accelerations) {
  const std::size_t nodes = state().nodeCount;
  requireNodalSize(function, "positions", positions, nodes);
  requireNodalSize(function, "velocities", velocities, nodes);
  requireNodalSize(function, "accelerations", accelerations, nodes);
  railcosim::NodalKinematics kinematics;
  kinematics.time = time;
  kinematics.positions = toVector(positions);
  kinematics.velocities = toVector(velocities);
  kinematics.accelerations = toVector(accelerations);
  return kinematics;
}

long connectWithScheme(string* const& endpoint, string* const& name, const double& timeoutSeconds,
                       const std::string& scheme) {
  return guarded("railcosimConnect", [&]() -> long {
    PluginState& s = state();
    if (s.participant || s.finalized)
      fail("railcosimConnect", "called twice; a FreeFem++ process hosts one participant");
    if (!(timeoutSeconds > 0.0)) {
      std::ostringstream message;
      message << "timeout " << timeoutSeconds << " s is not positive";
      fail("railcosimConnect", message.str());
    }
    railcosim::ParticipantConfig config;
    config.name = *name;
    config.endpoint = *endpoint;
    config.timeoutSeconds = timeoutSeconds;
    config.couplingScheme = scheme;
    s.name = config.name;
    s.participant = std::make_unique<railcosim::FemParticipant>(config);
    return 0L;
  });
}

long railcosimConnect(string* const& endpoint, string* const& name, const double& timeoutSeconds) {
  return connectWithScheme(endpoint, name, timeoutSeconds, "");
}

long railcosimConnectScheme(string* const& endpoint, string* const& name, const double& timeoutSeconds,
                            string* const& scheme) {
  return connectWithScheme(endpoint, name, timeoutSeconds, *scheme);
}

long railcosimInitialize(KN<double>* const& coordinates, KN<long>* const& triangles, const double& femTimeStep,
                         KN<double>* const& velocities, KN<double>* const& accelerations) {
  return guarded("railcosimInitialize", [&]() -> long {
    PluginState& s = state();
    railcosim::FemParticipant& participant = requireParticipant("railcosimInitialize", false);
    if (s.initialized) fail("railcosimInitialize", "called twice");
    railcosim::InterfaceMesh mesh;
    mesh.coordinates = toVector(*coordinates);
    mesh.triangles.resize(triangles->N());
    for (long i = 0; i < triangles->N(); ++i) mesh.triangles[i] = static_cast<std::int32_t>((*triangles)[i]);
    mesh.validate();
    const std::size_t nodes = mesh.nodeCount();
    requireNodalSize("railcosimInitialize", "velocities", *velocities, nodes);
    requireNodalSize("railcosimInitialize", "accelerations", *accelerations, nodes);
    railcosim::NodalKinematics initial;
    initial.time = 0.0;
    initial.positions = mesh.coordinates;
    initial.velocities = toVector(*velocities);
    initial.accelerations = toVector(*accelerations);
    participant.initialize(mesh, femTimeStep, initial);
    s.nodeCount = nodes;
    s.initialized = true;
    return static_cast<long>(nodes);
  });
}

long railcosimReceiveForces(KN<double>* const& forces) {
  return guarded("railcosimReceiveForces", [&]() -> long {
    PluginState& s = state();
    railcosim::FemParticipant& participant = requireParticipant("railcosimReceiveForces", true);
    std::optional<railcosim::ForceMessage> message = participant.receiveForces();
    if (!message) return 0L;
    if (message->forces.size() != 3 * s.nodeCount) {
      std::ostringstream text;
      text << "window " << message->window << " carries " << message->forces.size() << " force values, expected "
           << 3 * s.nodeCount << " (3 per interface node)";
      fail("railcosimReceiveForces", text.str());
    }
    if (static_cast<std::size_t>(forces->N()) != message->forces.size()) forces->resize(message->forces.size());
    for (long i = 0; i < static_cast<long>(message->forces.size()); ++i) (*forces)[i] = message->forces[i];
    s.lastForceTime = message->time;
    s.lastForceWindow = static_cast<long>(message->window);
    s.lastForceIteration = static_cast<long>(message->iteration);
    return 1L;
  });
}

long railcosimSendKinematics(const long& window, const double& time, KN<double>* const& positions,
                             KN<double>* const& velocities, KN<double>* const& accelerations) {
  return guarded("railcosimSendKinematics", [&]() -> long {
    railcosim::FemParticipant& participant = requireParticipant("railcosimSendKinematics", true);
    if (window < 0) fail("railcosimSendKinematics", "window index " + std::to_string(window) + " is negative");
    participant.sendKinematics(
        static_cast<std::uint64_t>(window),
        kinematicsFrom("railcosimSendKinematics", time, *positions, *velocities, *accelerations));
    return 0L;
  });
}

railcosim::FemCouplingScheme& requireScheme(const char* function) {
  PluginState& s = state();
  railcosim::FemParticipant& participant = requireParticipant(function, true);
  if (!s.scheme) s.scheme = railcosim::FemCouplingScheme::create(participant, s.nodeCount);
  return *s.scheme;
}

long railcosimBeginStep(KN<double>* const& forces) {
  return guarded("railcosimBeginStep", [&]() -> long {
    PluginState& s = state();
    railcosim::FemCouplingScheme& scheme = requireScheme("railcosimBeginStep");
    std::vector<double> values;
    if (!scheme.beginStep(values)) return 0L;
    if (values.size() != 3 * s.nodeCount) {
      std::ostringstream text;
      text << "window " << scheme.window() << " carries " << values.size() << " force values, expected "
           << 3 * s.nodeCount << " (3 per interface node)";
      fail("railcosimBeginStep", text.str());
    }
    if (static_cast<std::size_t>(forces->N()) != values.size()) forces->resize(values.size());
    for (long i = 0; i < static_cast<long>(values.size()); ++i) (*forces)[i] = values[i];
    s.lastForceTime = scheme.forcesTime();
    s.lastForceWindow = static_cast<long>(scheme.windowsReceived()) - 1;
    s.lastForceIteration = static_cast<long>(scheme.forcesIteration());
    return 1L;
  });
}

long railcosimEndStep(const double& time, KN<double>* const& positions, KN<double>* const& velocities,
                      KN<double>* const& accelerations) {
  return guarded("railcosimEndStep", [&]() -> long {
    railcosim::FemCouplingScheme& scheme = requireScheme("railcosimEndStep");
    scheme.endStep(kinematicsFrom("railcosimEndStep", time, *positions, *velocities, *accelerations));
    return 0L;
  });
}

long railcosimWriteCheckpoint() {
  return guarded("railcosimWriteCheckpoint", [&]() -> long {
    return requireScheme("railcosimWriteCheckpoint").requiresWritingCheckpoint() ? 1L : 0L;
  });
}

long railcosimReadCheckpoint() {
  return guarded("railcosimReadCheckpoint", [&]() -> long {
    return requireScheme("railcosimReadCheckpoint").requiresReadingCheckpoint() ? 1L : 0L;
  });
}

long railcosimStepAccepted() {
  PluginState& s = state();
  return s.scheme && s.scheme->takeAcceptedStep() ? 1L : 0L;
}

long railcosimStepWindow() {
  PluginState& s = state();
  return s.scheme ? static_cast<long>(s.scheme->window()) : 0L;
}

long railcosimFinalize() {
  return guarded("railcosimFinalize", [&]() -> long {
    PluginState& s = state();
    if (s.finalized || !s.participant) return 0L;
    s.participant->finalize();
    s.finalStatistics = s.participant->statistics();
    // Released here rather than at static destruction, after FreeFEM's own teardown.
    s.scheme.reset();
    s.participant.reset();
    s.finalized = true;
    return 0L;
  });
}

long railcosimAbort(string* const& reason) {
  PluginState& s = state();
  if (s.finalized || !s.participant) return 0L;
  try {
    s.participant->abort(*reason);
    s.finalStatistics = s.participant->statistics();
  } catch (...) {
    // Aborting is already the failure path; a vanished peer needs no further report.
  }
  s.scheme.reset();
  s.participant.reset();
  s.finalized = true;
  return 0L;
}

const railcosim::BridgeStatistics& currentStatistics() {
  PluginState& s = state();
  return s.participant ? s.participant->statistics() : s.finalStatistics;
}

double railcosimForceTime() { return state().lastForceTime; }
long railcosimForceWindow() { return state().lastForceWindow; }
long railcosimForceIteration() { return state().lastForceIteration; }
double railcosimBridgeSeconds() { return currentStatistics().bridgeSeconds(); }
double railcosimWaitSeconds() { return currentStatistics().waitSeconds; }
long railcosimExchanges() { return static_cast<long>(currentStatistics().exchanges); }

} // namespace

static void init() {
  Global.Add("railcosimConnect", "(", new OneOperator3_<long, string*, string*, double>(railcosimConnect));
  Global.Add("railcosimConnect", "(",
             new OneOperator4_<long, string*, string*, double, string*>(railcosimConnectScheme));
  Global.Add("railcosimInitialize", "(",
             new OneOperator5_<long, KN<double>*, KN<long>*, double, KN<double>*, KN<double>*>(railcosimInitialize));
  Global.Add("railcosimBeginStep", "(", new OneOperator1_<long, KN<double>*>(railcosimBeginStep));
  Global.Add("railcosimEndStep", "(",
             new OneOperator4_<long, double, KN<double>*, KN<double>*, KN<double>*>(railcosimEndStep));
  Global.Add("railcosimWriteCheckpoint", "(", new OneOperator0<long>(railcosimWriteCheckpoint));
  Global.Add("railcosimReadCheckpoint", "(", new OneOperator0<long>(railcosimReadCheckpoint));
  Global.Add("railcosimStepAccepted", "(", new OneOperator0<long>(railcosimStepAccepted));
  Global.Add("railcosimStepWindow", "(", new OneOperator0<long>(railcosimStepWindow));
  Global.Add("railcosimReceiveForces", "(", new OneOperator1_<long, KN<double>*>(railcosimReceiveForces));
  Global.Add("railcosimSendKinematics", "(",
             new OneOperator5_<long, long, double, KN<double>*, KN<double>*, KN<double>*>(railcosimSendKinematics));
  Global.Add("railcosimFinalize", "(", new OneOperator0<long>(railcosimFinalize));
  Global.Add("railcosimAbort", "(", new OneOperator1_<long, string*>(railcosimAbort));
  Global.Add("railcosimForceTime", "(", new OneOperator0<double>(railcosimForceTime));
  Global.Add("railcosimForceWindow", "(", new OneOperator0<long>(railcosimForceWindow));
  Global.Add("railcosimForceIteration", "(", new OneOperator0<long>(railcosimForceIteration));
  Global.Add("railcosimBridgeSeconds", "(", new OneOperator0<double>(railcosimBridgeSeconds));
  Global.Add("railcosimWaitSeconds", "(", new OneOperator0<double>(railcosimWaitSeconds));
  Global.Add("railcosimExchanges", "(", new OneOperator0<long>(railcosimExchanges));
}

LOADFUNC(init)
