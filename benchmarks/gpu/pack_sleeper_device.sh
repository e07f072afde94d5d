#!/usr/bin/env bash
# Packs what the sleeper-on-ballast case needs on a GPU machine without YADE, FreeFEM, ZeroMQ or a package registry
# (docs/benchmarks.md, "Sleeper on ballast on the GPU machine"), into one archive that travels with the working tree:
#   freefem/FreeFem++, freefem/plugins (msh3, gmsh, MUMPS_seq, iovtk, and railcosim_bridge of this build),
#   freefem/idp (FreeFEM's include scripts), lib/ and driverlib/ (every library ldd lists for FreeFEM, for the
#   polyhedra driver, but glibc's own and the C++ and OpenMP runtimes, which the machine's newer ones serve),
#   librailcosim_polyhedra_driver.so (built here with RAILCOSIM_WITH_CUDA=ON: the CUDA backend for sm_90 inside),
#   railcosim_checkpoint (the bridge's checkpoint tool, for runs carried across calls).
# Usage (repository root, after ./railcosim build): benchmarks/gpu/pack_sleeper_device.sh [ARCHIVE]
#   ARCHIVE defaults to build/device-runtime.tgz (an ignored path: give it to the device call's carry).
set -euo pipefail
archive=${1:-build/device-runtime.tgz}
build=${RAILCOSIM_BUILD:-build}
driver=$build/yade_engines/polyhedra/driver/librailcosim_polyhedra_driver.so
bridge_plugin=$build/freefem_scripts/plugin/railcosim_bridge.so
checkpoint_tool=$build/bridge/dummies/railcosim_checkpoint
for f in "$driver" "$bridge_plugin" "$checkpoint_tool"; do
  [ -f "$f" ] || { echo "missing $f: run ./railcosim build first" >&2; exit 1; }
done
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/runtime/freefem/plugins"
cp /usr/bin/FreeFem++ "$stage/runtime/freefem/"
for p in msh3 gmsh MUMPS_seq iovtk; do cp "/usr/lib/freefem++/$p.so" "$stage/runtime/freefem/plugins/"; done
cp "$bridge_plugin" "$stage/runtime/freefem/plugins/"
cp -r /usr/include/freefem++/idp "$stage/runtime/freefem/idp"
cp "$driver" "$stage/runtime/"
cp "$checkpoint_tool" "$stage/runtime/" # the runner finds and checks restart checkpoints with it (--resume, --time-limit)
# The library closures, glibc's own and the C++ runtime left to the machine: FreeFEM's (lib/, given to FreeFem++ alone by
# run_sleeper_device.sh's wrapper) and the driver's (driverlib/: ZeroMQ and what it needs, on Python's library path).
skip='^(libc|libm|libpthread|libdl|librt|libresolv|ld-linux-x86-64|libstdc\+\+|libgcc_s|libgomp|linux-vdso)\.so'
closure() { # closure FOLDER FILE...
  local folder=$1; shift
  mkdir -p "$folder"
  for f in "$@"; do ldd "$f" | awk '/=> \//{print $3}'; done | sort -u | while read -r lib; do
    name=$(basename "$lib")
    [[ $name =~ $skip ]] && continue
    cp -L "$lib" "$folder/$name"
  done
}
closure "$stage/runtime/lib" "$stage"/runtime/freefem/FreeFem++ "$stage"/runtime/freefem/plugins/*.so
closure "$stage/runtime/driverlib" "$stage"/runtime/librailcosim_polyhedra_driver.so
mkdir -p "$(dirname "$archive")"
tar -C "$stage" -czf "$archive" runtime
echo "$archive: $(du -h "$archive" | cut -f1); FreeFEM $(ls "$stage/runtime/lib" | wc -l) libraries," \
  "driver $(ls "$stage/runtime/driverlib" | tr '\n' ' ')"
