// Throughput benchmark of the polyhedra DEM: a packed bed of 20-vertex stones, GPU or CPU reference.
//
// Usage: polyhedra_bench [--n N]... [--steps S] [--prepare P] [--bed packing|settled] [--pressure PA]
//                        [--tile K] [--save-bed DIR] [--load-bed DIR]
//                        [--backend cpu|cuda|auto] [--json FILE] [--export PREFIX]
//   Builds a shallow bed (8 layers) of about N dodecahedral stones (4 templates, random orientations),
//   then times S production steps and prints one JSON record per N (also written to FILE as a JSON list),
//   with the cost of a state snapshot (saveSnapshot, restoreSnapshot: the rollback of an implicit coupling
//   window) and of writing the state to memory. Beds:
//   packing  the lattice collapses onto the floor in P coarse steps: the top layers are still falling;
//   settled  compacted ballast under a sleeper-like load: deposited without friction (denser, as ballast is
//            compacted), then frictional stones under a lid pressed to PA (default 150 kPa) and held until the
//            bed is at rest; the timed steps run under the held lid.
//   --tile K (settled bed) also times K × K copies of each prepared bed side by side in a box K times as long and wide
//            under the same lid, rested for 2000 steps: a settled bed of K² N stones without K² times the preparation.
//   --save-bed DIR writes each settled bed as prepared (before its timed steps) to DIR/settled-N.state and
//            DIR/settled-N.txt; --load-bed DIR takes it from there instead of preparing it (same build, same N):
//            another program run (a profiler, another build of the kernels) then times the very same bed.
//   --export PREFIX writes each bed after its timed steps to PREFIX-N.csv (one stone per row: position, velocity,
//   mass, volume of the dilated stone, circumradius) with its box, lid, time step and contact parameters in comment
//   lines: the same bed for another code (benchmarks/peers/deme).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <memory>
#include <sstream>
#include <string>
#include <omp.h>
#include <vector>

#include "polyhedra/PolyhedraShapes.hpp"
#include "polyhedra/PolyhedraSystem.hpp"
#ifdef RAILCOSIM_BENCH_PROFILER_RANGE
#include <cuda_profiler_api.h> // run_device.sh: the timed steps alone are profiled (ncu --profile-from-start off)
#endif

using namespace railcosim::polyhedra;

namespace {

// Measured device-to-device copy bandwidth (read + write), bytes/s: H100 3.0e12 and H200 4.3e12
// (reference/performance_anchors.md §6). Other devices and the CPU are compared with the H100 figure.
double bandwidthOf(const std::string& device) { return device.find("H200") != std::string::npos ? 4.3e12 : 3.0e12; }

struct Options {
  std::vector<long> sizes;
  int steps = 200;
  int prepare = 3000;
  bool settled = false;
  double pressure = 150e3; // Pa: 132 kN on a 2.5 x 0.3 m sleeper base is 176 kPa; the bed below carries a little less
  Backend backend = Backend::Automatic;
  std::string json;
  std::string exportPrefix;
  int tile = 1;
  std::string saveBed, loadBed;
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
    else if (a == "--bed") {
      const std::string b = next();
      if (b != "packing" && b != "settled") {
        std::fprintf(stderr, "--bed: packing or settled, not %s\n", b.c_str());
        std::exit(2);
      }
      o.settled = b == "settled";
    } else if (a == "--pressure") {
      o.pressure = std::atof(next().c_str());
      if (!(o.pressure > 0.0)) {
        std::fprintf(stderr, "--pressure: a lid pressure in Pa > 0, not %s\n", argv[k]);
        std::exit(2);
      }
    } else if (a == "--json")
      o.json = next();
    else if (a == "--export")
      o.exportPrefix = next();
    else if (a == "--tile") {
      o.tile = std::atoi(next().c_str());
      if (o.tile < 1 || o.tile > 8) {
        std::fprintf(stderr, "--tile: copies per side, 1 to 8, not %s\n", argv[k]);
        std::exit(2);
      }
    } else if (a == "--save-bed")
      o.saveBed = next();
    else if (a == "--load-bed")
      o.loadBed = next();
    else if (a == "--backend") {
      const std::string b = next();
      o.backend = b == "cpu" ? Backend::Cpu : b == "cuda" ? Backend::Cuda : Backend::Automatic;
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      std::exit(2);
    }
  }
  if (o.sizes.empty()) o.sizes = {10000};
  if (!o.exportPrefix.empty()) {
    // Checked before the preparation (minutes at 1e6 stones), not after it.
    const std::filesystem::path folder = std::filesystem::path(o.exportPrefix).parent_path();
    if (!o.settled) {
      std::fprintf(stderr,
                   "--export: only the settled bed (--bed settled) is at rest under a lid; the packing bed is "
                   "still falling\n");
      std::exit(2);
    }
    if (!folder.empty() && !std::filesystem::is_directory(folder)) {
      std::fprintf(stderr, "--export: no folder %s for %s-N.csv\n", folder.c_str(), o.exportPrefix.c_str());
      std::exit(2);
    }
  }
  if (!o.settled && (o.tile > 1 || !o.saveBed.empty() || !o.loadBed.empty())) {
    std::fprintf(stderr, "--tile, --save-bed and --load-bed apply to the settled bed (--bed settled)\n");
    std::exit(2);
  }
  for (const std::string& folder : {o.saveBed, o.loadBed})
    if (!folder.empty() && !std::filesystem::is_directory(folder)) {
      std::fprintf(stderr, "--save-bed/--load-bed: no folder %s\n", folder.c_str());
      std::exit(2);
    }
  for (const long n : o.sizes)
    if (n < 1) {
      std::fprintf(stderr, "--n: a number of stones >= 1, not %ld\n", n);
      std::exit(2);
    }
  if (o.steps < 1 || o.prepare < 0) {
    std::fprintf(stderr, "--steps must be >= 1 and --prepare >= 0\n");
    std::exit(2);
  }
  return o;
}

