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
//       resized if needed). Returns 1, or 0 once the DEM side has ended the run, or 2 when the DEM side ordered a
//       restart checkpoint: save the state with the calls below, then call railcosimBeginStep again.
//   long railcosimWriteCheckpoint()  1: save the solver state (u, v, a, t) before solving this step.
//   long railcosimReadCheckpoint()   1: restore the saved state before solving (the window is repeated).
//   long railcosimEndStep(real time, real[int] positions, real[int] velocities, real[int] accelerations)
//       Sends the interface kinematics at the end of the step just solved (time t_i+1 [s]).
//   long railcosimStepAccepted()     1 once per solved step that became final (record it then); ask after
//                                    railcosimBeginStep and after railcosimEndStep.
//   long railcosimStepWindow()       Window index of the step being solved.
// Restart checkpoints (docs/protocol.md §12; folders from RAILCOSIM_CHECKPOINT_DIR and RAILCOSIM_RESUME):
//   long railcosimSaveState(string name, real[int] values)   } after railcosimBeginStep returned 2: the solver's
//   long railcosimSaveState(string name, real value)         } state, each under a name (u, v, a, time, step, ...)
//   long railcosimSaveFile(string path)      an output file as it is now, put back there when the run resumes
//   long railcosimSaveDone()                 writes fem_state.bin (the state above and the coupling scheme's, CRC-32
//                                            in the manifest) and the files into the checkpoint, tells the DEM side
//   long railcosimResumeLoad()               before railcosimConnect: 1 when RAILCOSIM_RESUME names a checkpoint,
//                                            which is checked (manifest, sizes, CRC-32), its files put back and its
//                                            state loaded (the handshake then announces it); 0 for a fresh run
//   long railcosimLoadState(string name, real[int] values)   the saved array (resized)
//   real railcosimLoadReal(string name)                       the saved value
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

#include "railcosim/Checkpoint.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
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
  // Restart checkpoints: what the script hands over while saving, and what a resumed run loaded.
  std::vector<std::pair<std::string, std::vector<double>>> savedArrays;
  std::vector<std::string> savedFiles;
  bool saving = false;
  std::optional<railcosim::CheckpointManifest> resumedFrom;
  std::map<std::string, std::vector<double>> loadedArrays;
  std::string loadedScheme; // the coupling scheme's state, read by the first railcosimBeginStep
  long exchangesBefore = 0; // exchanges of the interrupted run up to the checkpoint (statistics go on from there)
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
    if (s.resumedFrom) {
      config.resumedFrom = s.resumedFrom->name;
      config.resumedWindow = s.resumedFrom->window;
    }
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
  if (!s.scheme) {
    if (s.resumedFrom) {
      std::istringstream saved(s.loadedScheme);
      s.scheme = railcosim::FemCouplingScheme::resume(participant, s.nodeCount, saved);
    } else {
      s.scheme = railcosim::FemCouplingScheme::create(participant, s.nodeCount);
    }
  }
  return *s.scheme;
}

