#!/usr/bin/python3
"""YADE started by railcosim opens no server: no TCP/UDP socket at all, no unix socket but its coupling endpoint.

YADE's own main script opens a Python prompt on 0.0.0.0:9000 (cookie printed to the log) and an XMLRPC
server on 0.0.0.0:21000; tools/yade_launch.py turns them off. Audited with iproute2's `ss` on the live process:
  idle       a plain script (railcosim yade idle.py), and that YADE behaves as usual otherwise
  coupled    a coupled YADE (engine connected to the stand-in FEM, which binds the ipc endpoint)
  localhost  RAILCOSIM_YADE_SERVERS=localhost: servers on 127.0.0.1 only, the cookie in a 0600 file, not in the log
  exit codes a failing script exits 1, sys.exit(3) exits 3, a finished script exits 0 (YADE's -x)
Usage: no_listening_sockets.py RAILCOSIM DUMMY_FEM
"""
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time

railcosim, dummy_fem = sys.argv[1:3]
if shutil.which("ss") is None:
    print("no_listening_sockets: iproute2's `ss` is missing; install it (apt-get install iproute2)")
    sys.exit(1)
checks = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "yade_engines", "checks")
READY_S = 180  # ensure_built may rebuild first
failures = []


def fail(message):
    failures.append(message)
    print("FAIL:", message, flush=True)


class Process:
    """A command with its output in a file, so that the test can wait for a line while it runs."""

    def __init__(self, argv, env=None):
        self.log = tempfile.TemporaryFile(mode="w+")
        self.process = subprocess.Popen(argv, stdout=self.log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        env=env, start_new_session=True)

    def output(self):
        self.log.seek(0)
        return self.log.read()

    def wait_for(self, pattern, timeout=READY_S):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            match = re.search(pattern, self.output())
            if match or self.process.poll() is not None:
                return match or re.search(pattern, self.output())
            time.sleep(0.2)
        return None

    def stop(self):
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait()


def listening_sockets(pid):
    """(netid, local address) of every listening TCP socket, UDP socket and listening unix socket of `pid`."""
    lines = subprocess.run(["ss", "-H", "-l", "-n", "-p", "-t", "-u", "-x"], capture_output=True, text=True,
                           check=True).stdout.splitlines()
    owned = [line.split() for line in lines if f"pid={pid}," in line]
    return [(fields[0], fields[4]) for fields in owned]


def audit(name, pid, allowed_unix=()):
    sockets = listening_sockets(pid)
    print(f"{name}: ss -Hlnp -tux for pid {pid}: {sockets or 'nothing'}", flush=True)
    for netid, address in sockets:
        if not netid.startswith("u_") or address not in allowed_unix:
            fail(f"{name}: YADE (pid {pid}) listens on {netid} {address}")
    return sockets


def yade_pid(process, output):
    """`railcosim yade` execs Python, so the PID is YADE's; the script's own report confirms it."""
    match = re.search(r"ready pid=(\d+)", output)
    return int(match.group(1)) if match else process.process.pid


def idle():
    yade = Process([railcosim, "yade", os.path.join(checks, "idle.py"), "60"])
    try:
        if not yade.wait_for(r"ready pid=\d+"):
            fail(f"idle: YADE did not reach 'ready' (exit {yade.process.poll()}):\n{yade.output()[-3000:]}")
            return
        audit("idle", yade_pid(yade, yade.output()))
        if re.search(r"cookie|TCP python prompt|XMLRPC", yade.output(), re.IGNORECASE):
            fail(f"idle: YADE's log announces a server or a cookie:\n{yade.output()[-3000:]}")
    finally:
        yade.stop()


def coupled():
    folder = tempfile.mkdtemp(prefix="railcosim-sockets-")
    socket_path = os.path.join(folder, "bridge.sock")
    endpoint = "ipc://" + socket_path
    fem = Process([dummy_fem, "--endpoint", endpoint, "--nx", "3", "--ny", "3", "--spacing", "0.05", "--dt", "1e-4"])
    yade = Process([railcosim, "yade", os.path.join(checks, "coupled_until_stopped.py"), endpoint])
    try:
        if not yade.wait_for(r"coupled: running"):
            fail(f"coupled: YADE did not couple (exit {yade.process.poll()}):\n{yade.output()[-3000:]}")
            return
        time.sleep(1.0)  # a few windows exchanged
        audit("coupled", yade_pid(yade, yade.output()), allowed_unix=(socket_path,))
    finally:
        yade.stop()
        fem.stop()
        shutil.rmtree(folder, ignore_errors=True)


def localhost():
    env = dict(os.environ, RAILCOSIM_YADE_SERVERS="localhost")
    yade = Process([railcosim, "yade", os.path.join(checks, "idle.py"), "60"], env=env)
    try:
        if not yade.wait_for(r"ready pid=\d+"):
            fail(f"localhost: YADE did not reach 'ready' (exit {yade.process.poll()}):\n{yade.output()[-3000:]}")
            return
        output = yade.output()
        sockets = listening_sockets(yade_pid(yade, output))
        print(f"localhost: listening {sockets}", flush=True)
        tcp = [address for netid, address in sockets if netid == "tcp"]
        if len(tcp) != 2 or any(not address.startswith("127.0.0.1:") for address in tcp):
            fail(f"localhost: expected the prompt and the info server on 127.0.0.1, got {sockets}")
        if any(not netid.startswith("u_") and netid != "tcp" for netid, _ in sockets):
            fail(f"localhost: unexpected sockets {sockets}")
        match = re.search(r"auth cookie in (\S+?)\)", output)
        if not match or not os.path.isfile(match.group(1)):
            fail(f"localhost: no cookie file named in the log:\n{output[-2000:]}")
            return
        mode = stat.S_IMODE(os.stat(match.group(1)).st_mode)
        with open(match.group(1)) as f:
            cookie = f.read().strip()
        if mode != 0o600:
            fail(f"localhost: cookie file mode {oct(mode)}, expected 0o600")
        if len(cookie) < 32 or cookie in output:
            fail("localhost: the cookie is short or appears in the log")
    finally:
        yade.stop()


def exit_codes():
    folder = tempfile.mkdtemp(prefix="railcosim-exit-")
    try:
        for body, expected in (("raise RuntimeError('failing on purpose')", 1), ("sys.exit(3)", 3),
                               ("O.run(3, True)", 0)):
            script = os.path.join(folder, "script.py")
            with open(script, "w") as f:
                f.write(f"import sys\n{body}\n")
            started = time.monotonic()
            try:
                result = subprocess.run([railcosim, "yade", script], capture_output=True, text=True, timeout=READY_S)
            except subprocess.TimeoutExpired:
                fail(f"exit codes: `{body}` did not exit within {READY_S} s (YADE's -x lost?)")
                continue
            print(f"exit codes: `{body}` -> {result.returncode} in {time.monotonic() - started:.1f} s", flush=True)
            if result.returncode != expected:
                fail(f"exit codes: `{body}` exited with {result.returncode}, expected {expected}:\n"
                     f"{(result.stdout + result.stderr)[-2000:]}")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


for scenario in (idle, coupled, localhost, exit_codes):
    scenario()
print("no_listening_sockets:", "FAILED\n" + "\n".join(failures) if failures else "passed")
sys.exit(1 if failures else 0)
