// The settled, loaded bed of polyhedra_bench (--bed settled --export) in Chrono DEM-Engine (DEME): each stone a
// one-sphere DEME clump of the stone's mass and volume (the sphere of equal volume), at the stone's position and
// velocity, in the same box under the same held lid, with the same material, time step and gravity; DEME's default
// Hertz–Mindlin model. Times the same number of steps as the bench and prints one JSON record (also to --json FILE).
//
// Usage: deme_settled_bed BED.csv [--steps S] [--warmup W] [--json FILE]
// Built against an installed DEME (benchmarks/peers/deme/run_device.sh): not part of railcosim's build.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <DEM/API.h>

using namespace deme;

namespace {

struct Stone {
  float3 position, velocity;
  double mass, volume;
};

struct BedFile {
  std::map<std::string, double> info; // "# key value" lines: box, lid, time step, material, gravity
  std::vector<Stone> stones;
  double get(const std::string& key) const {
    auto it = info.find(key);
    if (it == info.end()) throw std::runtime_error("bed file: no '# " + key + "' line");
    return it->second;
  }
};

BedFile readBed(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  BedFile bed;
  std::string line;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      std::istringstream fields(line.substr(1));
      std::string key;
      double value;
      if (fields >> key >> value) bed.info[key] = value;
      continue;
    }
    if (!header) { // column names
      header = true;
      continue;
    }
    std::vector<double> v;
    std::istringstream fields(line);
    for (std::string cell; std::getline(fields, cell, ',');) v.push_back(std::stod(cell));
    if (v.size() < 8) throw std::runtime_error(path + ": a stone row needs 9 columns: " + line);
    bed.stones.push_back({make_float3(v[0], v[1], v[2]), make_float3(v[3], v[4], v[5]), v[6], v[7]});
  }
  if (bed.stones.empty()) throw std::runtime_error(path + ": no stones");
  return bed;
}

} // namespace

int main(int argc, char** argv) try {
  if (argc < 2) throw std::runtime_error("usage: deme_settled_bed BED.csv [--steps S] [--warmup W] [--json FILE]");
  std::string bedPath = argv[1], json;
  int steps = 200, warmup = 20;
  auto count = [](const std::string& option, const std::string& text) {
    std::size_t used = 0;
    int value = -1;
    try {
      value = std::stoi(text, &used);
    } catch (const std::exception&) {
    }
    if (used != text.size() || value < 0) throw std::runtime_error(option + ": a whole number >= 0, not '" + text + "'");
    return value;
  };
  for (int k = 2; k < argc; k += 2) {
    const std::string a = argv[k];
    if (k + 1 >= argc) throw std::runtime_error("missing value after " + a);
    if (a == "--steps") steps = count(a, argv[k + 1]);
    else if (a == "--warmup") warmup = count(a, argv[k + 1]);
    else if (a == "--json") json = argv[k + 1];
    else throw std::runtime_error("unknown option " + a);
  }
  if (steps < 1) throw std::runtime_error("--steps: at least 1");
  const BedFile bed = readBed(bedPath);
  const double dt = bed.get("time_step_s"), boxX = bed.get("box_x_m"), boxY = bed.get("box_y_m");
  const double lid = bed.get("lid_z_m");

  DEMSolver sim;
  sim.SetVerbosity("ERROR");
  sim.SetOutputFormat("CSV");
  sim.InstructBoxDomainDimension({-0.01f, float(boxX + 0.01)}, {-0.01f, float(boxY + 0.01)},
                                 {-0.01f, float(lid + 0.01)});
  auto material = sim.LoadMaterial({{"E", float(bed.get("young_Pa"))}, {"nu", float(bed.get("poisson"))},
                                    {"CoR", float(bed.get("restitution"))}, {"mu", float(bed.get("friction"))},
                                    {"Crr", 0.0f}});
  // The floor, four sides and the lid, facing the stones.
  sim.AddBCPlane(make_float3(0, 0, 0), make_float3(0, 0, 1), material);
  sim.AddBCPlane(make_float3(0, 0, float(lid)), make_float3(0, 0, -1), material);
  sim.AddBCPlane(make_float3(0, 0, 0), make_float3(1, 0, 0), material);
  sim.AddBCPlane(make_float3(float(boxX), 0, 0), make_float3(-1, 0, 0), material);
  sim.AddBCPlane(make_float3(0, 0, 0), make_float3(0, 1, 0), material);
  sim.AddBCPlane(make_float3(0, float(boxY), 0), make_float3(0, -1, 0), material);

  // One sphere template per distinct stone (the bench's four), radius of the sphere of the stone's volume.
  std::map<std::pair<double, double>, std::shared_ptr<DEMClumpTemplate>> templates;
  std::vector<std::shared_ptr<DEMClumpTemplate>> types;
  std::vector<float3> positions, velocities;
  for (const Stone& s : bed.stones) {
    auto& t = templates[{s.mass, s.volume}];
    if (!t) t = sim.LoadSphereType(float(s.mass), float(std::cbrt(3.0 * s.volume / (4.0 * M_PI))), material);
    types.push_back(t);
    positions.push_back(s.position);
    velocities.push_back(s.velocity);
  }
  auto batch = sim.AddClumps(types, positions);
  batch->SetVel(velocities);
  sim.SetGravitationalAcceleration(make_float3(0, 0, float(-bed.get("gravity_m_s2"))));
  sim.SetInitTimeStep(dt);

  auto clock = [] { return std::chrono::steady_clock::now(); };
  auto since = [](auto t) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count(); };
  auto t0 = clock();
  sim.Initialize();
  const double initSeconds = since(t0);
  sim.DoDynamicsThenSync(warmup * dt); // contact lists built, kernels loaded
  t0 = clock();
  sim.DoDynamicsThenSync(steps * dt);
  const double wall = since(t0);
  const double n = double(bed.stones.size());
  const double contacts = double(sim.GetNumContacts());
  std::ostringstream record;
  record.precision(6);
  record << "{\"code\": \"DEME\", \"particles\": \"one-sphere clumps of equal mass and volume\", \"n_particles\": "
         << bed.stones.size() << ", \"steps\": " << steps << ", \"time_step_s\": " << dt << ", \"wall_s\": " << wall
         << ", \"particle_steps_per_s\": " << n * steps / wall << ", \"contacts_at_end\": " << contacts
         << ", \"contacts_per_particle\": " << contacts / n << ", \"initialize_s\": " << initSeconds << "}";
  std::printf("%s\n", record.str().c_str());
  if (!json.empty()) std::ofstream(json) << record.str() << "\n";
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "deme_settled_bed: %s\n", e.what());
  return 1;
}