long railcosimBeginStep(KN<double>* const& forces) {
  return guarded("railcosimBeginStep", [&]() -> long {
    PluginState& s = state();
    railcosim::FemCouplingScheme& scheme = requireScheme("railcosimBeginStep");
    if (s.saving) fail("railcosimBeginStep", "a restart checkpoint is being saved: finish it with railcosimSaveDone()");
    std::vector<double> values;
    const railcosim::FemCouplingScheme::Action action = scheme.beginStep(values);
    if (action == railcosim::FemCouplingScheme::Action::Stop) return 0L;
    if (action == railcosim::FemCouplingScheme::Action::SaveRestart) {
      s.saving = true;
      s.savedArrays.clear();
      s.savedFiles.clear();
      return 2L;
    }
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

// Where this process writes the checkpoint ordered now: the staging folder the DEM side prepared.
std::string stagingFolderOf(const railcosim::CheckpointOrder& order) {
  const std::string root = railcosim::CheckpointSettings::fromEnvironment().folder;
  if (root.empty())
    throw railcosim::Error(
        "the DEM side ordered restart checkpoint " + order.name +
        " but RAILCOSIM_CHECKPOINT_DIR is not set on the FEM side (./railcosim run sets it for both)");
  const std::string staging = railcosim::stagingFolder(root, order.name);
  if (!std::filesystem::is_directory(staging))
    throw railcosim::Error(
        "restart checkpoint " + order.name + ": the folder " + staging +
        " the DEM side prepares does not exist (do both sides have the same RAILCOSIM_CHECKPOINT_DIR?)");
  return staging;
}

void requireSaving(const char* function) {
  if (!state().saving)
    fail(function, "no restart checkpoint is being saved (railcosimBeginStep returns 2 when one is)");
}

long railcosimSaveArray(string* const& name, KN<double>* const& values) {
  return guarded("railcosimSaveState", [&]() -> long {
    requireSaving("railcosimSaveState");
    state().savedArrays.emplace_back(*name, toVector(*values));
    return 0L;
  });
}

long railcosimSaveReal(string* const& name, const double& value) {
  return guarded("railcosimSaveState", [&]() -> long {
    requireSaving("railcosimSaveState");
    state().savedArrays.emplace_back(*name, std::vector<double>{value});
    return 0L;
  });
}

long railcosimSaveFile(string* const& path) {
  return guarded("railcosimSaveFile", [&]() -> long {
    requireSaving("railcosimSaveFile");
    state().savedFiles.push_back(*path);
    return 0L;
  });
}

// The path of an output file relative to this process's working folder (the run's results folder), so that it goes
// back to the same place in a results folder that was renamed since.
std::string relativeToWorkFolder(const std::string& path) {
  const std::filesystem::path absolute = std::filesystem::absolute(path).lexically_normal();
  const std::filesystem::path relative = absolute.lexically_relative(std::filesystem::current_path());
  if (relative.empty() || *relative.begin() == "..")
    throw railcosim::Error("file " + path + " lies outside the working folder " +
                           std::filesystem::current_path().string() + "; only the run's own outputs can be saved");
  return relative.string();
}

long railcosimSaveDone() {
  return guarded("railcosimSaveDone", [&]() -> long {
    PluginState& s = state();
    requireSaving("railcosimSaveDone");
    railcosim::FemCouplingScheme& scheme = requireScheme("railcosimSaveDone");
    const railcosim::CheckpointOrder& order = scheme.restartOrder();
    const std::string staging = stagingFolderOf(order);
    {
      std::ofstream out(staging + "/fem_state.bin", std::ios::binary | std::ios::trunc);
      railcosim::StateWriter writer(out);
      writer.section("fem solver");
      writer.u64(s.savedArrays.size());
      for (const auto& [name, values] : s.savedArrays) {
        writer.text(name);
        writer.reals(values);
      }
      writer.section("fem bridge");
      writer.i64(static_cast<std::int64_t>(s.exchangesBefore + s.participant->statistics().exchanges));
      writer.real(s.lastForceTime);
      writer.i64(s.lastForceWindow);
      writer.i64(s.lastForceIteration);
      std::ostringstream schemeState;
      scheme.writeState(schemeState);
      writer.bytes(schemeState.str());
      writer.section("end");
      out.close();
      if (!out) throw railcosim::Error("writing " + staging + "/fem_state.bin failed (disk full?)");
    }
    std::vector<railcosim::CheckpointFile> files{railcosim::describeCheckpointFile(staging, "fem_state.bin", "fem")};
    for (const std::string& path : s.savedFiles) {
      const std::string relative = relativeToWorkFolder(path);
      files.push_back(railcosim::copyIntoCheckpoint(
          staging, path, "fem_" + std::filesystem::path(path).filename().string(), "fem", relative));
    }
    scheme.confirmRestart(files);
    s.saving = false;
    return 0L;
  });
}

long railcosimResumeLoad() {
  return guarded("railcosimResumeLoad", [&]() -> long {
    PluginState& s = state();
    if (s.participant || s.finalized) fail("railcosimResumeLoad", "call it before railcosimConnect");
    const std::string folder = railcosim::CheckpointSettings::fromEnvironment().resumeFrom;
    if (folder.empty()) return 0L;
    const railcosim::CheckpointManifest manifest = railcosim::verifyCheckpoint(folder);
    railcosim::restoreCheckpointFiles(folder, manifest, "fem", std::filesystem::current_path().string());
    std::ifstream in(folder + "/fem_state.bin", std::ios::binary);
    if (!in)
      throw railcosim::CheckpointError("checkpoint " + folder + " has no fem_state.bin (not listed for the fem side?)");
    railcosim::StateReader reader(in, folder + "/fem_state.bin");
    reader.section("fem solver");
    const std::uint64_t count = reader.u64();
    for (std::uint64_t k = 0; k < count; ++k) {
      const std::string name = reader.text();
      s.loadedArrays[name] = reader.reals();
    }
    reader.section("fem bridge");
    s.exchangesBefore = static_cast<long>(reader.i64());
    s.lastForceTime = reader.real();
    s.lastForceWindow = static_cast<long>(reader.i64());
    s.lastForceIteration = static_cast<long>(reader.i64());
    s.loadedScheme = reader.bytes();
    reader.section("end");
    s.resumedFrom = manifest;
    return 1L;
  });
}

const std::vector<double>& loaded(const char* function, const std::string& name) {
  PluginState& s = state();
  if (!s.resumedFrom) fail(function, "this run did not resume from a checkpoint (railcosimResumeLoad returned 0)");
  const auto found = s.loadedArrays.find(name);
  if (found == s.loadedArrays.end())
    fail(function, "checkpoint " + s.resumedFrom->name + " holds no state named '" + name + "'");
  return found->second;
}

long railcosimLoadArray(string* const& name, KN<double>* const& values) {
  return guarded("railcosimLoadState", [&]() -> long {
    const std::vector<double>& saved = loaded("railcosimLoadState", *name);
    if (static_cast<std::size_t>(values->N()) != saved.size()) values->resize(static_cast<long>(saved.size()));
    for (std::size_t i = 0; i < saved.size(); ++i) (*values)[static_cast<long>(i)] = saved[i];
    return 0L;
  });
}

double railcosimLoadReal(string* const& name) {
  return guarded("railcosimLoadReal", [&]() -> double {
    const std::vector<double>& saved = loaded("railcosimLoadReal", *name);
    if (saved.size() != 1)
      fail("railcosimLoadReal", "state '" + *name + "' holds " + std::to_string(saved.size()) + " values, not one");
    return saved[0];
  });
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
long railcosimExchanges() { return state().exchangesBefore + static_cast<long>(currentStatistics().exchanges); }

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
  Global.Add("railcosimSaveState", "(", new OneOperator2_<long, string*, KN<double>*>(railcosimSaveArray));
  Global.Add("railcosimSaveState", "(", new OneOperator2_<long, string*, double>(railcosimSaveReal));
  Global.Add("railcosimSaveFile", "(", new OneOperator1_<long, string*>(railcosimSaveFile));
  Global.Add("railcosimSaveDone", "(", new OneOperator0<long>(railcosimSaveDone));
  Global.Add("railcosimResumeLoad", "(", new OneOperator0<long>(railcosimResumeLoad));
  Global.Add("railcosimLoadState", "(", new OneOperator2_<long, string*, KN<double>*>(railcosimLoadArray));
  Global.Add("railcosimLoadReal", "(", new OneOperator1_<double, string*>(railcosimLoadReal));
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