// The benchmark's stones and contact parameters; `friction` replaces μ of stones and walls.
Parameters benchParameters(Backend backend, double friction, double young = 1e9) {
  Parameters p;
  p.timeStep = 1e-5; // Hertz period of a 0.17 kg stone at E = 1e9 Pa is ~2e-3 s: ≥ 200 steps per contact
  p.stone = Material{young, 0.25, 0.3, friction};
  p.wall = p.stone;
  p.neighbourSkin = 0.003; // packing at Δt = 5e-5 s and ≤ 1.5 m/s moves stones ≤ 7.5e-4 m per 10-step interval
  p.backend = backend;
  return p;
}

constexpr int layers = 8;
constexpr double spacing = 0.066;        // > largest bounding diameter (0.0638 m): no initial overlaps
constexpr double packingTimeStep = 5e-5; // ω Δt ≈ 0.15 for these contacts: stable, if not accurate
constexpr unsigned bedSeed = 2026u;
// Ballast's E (the sleeper case's stones) in the loaded bed: at 1e9 Pa the strongest force chains under the lid
// pressed dilated spheres of 3 mm through to the cores (core-overlap fallbacks, then stones thrown out of the box);
// the overlaps shrink by 10^(2/3) = 4.6 at 1e10 Pa, and the Hertz period by 10^0.4 = 2.5 (80 steps per contact
// period at Δt = 1e-5 s).
constexpr double settledYoung = 1e10;

int latticeSide(long requested) {
  return static_cast<int>(std::ceil(std::sqrt(static_cast<double>(requested) / layers)));
}

// The four stone templates and the lattice of about `requested` stones (same draw for the same size).
// Returns the template of each stone.
std::vector<int> addShapes(PolyhedraSystem& system) {
  return {system.addShape(dodecahedronStone(0.030, 0.025, 0.020, 0.003, 2600)),
          system.addShape(dodecahedronStone(0.026, 0.028, 0.022, 0.003, 2600)),
          system.addShape(dodecahedronStone(0.028, 0.022, 0.024, 0.003, 2600)),
          system.addShape(dodecahedronStone(0.024, 0.027, 0.026, 0.003, 2600))};
}

std::vector<int> addBed(PolyhedraSystem& system, long requested, bool withBox) {
  const std::vector<int> shapes = addShapes(system);
  const int side = latticeSide(requested);
  return addLatticeBed(system, shapes, side, side, layers, spacing, 0.0005, bedSeed, withBox);
}

double maxSpeedOf(const PolyhedraSystem& system) {
  double maxSpeed = 0.0;
  const std::vector<double> v = system.velocities();
  for (std::size_t k = 0; k + 2 < v.size(); k += 3)
    maxSpeed = std::max(maxSpeed, std::sqrt(v[k] * v[k] + v[k + 1] * v[k + 1] + v[k + 2] * v[k + 2]));
  return maxSpeed;
}

