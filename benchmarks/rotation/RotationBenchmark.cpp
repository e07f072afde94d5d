// Accuracy against cost of the rotation schemes (ZvW, RK4, direct) on tests R1, R2 and R4 over a range of Δt.
//
// Not a test: it prints a table and writes JSON (default benchmarks/results/rotation_accuracy_cost.json);
// plot with benchmarks/rotation/plot_rotation_benchmark.py. Kernels only, no YADE. Build and run:
//   benchmarks/rotation/run_rotation_benchmark.sh
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "RotationScenes.hpp"

using namespace railcosim;
using kernels::RotationScheme;

namespace {

struct Sample {
  std::string test;
  std::string scheme;
  double timeStep;
  double error;
  std::string errorMeasure;
  double wallSeconds; // per run
  double cpuSeconds;  // per run: the fair measure when other jobs share the machine
};

struct Timing {
  double wallSeconds;
  double cpuSeconds;
};

// Runs `once` repeatedly until at least `minimumSeconds` have passed; returns the mean times of one run.
Timing timeRuns(const std::function<void()>& once, double minimumSeconds) {
  using Clock = std::chrono::steady_clock;
  int runs = 0;
  const auto start = Clock::now();
  const std::clock_t cpuStart = std::clock();
  double elapsed = 0.0;
  do {
    once();
    ++runs;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < minimumSeconds);
  const double cpu = static_cast<double>(std::clock() - cpuStart) / CLOCKS_PER_SEC;
  return Timing{elapsed / runs, cpu / runs};
}

} // namespace

int main(int argc, char** argv) {
  const std::string output = argc > 1 ? argv[1] : "benchmarks/results/rotation_accuracy_cost.json";
  const RotationScheme schemes[] = {RotationScheme::zhaoVanWachem, RotationScheme::rungeKutta4, RotationScheme::direct};
  std::vector<Sample> samples;

  for (RotationScheme scheme : schemes) {
    for (double dt : {4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5}) {
      rotationscenes::PrecessionResult result{};
      const Timing seconds = timeRuns([&] { result = rotationscenes::runFreePrecession(scheme, dt); }, 0.05);
      samples.push_back({"R1", kernels::rotationSchemeName(scheme), dt, result.maxBodyOmegaError,
                         "max |w' - w'_exact| [rad/s] over 0.5 s", seconds.wallSeconds, seconds.cpuSeconds});
    }
    for (double dt : {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4}) {
      rotationscenes::SphereTorqueResult result{};
      const Timing seconds =
          timeRuns([&] { result = rotationscenes::runSphereUnderExponentialTorque(scheme, dt); }, 0.05);
      samples.push_back({"R2", kernels::rotationSchemeName(scheme), dt, result.angleError,
                         "|theta - theta_exact| [rad] at 1 s", seconds.wallSeconds, seconds.cpuSeconds});
    }
    for (double dt : {2e-5, 1e-5, 5e-6, 2e-6, 1e-6}) {
      rotationscenes::BounceResult result{};
      const Timing seconds = timeRuns([&] { result = rotationscenes::runNineFibres(scheme, dt, 0.6); }, 0.0);
      samples.push_back({"R4", kernels::rotationSchemeName(scheme), dt, result.maxRelativeEnergyError,
                         "max |E - E0|/E0 [-] over 0.6 s", seconds.wallSeconds, seconds.cpuSeconds});
    }
  }

  std::printf("%-4s %-14s %-10s %-12s %-12s %-12s\n", "test", "scheme", "dt [s]", "error", "wall [s]", "cpu [s]");
  for (const Sample& s : samples) {
    std::printf("%-4s %-14s %-10.3g %-12.4g %-12.4g %-12.4g\n", s.test.c_str(), s.scheme.c_str(), s.timeStep, s.error,
                s.wallSeconds, s.cpuSeconds);
  }
  std::ofstream json(output);
  if (!json) {
    std::cerr << "RotationBenchmark: cannot write '" << output << "'; pass a writable path as the first argument\n";
    return 1;
  }
  json
      << "{\n  \"description\": \"Rotation schemes accuracy vs cost (kernels only; Irazabal 2017 tests R1, R2, R4)\",\n"
      << "  \"samples\": [\n";
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    char line[512];
    std::snprintf(line, sizeof line,
                  "    {\"test\": \"%s\", \"scheme\": \"%s\", \"timeStep\": %.6g, \"error\": %.6g, "
                  "\"errorMeasure\": \"%s\", \"wallSeconds\": %.6g, \"cpuSeconds\": %.6g}%s\n",
                  s.test.c_str(), s.scheme.c_str(), s.timeStep, s.error, s.errorMeasure.c_str(), s.wallSeconds,
                  s.cpuSeconds, i + 1 < samples.size() ? "," : "");
    json << line;
  }
  json << "  ]\n}\n";
  return 0;
}
