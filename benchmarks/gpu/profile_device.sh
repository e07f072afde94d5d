#!/usr/bin/env bash
# Profiles one launch of each polyhedra kernel with Nsight Compute at N ≈ 1e5 (needs BUILD_DIR from run_device.sh).
# Usage: BUILD_DIR=/tmp/pbd benchmarks/gpu/profile_device.sh OUTDIR
set -euo pipefail
out=${1:-polyhedra-profile-out}
mkdir -p "$out"
bench=${BUILD_DIR:?set BUILD_DIR to the folder holding polyhedra_bench}/polyhedra_bench
# 300 packing steps then 40 timed ones; skip the packing launches, then catch one of each kernel.
ncu --launch-skip 1000 --launch-count 12 --section SpeedOfLight --section Occupancy --section LaunchStats \
    --section MemoryWorkloadAnalysis --metrics gpu__time_duration.sum,l1tex__t_bytes_pipe_lsu_mem_local_op_ld.sum,lts__t_bytes.sum \
    "$bench" --n 100000 --steps 40 --prepare 300 --backend cuda > "$out/ncu.txt" 2>&1 || true
grep -E "^  [a-zA-Z_:<>]+.*\(|gpu__time_duration|Duration|Achieved Occupancy|Registers Per|Local Memory|Memory Throughput|Compute \(SM\)|L1/TEX Hit|L2 Hit|local_op_ld|lts__t_bytes" "$out/ncu.txt" | head -150
