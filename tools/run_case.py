#!/usr/bin/python3
"""Runs a coupled case: starts the FEM and DEM solvers on a fresh endpoint, watches both, writes summary.json.

Usage: railcosim run cases/NAME [--smoke] [--out DIR] [--force] [--set key=value ...] [--time-limit SECONDS]
                             [--checkpoint-every SECONDS | --resume DIR]

A case folder holds case.toml, case.py (one subclass of railcosim.case.Case: the hooks the runner calls,
described in python/railcosim/case.py) and usually dem.py. case.toml has
  name, expected_wall_s      the case's name; the default run's wall time (sets the default --time-limit)
  [parameters] [coupling]    every parameter with its default; the default's type is the parameter's type.
  [fem] [output]             [coupling], [fem] and [output] group the coupling, the FreeFEM structure and the
                             reporting; a coupled case (one with [coupling]) gets the shared defaults of
                             python/railcosim/parameters.py (SHARED_DEFAULTS) for what it does not set
  [limits]                   the parameters' ranges, e.g. fem_dt = {min_exclusive = 0}, scheme = {choices = [...]}
  [smoke]                    overrides for --smoke
A parameter is named NAME or TABLE.NAME (names are unique across the tables), in --set, [smoke] and [limits].
A rule in [limits] combines min, min_exclusive, max, max_exclusive (a number, or the name of another
parameter: average_s = {max = "duration_s"}), choices (a list), divides (dem_dt = {divides = "fem_dt"}: a
whole number of steps) and force (the name of a boolean parameter that lifts the max bounds when true).
Parameters shared by the cases (fem_dt, dem_dt, scheme, duration_s, ...) have their rules in
python/railcosim/parameters.py (SHARED_LIMITS); a [limits] entry replaces them. Every parameter but a boolean
must have a rule ({} for any value of its type), NaN and inf are always refused, and a bad value or a misspelt
key is refused before anything starts (exit 2). Each check of the post-processing is {name, value, limit} and
passes when value <= limit; the runner marks it.

A DEM-only case (`dem_only = true` in case.toml: a bulk test of the particles, python/railcosim/case.py) runs its
YADE participant alone; --record, --replay-*, --checkpoint-every and --resume are refused for it.

A run is written to OUT.partial-XXXXXXXX beside OUT and renamed to OUT at the end. A run that did not
finish (failed, interrupted, time limit) never replaces an existing OUT: its folder is kept and named.
The solvers run in their own process groups with line-buffered output, on an ipc endpoint in a per-run
directory only the user can enter, with a per-run secret in RAILCOSIM_BRIDGE_TOKEN (environment only).
SIGTERM, SIGHUP and SIGINT stop every solver (SIGTERM, SIGKILL after STOP_GRACE_S) and the summary records
the signal and the stage. The default --time-limit is 20 x expected_wall_s (scaled with duration_s), at
least 600 s, 3600 s when the case declares no expected_wall_s; 0 means none.

--checkpoint-every S has both solvers save a coordinated restart checkpoint every S seconds of simulated time into
OUT/checkpoints (the newest two complete ones are kept). --resume DIR continues the interrupted run whose results
folder is DIR from its newest complete checkpoint, writing into DIR; it is refused in one line, before anything is
written, when DIR's parameters differ from this command's or the checkpoint is incomplete, damaged, of another run or
of another protocol version (python/railcosim/checkpoints.py; docs/protocol.md section 12). Both are refused before
anything runs when the case says its DEM side saves no checkpoints with these parameters (Case.restart_unsupported).

Exit codes: 0 ok, 1 failed, 2 refused (command line, case, values), 3 a check failed, 4 time limit,
128+N stopped by signal N (130 Ctrl-C, 129 SIGHUP, 143 SIGTERM).
"""
import argparse
import contextlib
import json
import math
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback

from railcosim import checkpoints, parameters, snapshots
from railcosim.case import CaseError, is_dem_only, load_case
from railcosim.parameters import ParameterError

