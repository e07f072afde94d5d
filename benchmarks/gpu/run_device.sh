#!/usr/bin/env bash
# Builds the polyhedra library, GPU comparison and benchmark with nvcc alone (no CMake/Boost needed) and runs them.
# Usage (repository root, on a machine with an NVIDIA GPU): benchmarks/gpu/run_device.sh [OUTDIR] [bench sizes...]
#   OUTDIR defaults to ./polyhedra-device-out; sizes default to 10000 100000 1000000.
# Needs Eigen 3 headers for the host code (Debian libeigen3-dev, or any copy: EIGEN_INCLUDE).
# Environment: NVCC (default /usr/local/cuda/bin/nvcc or nvcc on PATH), CUDA_ARCH (default sm_90),
#   EXTRA_NVCC_FLAGS (e.g. -maxrregcount=128), BENCH_STEPS (200), BENCH_PREPARE (3000), SKIP_COMPARISON=1,
#   BUILD_DIR (keeps the executables polyhedra_bench and polyhedra_gpu_comparison; default a temporary folder),
#   BUILD_ONLY=1 (stop after the build), EIGEN_INCLUDE (default /usr/include/eigen3),
#   BENCH_BED (packing, the default, or settled: see benchmarks/gpu/PolyhedraBench.cpp),
#   BENCH_ARGS (more options of polyhedra_bench, e.g. "--tile 2 --save-bed DIR" with BENCH_BED=settled).
set -euo pipefail
out=${1:-polyhedra-device-out}
shift || true
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(10000 100000 1000000)
mkdir -p "$out"
nvcc=${NVCC:-$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)}
arch=${CUDA_ARCH:-sm_90}
build=${BUILD_DIR:-$(mktemp -d)}
mkdir -p "$build"
includes="-Iyade_engines -Ibridge/include"
common="-O3 -std=c++17 $includes"
# Eigen configured as in the CMake build (yade_engines/polyhedra/CMakeLists.txt), so that both give the same numbers.
eigen="-I${EIGEN_INCLUDE:-/usr/include/eigen3} -DEIGEN_DONT_ALIGN -DEIGEN_DONT_VECTORIZE -DEIGEN_DISABLE_UNALIGNED_ARRAY_ASSERT"
echo "== device"; nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
echo "== tools"; "$nvcc" --version | tail -1; (cmake --version | head -1) || true
echo "== build ($arch ${EXTRA_NVCC_FLAGS:-})"
start=$(date +%s)
"$nvcc" $common -arch=$arch ${EXTRA_NVCC_FLAGS:-} -Xcompiler -fopenmp --expt-relaxed-constexpr -Xptxas -v \
  -c yade_engines/polyhedra/cuda/PolyhedraCudaBackend.cu -o "$build/cuda.o" 2> "$out/ptxas.txt" &
for f in yade_engines/polyhedra/PolyhedraSystem.cpp yade_engines/polyhedra/cpu/PolyhedraCpuBackend.cpp yade_engines/polyhedra/PolyhedraShapes.cpp \
         bridge/src/io/Log.cpp bridge/src/io/StateStream.cpp tests/polyhedra/PolyhedraGpuComparison.cpp \
         benchmarks/gpu/PolyhedraBench.cpp; do
  g++ $common $eigen -fopenmp -I/usr/local/cuda/include -DRAILCOSIM_BENCH_PROFILER_RANGE -c "$f" \
    -o "$build/$(basename "$f" .cpp).o" &
done
wait
grep -A2 -E "narrowPhaseKernel|filterKernel|wallForcesKernel|forcesKernel" "$out/ptxas.txt" | grep -E "stack|registers" || true
lib="$build/cuda.o $build/PolyhedraSystem.o $build/PolyhedraCpuBackend.o $build/PolyhedraShapes.o $build/Log.o \
  $build/StateStream.o"
"$nvcc" -arch=$arch $lib "$build/PolyhedraGpuComparison.o" -o "$build/polyhedra_gpu_comparison" -Xcompiler -fopenmp -lgomp
"$nvcc" -arch=$arch $lib "$build/PolyhedraBench.o" -o "$build/polyhedra_bench" -Xcompiler -fopenmp -lgomp
echo "build took $(( $(date +%s) - start )) s"
[ "${BUILD_ONLY:-0}" = 1 ] && exit 0
if [ "${SKIP_COMPARISON:-0}" != 1 ]; then
  echo "== GPU vs CPU comparison"
  "$build/polyhedra_gpu_comparison" 2>&1 | tee "$out/comparison.txt"
fi
echo "== benchmark"
args=()
for n in "${sizes[@]}"; do args+=(--n "$n"); done
"$build/polyhedra_bench" "${args[@]}" --steps "${BENCH_STEPS:-200}" --prepare "${BENCH_PREPARE:-3000}" --backend cuda \
  --bed "${BENCH_BED:-packing}" ${BENCH_ARGS:-} --json "$out/gpu_polyhedra_gpu.json" 2>&1 | tee "$out/bench.txt"
