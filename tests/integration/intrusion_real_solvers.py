#!/usr/bin/python3
"""Stray and hostile connections against a real coupled run (YADE + FreeFEM, beam case smoke size).

Usage: intrusion_real_solvers.py RAILCOSIM INTRUDER DUMMY_DEM WORKDIR

The intrusions of railcosim_intruder (raw connect-and-close, random bytes, a 1 TB frame announcement,
200 MB of junk, ZeroMQ peers without or with a wrong token) hit the FEM's endpoint twice: as soon as it
is bound, before YADE has joined (a stray must not take the run's one admission), and again right after
the handshake; a second DEM participant without the run's token tries to join in between. The run must end as it would
alone: exit 0, status ok, every check of the case passed.
"""
import json
import os
import re
import subprocess
import sys
import threading
import time

railcosim, intruder, dummy_dem, work = sys.argv[1:5]
out = os.path.join(work, "beam")
run = subprocess.Popen([railcosim, "run", os.path.join(os.path.dirname(railcosim), "cases", "beam_uniform_load"),
                        "--smoke", "--force", "--out", out, "--set", "duration_s=1.0"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
lines = []
endpoint_seen = threading.Event()
coupled = threading.Event()
endpoint = []


def pump():
    for line in run.stdout:
        lines.append(line)
        match = re.search(r"\[run\] endpoint ((?:ipc|tcp)://[^\s;,]+)", line)
        if match:
            endpoint.append(match.group(1))
            endpoint_seen.set()
        if "handshake done" in line:
            coupled.set()


threading.Thread(target=pump, daemon=True).start()
if not endpoint_seen.wait(120):
    run.kill()
    sys.exit("FAIL: the runner never printed its endpoint:\n" + "".join(lines[-30:]))
target = endpoint[0]
socket_path = target[len("ipc://"):] if target.startswith("ipc://") else None


def attack(label):
    started = time.monotonic()
    result = subprocess.run([intruder, target], capture_output=True, text=True, timeout=120)
    print(f"{label}: {result.stdout.strip()} {result.stderr.strip()} ({time.monotonic() - started:.1f} s)", flush=True)
    if result.returncode != 0:
        run.kill()
        sys.exit(f"FAIL: the intruder could not reach {target} ({label}): {result.stderr}")


# 1. As soon as the FEM side has bound (the socket file exists), before the DEM joins.
deadline = time.monotonic() + 120
while socket_path and not os.path.exists(socket_path) and run.poll() is None and time.monotonic() < deadline:
    time.sleep(0.01)
attack("before the DEM joined")

# 2. A second DEM participant without the run's token: refused at once with a clear message.
env = {k: v for k, v in os.environ.items() if k != "RAILCOSIM_BRIDGE_TOKEN"}
second = subprocess.run([dummy_dem, "--endpoint", target, "--timeout", "20", "--windows", "3"], capture_output=True,
                        text=True, timeout=60, env=env)
print(f"second participant: exit {second.returncode}: {second.stderr.strip()}", flush=True)
if second.returncode == 0 or "refused this participant" not in second.stderr:
    run.kill()
    sys.exit("FAIL: a second DEM participant was not refused plainly")

# 3. Mid-run: right after the FEM reports the handshake with YADE (the run then couples for ~14 s of
#    wall time: smoke size with 1 s of simulated time; the intrusions take ~2 s).
if not coupled.wait(120):
    run.kill()
    sys.exit("FAIL: the FEM never reported its handshake with the DEM:\n" + "".join(lines[-30:]))
attack("mid-run")
if run.poll() is not None:
    sys.exit("FAIL: the run had ended before the mid-run intrusions were over; they proved nothing")

code = run.wait(600)
summary_path = os.path.join(out, "summary.json")
if code != 0 or not os.path.isfile(summary_path):
    sys.exit(f"FAIL: the attacked run ended with exit {code}:\n" + "".join(lines[-40:]))
with open(summary_path) as f:
    summary = json.load(f)
failed = [c["name"] for c in summary.get("checks", []) if not c.get("passed")]
if summary.get("status") != "ok" or failed:
    sys.exit(f"FAIL: status {summary.get('status')}, failed checks {failed}")
print(f"OK: the attacked run finished normally ({summary['wall_time_s']:.1f} s coupled, {len(summary.get('checks', []))} checks passed)")
