#!/usr/bin/env bash
# Builds the protocol fuzzer (clang, libFuzzer, ASan, UBSan; tests/fuzz) and runs it; exits non-zero on any finding.
#
#   tools/fuzz.sh [RUNS] [LIBFUZZER FLAGS...]   RUNS inputs (default 1e6), e.g. tools/fuzz.sh 2e6 -seed=7
#   tools/fuzz.sh --coverage                    line/branch coverage of the decoders by the corpus gathered so far
#   tools/fuzz.sh --write-seeds                 rewrite tests/fuzz/corpus from the encoders (after a protocol change)
#
# Build and working corpus: $RAILCOSIM_FUZZ_BUILD (default $RAILCOSIM_CACHE/fuzz-protocol, ~/.cache/railcosim);
# the CTest test fuzz_protocol_short points it at the build tree's copy. Findings land in that folder's artifacts/.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RAILCOSIM_FUZZ_BUILD:-${RAILCOSIM_CACHE:-$HOME/.cache/railcosim}/fuzz-protocol}
jobs=${RAILCOSIM_JOBS:-$(nproc)}
corpus=$build/corpus        # new inputs the fuzzer finds: kept between runs, never committed
seeds=$build/seeds          # the seeds written afresh by this build: valid even right after a protocol change
artifacts=$build/artifacts  # crash-*, timeout-*, oom-*, leak-*: the inputs that found something
log=$build/last-run.log

say() { printf '[fuzz] %s\n' "$*"; }
die() { printf '[fuzz] ERROR: %s\n' "$*" >&2; exit 1; }

# build [TARGET]: configures once with clang++, then lets make decide what is out of date (the default targets first:
# they re-run cmake after a change of tests/fuzz/CMakeLists.txt, before TARGET is looked up).
build() {
  mkdir -p "$build"
  if [ ! -f "$build/CMakeCache.txt" ]; then
    local cxx=${RAILCOSIM_FUZZ_CXX:-$(command -v clang++ || command -v clang++-14 || true)}
    [ -n "$cxx" ] || die "no clang++ found; install Debian's clang and libclang-rt-14-dev"
    cmake -S "$root/tests/fuzz" -B "$build" -DCMAKE_CXX_COMPILER="$cxx" > "$build/configure.log" 2>&1 ||
      { tail -n 30 "$build/configure.log" >&2; die "configuring the fuzzer failed; see $build/configure.log"; }
  fi
  { cmake --build "$build" -j "$jobs" && if [ -n "${1:-}" ]; then cmake --build "$build" -j "$jobs" --target "$1"; fi; } \
    > "$build/build.log" 2>&1 ||
    { tail -n 40 "$build/build.log" >&2; die "building the fuzzer failed; see $build/build.log"; }
}

case "${1:-}" in
  --write-seeds)
    # Overwrites the generated seeds only: reproducers added to the corpus by hand stay.
    build
    exec "$build/protocol_seeds" "$root/tests/fuzz/corpus" ;;
  --coverage)
    # Replays the committed seeds and the working corpus once through a coverage build (no mutation).
    build protocol_fuzzer_coverage
    llvm=$(dirname "$(readlink -f "$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")")")
    mkdir -p "$build/coverage" "$corpus"
    LLVM_PROFILE_FILE=$build/coverage/replay.profraw "$build/protocol_fuzzer_coverage" -runs=0 -max_len=70000 \
      "$corpus" "$root/tests/fuzz/corpus" > "$build/coverage/replay.log" 2>&1 ||
      { tail -n 20 "$build/coverage/replay.log" >&2; die "replaying the corpus failed"; }
    "$llvm/llvm-profdata" merge -sparse "$build/coverage/replay.profraw" -o "$build/coverage/replay.profdata"
    say "$(find "$corpus" "$root/tests/fuzz/corpus" -type f | wc -l) corpus files replayed; per-line detail:" \
        "$llvm/llvm-cov show $build/protocol_fuzzer_coverage -instr-profile=$build/coverage/replay.profdata FILE"
    exec "$llvm/llvm-cov" report "$build/protocol_fuzzer_coverage" -instr-profile="$build/coverage/replay.profdata" \
      "$root/bridge/src/protocol/Message.cpp" "$root/bridge/src/mesh/InterfaceMesh.cpp" ;;
esac

runs=${1:-1e6}
[ $# -gt 0 ] && shift
[[ $runs =~ ^[0-9]+([.][0-9]*)?([eE][0-9]+)?$ ]] || die "RUNS must be a number such as 20000 or 1e6, got '$runs'"
runs=$(printf '%.0f' "$runs")
build
mkdir -p "$corpus" "$seeds" "$artifacts"
"$build/protocol_seeds" "$seeds" > /dev/null

# -max_len 70000: the largest Abort (56 + 65,536 bytes) plus room to overstep its limit; meshes of ~1000 nodes.
# -malloc_limit_mb 64: no input of at most 70 kB may make the decoders allocate more in one piece; a larger
# allocation is a count trusted before it was checked against the frame size.
flags=(-runs="$runs" -max_len=70000 -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=64
       -dict="$root/tests/fuzz/protocol.dict" -artifact_prefix="$artifacts/" -print_final_stats=1)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

say "$runs inputs from $corpus, tests/fuzz/corpus and fresh seeds; log $log"
start=$(date +%s.%N)
set +e
"$build/protocol_fuzzer" "${flags[@]}" "$@" "$corpus" "$root/tests/fuzz/corpus" "$seeds" 2>&1 | tee "$log" |
  grep --line-buffered -E '^#[0-9]+[[:space:]]+(INITED|pulse|DONE)'
status=${PIPESTATUS[0]}
set -e
seconds=$(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN { printf "%.1f", e - s }')

if [ "$status" -ne 0 ]; then
  tail -n 60 "$log" >&2
  finding=$(ls -t "$artifacts" | head -n1)
  die "finding after $seconds s (fuzzer status $status); reproduce: $build/protocol_fuzzer $artifacts/$finding"
fi
executed=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
rate=$(awk -v n="$executed" -v s="$seconds" 'BEGIN { printf "%.0f", n / s }')
coverage=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -n1 |
           sed -E 's/.*cov: ([0-9]+) ft: ([0-9]+) corp: ([0-9]+)\/([^ ]+).*/\1 edges, \2 features, corpus \3 inputs (\4)/')
say "OK: $executed inputs in $seconds s ($rate inputs/s), coverage $coverage," \
    "peak RSS $(sed -n 's/^stat::peak_rss_mb: *//p' "$log") MB, no findings"
