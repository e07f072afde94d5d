// Stand-in FEM participant: a flat nx x ny surface whose nodes are vertical spring-masses driven by the DEM forces.
#include "DummyCommon.hpp"

#include "railcosim/Error.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/StateStream.hpp"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <thread>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_dummy_fem: stand-in FEM participant (binds the endpoint).\n"
    "  --endpoint E     ZeroMQ endpoint (ipc:///path or tcp://127.0.0.1:PORT)\n"
    "  --name N         participant name (fem)\n"
    "  --windows W      finalize after W windows (0: run until the DEM side finalizes)\n"
    "  --timeout S      longest wait for the DEM side [s] (60)\n"
    "  --heartbeat S    transport heartbeat [s] (1)\n"
    "  --nodes N        interface size, about N nodes on a square grid (100); or --nx/--ny\n"
    "  --spacing H      node spacing [m] (0.1)\n"
    "  --dt S           coupling window = FEM step [s] (1e-4)\n"
    "  --scheme X       justInTime | predictive | implicit (justInTime); implicit repeats a window from its\n"
    "                   saved start state whenever the DEM side sends another pass over it\n"
    "  --mass M         mass per node [kg] (1);  --stiffness K  spring per node [N/m] (1e6)\n"
    "  --compute-ms T   pretend to compute T ms per window (0)\n"
    "  --result FILE    write the final nodal state (hexadecimal floats, exact) and the counts to FILE\n"
    "Restart checkpoints as the real solvers: ordered by the DEM side, written into RAILCOSIM_CHECKPOINT_DIR;\n"
    "RAILCOSIM_RESUME names the checkpoint to resume from.\n"
    "Exit status: 0 success, 2 peer lost, 3 protocol error, 1 other error.";

const char* const stateFile = "fem_state.bin";

} // namespace