# After one solver fails, how long the other may take to notice (the bridge reports a lost peer within a
# few seconds) before it is stopped.
PEER_GRACE_S = 15.0
# SIGTERM to SIGKILL: stopping must end every solver within a second of a signal, and a solver that handles
# SIGTERM needs only to close its files.
STOP_GRACE_S = 0.5
# A solver with neither output nor CPU use this long is described as frozen (a computing solver uses CPU
# every second; one blocked on its peer does not, and the peer's state says which of them is stuck).
FROZEN_IDLE_S = 10.0
CPU_SAMPLE_S = 1.0
POLL_S = 0.1
EXIT_FAILED, EXIT_REFUSED, EXIT_CHECKS, EXIT_TIME_LIMIT = 1, 2, 3, 4
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)


class Stop(BaseException):
    """Raised in the main thread by a stop signal or the time limit. A BaseException, so that a case's own
    `except Exception` in its post-processing cannot swallow it."""

    def __init__(self, signum):
        self.signum = signum
        self.time_limit = signum == signal.SIGALRM
        super().__init__("time limit reached" if self.time_limit else f"{signal.Signals(signum).name} received")

    @property
    def exit_code(self):
        return EXIT_TIME_LIMIT if self.time_limit else 128 + self.signum


def say(text):
    """Prints a runner line; a terminal that went away (SIGHUP) must not stop the clean-up."""
    try:
        print(text, flush=True)
    except OSError:
        pass


class SignalGuard:
    """Turns SIGTERM, SIGHUP, SIGINT and the time limit (SIGALRM) into Stop in the main thread. Inside
    deferred() a signal is only recorded and raised on leaving it, so that no child is started unrecorded and
    no file is half written; after disarm() signals are recorded only (the clean-up is already under way)."""

    def __init__(self):
        self.stop = None
        self.armed = True
        for signum in STOP_SIGNALS + (signal.SIGALRM,):
            signal.signal(signum, self._handle)

    def _handle(self, signum, frame):
        if self.stop is None:
            self.stop = Stop(signum)
        if self.armed:
            self.armed = False
            raise self.stop

    @contextlib.contextmanager
    def deferred(self):
        was_armed, self.armed = self.armed, False
        try:
            yield
        finally:
            self.armed = was_armed
        if self.armed and self.stop is not None:
            self.armed = False
            raise self.stop

    def disarm(self):
        self.armed = False
        signal.setitimer(signal.ITIMER_REAL, 0)

    @staticmethod
    def set_time_limit(seconds):
        if seconds > 0:
            signal.setitimer(signal.ITIMER_REAL, seconds)


def process_group_stats():
    """{process group: (CPU ticks of its members, whether one of them is stopped)} from /proc."""
    stats = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue  # exited meanwhile
        state, group, ticks = fields[0], int(fields[2]), int(fields[11]) + int(fields[12])
        cpu, stopped = stats.get(group, (0, False))
        stats[group] = (cpu + ticks, stopped or state == "T")
    return stats


