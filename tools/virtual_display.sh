#!/usr/bin/env bash
# Runs a command on a private virtual X display (Debian's ParaView renders only through X).
# usage: tools/virtual_display.sh COMMAND [ARGS...]     e.g. tools/virtual_display.sh pvpython tools/render_fields.py RUN PNG
# Xvfb picks a free display itself and names it on a pipe once it accepts clients (-displayfd), so two runs at once
# never race for one display number and the command starts only on a server that is up (xvfb-run -a guesses the
# number from lock files and was seen to hand out a display that refused the connection on a loaded machine).
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: tools/virtual_display.sh COMMAND [ARGS...]" >&2; exit 2; }
command -v Xvfb > /dev/null || { echo "tools/virtual_display.sh: Xvfb is missing (Debian package xvfb; ./railcosim setup installs it)" >&2; exit 2; }
folder=$(mktemp -d)
mkfifo "$folder/display"
Xvfb -displayfd 3 -screen 0 1600x1200x24 -nolisten tcp 3> "$folder/display" 2> "$folder/xvfb.log" &
server=$!
trap 'kill "$server" 2> /dev/null || true; wait "$server" 2> /dev/null || true; rm -rf "$folder"' EXIT
# The server writes its display number when it is ready; 30 s covers a start on a busy machine.
if ! read -r -t 30 number < "$folder/display"; then
  echo "tools/virtual_display.sh: Xvfb did not start within 30 s:" >&2
  cat "$folder/xvfb.log" >&2
  exit 1
fi
DISPLAY=":$number" "$@"
