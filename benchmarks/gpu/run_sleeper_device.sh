#!/usr/bin/env bash
# Runs the sleeper-on-ballast case on a GPU machine without YADE (docs/benchmarks.md, "Sleeper on ballast on the GPU
# machine"): the standalone DEM driver (dem_driver=standalone) on the CUDA backend, FreeFEM from the archive
# pack_sleeper_device.sh made, through the case runner (tools/run_case.py) as on the desk: the same case, larger.
# Usage (repository root, on the GPU machine): benchmarks/gpu/run_sleeper_device.sh OUTDIR [runner options ...]
#   e.g. ... OUTDIR --set stones=0 --set bed_width_m=1.0 --set cycles=100      (the seed's scene, README)
# CASE=NAME runs another case of cases/ whose DEM side has a standalone driver (dem_driver = "standalone"), the same
# way: CASE=steel_sheet (cases/steel_sheet/README.md, "On the GPU machine"); CASE=angle_of_repose with
# --set particle_shape=polyhedron (cases/angle_of_repose/README.md, "Polyhedra"); CASE=direct_shear with
# --set dem_driver=standalone (cases/direct_shear/README.md, "Polyhedra"); CASE=track_stiffness and
# CASE=train_passage with --set fem_mesh=FILE, a fem/track.msh of a desk run of the same track (no gmsh there;
# cases/track_stiffness/README.md, "The thesis's grading on the GPU machine").
# Environment: RUNTIME_ARCHIVE (default build/device-runtime.tgz), RUNTIME_DIR (where it is unpacked, default a
# folder under /tmp), RAILCOSIM_CACHE (where bed files are kept, default OUTDIR/cache), THREADS (OpenMP threads of
# the DEM process, default the cores), PYTHON (default python3). Writes OUTDIR/run (the results
# folder: summary.json, timeseries.h5, plots, logs) and OUTDIR/device.txt. A bed preparation stopped by the time limit
# resumes after its last finished stage when run again with the same cache (preparation.StageCheckpoints).
# CAMPAIGN=FILE runs that campaign (tools/campaign.py, local pool of JOBS runs at a time, default 4) into
# OUTDIR/campaign instead of one run; its [set] table chooses the standalone driver and the CUDA backend.
# A load run longer than one call: give it restart checkpoints and a time limit inside the call, e.g.
#   ... OUTDIR --set cycles=100 --checkpoint-every 0.05 --time-limit 540
# and continue it in the next call with the same command and RESUME=1: the interrupted run goes on from its newest
# checkpoint (railcosim run --resume: the same --set values; --checkpoint-every and --time-limit again, so that a
# third call can go on). It is OUTDIR/run, or OUTDIR/run.partial-XXXXXXXX when a finished OUTDIR/run was there
# (that one moves to OUTDIR/run once finished only if OUTDIR/run has gone).
# A bed carried between calls (a device call brings back at most 8 files, 2 folders deep: the cache's bed is deeper):
# BED_ARCHIVE=FILE packs the bed cache into FILE after the run (e.g. $OUT/bed.tgz, about 10 MB at 94,000 stones);
# BED_FROM=FILE unpacks such an archive into the cache before it (FILE carried in an ignored folder, e.g. build/).
set -euo pipefail
out=${1:?usage: run_sleeper_device.sh OUTDIR [runner options ...]}
shift
root=$(pwd)
mkdir -p "$out"
out=$(cd "$out" && pwd)
runtime=${RUNTIME_DIR:-/tmp/railcosim-runtime}
if [ ! -x "$runtime/runtime/freefem/FreeFem++" ]; then
  mkdir -p "$runtime"
  tar -C "$runtime" -xzf "${RUNTIME_ARCHIVE:-build/device-runtime.tgz}"
