#!/usr/bin/env bash
# Profiles one launch of each polyhedra kernel with Nsight Compute during the benchmark's timed steps (needs BUILD_DIR
# from run_device.sh, whose benchmark opens the profiler range around them: the bed's preparation, however long, is
# not profiled).
# Usage: BUILD_DIR=/tmp/pbd [N=100000] [BENCH_BED=packing|settled] [BENCH_ARGS="--load-bed DIR"] \
#          benchmarks/gpu/profile_device.sh OUTDIR
# With BENCH_ARGS="--load-bed DIR" the settled bed that run_device.sh saved (BENCH_ARGS="--save-bed DIR") is profiled
# without being prepared again. Warp stall reasons per kernel: the WarpStateStats section in ncu.txt.
set -euo pipefail
out=${1:-polyhedra-profile-out}
mkdir -p "$out"
bench=${BUILD_DIR:?set BUILD_DIR to the folder holding polyhedra_bench}/polyhedra_bench
# 40 timed steps; the first 20 kernel launches inside them (one rebuild chunk: each kernel at least once).
ncu --profile-from-start off --launch-count 20 --section SpeedOfLight --section Occupancy --section LaunchStats \
    --section MemoryWorkloadAnalysis --section WarpStateStats --section SourceCounters \
    --metrics gpu__time_duration.sum,l1tex__t_bytes_pipe_lsu_mem_local_op_ld.sum,lts__t_bytes.sum \
    "$bench" --n "${N:-100000}" --steps 40 --prepare "${BENCH_PREPARE:-300}" --bed "${BENCH_BED:-packing}" \
    ${BENCH_ARGS:-} --backend cuda > "$out/ncu.txt" 2>&1 || true
pattern="^  [a-zA-Z_:<>]+.*\(|gpu__time_duration|Duration|Achieved Occupancy|Registers Per|Local Memory"
pattern+="|Memory Throughput|Compute \(SM\)|L1/TEX Hit|L2 Hit|local_op_ld|lts__t_bytes|Stall|Warp Cycles Per"
grep -E "$pattern" \
  "$out/ncu.txt" | head -250
