// Shared pieces of the stand-in participants: command-line parsing, the test surface and the oracle.
#pragma once

#include "railcosim/Checkpoint.hpp"
#include "railcosim/InterfaceMesh.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace railcosim::dummy {

/// "--help": the usage text, printed by runReportingErrors (exit status 0).
class HelpRequested : public std::runtime_error {
public:
  explicit HelpRequested(const std::string& usage) : std::runtime_error(usage) {}
};

/// "--key value" pairs and "--flag" switches (Boost.Program_options); unknown keys are an error so typos
/// do not pass silently. Every key of `defaults` is an option; a default of "false" makes it a switch.
class Options {
public:
  Options(int argc, char** argv, const std::map<std::string, std::string>& defaults, const std::string& usage);
  std::string text(const std::string& key) const;
  double number(const std::string& key) const;
  long integer(const std::string& key) const;
  bool flag(const std::string& key) const;

private:
  std::map<std::string, std::string> values_;
};

/// Flat rectangular surface in the plane z = 0: nx x ny nodes spaced `spacing` m, two triangles per
/// cell, counter-clockwise seen from +z (normal +z, towards the particles above).
InterfaceMesh rectangularSurface(long nx, long ny, double spacing);

/// Node grid close to `nodes` in total (nx = ny = round(sqrt(nodes)), at least 2).
long sideForNodes(long nodes);

/// Each FEM node carries a vertical spring-mass: m u'' + k u = F_z. Its state is advanced over a
/// window with constant force by the exact solution, so the DEM side can check the closed form
/// u(t) = (F/k) (1 - cos(w (t - t0))) from rest at t0 to round-off.
struct SpringMass {
  double mass = 1.0;        // kg per node
  double stiffness = 1.0e6; // N/m per node
  double omega() const { return std::sqrt(stiffness / mass); }
  /// Advances (u, v) by dt under constant force; returns the acceleration at the end.
  double advance(double& displacement, double& velocity, double force, double dt) const;
};

/// Restart checkpoints of a stand-in, in the folders `railcosim run` sets (CheckpointSettings::fromEnvironment):
/// the checkpoint resumed from (checked: manifest, sizes, CRC-32) and this side's state file in it.
struct ResumedState {
  CheckpointManifest manifest;
  std::string state; // the side's state file, whole
};
/// Empty unless RAILCOSIM_RESUME names a checkpoint; `file` is the side's state file in it.
std::optional<ResumedState> resumedState(const std::string& file);
/// The participant settings both stand-ins take from --name, --endpoint, --timeout, --heartbeat, and the checkpoint
/// they resumed from, if any (announced at the handshake).
ParticipantConfig participantConfig(const Options& options, CouplingScheme scheme,
                                    const std::optional<ResumedState>& resumed = std::nullopt);
/// Writes `state` as `file` into the staging folder of checkpoint `name` and describes it.
CheckpointFile writeStateFile(const std::string& name, const std::string& file, const std::string& side,
                              const std::string& state);
/// Writes `text` to `path` through a temporary file and a rename ("" for no file).
void writeResult(const std::string& path, const std::string& text);

/// Runs a stand-in's main body, prints the usage on --help, and maps failures to its documented exit status (2 peer
/// lost, 3 protocol error, 1 anything else), printing "PROGRAM: KIND: message" on stderr.
int runReportingErrors(const char* program, const std::function<int()>& body);

} // namespace railcosim::dummy
