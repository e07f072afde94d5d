#!/usr/bin/env bash
# One-time, idempotent set-up: Debian packages, YADE 2025.2.0 from Debian's source package (cached
# outside the repo), then railcosim's own build (bridge, YADE plugin, FreeFEM plugin, tests).
#
# Usage: tools/setup.sh [--packages-only | --yade-only | --build-only | --print-yade-root]
# Environment: RAILCOSIM_CACHE (default ~/.cache/railcosim), RAILCOSIM_JOBS (default: nproc),
#              RAILCOSIM_BUILD (default ./build), RAILCOSIM_WITH_CUDA (auto: ON when nvcc is found).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cache=${RAILCOSIM_CACHE:-$HOME/.cache/railcosim}
jobs=${RAILCOSIM_JOBS:-$(nproc)}
yade_version=2025.2.0
yade_debian_version=2025.2.0-1
yade_sha256=42702372251bf5e8f07a364bdf30533a1318947e4db90435b1f89293dc029156
yade_cmake_options=(-DDISABLE_ALL=ON -DENABLE_OPENMP=ON -DENABLE_LOGGER=OFF -DCMAKE_BUILD_TYPE=Release)
# The cache key names the version and a digest of the options, so a change of either builds anew.
yade_key="yade-${yade_version}-$(printf '%s ' "${yade_cmake_options[@]}" | sha256sum | cut -c1-8)"
yade_root="$cache/$yade_key"
# pyenv's shims break YADE's Python detection: YADE is built and run with Debian's Python only.
clean_path=/usr/bin:/bin:/usr/sbin:/sbin

