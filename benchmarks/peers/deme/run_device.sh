#!/usr/bin/env bash
# The peer side by side on a GPU machine (README.md): the settled, loaded bed of polyhedra_bench at each size, then
# the same bed in Chrono DEM-Engine (DEME) with the same time step and number of steps, in one run.
# Usage (repository root): DEME_SRC=DIR benchmarks/peers/deme/run_device.sh OUTDIR [sizes...]   (default 100000)
#   DEME_SRC: projectchrono/DEM-Engine with its thirdparty/jitify submodule (not part of railcosim: README.md gives
#   the commits). Environment: DEME_BUILD (default /tmp/deme-build, reused when built), BENCH_BUILD (polyhedra_bench,
#   default /tmp/polyhedra-bench-build), BENCH_STEPS (200), EIGEN_INCLUDE (as benchmarks/gpu/run_device.sh).
# Writes OUTDIR/peer.json (one record per size with both codes' particle-steps/s and their ratio) and the logs.
set -euo pipefail
out=${1:?usage: DEME_SRC=DIR run_device.sh OUTDIR [sizes...]}
shift
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(100000)
src=${DEME_SRC:?set DEME_SRC to a DEM-Engine checkout with thirdparty/jitify}
deme_build=${DEME_BUILD:-/tmp/deme-build}
bench_build=${BENCH_BUILD:-/tmp/polyhedra-bench-build}
steps=${BENCH_STEPS:-200}
root=$(pwd)
mkdir -p "$out" "$deme_build" "$bench_build"
out=$(cd "$out" && pwd)
export PATH=/usr/local/cuda/bin:$PATH
# Jitify (v1) takes the -I options away from NVRTC and finds each header by compiling until NVRTC names the next
# missing one: under CUDA 13 a kernel program of DEME pulls about 220 CCCL headers, one compile each (about 85 s per
# program, more than 10 minutes before DEME's first step). Kept on NVRTC's command line, the include paths let NVRTC
# open the headers itself (about 18 s for all programs). Applied to the copy being built, once.
python3 - "$src/thirdparty/jitify/jitify.hpp" <<'PATCH'
import sys
path = sys.argv[1]
text = open(path).read()
old = """      include_paths->push_back(opt.substr(2));
      iter = program_options->erase(iter);"""
new = """      include_paths->push_back(opt.substr(2));
      ++iter;  // kept: NVRTC resolves headers on these paths itself"""
if new not in text:
    if old not in text:
        sys.exit(f"{path}: the include-path handling of load_program is not the expected one; patch not applied")
    open(path, "w").write(text.replace(old, new))
    print("jitify: include paths kept for NVRTC")
PATCH
start=$(date +%s)
(
  if [ ! -f "$deme_build/.built" ]; then
    cub=$(ls -d /usr/local/cuda*/targets/x86_64-linux/lib/cmake/cub 2>/dev/null | head -1)
    cmake -S "$src" -B "$deme_build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=90 ${cub:+-DCUB_DIR=$cub}
    cmake --build "$deme_build" -j"$(nproc)" --target simulator_multi_gpu
    touch "$deme_build/.built"
  fi
  cmake -S "$root/benchmarks/peers/deme" -B "$deme_build/peer" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CUDA_ARCHITECTURES=90 -DDEME_DIR="$deme_build/DEME"
  cmake --build "$deme_build/peer" -j"$(nproc)"
) > "$out/deme_build.log" 2>&1 &
deme_job=$!
BUILD_ONLY=1 BUILD_DIR="$bench_build" "$root/benchmarks/gpu/run_device.sh" "$out/polyhedra_build" > "$out/bench_build.log" 2>&1
wait "$deme_job" || { tail -30 "$out/deme_build.log"; exit 1; }
echo "builds: $(( $(date +%s) - start )) s"
beds=$(mktemp -d)
records=()
for n in "${sizes[@]}"; do
  "$bench_build/polyhedra_bench" --n "$n" --bed settled --backend cuda --steps "$steps" \
    --json "$out/polyhedra-$n.json" --export "$beds/bed" 2>&1 | tee "$out/polyhedra-$n.log"
  "$deme_build/peer/deme_settled_bed" "$beds/bed-$n.csv" --steps "$steps" --json "$out/deme-$n.json" 2>&1 \
    | tee "$out/deme-$n.log"
  head -11 "$beds/bed-$n.csv" > "$out/bed-$n-header.txt"
  records+=("$n")
done
python3 - "$out" "${records[@]}" <<'JOIN'
import json, sys
out, sizes = sys.argv[1], sys.argv[2:]
rows = []
for n in sizes:
    ours = json.load(open(f"{out}/polyhedra-{n}.json"))[0]
    deme = json.load(open(f"{out}/deme-{n}.json"))
    rows.append({"stones": ours["n_particles"], "steps": ours["steps"], "time_step_s": ours["time_step_s"],
                 "railcosim_particle_steps_per_s": ours["particle_steps_per_s"],
                 "railcosim_contacts_per_particle": ours["contacts_per_particle"],
                 "railcosim_coordination_number": ours["coordination_number"],
                 "deme_particle_steps_per_s": deme["particle_steps_per_s"],
                 "deme_contacts_per_particle": deme["contacts_per_particle"],
                 "deme_initialize_s": deme["initialize_s"],
                 "ratio_railcosim_over_deme": ours["particle_steps_per_s"] / deme["particle_steps_per_s"],
                 "device": ours["device"]})
    print(json.dumps(rows[-1]))
json.dump(rows, open(f"{out}/peer.json", "w"), indent=1)
JOIN
rm -rf "$beds"