struct Bed {
  std::unique_ptr<PolyhedraSystem> system;
  int prepareSteps = 0;
  double prepareSeconds = 0.0;
  double lidPressure = 0.0;  // Pa, mean over the timed steps (settled bed)
  double coordination = 0.0; // 2 × stone–stone contacts / stones after the timed steps
  double wallContacts = 0.0; // stone–wall contacts per stone
  double restingSpeed = 0.0; // largest stone speed before the timed steps [m/s]
  double speed99 = 0.0;      // its 99th percentile [m/s]
  double speedMedian = 0.0;  // its median [m/s]
  std::vector<int> lidTriangles;
  double lidArea = 0.0;
  double lidHeight = 0.0; // z of the held lid (settled bed) [m]
  int side = 0;           // the box holds side × side lattice columns (spacing apart)
  int tile = 1;           // copies per side of a prepared bed (--tile)
  std::vector<int> shapeOfStone;
};

double seconds(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Today's bed: the lattice collapses onto the floor under 10 g in `prepare` coarse steps; the timed run then uses
// the production Δt and gravity while the top layers are still falling.
Bed packingBed(const Options& options, long requested) {
  Bed bed;
  const Parameters p = benchParameters(options.backend, 0.6);
  bed.system = std::make_unique<PolyhedraSystem>(p);
  PolyhedraSystem& system = *bed.system;
  bed.shapeOfStone = addBed(system, requested, true);
  system.setTimeStep(packingTimeStep);
  system.setGravity({0.0, 0.0, -98.1});
  const auto start = std::chrono::steady_clock::now();
  for (int done = 0; done < options.prepare; done += 500) system.step(std::min(500, options.prepare - done));
  bed.prepareSteps = options.prepare;
  bed.prepareSeconds = seconds(start);
  system.setTimeStep(p.timeStep);
  system.setGravity(p.gravity);
  return bed;
}

double lidForce(const PolyhedraSystem& system, const std::vector<int>& lid) {
  const std::vector<double> f = system.triangleForces(); // force of the stones on each triangle
  double sum = 0.0;
  for (int t : lid) sum += f[3 * t + 2];
  return sum;
}

// The box of addLatticeBed (latticeBox: floor, four sides, nodes 0–7, triangles 0–9) and a lid of two triangles over
// the whole bed at height `lid`, facing down (nodes 8–11, triangles 10 and 11).
WallMesh boxWithLid(int side, double lid) {
  WallMesh mesh = latticeBox(side, side, layers, spacing);
  const double x = side * spacing, y = side * spacing;
  mesh.nodes.insert(mesh.nodes.end(), {0, 0, lid, x, 0, lid, x, y, lid, 0, y, lid});
  mesh.triangles.insert(mesh.triangles.end(), {8, 10, 9, 8, 11, 10});
  return mesh;
}

// Velocity servo of the lid (nodes 8–11 of `nodes`, moved here): it approaches at 0.5 m/s until it carries 2 % of
// the target (0.5 mm per 100-step window at Δt = 1e-5 s: less than a contact's overlap at the target), then at up
// to 0.05 m/s in proportion to the pressure error, until the pressure has stayed within 2 % for 20 windows (or
// 60,000 steps). Returns the steps taken and leaves the lid still.
int pressLid(PolyhedraSystem& system, std::vector<double>& nodes, Bed& bed, double target, double timeStep) {
  const int window = 100;
  double lidSpeed = -0.5;
  int calm = 0, steps = 0;
  std::vector<double> velocities(nodes.size(), 0.0);
  while (calm < 20 && steps < 60000) {
    for (int n = 8; n < 12; ++n) velocities[3 * n + 2] = lidSpeed;
    system.setSurfaceKinematics(nodes, velocities);
    system.step(window);
    steps += window;
    for (int n = 8; n < 12; ++n) nodes[3 * n + 2] += lidSpeed * window * timeStep;
    const double pressure = lidForce(system, bed.lidTriangles) / bed.lidArea;
    const double error = (target - pressure) / target;
    lidSpeed = pressure < 0.02 * target ? -0.5 : -0.05 * std::clamp(error, -1.0, 1.0);
    calm = std::abs(error) < 0.02 ? calm + 1 : 0;
  }
  std::fill(velocities.begin(), velocities.end(), 0.0);
  system.setSurfaceKinematics(nodes, velocities);
  return steps;
}

// The frictional stones of the settled bed under the held lid.
std::unique_ptr<PolyhedraSystem> heldLidSystem(const Options& options) {
  Parameters p = benchParameters(options.backend, 0.6, settledYoung);
  p.maxWallNeighbours = 12; // a stone in a corner under the lid: floor, two sides and lid, two each
  return std::make_unique<PolyhedraSystem>(p);
}

// `steps` steps under the held lid, then the stones' speeds (rattlers in voids keep moving slowly).
void rest(Bed& bed, int steps, std::chrono::steady_clock::time_point start) {
  PolyhedraSystem& system = *bed.system;
  system.step(steps);
  bed.prepareSteps += steps;
  const std::vector<double> v = system.velocities();
  std::vector<double> speeds;
  for (std::size_t k = 0; k + 2 < v.size(); k += 3)
    speeds.push_back(std::sqrt(v[k] * v[k] + v[k + 1] * v[k + 1] + v[k + 2] * v[k + 2]));
  std::sort(speeds.begin(), speeds.end());
  bed.restingSpeed = speeds.back();
  bed.speed99 = speeds[speeds.size() * 99 / 100];
  bed.speedMedian = speeds[speeds.size() / 2];
  bed.prepareSeconds = seconds(start);
  std::printf(
      "  mu 0.6, lid held: %d steps, stone speeds median %.3g, 99th percentile %.3g, largest %.3g m/s, "
      "lid %.1f kPa, %.1f s\n",
      steps, bed.speedMedian, bed.speed99, bed.restingSpeed, lidForce(system, bed.lidTriangles) / bed.lidArea / 1e3,
      bed.prepareSeconds);
}

// Compacted ballast under a load. (1) Deposition without friction under 10 g in a box whose lid waits at the top,
// for 20,000 steps of 5e-5 s or until the fastest stone is below 0.05 m/s; (2) still without friction, 1 g and the
// production Δt, the lid pressed to `pressure` (frictionless grains pack as densely as tamping and compaction make
// ballast: with μ = 0.6 during the pressing the 392-stone bed kept a coordination number of 3.5); (3) the same stones
// with μ = 0.6 under the lid held still for 10,000 steps. Stones in voids (rattlers) keep moving slowly; the speed
// percentiles are reported.
Bed settledBed(const Options& options, long requested) {
  Bed bed;
  const auto start = std::chrono::steady_clock::now();
  const int side = latticeSide(requested);
  bed.lidTriangles = {10, 11};
  bed.lidArea = side * spacing * side * spacing;
  bed.side = side;
  const WallMesh box = boxWithLid(side, (layers + 1) * spacing);
  std::vector<double> nodes = box.nodes;
  std::vector<double> positions, orientations;
  {
    // Falling 0.5 m under 10 g reaches ~10 m/s: 2.5 mm per 5 steps, inside half of a 6 mm skin.
    Parameters depositing = benchParameters(options.backend, 0.0, settledYoung);
    depositing.neighbourSkin = 0.006;
    depositing.rebuildInterval = 5;
    depositing.maxWallNeighbours = 12; // a stone in a corner under the lid: floor, two sides and lid, two each
    PolyhedraSystem deposit(depositing);
    addBed(deposit, requested, false);
    deposit.setWalls(nodes, box.triangles);
    deposit.setTimeStep(packingTimeStep);
    deposit.setGravity({0.0, 0.0, -98.1});
    double speed = 1e9;
    for (int chunk = 0; chunk < 20 && speed > 0.05; ++chunk) {
      deposit.step(1000);
      bed.prepareSteps += 1000;
      if (chunk >= 3) speed = maxSpeedOf(deposit);
    }
    std::printf("  deposition (no friction, 10 g): %d steps, fastest stone %.3g m/s, %.1f s\n", bed.prepareSteps, speed,
                seconds(start));
    // Under load the coarse packing step let the bed stir at ~0.5 m/s and squeezed stones through the lid.
    deposit.setTimeStep(1e-5);
    deposit.setGravity({0.0, 0.0, -9.81});
    const std::vector<double> p0 = deposit.positions();
    double top = 0.0;
    for (std::size_t k = 2; k < p0.size(); k += 3) top = std::max(top, p0[k]);
    for (int n = 8; n < 12; ++n) nodes[3 * n + 2] = top + 0.033; // largest bounding radius (0.0319 m) and a gap
    deposit.setSurfaceKinematics(nodes, std::vector<double>(nodes.size(), 0.0));
    const int pressSteps = pressLid(deposit, nodes, bed, options.pressure, 1e-5);
    bed.prepareSteps += pressSteps;
    std::printf("  lid pressed (no friction, 1 g): %d steps to %.1f kPa, lid at %.4f m, %.1f s\n", pressSteps,
                lidForce(deposit, bed.lidTriangles) / bed.lidArea / 1e3, nodes[3 * 8 + 2], seconds(start));
    positions = deposit.positions();
    orientations = deposit.orientations();
  }
  bed.lidHeight = nodes[3 * 8 + 2];
  bed.system = heldLidSystem(options);
  bed.shapeOfStone = addBed(*bed.system, requested, false); // the same stones in the same order; state replaced below
  const std::vector<double> zeros(positions.size(), 0.0);
  bed.system->setState(positions, orientations, zeros, zeros);
  bed.system->setWalls(nodes, box.triangles);
  rest(bed, 10000, start); // 0.1 s: many wave transits of the bed's depth
  return bed;
}

// Hamilton product a ⊗ b of quaternions (w, x, y, z).
std::array<double, 4> product(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1], a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

// K × K copies of a prepared settled bed in a box K times as long and wide under the lid at the same height, each
// copy the mirror image of its neighbours across the plane where they meet (copy (a, b): x → a L + x or (a + 1) L − x
// for odd a, likewise y; L the box's side). A stone that leaned on a side wall then leans on its own mirror image,
// and the seam is as dense as the wall was (plain copies left gaps there: in a 392-stone bed the coordination number
// fell from 5.7 to 5.4). The mirror image of a stone is a stone of the same template: the dodecahedra are symmetric
// about their principal planes, so a world reflection M R is the rotation M R D with D the flip of one body axis, i.e.
// q → q_x(π) ⊗ q ⊗ q_x(π) for a mirror in x, q_y(π) ⊗ q ⊗ q_y(π) in y, q_z(π) ⊗ q in both. Rested for 2000 steps
// (0.02 s; a compression wave crosses the bed's depth in ~0.3 ms).
Bed tiledBed(const Options& options, const Bed& base) {
  const auto start = std::chrono::steady_clock::now();
  const int K = options.tile;
  Bed bed;
  bed.side = base.side;
  bed.tile = K;
  bed.lidTriangles = base.lidTriangles;
  bed.lidHeight = base.lidHeight;
  const double length = base.side * spacing;
  bed.lidArea = K * length * K * length;
  bed.system = heldLidSystem(options);
  PolyhedraSystem& system = *bed.system;
  const std::vector<int> shapes = addShapes(system);
  const std::vector<double> x = base.system->positions(), q = base.system->orientations();
  const std::array<double, 4> halfTurnX{0, 1, 0, 0}, halfTurnY{0, 0, 1, 0}, halfTurnZ{0, 0, 0, 1};
  for (int a = 0; a < K; ++a)
    for (int b = 0; b < K; ++b)
      for (std::size_t k = 0; k < base.shapeOfStone.size(); ++k) {
        const bool mirrorX = a % 2 == 1, mirrorY = b % 2 == 1;
        std::array<double, 4> orientation{q[4 * k], q[4 * k + 1], q[4 * k + 2], q[4 * k + 3]};
        if (mirrorX && mirrorY)
          orientation = product(halfTurnZ, orientation);
        else if (mirrorX)
          orientation = product(product(halfTurnX, orientation), halfTurnX);
        else if (mirrorY)
          orientation = product(product(halfTurnY, orientation), halfTurnY);
        system.addStone(shapes[base.shapeOfStone[k]],
                        {a * length + (mirrorX ? length - x[3 * k] : x[3 * k]),
                         b * length + (mirrorY ? length - x[3 * k + 1] : x[3 * k + 1]), x[3 * k + 2]},
                        orientation);
        bed.shapeOfStone.push_back(base.shapeOfStone[k]);
      }
  const WallMesh box = boxWithLid(base.side * K, base.lidHeight);
  system.setWalls(box.nodes, box.triangles);
  bed.prepareSteps = base.prepareSteps;
  rest(bed, 2000, start);
  bed.prepareSeconds += base.prepareSeconds;
  std::printf("  %d x %d copies of the %zu-stone bed: %zu stones\n", K, K, base.shapeOfStone.size(),
              system.stoneCount());
  return bed;
}

std::string bedPath(const std::string& folder, long requested, const char* suffix) {
  return (std::filesystem::path(folder) / ("settled-" + std::to_string(requested) + suffix)).string();
}

// --save-bed: the prepared bed's state (PolyhedraSystem::writeState) and what the bench reports of its preparation.
void saveBed(const std::string& folder, long requested, const Bed& bed) {
  std::ofstream state(bedPath(folder, requested, ".state"), std::ios::binary);
  bed.system->writeState(state);
  std::ofstream info(bedPath(folder, requested, ".txt"));
  info.precision(17);
  info << bed.lidHeight << ' ' << bed.prepareSteps << ' ' << bed.prepareSeconds << ' ' << bed.speedMedian << ' '
       << bed.speed99 << ' ' << bed.restingSpeed << '\n';
  if (!state || !info) throw std::runtime_error("cannot write the bed to " + folder);
}

// --load-bed: the system built as settledBed builds its last stage, then the saved state read into it.
Bed loadBed(const Options& options, long requested) {
  Bed bed;
  std::ifstream info(bedPath(options.loadBed, requested, ".txt"));
  std::ifstream state(bedPath(options.loadBed, requested, ".state"), std::ios::binary);
  if (!info || !state)
    throw std::runtime_error("--load-bed: no saved bed of " + std::to_string(requested) + " stones in " +
                             options.loadBed + " (written by --save-bed with the same --n)");
  info >> bed.lidHeight >> bed.prepareSteps >> bed.prepareSeconds >> bed.speedMedian >> bed.speed99 >> bed.restingSpeed;
  if (!info) throw std::runtime_error("--load-bed: unreadable " + bedPath(options.loadBed, requested, ".txt"));
  bed.side = latticeSide(requested);
  bed.lidTriangles = {10, 11};
  bed.lidArea = bed.side * spacing * bed.side * spacing;
  bed.system = heldLidSystem(options);
  bed.shapeOfStone = addBed(*bed.system, requested, false);
  const WallMesh box = boxWithLid(bed.side, bed.lidHeight);
  bed.system->setWalls(box.nodes, box.triangles);
  bed.system->readState(state);
  std::printf("  bed of %zu stones read from %s (prepared in %d steps, %.1f s)\n", bed.system->stoneCount(),
              options.loadBed.c_str(), bed.prepareSteps, bed.prepareSeconds);
  return bed;
}

// The bed as a table (--export): stones in the system's order, and what another code needs to rebuild the scene.
void exportBed(const std::string& path, const PolyhedraSystem& system, const Bed& bed, const Parameters& p) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  out.precision(9);
  const int side = bed.side * bed.tile;
  const std::vector<double> x = system.positions(), v = system.velocities();
  out << "# box_x_m " << side * spacing << "\n# box_y_m " << side * spacing << "\n# lid_z_m " << bed.lidHeight
      << "\n# lid_pressure_Pa " << bed.lidPressure << "\n# time_step_s " << p.timeStep << "\n# young_Pa "
      << p.stone.youngModulus << "\n# poisson " << p.stone.poissonRatio << "\n# restitution " << p.stone.restitution
      << "\n# friction " << p.stone.friction << "\n# gravity_m_s2 " << -p.gravity[2] << "\n";
  out << "x,y,z,vx,vy,vz,mass,volume,circumradius\n";
  for (std::size_t k = 0; k < system.stoneCount(); ++k) {
    const ShapeProperties& shape = system.shapeProperties(bed.shapeOfStone[k]);
    out << x[3 * k] << ',' << x[3 * k + 1] << ',' << x[3 * k + 2] << ',' << v[3 * k] << ',' << v[3 * k + 1] << ','
        << v[3 * k + 2] << ',' << shape.mass << ',' << shape.dilatedVolume << ',' << shape.circumradius << '\n';
  }
}