say() { printf '[setup %s] %s\n' "$(date +%H:%M:%S)" "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

packages=(
  build-essential cmake ccache pkg-config dpkg-dev bzip2 ca-certificates
  libboost-all-dev python3-dev python3-numpy libloki-dev python3-mpmath libbz2-dev zlib1g-dev
  python3-ipython python3-matplotlib python3-pygraphviz python3-xlib python3-sphinx python3-tk
  libeigen3-dev python3-future python3-pil
  libzmq3-dev cppzmq-dev python3-h5py python3-scipy
  freefem++ libfreefem++-dev gmsh
  clang libclang-rt-14-dev iproute2 util-linux
  slurm-wlm munge
  paraview python3-paraview xvfb xauth
)

# with_progress LABEL LOG COMMAND...: runs COMMAND (output appended to LOG) and prints the percentage
# that make/cmake report, with the elapsed minutes, every 30 s until it ends; returns its status.
with_progress() {
  local label=$1 log=$2; shift 2
  local start=$SECONDS
  "$@" >> "$log" 2>&1 &
  local pid=$!
  while kill -0 "$pid" 2>/dev/null; do
    local waited=0
    while [ $waited -lt 30 ] && kill -0 "$pid" 2>/dev/null; do sleep 1; waited=$((waited + 1)); done
    kill -0 "$pid" 2>/dev/null || break
    local pct; pct=$(grep -o '^\[ *[0-9]*%\]' "$log" | tail -n1 | tr -d '[] ' || true)
    say "$label: ${pct:-0%} done, $(( (SECONDS-start)/60 )) min elapsed (log: $log)"
  done
  wait "$pid"
}

install_packages() {
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then say "Debian packages: all present"; return; fi
  say "Debian packages: installing ${#missing[@]} (${missing[*]:0:6}...)"
  local sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    > "$cache/apt-install.log" 2>&1 || die "apt-get install failed; see $cache/apt-install.log"
}

# Adds a deb-src entry for trixie derived from the machine's own Debian sources (first stanza only).
ensure_source_entry() {
  local target=/etc/apt/sources.list.d/railcosim-yade-src.sources
  [ -f "$target" ] && return
  local origin=/etc/apt/sources.list.d/debian.sources
  [ -f "$origin" ] || die "no $origin to derive a deb-src entry from; add a 'deb-src ... trixie main' line by hand"
  local sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
  awk 'BEGIN{RS="";ORS="\n\n"} NR==1' "$origin" \
    | sed -e 's/^Types:.*/Types: deb-src/' -e 's/^Suites:.*/Suites: trixie/' | $sudo tee "$target" >/dev/null
  $sudo apt-get update -qq
}

fetch_yade_source() {
  local src="$yade_root/src"
  [ -f "$src/trunk-${yade_version}/CMakeLists.txt" ] && return
  mkdir -p "$src"
  ensure_source_entry
  local tarball="$src/yade_${yade_version}.orig.tar.bz2"
  if [ ! -f "$tarball" ]; then
    say "YADE source: downloading yade=${yade_debian_version} from Debian"
    # The Debian patch tarball of this version is not served, so apt-get exits non-zero even when the
    # orig tarball arrived: the tarball and its checksum are what is checked, not the exit code.
    (cd "$src" && apt-get source --download-only "yade=${yade_debian_version}" > "$src/fetch.log" 2>&1) || true
    [ -f "$tarball" ] || die "YADE source package yade=${yade_debian_version} not available (see $src/fetch.log).
  Check that /etc/apt/sources.list.d/railcosim-yade-src.sources points at a Debian mirror serving trixie sources, then rerun."
  fi
  local expected actual
  expected=$(apt-cache showsrc "yade=${yade_debian_version}" 2>/dev/null \
    | awk -v f="yade_${yade_version}.orig.tar.bz2" '/^Checksums-Sha256:/{s=1;next} /^[^ ]/{s=0} s && $3==f {print $1; exit}')
  [ -n "$expected" ] || expected=$yade_sha256
  [ "$expected" = "$yade_sha256" ] || die "apt-cache showsrc reports sha256 $expected for the YADE tarball, railcosim expects $yade_sha256; refusing to build."
  actual=$(sha256sum "$tarball" | cut -d' ' -f1)
  if [ "$actual" != "$expected" ]; then
    mv "$tarball" "$tarball.bad"
    die "YADE tarball checksum mismatch: got $actual, expected $expected (moved aside to $tarball.bad); rerun to download again."
  fi
  say "YADE source: checksum OK, extracting"
  tar -xjf "$tarball" -C "$src"
}

build_yade() {
  local stamp="$yade_root/.installed"
  if [ -f "$stamp" ]; then say "YADE ${yade_version}: cached at $yade_root/prefix"; return; fi
  mkdir -p "$yade_root"
  fetch_yade_source
  local build="$yade_root/build" log="$yade_root/build.log"
  mkdir -p "$build"
  say "YADE ${yade_version}: configuring (log: $log)"
  (cd "$build" && PATH=$clean_path cmake "$yade_root/src/trunk-${yade_version}" "${yade_cmake_options[@]}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_INSTALL_PREFIX="$yade_root/prefix" \
      -DCMAKE_CXX_COMPILER_LAUNCHER=ccache > "$log" 2>&1) || die "YADE configure failed; see $log"
  say "YADE ${yade_version}: compiling with $jobs jobs (about 35 min on 2 idle cores; log: $log)"
  local start=$SECONDS
  (cd "$build" && PATH=$clean_path with_progress "YADE build" "$log" make -j"$jobs") \
    || die "YADE build failed; see $log (last lines: $(tail -n 3 "$log" | tr '\n' ' '))"
  (cd "$build" && PATH=$clean_path make install >> "$log" 2>&1) || die "YADE install failed; see $log"
  touch "$stamp"
  say "YADE ${yade_version}: built in $(( (SECONDS-start)/60 )) min"
}

build_railcosim() {
  local build=${RAILCOSIM_BUILD:-$here/build}
  # Paths relative to the checkout in ccache's hashes: a fresh clone elsewhere reuses the cache.
  export CCACHE_BASEDIR=$here CCACHE_NOHASHDIR=1
  local cuda=${RAILCOSIM_WITH_CUDA:-}
  if [ -z "$cuda" ]; then
    if [ -x /usr/local/cuda/bin/nvcc ]; then cuda=ON; else cuda=OFF; fi
  fi
  local start=$SECONDS
  mkdir -p "$build"
  say "railcosim: configuring and building in $build (CUDA: $cuda)"
  PATH=/usr/local/cuda/bin:$clean_path cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache \
      -DRAILCOSIM_WITH_YADE=ON -DRAILCOSIM_YADE_ROOT="$yade_root" -DRAILCOSIM_WITH_FREEFEM=ON \
      -DRAILCOSIM_WITH_CUDA="$cuda" > "$build/configure.log" 2>&1 \
    || { tail -n 30 "$build/configure.log" >&2; die "CMake configure failed; full log: $build/configure.log"; }
  : > "$build/build.log"
  PATH=/usr/local/cuda/bin:$clean_path with_progress "railcosim build" "$build/build.log" cmake --build "$build" -j "$jobs" \
    || { grep -E "error|Error" "$build/build.log" | head -n 20 >&2; die "build failed; full log: $build/build.log"; }
  touch "$build/.railcosim-built"
  say "railcosim: built in $((SECONDS-start)) s"
}

case "${1:-}" in
  --print-yade-root) echo "$yade_root"; exit 0 ;;
  --build-only) build_railcosim; exit 0 ;;
esac
mkdir -p "$cache"
install_packages
[ "${1:-}" = "--packages-only" ] && exit 0
build_yade
[ "${1:-}" = "--yade-only" ] && exit 0
build_railcosim
