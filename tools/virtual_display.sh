#!/usr/bin/env bash
# Runs a command on a private virtual X display (Debian's ParaView renders only through X).
# usage: tools/virtual_display.sh COMMAND [ARGS...]     e.g. tools/virtual_display.sh pvpython tools/render_fields.py RUN PNG
# Xvfb picks a free display itself (-displayfd: it tries numbers until one is free; the "server already running"
# lines in its log are those tries) and names it on a pipe once it accepts clients, so the command starts only on a
# server that is up. Starts are serialised with flock, so that each start sees the sockets of those before it.
# Debian's ParaView may still abort opening its window on a fresh display now and then ("bad X server connection");
# callers that must not fail on that retry (tests/paraview/run_check.sh).
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: tools/virtual_display.sh COMMAND [ARGS...]" >&2; exit 2; }
command -v Xvfb > /dev/null || { echo "tools/virtual_display.sh: Xvfb is missing (Debian package xvfb; ./railcosim setup installs it)" >&2; exit 2; }
folder=$(mktemp -d)
mkfifo "$folder/display"
server=""
trap '[ -z "$server" ] || kill "$server" 2> /dev/null || true; [ -z "$server" ] || wait "$server" 2> /dev/null || true; rm -rf "$folder"' EXIT
exec 4> "${TMPDIR:-/tmp}/railcosim-virtual-display.lock"
flock -w 60 4 || { echo "tools/virtual_display.sh: another Xvfb start held the lock for 60 s" >&2; exit 1; }
Xvfb -displayfd 3 -screen 0 1600x1200x24 -nolisten tcp 3> "$folder/display" 2> "$folder/xvfb.log" 4>&- &
server=$!
# The server writes its display number when it is ready; 30 s covers a start on a busy machine.
if ! read -r -t 30 number < "$folder/display" || ! kill -0 "$server" 2> /dev/null; then
  echo "tools/virtual_display.sh: Xvfb did not start within 30 s:" >&2
  cat "$folder/xvfb.log" >&2
  exit 1
fi
flock -u 4
exec 4>&-
DISPLAY=":$number" "$@"
