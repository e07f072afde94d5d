#!/usr/bin/env bash
# Builds the bridge with its unit and integration tests under ASan + UBSan in a separate build folder and runs them.
#
#   tools/sanitize.sh [CTEST ARGS...]    e.g. tools/sanitize.sh -R integration_dummies
#
# Build folder: $RAILCOSIM_SANITIZE_BUILD (default $RAILCOSIM_CACHE/sanitize, ~/.cache/railcosim). YADE, FreeFEM and
# CUDA are left out: the tests run are the bridge's, the kernels' and the integration tests with the stand-in
# participants over real ipc and tcp. Exits non-zero on a failed test, and every sanitizer report fails its test.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RAILCOSIM_SANITIZE_BUILD:-${RAILCOSIM_CACHE:-$HOME/.cache/railcosim}/sanitize}
jobs=${RAILCOSIM_JOBS:-$(nproc)}

say() { printf '[sanitize] %s\n' "$*"; }
die() { printf '[sanitize] ERROR: %s\n' "$*" >&2; exit 1; }

flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
launcher=()
if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
mkdir -p "$build"
start=$(date +%s)
# -O1 -g: readable stacks at a bearable speed; no NDEBUG, so assertions run too.
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" \
  -DRAILCOSIM_WITH_YADE=OFF -DRAILCOSIM_WITH_FREEFEM=OFF -DRAILCOSIM_WITH_CUDA=OFF -DRAILCOSIM_WITH_FUZZ=OFF \
  "${launcher[@]}" > "$build/configure.log" 2>&1 ||
  { tail -n 30 "$build/configure.log" >&2; die "configure failed; see $build/configure.log"; }
say "building with $flags ($jobs jobs; log $build/build.log)"
cmake --build "$build" -j "$jobs" > "$build/build.log" 2>&1 ||
  { grep -E 'error|Error' "$build/build.log" | head -n 20 >&2; die "build failed; see $build/build.log"; }
built=$(date +%s)

# detect_leaks: LeakSanitizer at exit (the default on x86_64 Linux; said for clarity). No suppressions: libzmq 4.3.4,
# Boost.Test and libgomp report nothing here. exitcode 86: the stand-in participants the integration tests start
# inherit these settings, and their stderr goes to files the test deletes; a report there still shows as exit code 86,
# which no test expects from a participant (0 done, 1 failed check, 2 peer lost, 3 protocol error).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:exitcode=86}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:exitcode=86}
say "running ctest -L 'unit|integration' -LE 'yade|freefem' (ASAN_OPTIONS=$ASAN_OPTIONS)"
set +e
ctest --test-dir "$build" -L 'unit|integration' -LE 'yade|freefem' --output-on-failure -j "$jobs" "$@" \
  2>&1 | tee "$build/ctest.log"
status=${PIPESTATUS[0]}
set -e
# A sanitizer report fails its process; counted in every test's output as well, passed or not.
reports=$(grep -cE '^==[0-9]+==ERROR: |^SUMMARY: (Address|Undefined|Leak)Sanitizer|runtime error: ' \
          "$build/Testing/Temporary/LastTest.log" || true)
say "build $((built - start)) s, tests $(($(date +%s) - built)) s, sanitizer reports: $reports"
if [ "$status" -ne 0 ] || [ "$reports" -ne 0 ]; then
  die "see $build/ctest.log and $build/Testing/Temporary/LastTest.log"
fi
say "OK"
