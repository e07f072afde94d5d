#!/usr/bin/env bash
# Builds and runs the rotation-scheme accuracy-vs-cost benchmark, then plots it (about one minute).
# Usage: benchmarks/rotation/run_rotation_benchmark.sh [build-dir]   (default /tmp/railcosim-rotation-benchmark)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-/tmp/railcosim-rotation-benchmark}
mkdir -p "$build" "$root/benchmarks/results"
# Header-only kernels: one translation unit, compiled like the Release build of the tests.
g++ -std=c++17 -O3 -DNDEBUG -I"$root/yade_engines" -I"$root/tests/rotation" \
    "$root/benchmarks/rotation/RotationBenchmark.cpp" -o "$build/rotation_benchmark"
"$build/rotation_benchmark" "$root/benchmarks/results/rotation_accuracy_cost.json" \
    | tee "$root/benchmarks/results/rotation_accuracy_cost.txt"
/usr/bin/python3 "$root/benchmarks/rotation/plot_rotation_benchmark.py" "$root/benchmarks/results/rotation_accuracy_cost.png" \
    "$root/benchmarks/results/rotation_accuracy_cost.json"
