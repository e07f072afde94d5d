// Stand-in DEM participant: the weight of a block spread over the surface nodes; checks the FEM's answer.
#include "DummyCommon.hpp"

#include "railcosim/Error.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Participant.hpp"
#include "railcosim/StateStream.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <thread>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_dummy_dem: stand-in DEM participant (connects to the endpoint).\n"
    "  --endpoint E     ZeroMQ endpoint (ipc:///path or tcp://127.0.0.1:PORT)\n"
    "  --name N         participant name (dem)\n"
    "  --windows W      number of coupling windows (100)\n"
    "  --timeout S      longest wait for the FEM side [s] (60)\n"
    "  --heartbeat S    transport heartbeat [s] (1)\n"
    "  --load F         total vertical force of the block on the surface [N] (-1000, i.e. downwards)\n"
    "  --scheme X       justInTime | predictive | implicit (justInTime); must match the FEM side\n"
    "  --contact-stiffness KC  a scheme that iterates (implicit) only: the particles also act as a spring of KC N/m "
    "per node on the\n"
    "                   surface, F = load/nodes - KC u(t_i+1); checked against the monolithic solution (0)\n"
    "  --tolerance T --absolute-tolerance A --max-iterations K --relaxation W --no-aitken\n"
    "                   implicit window iteration (1e-10, 0 m, 30, 0.5, Aitken on)\n"
    "  --mass M --stiffness K   spring-mass per FEM node, for the check (1 kg, 1e6 N/m)\n"
    "  --no-check       do not compare the kinematics with the closed form\n"
    "  --compute-ms T   pretend to compute T ms per window (0)\n"
    "  --checkpoint-every S  order a restart checkpoint every S seconds of simulated time (default: the environment's\n"
    "                   RAILCOSIM_CHECKPOINT_EVERY, else none), written into RAILCOSIM_CHECKPOINT_DIR; "
    "RAILCOSIM_RESUME\n"
    "                   names the checkpoint to resume from\n"
    "  --result FILE    write the figures of the run (hexadecimal floats, exact) to FILE\n"
    "Exit status: 0 success, 2 peer lost, 3 protocol error, 1 other error or failed check.";

const char* const stateFile = "dem_state.bin";

} // namespace

