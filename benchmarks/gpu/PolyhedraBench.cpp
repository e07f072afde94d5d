// Throughput benchmark of the polyhedra DEM: a packed bed of 20-vertex stones, GPU or CPU reference.
//
// Usage: polyhedra_bench [--n N]... [--steps S] [--prepare P] [--backend cpu|cuda|auto] [--json FILE]
//   Builds a shallow bed (8 layers) of about N dodecahedral stones (4 templates, random orientations),
//   packs it onto the floor in P coarse steps, then times S production steps and prints one
//   JSON record per N (also written to FILE as a JSON list), with the cost of a state snapshot (saveSnapshot,
//   restoreSnapshot: the rollback of an implicit coupling window) and of writing the state to memory.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <omp.h>
#include <vector>

#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraSystem.hpp"

using namespace railcosim::polyhedra;

namespace {

// Measured device-to-device copy bandwidth (read + write), bytes/s: H100 3.0e12 and H200 4.3e12
// (reference/performance_anchors.md §6). Other devices and the CPU are compared with the H100 figure.
double bandwidthOf(const std::string& device) { return device.find("H200") != std::string::npos ? 4.3e12 : 3.0e12; }

struct Options {
  std::vector<long> sizes;
  int steps = 200;
  int prepare = 3000;
  Backend backend = Backend::Automatic;
  std::string json;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    auto next = [&]() -> std::string {
      if (k + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", a.c_str());
        std::exit(2);
      }
      return argv[++k];
    };
    if (a == "--n")
      o.sizes.push_back(std::atol(next().c_str()));
    else if (a == "--steps")
      o.steps = std::atoi(next().c_str());
    else if (a == "--prepare")
      o.prepare = std::atoi(next().c_str());
    else if (a == "--json")
      o.json = next();
    else if (a == "--backend") {
      const std::string b = next();
      o.backend = b == "cpu" ? Backend::Cpu : b == "cuda" ? Backend::Cuda : Backend::Automatic;
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      std::exit(2);
    }
  }
  if (o.sizes.empty()) o.sizes = {10000};
  return o;
}

} // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  std::vector<std::string> records;
  std::printf("%-30s %10s %6s %8s %10s %14s %14s %10s %10s\n", "device", "stones", "steps", "wall_s", "ms/step",
              "p-steps/s", "contacts/s", "cont/stone", "bw_frac");
  for (const long requested : options.sizes) {
    Parameters p;
    p.timeStep = 1e-5; // Hertz period of a 0.17 kg stone at E = 1e9 Pa is ~2e-3 s: ≥ 200 steps per contact
    p.stone = Material{1e9, 0.25, 0.3, 0.6};
    p.wall = p.stone;
    p.neighbourSkin = 0.003; // packing at Δt = 5e-5 s and ≤ 1.5 m/s moves stones ≤ 7.5e-4 m per 10-step interval
    p.backend = options.backend;
    PolyhedraSystem system(p);
    std::vector<int> shapes = {system.addShape(dodecahedronStone(0.030, 0.025, 0.020, 0.003, 2600)),
                               system.addShape(dodecahedronStone(0.026, 0.028, 0.022, 0.003, 2600)),
                               system.addShape(dodecahedronStone(0.028, 0.022, 0.024, 0.003, 2600)),
                               system.addShape(dodecahedronStone(0.024, 0.027, 0.026, 0.003, 2600))};
    const int layers = 8;
    const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(requested) / layers)));
    const double spacing = 0.066; // > largest bounding diameter (0.0638 m): no initial overlaps
    addLatticeBed(system, shapes, side, side, layers, spacing, 0.0005, 2026u, true);
    // Packing phase: the lattice collapses onto the floor under 10 g with a coarse Δt = 5e-5 s (ω Δt ≈ 0.15
    // for these contacts: stable, if not accurate) until the stones rest on each other; then the timed
    // run uses the production Δt and gravity.
    system.setTimeStep(5e-5);
    system.setGravity({0.0, 0.0, -98.1});
    const auto prepareStart = std::chrono::steady_clock::now();
    for (int done = 0; done < options.prepare; done += 500) system.step(std::min(500, options.prepare - done));
    const double prepareSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - prepareStart).count();
    system.setTimeStep(p.timeStep);
    system.setGravity(p.gravity);
    system.step(20); // warm-up: CUDA graphs captured, caches filled
    const auto start = std::chrono::steady_clock::now();
    system.step(options.steps);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const StepStatistics stats = system.lastStatistics();
    // Snapshot cost: the mean of 10 saves and of 10 restores, and one writeState into memory.
    auto seconds = [](std::chrono::steady_clock::time_point t) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < 10; ++k) system.saveSnapshot();
    const double saveSeconds = seconds(t0) / 10;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < 10; ++k) system.restoreSnapshot();
    const double restoreSeconds = seconds(t0) / 10;
    std::ostringstream state;
    t0 = std::chrono::steady_clock::now();
    system.writeState(state);
    const double writeSeconds = seconds(t0);
    double maxSpeed = 0.0; // how settled the bed is (it decides how many list rebuilds are needed)
    const std::vector<double> velocities = system.velocities();
    for (std::size_t k = 0; k + 2 < velocities.size(); k += 3)
      maxSpeed = std::max(maxSpeed, std::sqrt(velocities[k] * velocities[k] + velocities[k + 1] * velocities[k + 1] +
                                              velocities[k + 2] * velocities[k + 2]));
    const double n = static_cast<double>(system.stoneCount());
    const double particleSteps = n * options.steps / wall;
    const double contactsPerStone = stats.meanActiveContacts / n;
    const double contactsPerSecond = stats.meanActiveContacts * options.steps / wall;
    // Fewest bytes per stone-step: state (position, velocity, quaternion, angular velocity: 13 doubles)
    // read and written once, plus one 64-byte history slot read and written per active contact.
    const double bytes = 2.0 * 13 * 8 + contactsPerStone * 2.0 * 64;
    std::string device = system.activeBackend() == Backend::Cuda
                             ? system.backendReason().substr(system.backendReason().find(':') + 2)
                             : "CPU reference, " + std::to_string(omp_get_max_threads()) + " threads";
    const double bandwidth = bandwidthOf(device);
    const double fraction = particleSteps / (bandwidth / bytes);
    std::ostringstream record;
    record.precision(6);
    record << "{\"device\": \"" << device << "\", \"backend\": \"" << backendName(system.activeBackend())
           << "\", \"n_particles\": " << system.stoneCount()
           << ", \"vertices_per_stone\": 20, \"steps\": " << options.steps << ", \"wall_s\": " << wall
           << ", \"particle_steps_per_s\": " << particleSteps << ", \"contacts_per_s\": " << contactsPerSecond
           << ", \"contacts_per_particle\": " << contactsPerStone << ", \"bytes_per_particle_step_bound\": " << bytes
           << ", \"fraction_of_bandwidth_bound\": " << fraction << ", \"bandwidth_assumed_Bps\": " << bandwidth
           << ", \"core_overlap_fallbacks\": " << stats.coreOverlapFallbacks
           << ", \"dangerous_rebuilds\": " << stats.dangerousRebuilds
           << ", \"neighbour_rebuilds\": " << stats.neighbourRebuilds << ", \"max_speed_m_s\": " << maxSpeed
           << ", \"prepare_steps\": " << options.prepare << ", \"prepare_wall_s\": " << prepareSeconds
           << ", \"time_step_s\": " << p.timeStep << ", \"snapshot_save_s\": " << saveSeconds
           << ", \"snapshot_restore_s\": " << restoreSeconds << ", \"write_state_s\": " << writeSeconds
           << ", \"state_bytes\": " << state.str().size() << "}";
    records.push_back(record.str());
    std::printf("%-30s %10zu %6d %8.3f %10.4f %14.4e %14.4e %10.2f %10.4f\n", device.substr(0, 30).c_str(),
                system.stoneCount(), options.steps, wall, 1e3 * wall / options.steps, particleSteps, contactsPerSecond,
                contactsPerStone, fraction);
    std::fflush(stdout);
  }
  std::string list = "[\n";
  for (std::size_t k = 0; k < records.size(); ++k) list += "  " + records[k] + (k + 1 < records.size() ? ",\n" : "\n");
  list += "]\n";
  if (!options.json.empty()) std::ofstream(options.json) << list;
  std::printf("%s", list.c_str());
  return 0;
}
