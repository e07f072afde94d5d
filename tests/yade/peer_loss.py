#!/usr/bin/python3
"""Kills one participant of a running coupling and checks the survivor reports it clearly within 10 s.

Pairs: the YADE engine against the stand-in FEM, and the FreeFEM solver against the stand-in DEM.
Usage: peer_loss.py RAILCOSIM DUMMY_FEM DUMMY_DEM BOX_SOLVER_EDP
"""
import os
import signal
import subprocess
import sys
import tempfile
import time
import uuid

railcosim, dummy_fem, dummy_dem, solver = sys.argv[1:5]
root = os.path.dirname(os.path.abspath(railcosim))
LIMIT_S = 10.0  # the requirement for reporting a dead peer
failures = []


def endpoint():
    return f"ipc:///tmp/railcosim-peerloss-{os.getpid()}-{uuid.uuid4().hex[:6]}.sock"


def start(argv):
    log = tempfile.TemporaryFile(mode="w+")
    return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, start_new_session=True), log


def wait_for(log, needle, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        log.seek(0)
        if needle in log.read():
            return True
        time.sleep(0.2)
    return False


def scenario(name, survivor_argv, victim_argv, ready_text, victim_first):
    ep = endpoint()
    procs = {}
    order = [("victim", victim_argv), ("survivor", survivor_argv)]
    if not victim_first:
        order.reverse()
    for role, argv in order:
        procs[role] = start([a.replace("ENDPOINT", ep) for a in argv])
    survivor, survivor_log = procs["survivor"]
    victim, _ = procs["victim"]
    if not wait_for(survivor_log, ready_text, 120):
        failures.append(f"{name}: survivor never reached '{ready_text}'")
        for p, _ in procs.values():
            p.kill()
        return
    time.sleep(1.0)  # let the coupling run a little
    killed_at = time.monotonic()
    os.killpg(victim.pid, signal.SIGKILL)
    try:
        code = survivor.wait(LIMIT_S + 20)
    except subprocess.TimeoutExpired:
        survivor.kill()
        code = None
    elapsed = time.monotonic() - killed_at
    survivor_log.seek(0)
    text = survivor_log.read()
    message = [line for line in text.splitlines() if "peer" in line.lower() or "disconnect" in line.lower()]
    print(f"{name}: survivor exited with {code} after {elapsed:.2f} s; message: {message[-1] if message else '(none)'}")
    if code in (0, None):
        failures.append(f"{name}: survivor exit code {code}, expected a failure code")
    if elapsed > LIMIT_S:
        failures.append(f"{name}: survivor took {elapsed:.1f} s > {LIMIT_S} s")
    if not message:
        failures.append(f"{name}: survivor output does not mention the lost peer:\n{text[-2000:]}")


scenario("YADE survives killed FEM",
         [railcosim, "yade", os.path.join(root, "yade_engines", "checks", "coupled_until_stopped.py"), "ENDPOINT"],
         [dummy_fem, "--endpoint", "ENDPOINT", "--nx", "3", "--ny", "3", "--spacing", "0.05", "--dt", "1e-4"],
         "coupled: running", victim_first=False)
scenario("FreeFEM survives killed DEM",
         [railcosim, "freefem", solver, "-mode", "coupled", "-endpoint", "ENDPOINT", "-nx", "4", "-ny", "1", "-nz", "1",
          "-order", "1", "-dt", "1e-4", "-progressEvery", "50", "-out", tempfile.mkdtemp()],
         [dummy_dem, "--endpoint", "ENDPOINT", "--windows", "1000000", "--no-check", "--compute-ms", "1"],
         "step", victim_first=True)
print("peer_loss:", "FAILED\n" + "\n".join(failures) if failures else "passed")
sys.exit(1 if failures else 0)