int main(int argc, char** argv) {
  return dummy::runReportingErrors("railcosim_dummy_fem", [&]() -> int {
    const dummy::Options options(argc, argv,
                                 {{"endpoint", "ipc:///tmp/railcosim-dummy.sock"},
                                  {"name", "fem"},
                                  {"windows", "0"},
                                  {"timeout", "60"},
                                  {"heartbeat", "1"},
                                  {"nodes", "100"},
                                  {"nx", "0"},
                                  {"ny", "0"},
                                  {"spacing", "0.1"},
                                  {"dt", "1e-4"},
                                  {"scheme", "justInTime"},
                                  {"mass", "1"},
                                  {"stiffness", "1e6"},
                                  {"compute-ms", "0"},
                                  {"result", ""}},
                                 usage);
    const CouplingScheme scheme = parseCouplingScheme(options.text("scheme"));
    const long side = dummy::sideForNodes(options.integer("nodes"));
    const long nx = options.integer("nx") > 0 ? options.integer("nx") : side;
    const long ny = options.integer("ny") > 0 ? options.integer("ny") : side;
    const double dt = options.number("dt");
    const long maxWindows = options.integer("windows");
    const auto computeTime = std::chrono::microseconds(static_cast<long>(options.number("compute-ms") * 1000.0));
    dummy::SpringMass model;
    model.mass = options.number("mass");
    model.stiffness = options.number("stiffness");

    const InterfaceMesh mesh = dummy::rectangularSurface(nx, ny, options.number("spacing"));
    const std::size_t nodes = mesh.nodeCount();
    std::vector<double> displacement(nodes, 0.0), velocity(nodes, 0.0), appliedForce(nodes, 0.0);
    NodalKinematics state;
    state.positions = mesh.coordinates;
    state.velocities.assign(3 * nodes, 0.0);
    state.accelerations.assign(3 * nodes, 0.0);

    std::vector<double> savedDisplacement, savedVelocity;
    std::uint64_t passes = 0; // FEM solves (a scheme that repeats windows solves a window once per pass)
    const auto resumed = dummy::resumedState(stateFile);
    std::string schemeState;
    if (resumed) {
      std::istringstream in(resumed->state);
      StateReader saved(in, "fem_state.bin of " + resumed->manifest.name);
      saved.section("dummy fem");
      displacement = saved.reals();
      velocity = saved.reals();
      appliedForce = saved.reals();
      savedDisplacement = saved.reals();
      savedVelocity = saved.reals();
      passes = saved.u64();
      state = saved.kinematics();
      schemeState = saved.bytes();
      if (displacement.size() != nodes) saved.fail("the state is of " + std::to_string(displacement.size()) + " nodes");
    }
    FemParticipant participant(dummy::participantConfig(options, scheme, resumed));
    participant.initialize(mesh, dt, state);

    // One FEM step t_i -> t_i+1 with the vertical nodal forces in appliedForce.
    auto step = [&](std::uint64_t window) {
      ++passes;
      if (computeTime.count() > 0) std::this_thread::sleep_for(computeTime);
      for (std::size_t n = 0; n < nodes; ++n) {
        const double acceleration = model.advance(displacement[n], velocity[n], appliedForce[n], dt);
        state.positions[3 * n + 2] = mesh.coordinates[3 * n + 2] + displacement[n];
        state.velocities[3 * n + 2] = velocity[n];
        state.accelerations[3 * n + 2] = acceleration;
      }
      state.time = static_cast<double>(window + 1) * dt;
    };

    // The scheme orders the messages; this loop only solves, saves and restores as it is told.
    std::unique_ptr<FemCouplingScheme> coupling;
    if (resumed) {
      std::istringstream in(schemeState);
      coupling = FemCouplingScheme::resume(participant, nodes, in);
    } else {
      coupling = FemCouplingScheme::create(participant, nodes);
    }
    std::vector<double> forces;
    while (maxWindows <= 0 || coupling->windowsReceived() < static_cast<std::uint64_t>(maxWindows)) {
      const FemCouplingScheme::Action action = coupling->beginStep(forces);
      if (action == FemCouplingScheme::Action::Stop) break;
      if (action == FemCouplingScheme::Action::SaveRestart) {
        std::ostringstream out, schemeOut;
        StateWriter saved(out);
        saved.section("dummy fem");
        saved.reals(displacement);
        saved.reals(velocity);
        saved.reals(appliedForce);
        saved.reals(savedDisplacement);
        saved.reals(savedVelocity);
        saved.u64(passes);
        saved.kinematics(state);
        coupling->writeState(schemeOut);
        saved.bytes(schemeOut.str());
        coupling->confirmRestart({dummy::writeStateFile(coupling->restartOrder().name, stateFile, "fem", out.str())});
        continue;
      }
      if (maxWindows > 0 && coupling->window() >= static_cast<std::uint64_t>(maxWindows))
        break; // no step past the last window
      if (coupling->requiresWritingCheckpoint()) {
        savedDisplacement = displacement;
        savedVelocity = velocity;
      }
      if (coupling->requiresReadingCheckpoint()) {
        displacement = savedDisplacement;
        velocity = savedVelocity;
      }
      for (std::size_t n = 0; n < nodes; ++n) appliedForce[n] = forces[3 * n + 2];
      step(coupling->window());
      coupling->endStep(state);
    }
    const std::uint64_t window = coupling->windowsReceived();
    participant.finalize();
    std::ostringstream result;
    result << std::hexfloat << "windows " << window << "\npasses " << passes << "\n";
    for (std::size_t n = 0; n < nodes; ++n) result << displacement[n] << ' ' << velocity[n] << '\n';
    dummy::writeResult(options.text("result"), result.str());
    const BridgeStatistics& statistics = participant.statistics();
    const double perExchange = statistics.exchanges > 0 ? 1e6 / static_cast<double>(statistics.exchanges) : 0.0;
    std::printf(
        "railcosim_dummy_fem: OK %llu windows, %llu FEM solves, %llu exchanges, %zu nodes, %s, bridge %.1f us/exchange "
        "(encode %.1f + transfer %.1f), wait %.1f us/exchange\n",
        static_cast<unsigned long long>(window), static_cast<unsigned long long>(passes),
        static_cast<unsigned long long>(statistics.exchanges), nodes, toString(scheme).c_str(),
        statistics.bridgeSeconds() * perExchange, statistics.encodeSeconds * perExchange,
        statistics.transferSeconds * perExchange, statistics.waitSeconds * perExchange);
    return 0;
  });
}