class Solver:
    """One child process in its own process group, output saved to NAME.log (and echoed with a prefix)."""

    def __init__(self, name, argv, out, env, echo=True, append_log=None):
        """`append_log`: a line that starts this process's part of NAME.log, which it extends (a resumed run)."""
        self.name, self.echo = name, echo
        self.log_name = f"{name}.log"
        self.log = open(os.path.join(out, self.log_name), "a" if append_log else "w", buffering=1)
        if append_log:
            self.log.write(f"{append_log}\n")
        self.last_lines = []
        self.code = None
        self.stopped_by = None      # why the runner stopped it, if it did
        self.state_when_stopped = None
        now = time.monotonic()
        self.last_output = self.last_cpu_change = now
        self.cpu_ticks, self.stopped_since = None, None
        # stdbuf: FreeFEM's C++ stdout is block-buffered on a pipe (progress lines arrived 90 s late, and a
        # killed run kept one line); stderr stays unbuffered so that an abort's last words are not lost.
        prefix = ["stdbuf", "-oL"] if shutil.which("stdbuf") else []
        self.process = subprocess.Popen(prefix + list(argv), cwd=out, env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True,
                                        errors="replace", bufsize=1, start_new_session=True)
        self.pid = self.process.pid
        self.thread = threading.Thread(target=self._pump, daemon=True)
        self.thread.start()

    def _pump(self):
        for line in self.process.stdout:
            self.log.write(line)
            self.last_output = time.monotonic()
            self.last_lines = (self.last_lines + [line.rstrip()])[-20:]
            if self.echo and not line.startswith("Using python version") and line.strip():
                say(f"[{self.name}] {line.rstrip()}")
        self.log.close()

    @property
    def running(self):
        return self.code is None

    def reap_if_exited(self):
        """True once the process has exited. The group's remaining members are killed before the leader is
        reaped: while it is a zombie its pid, and so the group id, cannot be reused by another process."""
        if self.code is not None:
            return True
        try:
            if os.waitid(os.P_PID, self.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is None:
                return False
        except ChildProcessError:
            pass  # already reaped: wait() below returns its code
        else:
            self._signal_group(signal.SIGKILL)
        self.code = self.process.wait()
        self.thread.join(2)
        return True

    def _signal_group(self, signum):
        try:
            os.killpg(self.pid, signum)
        except (ProcessLookupError, PermissionError):
            pass

    def sample(self, stats, now):
        """Updates CPU and stopped-state bookkeeping from process_group_stats()."""
        ticks, stopped = stats.get(self.pid, (None, False))
        if ticks is not None and ticks != self.cpu_ticks:
            self.cpu_ticks, self.last_cpu_change = ticks, now
        if stopped and self.stopped_since is None:
            self.stopped_since = now
        elif not stopped:
            self.stopped_since = None

    def state(self, now):
        """What the process is doing, in words: frozen (stopped, or no output and no CPU), or running."""
        if self.stopped_since is not None:
            return f"appears frozen (stopped, state T, for {now - self.stopped_since:.0f} s)"
        idle = now - max(self.last_output, self.last_cpu_change)
        if idle >= FROZEN_IDLE_S:
            return f"appears frozen (no output and no CPU for {idle:.0f} s)"
        return f"was running (last output {now - self.last_output:.0f} s ago)"

    def terminate(self, reason, now):
        """SIGTERM (and SIGCONT, so that a stopped process can act on it) to the group; records why."""
        if self.running and not self.stopped_by:
            self.stopped_by = reason
            self.state_when_stopped = self.state(now)
            self._signal_group(signal.SIGTERM)
            self._signal_group(signal.SIGCONT)

    def kill(self):
        if self.running:
            self._signal_group(signal.SIGKILL)

    def report(self):
        entry = {"exit_code": self.code, "log": self.log_name}
        if self.stopped_by:
            entry.update({"stopped_by_runner": self.stopped_by, "state_when_stopped": self.state_when_stopped})
        return entry

    def failure(self):
        """One phrase for the error line, or None when it exited with 0."""
        if self.stopped_by:
            return f"{self.name} {self.state_when_stopped}, stopped by the runner: {self.stopped_by}"
        if self.code == 0:
            return None
        if self.code < 0:
            return f"{self.name} was killed by {signal.Signals(-self.code).name} from outside the runner (see {self.log_name})"
        return f"{self.name} exited with {self.code} (see {self.log_name})"


def stop_solvers(solvers, reason):
    """Stops every running solver within STOP_GRACE_S + a few ms: SIGTERM, then SIGKILL; all reaped."""
    now = time.monotonic()
    stats = process_group_stats()
    for s in solvers:
        if not s.reap_if_exited():  # one that has just ended by itself is not reported as stopped
            s.sample(stats, now)
            s.terminate(reason, now)
    deadline = now + STOP_GRACE_S
    while any(not s.reap_if_exited() for s in solvers) and time.monotonic() < deadline:
        time.sleep(0.01)
    for s in solvers:
        s.kill()
    for s in solvers:
        while not s.reap_if_exited():
            time.sleep(0.005)


def watch_pair(solvers, guard):
    """Waits for both solvers. Once one fails, the other gets PEER_GRACE_S to stop by itself, or none if it is
    stopped (state T): it cannot act on its peer's loss."""
    failed_at, warned, next_sample = None, set(), 0.0
    while True:
        with guard.deferred():
            now = time.monotonic()
            for s in solvers:
                s.reap_if_exited()
            running = [s for s in solvers if s.running]
            if not running:
                return
            failed = [s for s in solvers if not s.running and s.code != 0]
            if failed and failed_at is None:
                failed_at, next_sample = now, now  # judge the survivor on a fresh sample
            if now >= next_sample:
                stats = process_group_stats()
                for s in running:
                    s.sample(stats, now)
                next_sample = now + CPU_SAMPLE_S
            for s in running:
                if failed and s.stopped_since is not None:
                    stop_solvers([s], f"{failed[0].name} failed and {s.name} is stopped, so it cannot finish")
                elif failed and now - failed_at > PEER_GRACE_S:
                    stop_solvers([s], f"still running {PEER_GRACE_S:.0f} s after {failed[0].name} failed")
                elif s.stopped_since is not None and now - s.stopped_since > FROZEN_IDLE_S and s.name not in warned:
                    warned.add(s.name)
                    say(f"[run] {s.name} (pid {s.pid}) is stopped: the run cannot go on until it is continued (kill -CONT)")
        time.sleep(POLL_S)


def wait_reference(solver, guard):
    while True:
        with guard.deferred():
            if solver.reap_if_exited():
                return solver.code
        time.sleep(POLL_S)


def make_partial_folder(out):
    """OUT.partial-XXXXXXXX beside OUT, so that the final rename stays on one file system (atomic)."""
    parent = os.path.dirname(out)
    try:
        os.makedirs(parent, exist_ok=True)
        partial = tempfile.mkdtemp(prefix=os.path.basename(out) + ".partial-", dir=parent)
    except OSError as e:
        raise CaseError(f"cannot write beside {out}: {e}") from None
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(partial, 0o777 & ~umask)  # mkdtemp's 0700 is for secrets; results are ordinary files
    return partial


def make_ipc_folder():
    """A directory only this user can enter (mkdtemp: 0700) for the run's socket; /tmp when $TMPDIR would
    make the socket path longer than a Unix socket address allows."""
    folder = tempfile.mkdtemp(prefix="railcosim-run-")
    if len(os.path.join(folder, "bridge.sock")) > 100:
        os.rmdir(folder)
        folder = tempfile.mkdtemp(prefix="railcosim-run-", dir="/tmp")
    return folder


RECORDING_FILE = "interface.rec"  # --record: every interface message of the run (railcosim_replay reads it)

class Run:
    """One run of a case, from its partial folder to the summary and the rename into place."""

    def __init__(self, name, case, params, out, args, time_limit, guard, resume=None, dem_only=False):
        """`resume`: (checkpoint folder, manifest) when the run continues the interrupted one in `out`; `dem_only`:
        the case runs the YADE participant alone (case.toml dem_only = true)."""
        self.name, self.case, self.params, self.out = name, case, params, out
        self.dem_only = dem_only
        self.args, self.time_limit, self.guard = args, time_limit, guard
        self.resume = resume
        self.stage = "start"
        self.status, self.error = "ok", None
        self.solvers, self.references = [], []
        self.summary = {}
        self.stop, self.partial, self.coupled_wall = None, None, None
        self.early_end = "the run ended"  # why solvers still running at the end are stopped, if no signal

    def execute(self):
        start = time.monotonic()
        ipc_folder = None
        try:
            with self.guard.deferred():
                # A resumed run goes on in the interrupted run's folder, which holds its checkpoints.
                self.partial = self.out if self.resume else make_partial_folder(self.out)
                self.guard.set_time_limit(self.time_limit)
                ipc_folder = make_ipc_folder()
                self._write_parameters()
            if not self._replayed_side():
                self._run_preparation()
            if self.status == "ok":
                self._run_coupled(ipc_folder, time.monotonic())
            # A replay checks one solver against a recording: the other's outputs, which the references
            # and the post-processing read, do not exist.
            if self.status == "ok" and not self._replayed_side():
                self._run_references()
            if self.status == "ok" and not self._replayed_side():
                self._postprocess()
        except Stop as stop:
            self.stop = stop
        except Exception as e:  # mostly the case's own code: recorded with the run's files, not lost
            if self.partial is None:
                raise
            with open(os.path.join(self.partial, "traceback.log"), "w") as f:
                f.write(traceback.format_exc())
            self.status = "failed"
            self.error = f"{self.stage} failed: {type(e).__name__}: {e} (traceback in traceback.log)"
        finally:
            self.guard.disarm()
            stop_solvers(self.solvers + self.references, self._stop_reason())
            if ipc_folder:
                shutil.rmtree(ipc_folder, ignore_errors=True)
        if self.partial is None:
            raise self.stop  # stopped before anything was written
        if self.coupled_wall is None:
            self.coupled_wall = time.monotonic() - start
        if self.stop:
            self._record_stop(self.stop)
        self._write_summary(start)
        where, note = self._move_into_place()
        print_summary(self.summary, where)
        if note:
            say(f"[run] {note}")
        return self._exit_code()

    def _stop_reason(self):
        stop = self.stop or self.guard.stop
        if stop is None:
            return self.early_end
        if stop.time_limit:
            return f"time limit of {self.time_limit:g} s reached"
        return f"{signal.Signals(stop.signum).name} received by the runner"

    def _write_parameters(self, resolved=None):
        record = dict(self.params, **({"resolved": resolved} if resolved else {}))
        with open(os.path.join(self.partial, "parameters.json"), "w") as f:
            json.dump(record, f, indent=2, sort_keys=True)

    def _environment(self, token=None):
        env = dict(os.environ, PYTHONUNBUFFERED="1")  # YADE's Python prints reach dem.log as they happen
        for variable in ("RAILCOSIM_BRIDGE_TOKEN",) + checkpoints.ENVIRONMENT:
            env.pop(variable, None)
        if token:
            env["RAILCOSIM_BRIDGE_TOKEN"] = token  # never on the command line: argv is public in ps
            env.update(checkpoints.solver_environment(self.partial, checkpoints.run_identity(self.name, self.params),
                                                      self.args.checkpoint_every,
                                                      self.resume[0] if self.resume else None))
        return env

    def _run_coupled(self, ipc_folder, start):
        self.stage = "coupled run"
        endpoint = f"ipc://{os.path.join(ipc_folder, 'bridge.sock')}"
        env = self._environment(secrets.token_hex(16))
        say(f"[run] case {self.name}{' (smoke)' if self.args.smoke else ''} -> {self.out}")
        if self.resume:
            manifest = self.resume[1]
            self.summary["resumed_from"] = {"checkpoint": manifest["name"], "window": manifest["window"],
                                            "time_s": manifest["time"]}
            say(f"[run] resuming from {self.resume[0]} (window {manifest['window']}, t = {manifest['time']:.6g} s)")
        if self.args.checkpoint_every is not None:
            self.summary["checkpoints"] = {"every_s": self.args.checkpoint_every, "folder": checkpoints.FOLDER}
        say(f"[run] endpoint {endpoint}; time limit {self.time_limit:.0f} s" if self.time_limit
            else f"[run] endpoint {endpoint}; no time limit")
        commands = [("dem", self.case.dem_command(self.params, endpoint, self.partial))]
        if not self.dem_only:
            commands.insert(0, ("fem", self.case.fem_command(self.params, endpoint, self.partial)))
        played = self._replayed_side()
        if played:
            # The recording stands in for one solver; the other runs live and is compared with its recorded answers.
            recording = os.path.abspath(getattr(self.args, f"replay_{played}"))
            replay = [os.path.join(os.environ.get("RAILCOSIM_BUILD", "build"), "bridge", "dummies", "railcosim_replay"),
                      "--recording", recording, "--play", played, "--endpoint", endpoint]
            commands = [(name, replay if name == played else argv) for name, argv in commands]
            self.summary["replay"] = {"played": played, "recording": recording}
            say(f"[run] replaying the {played} side from {recording}")
        for name, argv in commands:
            solver_env = env
            if self.args.record and name == "fem":
                # The FEM side sees both directions; the file moves with the results folder.
                solver_env = dict(env, RAILCOSIM_BRIDGE_RECORD=os.path.join(self.partial, RECORDING_FILE))
                self.summary["recording"] = RECORDING_FILE
            if not self._start(self.solvers, name, argv, solver_env):
                return
        watch_pair(self.solvers, self.guard)
        self.coupled_wall = time.monotonic() - start
        if played:
            lines = [line for s in self.solvers if s.name == played for line in s.last_lines
                     if line.startswith("railcosim_replay:")]
            self.summary["replay"]["result"] = lines[-1] if lines else None
        # The likely cause first: a frozen solver, then one that failed by itself, then those the runner stopped.
        order = lambda s: 0 if (s.state_when_stopped or "").startswith("appears frozen") else 2 if s.stopped_by else 1
        problems = [s.failure() for s in sorted(self.solvers, key=order) if s.failure()]
        if problems:
            self.status, self.error = "failed", "; ".join(problems)
        else:
            self._record_resolved()

    def _replayed_side(self):
        return "fem" if self.args.replay_fem else "dem" if self.args.replay_dem else None

    def _start(self, group, name, argv, env, echo=True):
        """Starts a solver into group (a signal waits until it is recorded there); False if it cannot start."""
        append_log = None
        if self.resume and group is self.solvers:
            append_log = f"[run] ---- resumed from {self.resume[0]} ----"
        with self.guard.deferred():
            try:
                group.append(Solver(name, argv, self.partial, env, echo, append_log))
            except OSError as e:
                self.status, self.error = "failed", f"could not start {name} ({argv[0]}): {e}"
                self.early_end = f"{name} could not be started"
                return False
        return True

    def _record_resolved(self):
        """The DEM step the run really used, from dem_info.json, next to the parameters that asked for it."""
        path = os.path.join(self.partial, "dem_info.json")
        if not os.path.isfile(path):
            return
        try:
            with open(path) as f:
                info = json.load(f)
        except ValueError:
            return  # the post-processing reads it too and reports it
        resolved = {key: info[source] for key, source in (("dem_dt", "dt"), ("dem_steps_per_window", "subcycles"))
                    if source in info}
        if not resolved:
            return
        self.summary["resolved"] = resolved
        asked = self.params.get("dem_dt")
        if asked and "dem_dt" in resolved and not math.isclose(asked, resolved["dem_dt"], rel_tol=1e-6):
            self.summary["warning"] = f"dem_dt={asked:g} was asked, the DEM ran with {resolved['dem_dt']:g}"
        with self.guard.deferred():
            self._write_parameters(resolved)

    def _run_preparation(self):
        """The case's preparation runs (e.g. a particle bed the coupled run starts from), one after the other, their
        output echoed; their wall times go to the summary."""
        env = self._environment()
        self.stage = "preparation"
        for name, argv in self.case.preparation_runs(self.params, self.partial):
            self.stage = f"preparation run '{name}'"
            say(f"[run] preparation run '{name}'")
            started = time.monotonic()
            if not self._start(self.references, name, argv, env):
                return
            solver = self.references[-1]
            code = wait_reference(solver, self.guard)
            self.summary.setdefault("preparation", {})[name] = {"wall_time_s": round(time.monotonic() - started, 3)}
            if code != 0:
                self.status = "failed"
                self.error = f"preparation run '{name}' failed (exit {solver.code}; see {solver.log_name})"
                return

    def _run_references(self):
        env = self._environment()
        self.stage = "reference runs"
        for ref_name, argv in self.case.reference_runs(self.params, self.partial):
            self.stage = f"reference run '{ref_name}'"
            say(f"[run] reference run '{ref_name}'")
            if not self._start(self.references, ref_name, argv, env, echo=False):
                return
            solver = self.references[-1]
            if wait_reference(solver, self.guard) != 0:
                tail = "\n".join(solver.last_lines[-15:])
                self.status = "failed"
                self.error = f"reference run '{ref_name}' failed (exit {solver.code}; see {solver.log_name})"
                say(f"[run] {self.error}:\n{tail}")
                return

    def _postprocess(self):
        self.stage = "post-processing"
        fields = snapshots.assemble(self.partial)  # ParaView's fields.xdmf, before the case reads the run
        if fields:
            self.summary["snapshots"] = fields
        self.summary.update(self.case.postprocess(self.params, self.partial))
        for check in self.summary.get("checks", []):
            check["passed"] = bool(check["value"] <= check["limit"])

    def _record_stop(self, stop):
        if stop.time_limit:
            self.status = "time_limit"
            self.summary["time_limit"] = {"limit_s": self.time_limit, "stage": self.stage}
            what = f"time limit of {self.time_limit:g} s reached during the {self.stage}"
        else:
            self.status = "interrupted"
            self.summary["interrupted"] = {"signal": signal.Signals(stop.signum).name, "signal_number": stop.signum,
                                           "stage": self.stage}
            what = f"{signal.Signals(stop.signum).name} received during the {self.stage}"
        states = [f"{s.name} {s.state_when_stopped}" for s in self.solvers + self.references if s.stopped_by]
        self.error = what + ("; stopped by the runner: " + ", ".join(states) if states else "")

    def _write_summary(self, start):
        summary = {"case": self.name, "status": self.status, "smoke": self.args.smoke,
                   "wall_time_s": round(self.coupled_wall, 3), "time_limit_s": self.time_limit or None,
                   "parameters": self.params}
        summary.update(self.summary)
        if "checkpoints" in summary:
            newest = checkpoints.latest(self.partial)
            summary["checkpoints"]["latest"] = os.path.basename(newest) if newest else None
        if self.solvers or self.references:
            summary["solvers"] = {s.name: s.report() for s in self.solvers + self.references}
        if self.error:
            summary["error"] = self.error
        summary["total_wall_time_s"] = round(time.monotonic() - start, 3)
        self.summary = summary
        with open(os.path.join(self.partial, "summary.json"), "w") as f:
            json.dump(summary, f, indent=2)

    def _move_into_place(self):
        """Renames the partial folder to OUT; an existing OUT (--force) is replaced only by a finished run.
        Returns where the run's files are and a note when that is not OUT."""
        if self.resume:
            # A resumed run stays in its folder; one left as OUT.partial-XXXXXXXX moves to OUT once it has finished.
            target = re.sub(r"\.partial-[^/]+$", "", self.out)
            if self.status == "ok" and target != self.out and not os.path.exists(target):
                os.rename(self.out, target)
                return target, None
            return self.out, None
        if not os.path.exists(self.out):
            os.rename(self.partial, self.out)
            return self.out, None
        if self.status != "ok" or not self.args.force:
            why = "this run did not finish" if self.status != "ok" else "it appeared during the run (no --force)"
            return self.partial, f"{self.out} kept ({why}); this run's output is in {self.partial}"
        trash = tempfile.mkdtemp(prefix=os.path.basename(self.out) + ".old-", dir=os.path.dirname(self.out))
        os.rename(self.out, os.path.join(trash, "previous"))
        os.rename(self.partial, self.out)
        shutil.rmtree(trash, ignore_errors=True)
        return self.out, None

    def _exit_code(self):
        if self.stop:
            return self.stop.exit_code
        if self.status != "ok":
            return EXIT_FAILED
        return EXIT_CHECKS if any(not c["passed"] for c in self.summary.get("checks", [])) else 0


def print_summary(summary, where):
    say(f"[run] status: {summary['status']}  coupled wall time: {summary['wall_time_s']:.1f} s")
    if "error" in summary:
        say(f"[run] error: {summary['error']}")
    for key, value in summary.get("metrics", {}).items():
        say(f"[run]   {key} = {value}")
    for key, value in summary.get("relative_error", {}).items():
        say(f"[run]   relative error {key} = {value:.3%}" if isinstance(value, float) else f"[run]   {key} = {value}")
    for check in summary.get("checks", []):
        mark = "PASS" if check["passed"] else "FAIL"
        say(f"[run]   check {mark}: {check['name']}: {check['value']:.4g} (limit {check['limit']:.4g})")
    say(f"[run] summary: {os.path.join(where, 'summary.json')}")


def time_limit_argument(text):
    value = float(text)
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text} is not a number of seconds >= 0")
    return value