fi
rt=$runtime/runtime
# FreeFEM sees its own library closure; Python (the runner, the DEM driver) only the driver's (ZeroMQ).
mkdir -p "$rt/bin"
cat > "$rt/bin/FreeFem++" <<WRAPPER
#!/usr/bin/env bash
LD_LIBRARY_PATH="$rt/lib" exec "$rt/freefem/FreeFem++" "\$@"
WRAPPER
chmod +x "$rt/bin/FreeFem++"
export PATH="$rt/bin:$PATH"
export LD_LIBRARY_PATH="$rt/driverlib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export FF_LOADPATH="$rt/freefem/plugins;./"
export FF_INCLUDEPATH="$root/freefem_scripts/lib;$rt/freefem/idp;./"
export RAILCOSIM_ROOT=$root RAILCOSIM_CACHE="${RAILCOSIM_CACHE:-$out/cache}" PYTHONPATH="$root/python"
if [ -n "${BED_FROM:-}" ]; then
  mkdir -p "$RAILCOSIM_CACHE"
  tar -C "$RAILCOSIM_CACHE" -xzf "$BED_FROM"
  echo "beds from $BED_FROM: $(cd "$RAILCOSIM_CACHE" && find beds -name '*.h5' | tr '\n' ' ')"
fi
pack_beds() {
  if [ -n "${BED_ARCHIVE:-}" ] && [ -d "$RAILCOSIM_CACHE/beds" ]; then
    tar -C "$RAILCOSIM_CACHE" -czf "$BED_ARCHIVE" --exclude='*.lock' beds && echo "beds packed into $BED_ARCHIVE"
  fi
}
export RAILCOSIM_POLYHEDRA_DRIVER="$rt/librailcosim_polyhedra_driver.so" RAILCOSIM_CHECKPOINT_TOOL="$rt/railcosim_checkpoint"
{
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
  echo "cores: $(nproc); python: $(${PYTHON:-python3} --version)"
} | tee "$out/device.txt"
# The runner and the campaign stop their solvers on SIGTERM, SIGINT or SIGHUP and write their summaries. A signal sent
# to this script alone (kill PID, a scheduler; `timeout` signals the whole group) would end bash and leave a foreground
# child running: run it in the background, pass such a signal on to it, and wait for it to finish.
forwarded_child=
forwarding() {
  trap 'kill -TERM "$forwarded_child" 2>/dev/null' TERM
  trap 'kill -HUP "$forwarded_child" 2>/dev/null' HUP
  trap 'kill -INT "$forwarded_child" 2>/dev/null' INT
  "$@" &
  forwarded_child=$!
  local status
  wait "$forwarded_child"
  status=$?
  while kill -0 "$forwarded_child" 2>/dev/null; do # a signal ended `wait` early: the child is still stopping
    wait "$forwarded_child"
    status=$?
  done
  wait "$forwarded_child" 2>/dev/null && status=0 || status=$? # the child's own status, once it has been reaped
  trap - TERM HUP INT
  return "$status"
}
start=$(date +%s)
set +e
if [ -n "${CAMPAIGN:-}" ]; then
  RAILCOSIM_CAMPAIGN_DIRECT=1 forwarding ${PYTHON:-python3} "$root/tools/campaign.py" "$CAMPAIGN" --jobs "${JOBS:-4}" \
    --out "$out/campaign" "$@"
  code=$?
  echo "campaign exit $code after $(( $(date +%s) - start )) s" | tee -a "$out/device.txt"
  pack_beds
  exit $code
fi
target=(--out "$out/run" --force)
if [ -n "${RESUME:-}" ]; then
  partial=$(ls -dt "$out"/run.partial-* 2>/dev/null | head -n 1)
  if [ -z "$partial" ] && [ -d "$out/run/checkpoints" ]; then
    partial=$out/run
  fi
  if [ -z "$partial" ]; then
    echo "run_sleeper_device.sh: RESUME is set but there is no interrupted run with checkpoints in $out" >&2
    exit 2
  fi
  target=(--resume "$partial")
fi
case_dir=$root/cases/${CASE:-sleeper_on_ballast}
# a case whose YADE side has a standalone twin chooses it by dem_driver (angle_of_repose: spheres; polyhedra always)
driver=()
if grep -q '^dem_driver *=' "$case_dir/case.toml"; then driver=(--set dem_driver=standalone); fi
forwarding ${PYTHON:-python3} "$root/tools/run_case.py" "$case_dir" "${target[@]}" \
  ${driver[@]+"${driver[@]}"} --set polyhedra_backend=cuda --set "dem_threads=${THREADS:-$(nproc)}" "$@"
code=$?
set -e
echo "runner exit $code after $(( $(date +%s) - start )) s" | tee -a "$out/device.txt"
pack_beds
exit $code
