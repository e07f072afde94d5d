#!/usr/bin/env bash
# Builds and runs the rotation-scheme accuracy-vs-cost benchmark, then plots it (about one minute).
# Usage: benchmarks/rotation/run_rotation_benchmark.sh [build-dir [out-dir]]
#   build-dir default /tmp/railcosim-rotation-benchmark; out-dir (rotation_accuracy_cost.{json,txt,png}) default
#   ./results/bench/rotation, which git ignores: benchmarks/results/ only when named (`./railcosim bench rotation --save`).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-/tmp/railcosim-rotation-benchmark}
out=${2:-$root/results/bench/rotation}
mkdir -p "$build" "$out"
# Header-only kernels: one translation unit, compiled like the Release build of the tests.
g++ -std=c++17 -O3 -DNDEBUG -I"$root/yade_engines" -I"$root/tests/rotation" \
    "$root/benchmarks/rotation/RotationBenchmark.cpp" -o "$build/rotation_benchmark"
"$build/rotation_benchmark" "$out/rotation_accuracy_cost.json" | tee "$out/rotation_accuracy_cost.txt"
/usr/bin/python3 "$root/benchmarks/rotation/plot_rotation_benchmark.py" "$out/rotation_accuracy_cost.png" \
    "$out/rotation_accuracy_cost.json"