// Times `options.steps` steps of `bed` and returns its JSON record; `label` names the bed in --export files.
std::string timeBed(const Options& options, Bed& bed, const std::string& label) {
  PolyhedraSystem& system = *bed.system;
  const Parameters p = benchParameters(options.backend, 0.6);
  const double maxSpeedBefore = maxSpeedOf(system);
  system.step(20); // warm-up: CUDA graphs captured, caches filled
  const auto start = std::chrono::steady_clock::now();
#ifdef RAILCOSIM_BENCH_PROFILER_RANGE
  cudaProfilerStart();
#endif
  system.step(options.steps);
#ifdef RAILCOSIM_BENCH_PROFILER_RANGE
  cudaProfilerStop();
#endif
  const double wall = seconds(start);
  const StepStatistics stats = system.lastStatistics();
  if (options.settled) {
    bed.lidPressure = lidForce(system, bed.lidTriangles) / bed.lidArea;
    long pairs = 0, walls = 0;
    for (const ContactRecord& c : system.contacts()) (c.wall ? walls : pairs) += 1;
    bed.coordination = 2.0 * pairs / static_cast<double>(system.stoneCount());
    bed.wallContacts = walls / static_cast<double>(system.stoneCount());
  }
  // Snapshot cost: the mean of 10 saves and of 10 restores, and one writeState into memory.
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
  const double maxSpeed = maxSpeedOf(system); // how settled the bed is (it decides how many list rebuilds are needed)
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
         << ", \"bed\": \"" << (options.settled ? "settled" : "packing")
         << "\", \"max_speed_before_m_s\": " << maxSpeedBefore << ", \"coordination_number\": " << bed.coordination
         << ", \"wall_contacts_per_particle\": " << bed.wallContacts
         << ", \"speed_before_median_m_s\": " << bed.speedMedian << ", \"speed_before_p99_m_s\": " << bed.speed99
         << ", \"lid_pressure_Pa\": " << bed.lidPressure
         << ", \"target_pressure_Pa\": " << (options.settled ? options.pressure : 0.0)
         << ", \"prepare_steps\": " << bed.prepareSteps << ", \"prepare_wall_s\": " << bed.prepareSeconds
         << ", \"time_step_s\": " << p.timeStep << ", \"snapshot_save_s\": " << saveSeconds
         << ", \"snapshot_restore_s\": " << restoreSeconds << ", \"write_state_s\": " << writeSeconds
         << ", \"state_bytes\": " << state.str().size() << ", \"tile\": " << bed.tile << "}";
  if (!options.exportPrefix.empty())
    exportBed(options.exportPrefix + "-" + label + ".csv", system, bed,
              options.settled ? benchParameters(options.backend, 0.6, settledYoung) : p);
  std::printf("%-30s %10zu %6d %8.3f %10.4f %14.4e %14.4e %10.2f %10.4f\n", device.substr(0, 30).c_str(),
              system.stoneCount(), options.steps, wall, 1e3 * wall / options.steps, particleSteps, contactsPerSecond,
              contactsPerStone, fraction);
  std::fflush(stdout);
  return record.str();
}

} // namespace

