#!/usr/bin/env bash
# Runs the beam case's smoke run with 20 snapshots and checks its fields.xdmf in ParaView (check_fields.py).
# usage: run_check.sh REPOSITORY OUT
set -euo pipefail
repo=$1 out=$2
"$repo/railcosim" run "$repo/cases/beam_uniform_load" --smoke --force --set snapshot_every_s=0.02 --out "$out"
cd "$out"  # pvpython writes nothing else; keep any stray file with the run
"$repo/tools/virtual_display.sh" pvpython "$repo/tests/paraview/check_fields.py" "$out" "$out/fields.png"
