#!/usr/bin/python3
"""Runs a coupled case: starts the FEM and DEM solvers on a fresh endpoint, watches both, writes summary.json.

Usage: railcosim run cases/NAME [--smoke] [--out DIR] [--force] [--set key=value ...]

A case folder holds case.toml (parameters, with a [smoke] table of overrides) and case.py, which defines
  fem_command(params, endpoint, out) -> argv list      the FreeFEM participant
  dem_command(params, endpoint, out) -> argv list      the YADE participant (default: the folder's dem.py)
  reference_runs(params, out) -> [(name, argv), ...]   solver-only runs to compare with (default: none)
  postprocess(params, out) -> dict                     metrics, reference, relative_error, checks
Each check is {name, value, limit} and passes when value <= limit; the runner marks it.
"""
import argparse
import importlib.util
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import tomllib
import uuid

import railcosim_results as results

# After one solver fails, how long the other may take to notice (the bridge reports a lost peer within a
# few seconds) before it is stopped.
PEER_GRACE_S = 15.0


class CaseError(Exception):
    """A problem with the case definition or the command line, reported without a traceback."""


def load_case(case_dir):
    toml_path = os.path.join(case_dir, "case.toml")
    py_path = os.path.join(case_dir, "case.py")
    for path in (toml_path, py_path):
        if not os.path.isfile(path):
            raise CaseError(f"{case_dir} is not a case folder: {os.path.basename(path)} is missing")
    with open(toml_path, "rb") as f:
        try:
            config = tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise CaseError(f"{toml_path}: {e}") from e
    spec = importlib.util.spec_from_file_location("railcosim_case", py_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return config, module


def convert_like(key, text, default):
    """Converts a --set value to the type of the parameter's default, so typos fail loudly."""
    try:
        if isinstance(default, bool):
            if text.lower() in ("1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError
        if isinstance(default, int):
            return int(text)
        if isinstance(default, float):
            return float(text)
        return text
    except ValueError:
        raise CaseError(f"--set {key}={text}: expected a {type(default).__name__} like the default {default!r}") from None


def resolve_parameters(config, smoke, assignments):
    params = dict(config.get("parameters", {}))
    if smoke:
        for key, value in config.get("smoke", {}).items():
            if key not in params:
                raise CaseError(f"case.toml [smoke] sets unknown parameter '{key}'")
            params[key] = value
    for item in assignments:
        if "=" not in item:
            raise CaseError(f"--set needs key=value, got '{item}'")
        key, text = item.split("=", 1)
        if key not in params:
            known = ", ".join(sorted(params))
            raise CaseError(f"--set: unknown parameter '{key}'. Known parameters: {known}")
        params[key] = convert_like(key, text, params[key])
    return params


class Solver:
    """One participant process whose output is echoed with a prefix and saved to a log file."""

    def __init__(self, name, argv, out, env):
        self.name = name
        self.log_path = os.path.join(out, f"{name}.log")
        self.log = open(self.log_path, "w")
        self.last_lines = []
        self.process = subprocess.Popen(argv, cwd=out, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, text=True, bufsize=1, start_new_session=True)
        self.thread = threading.Thread(target=self._pump, daemon=True)
        self.thread.start()

    def _pump(self):
        for line in self.process.stdout:
            self.log.write(line)
            self.last_lines = (self.last_lines + [line.rstrip()])[-20:]
            if not line.startswith("Using python version") and line.strip():
                print(f"[{self.name}] {line.rstrip()}", flush=True)
        self.log.close()

    def poll(self):
        return self.process.poll()

    def stop(self):
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        self.thread.join(5)


def run_pair(solvers):
    """Waits for both solvers; once one fails, gives the other PEER_GRACE_S to stop by itself."""
    failed_at = None
    while any(s.poll() is None for s in solvers):
        if failed_at is None and any(s.poll() not in (None, 0) for s in solvers):
            failed_at = time.monotonic()
        if failed_at is not None and time.monotonic() - failed_at > PEER_GRACE_S:
            for s in solvers:
                if s.poll() is None:
                    print(f"[run] {s.name} still running {PEER_GRACE_S:.0f} s after its peer failed: stopping it",
                          flush=True)
                    s.stop()
        time.sleep(0.1)
    for s in solvers:
        s.thread.join(5)
    return {s.name: s.poll() for s in solvers}


def run_reference(name, argv, out, env):
    print(f"[run] reference run '{name}'", flush=True)
    log_path = os.path.join(out, f"{name}.log")
    with open(log_path, "w") as log:
        result = subprocess.run(argv, cwd=out, env=env, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, timeout=1800)
    if result.returncode != 0:
        with open(log_path) as log:
            tail = "".join(log.readlines()[-15:])
        raise CaseError(f"reference run '{name}' failed (exit {result.returncode}); see {log_path}:\n{tail}")


def main(argv):
    parser = argparse.ArgumentParser(prog="railcosim run", description="Run a coupled DEM-FEM case.")
    parser.add_argument("case", help="case folder, e.g. cases/beam_uniform_load")
    parser.add_argument("--smoke", action="store_true", help="small, fast variant (<= 60 s) used by the tests")
    parser.add_argument("--out", help="results folder (default results/NAME or results/NAME-smoke)")
    parser.add_argument("--force", action="store_true", help="replace an existing results folder")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a parameter")
    args = parser.parse_args(argv)

    case_dir = os.path.abspath(args.case.rstrip("/"))
    if not os.path.isdir(case_dir):
        raise CaseError(f"no such case folder: {args.case}")
    config, case = load_case(case_dir)
    name = config.get("name", os.path.basename(case_dir))
    params = resolve_parameters(config, args.smoke, args.set)
    params["smoke"] = args.smoke
    params["case_dir"] = case_dir

    out = os.path.abspath(args.out or os.path.join(os.getcwd(), "results", name + ("-smoke" if args.smoke else "")))
    if os.path.exists(out):
        if not args.force:
            raise CaseError(f"results folder {out} already exists; pass --force to replace it or --out to choose another")
        shutil.rmtree(out)
    os.makedirs(out)
    with open(os.path.join(out, "parameters.json"), "w") as f:
        json.dump(params, f, indent=2, sort_keys=True)

    endpoint = f"ipc:///tmp/railcosim-{os.getpid()}-{uuid.uuid4().hex[:8]}.sock"
    env = dict(os.environ)
    print(f"[run] case {name}{' (smoke)' if args.smoke else ''} -> {out}", flush=True)
    print(f"[run] endpoint {endpoint}", flush=True)

    start = time.monotonic()
    status, error = "ok", None
    solvers = []
    try:
        dem_command = getattr(case, "dem_command", results.standard_dem_command)
        solvers = [Solver("fem", case.fem_command(params, endpoint, out), out, env),
                   Solver("dem", dem_command(params, endpoint, out), out, env)]
        codes = run_pair(solvers)
        bad = {k: v for k, v in codes.items() if v != 0}
        if bad:
            status = "failed"
            error = "; ".join(f"{k} exited with {v} (log: {os.path.join(out, k + '.log')})" for k, v in bad.items())
    except KeyboardInterrupt:
        status, error = "failed", "interrupted by the user"
        for s in solvers:
            s.stop()
    finally:
        ipc_path = endpoint[len("ipc://"):]
        if os.path.exists(ipc_path):
            os.unlink(ipc_path)
    coupled_wall = time.monotonic() - start

    summary = {"case": name, "status": status, "smoke": args.smoke, "wall_time_s": round(coupled_wall, 3),
               "parameters": params}
    if status == "ok":
        for ref_name, ref_argv in getattr(case, "reference_runs", lambda p, o: [])(params, out):
            run_reference(ref_name, ref_argv, out, env)
        summary.update(case.postprocess(params, out))
        for check in summary.get("checks", []):
            check["passed"] = bool(check["value"] <= check["limit"])
    else:
        summary["error"] = error
    summary["total_wall_time_s"] = round(time.monotonic() - start, 3)
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)

    print_summary(summary, out)
    if status != "ok":
        return 1
    failed_checks = [c for c in summary.get("checks", []) if not c["passed"]]
    return 3 if failed_checks else 0


def print_summary(summary, out):
    print(f"[run] status: {summary['status']}  coupled wall time: {summary['wall_time_s']:.1f} s", flush=True)
    if "error" in summary:
        print(f"[run] error: {summary['error']}", flush=True)
    for key, value in summary.get("metrics", {}).items():
        print(f"[run]   {key} = {value}")
    for key, value in summary.get("relative_error", {}).items():
        print(f"[run]   relative error {key} = {value:.3%}" if isinstance(value, float) else f"[run]   {key} = {value}")
    for check in summary.get("checks", []):
        mark = "PASS" if check["passed"] else "FAIL"
        print(f"[run]   check {mark}: {check['name']}: {check['value']:.4g} (limit {check['limit']:.4g})")
    print(f"[run] summary: {os.path.join(out, 'summary.json')}", flush=True)


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except CaseError as e:
        print(f"railcosim run: {e}", file=sys.stderr)
        sys.exit(2)