// The records as a JSON list.
std::string jsonList(const std::vector<std::string>& records) {
  std::string list = "[\n";
  for (std::size_t k = 0; k < records.size(); ++k) list += "  " + records[k] + (k + 1 < records.size() ? ",\n" : "\n");
  return list + "]\n";
}

int main(int argc, char** argv) try {
  const Options options = parse(argc, argv);
  std::vector<std::string> records;
  // Each record is written as soon as it exists: a run stopped by a time limit keeps the beds already timed.
  auto keep = [&](std::string record) {
    records.push_back(std::move(record));
    if (!options.json.empty()) std::ofstream(options.json) << jsonList(records);
  };
  std::printf("%-30s %10s %6s %8s %10s %14s %14s %10s %10s\n", "device", "stones", "steps", "wall_s", "ms/step",
              "p-steps/s", "contacts/s", "cont/stone", "bw_frac");
  for (const long requested : options.sizes) {
    Bed bed = !options.loadBed.empty() ? loadBed(options, requested)
              : options.settled        ? settledBed(options, requested)
                                       : packingBed(options, requested);
    if (!options.saveBed.empty()) saveBed(options.saveBed, requested, bed);
    keep(timeBed(options, bed, std::to_string(requested)));
    if (options.tile > 1) {
      Bed tiled = tiledBed(options, bed);
      bed.system.reset(); // the copies' device memory beside the base bed's, not three beds at once
      keep(timeBed(options, tiled, std::to_string(requested) + "x" + std::to_string(options.tile * options.tile)));
    }
  }
  std::printf("%s", jsonList(records).c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "polyhedra_bench: %s\n", e.what());
  return 1;
}
