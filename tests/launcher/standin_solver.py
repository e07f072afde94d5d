#!/usr/bin/python3
# Stand-in solver for the launcher tests: prints, sleeps, fails or ignores SIGTERM as told, and records what it got.
import hashlib
import json
import os
import signal
import stat
import sys
import time

name, marker_dir, behaviour, endpoint, lines, interval, fail_after = sys.argv[1:8]
lines, interval, fail_after = int(lines), float(interval), float(fail_after)

# What the launcher gave this process, for the test to judge: pid (to watch it), token, endpoint folder.
token = os.environ.get("RAILCOSIM_BRIDGE_TOKEN", "")
socket_dir = os.path.dirname(endpoint[len("ipc://"):]) if endpoint.startswith("ipc://") else ""
record = {"pid": os.getpid(), "pgid": os.getpgid(0), "token": token,
          "token_sha256": hashlib.sha256(token.encode()).hexdigest(), "token_in_argv": bool(token) and token in " ".join(sys.argv),
          "endpoint": endpoint, "socket_dir": socket_dir,
          "socket_dir_mode": stat.S_IMODE(os.stat(socket_dir).st_mode) if socket_dir and os.path.isdir(socket_dir) else None,
          "unbuffered": os.environ.get("PYTHONUNBUFFERED")}
with open(os.path.join(marker_dir, f"{name}.json.tmp"), "w") as f:
    json.dump(record, f)
os.rename(os.path.join(marker_dir, f"{name}.json.tmp"), os.path.join(marker_dir, f"{name}.json"))

if behaviour == "ignore_term":
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
# No flush: the launcher must make a Python child's output line-buffered (PYTHONUNBUFFERED).
if behaviour in ("hang", "ignore_term"):
    k = 0
    while True:
        print(f"{name} line {k}")
        k += 1
        time.sleep(interval)
if behaviour == "fail":
    print(f"{name}: something went wrong")
    time.sleep(fail_after)
    sys.exit(3)
if behaviour == "fail_after":
    time.sleep(fail_after)
    print(f"{name}: no answer from the peer for {fail_after} s")
    sys.exit(1)
for k in range(lines):
    print(f"{name} line {k}")
    time.sleep(interval)
if name == "dem":
    # What a real dem.py leaves: the DEM step it ran with (FemCouplingEngine's O.dt) and the sub-steps per window.
    with open("dem_info.json", "w") as f:
        json.dump({"dt": 0.001, "subcycles": 10}, f)