def simulated_seconds(text):
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text} is not a positive number of seconds of simulated time")
    return value


def main(argv, guard):
    parser = argparse.ArgumentParser(prog="railcosim run", description="Run a coupled DEM-FEM case.")
    parser.add_argument("case", help="case folder, e.g. cases/beam_uniform_load")
    parser.add_argument("--smoke", action="store_true", help="small, fast variant (<= 60 s) used by the tests")
    parser.add_argument("--out", help="results folder (default results/NAME or results/NAME-smoke)")
    parser.add_argument("--force", action="store_true", help="replace an existing results folder once this run finished")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a parameter")
    parser.add_argument("--record", action="store_true",
                        help=f"write every interface message (both directions, with times) to OUT/{RECORDING_FILE}")
    replay = parser.add_mutually_exclusive_group()
    replay.add_argument("--replay-fem", metavar="RECORDING",
                        help="play the FEM side back from a recording; the DEM solver runs live and its forces are "
                             "compared with the recorded ones (no post-processing)")
    replay.add_argument("--replay-dem", metavar="RECORDING",
                        help="play the DEM side back from a recording; the FEM solver runs live and its kinematics "
                             "are compared with the recorded ones (no post-processing)")
    parser.add_argument("--time-limit", type=time_limit_argument, metavar="SECONDS",
                        help="wall-clock limit of the whole run (default: from the case, at least 600 s; 0: none)")
    parser.add_argument("--checkpoint-every", type=simulated_seconds, metavar="SECONDS",
                        help="save a restart checkpoint of both solvers every SECONDS of simulated time into "
                             "OUT/checkpoints (the newest two are kept)")
    parser.add_argument("--resume", metavar="DIR",
                        help="continue the interrupted run whose results folder is DIR from its newest complete "
                             "checkpoint, writing into DIR (same case, --smoke and --set values)")
    args = parser.parse_args(argv)

    case_dir = os.path.abspath(args.case.rstrip("/"))
    if not os.path.isdir(case_dir):
        raise CaseError(f"no such case folder: {args.case}")
    config, case = load_case(case_dir)
    name = config.get("name", os.path.basename(case_dir))
    params = parameters.resolve_parameters(config, args.smoke, args.set)
    dem_only = is_dem_only(config)
    if dem_only:
        # Restart checkpoints, recordings and replays are coordinated over the coupling, which a DEM-only case has not.
        for given, option in ((args.record, "--record"), (args.replay_fem or args.replay_dem, "--replay-*"),
                              (args.checkpoint_every is not None, "--checkpoint-every"), (args.resume, "--resume")):
            if given:
                raise CaseError(f"{option} needs the FEM participant; {name} is a DEM-only case (dem_only = true)")
    problems = parameters.check_parameters(params, config, case)
    if problems:
        raise ParameterError("\n".join(problems))
    if args.checkpoint_every is not None or args.resume:
        # A DEM side that saves no state would run through unsaved: refused rather than ignored.
        reason = case.restart_unsupported(params)
        if reason:
            option = "--checkpoint-every" if args.checkpoint_every is not None else "--resume"
            raise CaseError(f"{option} is not available for this run: {reason}")
    time_limit = args.time_limit if args.time_limit is not None else parameters.default_time_limit(config, params)
    params["smoke"] = args.smoke
    params["case_dir"] = case_dir

    for recording in (args.replay_fem, args.replay_dem):
        if recording and not os.path.isfile(recording):
            raise CaseError(f"no such recording: {recording} (made by ./railcosim run CASE --record)")
    replaying = args.replay_fem or args.replay_dem
    if args.resume and (args.record or replaying):
        raise CaseError("--resume does not combine with --record or --replay-*: a recording covers one run from its "
                        "first window")
    if args.checkpoint_every is not None and replaying:
        raise CaseError("--checkpoint-every does not combine with --replay-*: the played-back side saves no state")
    if args.resume:
        if args.out or args.force:
            raise CaseError("--resume DIR continues in DIR: --out and --force do not apply")
        out = os.path.abspath(args.resume.rstrip("/"))
        resume = checkpoints.resume_checkpoint(out, name, params)
        return Run(name, case, params, out, args, time_limit, guard, resume).execute()
    out = os.path.abspath(args.out or os.path.join(os.getcwd(), "results", name + ("-smoke" if args.smoke else "")))
    if os.path.exists(out) and not args.force:
        raise CaseError(f"results folder {out} already exists; pass --force to replace it or --out to choose another")
    return Run(name, case, params, out, args, time_limit, guard, dem_only=dem_only).execute()


if __name__ == "__main__":
    guard = SignalGuard()
    try:
        sys.exit(main(sys.argv[1:], guard))
    except (CaseError, ParameterError) as e:
        for line in str(e).splitlines():
            print(f"railcosim run: {line}", file=sys.stderr)
        sys.exit(EXIT_REFUSED)
    except Stop as stop:
        print(f"railcosim run: {stop} before the run started; nothing was written", file=sys.stderr)
        sys.exit(stop.exit_code)