int main(int argc, char** argv) {
  return dummy::runReportingErrors("railcosim_dummy_dem", [&]() -> int {
    const dummy::Options options(argc, argv,
                                 {{"endpoint", "ipc:///tmp/railcosim-dummy.sock"},
                                  {"name", "dem"},
                                  {"windows", "100"},
                                  {"timeout", "60"},
                                  {"heartbeat", "1"},
                                  {"load", "-1000"},
                                  {"scheme", "justInTime"},
                                  {"mass", "1"},
                                  {"stiffness", "1e6"},
                                  {"no-check", "false"},
                                  {"compute-ms", "0"},
                                  {"contact-stiffness", "0"},
                                  {"tolerance", "1e-10"},
                                  {"max-iterations", "30"},
                                  {"relaxation", "0.5"},
                                  {"no-aitken", "false"},
                                  {"absolute-tolerance", "0"},
                                  {"checkpoint-every", ""},
                                  {"result", ""}},
                                 usage);
    const CouplingScheme scheme = parseCouplingScheme(options.text("scheme"));
    long windows = options.integer("windows");
    const bool check = !options.flag("no-check");
    const auto computeTime = std::chrono::microseconds(static_cast<long>(options.number("compute-ms") * 1000.0));
    dummy::SpringMass model;
    model.mass = options.number("mass");
    model.stiffness = options.number("stiffness");

    const auto resumed = dummy::resumedState(stateFile);
    DemParticipant participant(dummy::participantConfig(options, scheme, resumed));
    const InterfaceSetup setup = participant.initialize();
    const std::size_t nodes = setup.mesh.nodeCount();
    const double dt = setup.femTimeStep;
    const double nodalForce = options.number("load") / static_cast<double>(nodes);

    // The implicit settings are read by a scheme that iterates a window.
    const SchemeSettings settings = SchemeSettings::of(
        scheme, options.number("tolerance"), options.number("absolute-tolerance"),
        static_cast<int>(options.integer("max-iterations")), options.number("relaxation"), !options.flag("no-aitken"));
    // The oracle's state and the window to go on from; a resumed run reads them (and the scheme's) from its checkpoint.
    double oracleU = 0.0, oracleV = 0.0, amplitude = 0.0;
    double maxError[3] = {0.0, 0.0,
                          0.0}; // closed form: relative to the amplitudes F/k, w F/k, F/m; bed: u relative to max |u|
    double maxBedError = 0.0;
    long firstWindow = 0;
    std::unique_ptr<DemCouplingScheme> coupling;
    if (resumed) {
      std::istringstream in(resumed->state);
      StateReader saved(in, "dem_state.bin of " + resumed->manifest.name);
      saved.section("dummy dem");
      firstWindow = saved.i64();
      oracleU = saved.real();
      oracleV = saved.real();
      amplitude = saved.real();
      for (double& error : maxError) error = saved.real();
      maxBedError = saved.real();
      std::istringstream schemeState(saved.bytes());
      coupling = DemCouplingScheme::resume(settings, participant, setup, schemeState);
    } else {
      coupling = DemCouplingScheme::create(settings, participant, setup);
    }
    const std::string everyText =
        options.text("checkpoint-every").empty()
            ? (std::getenv("RAILCOSIM_CHECKPOINT_EVERY") ? std::getenv("RAILCOSIM_CHECKPOINT_EVERY") : "")
            : options.text("checkpoint-every");
    const long checkpointWindows = everyText.empty() ? 0 : std::max(1L, std::lround(std::stod(everyText) / dt));
    const CheckpointSettings checkpoints = CheckpointSettings::fromEnvironment();
    if (checkpointWindows > 0 && checkpoints.folder.empty())
      throw Error("checkpoints every " + everyText + " s need RAILCOSIM_CHECKPOINT_DIR");
    const double contactStiffness = options.number("contact-stiffness");
    if (contactStiffness != 0.0 && !coupling->iterates()) {
      throw Error("--contact-stiffness needs a scheme that iterates a window (implicit): with " + toString(scheme) +
                  " the spring acts a window late, which the monolithic oracle does not model");
    }

    // The particles: the block's weight plus, with --contact-stiffness, a spring bed on every node evaluated
    // where the surface is at the window's end (an implicit contact force).
    // Oracles, both independent of the FEM's integrator: without the bed, each node's spring-mass starts from
    // rest when the load first acts (t = lag dt, lag = 1 for predictive, whose first FEM step precedes any DEM
    // force): u = (F/k)(1 - cos w s), v = w (F/k) sin w s, a = (F/m) cos w s. With the bed, the monolithic
    // solution of each window, where the FEM's exact update u1 = A u0 + B v0 + C F meets F = F0 - KC u1, so
    // u1 = (A u0 + B v0 + C F0) / (1 + C KC).
    const double lagTime = static_cast<double>(coupling->forcesLag()) * dt;
    const double w = model.omega();
    const double staticDisplacement = nodalForce / model.stiffness;
    auto advanced = [&](double u, double v, double force) {
      model.advance(u, v, force, dt);
      return std::pair<double, double>(u, v);
    };
    const double C = advanced(0.0, 0.0, 1.0).first; // displacement per unit constant force over one window
    auto checkKinematics = [&](const NodalKinematics& kinematics) {
      if (contactStiffness != 0.0) {
        const double free = advanced(oracleU, oracleV, 0.0).first;
        const double u1 = (free + C * nodalForce) / (1.0 + C * contactStiffness);
        const auto next = advanced(oracleU, oracleV, nodalForce - contactStiffness * u1);
        oracleU = next.first;
        oracleV = next.second;
        amplitude = std::max(amplitude, std::abs(oracleU));
        for (std::size_t n = 0; n < nodes; ++n)
          maxBedError = std::max(
              maxBedError, std::abs(kinematics.positions[3 * n + 2] - setup.mesh.coordinates[3 * n + 2] - oracleU));
        return;
      }
      const double s = kinematics.time - lagTime;
      const double expected[3] = {staticDisplacement * (1.0 - std::cos(w * s)),
                                  staticDisplacement * w * std::sin(w * s),
                                  s > 0.0 ? nodalForce / model.mass * std::cos(w * s) : 0.0};
      const double scale[3] = {std::abs(staticDisplacement), std::abs(staticDisplacement * w),
                               std::abs(nodalForce / model.mass)};
      for (std::size_t n = 0; n < nodes; ++n) {
        const double got[3] = {kinematics.positions[3 * n + 2] - setup.mesh.coordinates[3 * n + 2],
                               kinematics.velocities.empty() ? 0.0 : kinematics.velocities[3 * n + 2],
                               kinematics.accelerations.empty() ? 0.0 : kinematics.accelerations[3 * n + 2]};
        for (int q = 0; q < 3; ++q) maxError[q] = std::max(maxError[q], std::abs(got[q] - expected[q]) / scale[q]);
      }
    };

    std::vector<double> forces(3 * nodes, 0.0), positions, velocities;
    long unconverged = 0;
    // A restart checkpoint after window `window`: the FEM side's part first, then this side's and the manifest.
    auto checkpoint = [&](long completed) {
      const std::string name = checkpointName(static_cast<std::uint64_t>(completed));
      prepareCheckpoint(checkpoints.folder, name);
      CheckpointManifest manifest;
      manifest.name = name;
      manifest.window = static_cast<std::uint64_t>(completed);
      manifest.time = static_cast<double>(completed) * dt;
      manifest.scheme = toString(scheme);
      manifest.run = checkpoints.run;
      manifest.files = coupling->orderRestart(name, manifest.time);
      std::ostringstream out, schemeState;
      StateWriter saved(out);
      saved.section("dummy dem");
      saved.i64(completed);
      saved.real(oracleU);
      saved.real(oracleV);
      saved.real(amplitude);
      for (double error : maxError) saved.real(error);
      saved.real(maxBedError);
      coupling->writeState(schemeState);
      saved.bytes(schemeState.str());
      manifest.files.push_back(dummy::writeStateFile(name, stateFile, "dem", out.str()));
      commitCheckpoint(checkpoints.folder, manifest);
    };
    for (long window = firstWindow; window < windows; ++window) {
      WindowResult result;
      do {
        coupling->surfaceAt(dt, positions, velocities);
        for (std::size_t n = 0; n < nodes; ++n)
          forces[3 * n + 2] =
              nodalForce - contactStiffness * (positions[3 * n + 2] - setup.mesh.coordinates[3 * n + 2]);
        if (computeTime.count() > 0) std::this_thread::sleep_for(computeTime);
        result = coupling->completeWindow(forces, static_cast<double>(window + 1) * dt, true);
      } while (result.repeat);
      if (!result.converged) {
        // A diverging window poisons every later one: stop here with the figures that say why.
        ++unconverged;
        windows = window + 1;
        break;
      }
      if (check) checkKinematics(coupling->lastReceived());
      if (checkpointWindows > 0 && (window + 1) % checkpointWindows == 0) checkpoint(window + 1);
    }
    participant.finalize();

    // Closed form: exact propagation per window, only round-off accumulates (~1e-16 per window, a few thousand
    // windows), so 1e-9 of the amplitude separates a correct exchange from any real error. Bed: each window's
    // answer lies within the convergence limit of the fixed point (tolerance x displacement, with
    // --absolute-tolerance 0) and that error is carried on by a stable recursion: 2000 windows at 1e-8...1e-12
    // gave 0.9-2.8 x tolerance, so 100 x tolerance separates a converged run from a wrong one.
    const double bedError = amplitude > 0.0 ? maxBedError / amplitude : maxBedError;
    const bool withinOracle = contactStiffness != 0.0
                                  ? bedError <= 100.0 * settings.implicit.tolerance
                                  : maxError[0] <= 1e-9 && maxError[1] <= 1e-9 && maxError[2] <= 1e-9;
    const bool passed = unconverged == 0 && (!check || withinOracle);
    const WindowIterationStatistics& iterations = coupling->iterationStatistics();
    const long passes = coupling->iterates() ? iterations.passes : windows;
    const BridgeStatistics& statistics = participant.statistics();
    const double perExchange = statistics.exchanges > 0 ? 1e6 / static_cast<double>(statistics.exchanges) : 0.0;
    std::printf(
        "railcosim_dummy_dem: %s %ld windows, %ld passes (%.2f per window), %ld not converged, %llu exchanges, "
        "%zu nodes, %s%s, contact stiffness %g N/m, bridge %.1f us/exchange (encode %.1f + transfer %.1f), "
        "wait %.1f us/exchange, max relative error u %.2e v %.2e a %.2e, vs monolithic %.2e%s\n",
        passed ? "OK" : "FAILED", windows, passes, windows > 0 ? static_cast<double>(passes) / windows : 0.0,
        unconverged, static_cast<unsigned long long>(statistics.exchanges), nodes, toString(scheme).c_str(),
        coupling->iterates() && settings.implicit.aitken ? " (Aitken)" : "", contactStiffness,
        statistics.bridgeSeconds() * perExchange, statistics.encodeSeconds * perExchange,
        statistics.transferSeconds * perExchange, statistics.waitSeconds * perExchange, maxError[0], maxError[1],
        maxError[2], bedError, check ? "" : " (not checked)");
    std::ostringstream result;
    result << std::hexfloat << "windows " << windows << "\npasses " << passes << "\nerrors " << maxError[0] << ' '
           << maxError[1] << ' ' << maxError[2] << "\nbed " << maxBedError << "\noracle " << oracleU << ' ' << oracleV
           << "\nlast";
    for (double position : coupling->lastReceived().positions) result << ' ' << position;
    result << '\n';
    dummy::writeResult(options.text("result"), result.str());
    if (unconverged > 0)
      std::fprintf(
          stderr,
          "railcosim_dummy_dem: window %ld did not converge within %d passes (last residual %.3e m, limit %.3e m); "
          "stopped there\n",
          windows - 1, settings.implicit.maxIterations, iterations.lastResidual, iterations.lastLimit);
    return passed ? 0 : 1;
  });
}
