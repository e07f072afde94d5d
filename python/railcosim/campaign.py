"""Campaigns: one case over a grid and/or list of --set values, with repetitions, run in a local pool or as a
Slurm job array; one folder per run, one index (campaign.csv), aggregates per point, plots (docs/campaigns.md)."""
import csv
import fcntl
import glob
import itertools
import json
import math
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib

from railcosim import parameters
from railcosim.case import CaseError, load_case
from railcosim.parameters import ParameterError

# A run is finished when run_case.py put its folder in place with one of these statuses; a run whose checks
# failed has status "ok" (the checks are listed in its summary). Anything else (failed, interrupted,
# time_limit, no folder, a left-over OUT.partial-*) is run again.
FINISHED_STATUSES = ("ok",)
CAMPAIGN_KEYS = ("case", "smoke", "repetitions", "seed", "out", "time_limit_s", "set", "grid", "points",
                 "pool", "slurm")
SLURM_KEYS = ("partition", "account", "time", "cpus_per_task", "mem", "qos", "constraint", "max_parallel",
              "modules", "setup", "options", "poll_s")
PLAN_FILE, INDEX_FILE, AGGREGATES_FILE = "plan.json", "campaign.csv", "aggregates.csv"
ACTIVE_JOB_FILE, LOCK_FILE = "job.json", ".lock"  # in CAMPAIGN/slurm: the last job array; in CAMPAIGN: one campaign at a time
# Each coupled run is two solver processes (FEM and DEM) working in turn or together: a core each.
PROCESSES_PER_RUN = 2
PROGRESS_EVERY_S = 10.0
EXIT_FAILED, EXIT_CHECKS = 1, 3  # as `railcosim run`: a run did not finish; every run finished, some checks failed
# SIGTERM to a run, then SIGKILL after this: run_case.py stops its solvers within a second and writes its summary.
RUN_STOP_GRACE_S = 10.0
POLL_S = 0.2
SQUEUE_PATIENCE_S = 300.0  # a controller restart or failover takes seconds to minutes
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class CampaignError(Exception):
    """A campaign file or command that is refused before any run starts."""


def value_text(value):
    """The --set text of a TOML value: booleans as true/false, numbers by repr (no precision lost)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value) if not isinstance(value, float) else repr(value)
    raise CampaignError(f"campaign value {value!r}: expected a number, a boolean or a string")


def label_of(point):
    """Folder name of a parameter point: key-value pairs joined by '_', unsafe characters replaced."""
    if not point:
        return "default"
    text = "_".join(f"{k}-{v}" for k, v in point.items())
    return re.sub(r"[^A-Za-z0-9.=+-]", "_", text)


def load_spec(path):
    """The campaign file as a dict, with the case and the output folder resolved against the file's folder."""
    try:
        with open(path, "rb") as f:
            spec = tomllib.load(f)
    except OSError as e:
        raise CampaignError(f"cannot read campaign file {path}: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise CampaignError(f"{path}: {e}") from None
    here = os.path.dirname(os.path.abspath(path))
    for key in ("case", "out"):
        if key in spec and isinstance(spec[key], str):
            spec[key] = resolve_path(spec[key], here)
    spec.setdefault("out", os.path.join(os.getcwd(), "results",
                                        os.path.splitext(os.path.basename(path))[0]))
    return spec


def resolve_path(text, here):
    """A path of the campaign file: absolute, or relative to the file's folder, else to the repository root."""
    text = os.path.expanduser(text)
    if os.path.isabs(text):
        return text
    for base in (here, ROOT):
        if os.path.exists(os.path.join(base, text)):
            return os.path.abspath(os.path.join(base, text))
    return os.path.abspath(os.path.join(here, text))


def build_plan(spec):
    """The list of runs of a campaign spec, each {folder, point, repetition, seed, settings}; validates every
    run's parameters against the case (CampaignError / ParameterError before anything starts)."""
    unknown = sorted(set(spec) - set(CAMPAIGN_KEYS))
    if unknown:
        raise CampaignError(f"campaign file: unknown entries {', '.join(unknown)}{parameters.nearest(unknown[0], CAMPAIGN_KEYS)}; "
                            f"the entries are {', '.join(CAMPAIGN_KEYS)}")
    if "case" not in spec:
        raise CampaignError("campaign file: 'case' (a case folder, e.g. \"cases/_template\") is required")
    case_dir = spec["case"]
    if not os.path.isdir(case_dir):
        raise CampaignError(f"campaign file: no such case folder: {case_dir}")
    config, case = load_case(case_dir)
    defaults, _ = parameters.case_defaults(config)
    repetitions = spec.get("repetitions", 1)
    if not isinstance(repetitions, int) or isinstance(repetitions, bool) or repetitions < 1:
        raise CampaignError(f"campaign file: repetitions must be a whole number >= 1, got {repetitions!r}")
    smoke = spec.get("smoke", False)
    if not isinstance(smoke, bool):
        raise CampaignError(f"campaign file: smoke must be true or false, got {smoke!r}")
    fixed = {k: value_text(v) for k, v in spec.get("set", {}).items()}
    grid = spec.get("grid", {})
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise CampaignError(f"campaign file [grid] {key}: expected a non-empty list of values, got {values!r}")
    points = [dict(p) for p in itertools.product(*[[(k, value_text(v)) for v in vs] for k, vs in grid.items()])] \
        if grid else []
    for extra in spec.get("points", []):
        if not isinstance(extra, dict):
            raise CampaignError(f"campaign file: each entry of points is a table of values, got {extra!r}")
        points.append({k: value_text(v) for k, v in extra.items()})
    if not points:
        points = [{}]
    has_seed = "seed" in defaults
    if any("seed" in p for p in points) or "seed" in fixed:
        raise CampaignError("campaign file: the seed is the campaign's: give its base as seed = N "
                            "(repetition r runs with seed N + r), not in [set], [grid] or points")
    base_seed = spec.get("seed")
    if base_seed is not None and not has_seed:
        raise CampaignError(f"campaign file: seed = {base_seed}, but case {case_dir} has no seed parameter")
    if has_seed and base_seed is None:
        base_seed = parameters.resolve_parameters(config, smoke, [])["seed"]
    runs, labels = [], set()
    for point in points:
        label = label_of(point)
        while label in labels:
            label += "+"
        labels.add(label)
        for r in range(repetitions):
            settings = dict(fixed)
            settings.update(point)
            seed = base_seed + r if has_seed else None
            if has_seed:
                settings["seed"] = str(seed)
            assignments = [f"{k}={v}" for k, v in settings.items()]
            params = parameters.resolve_parameters(config, smoke, assignments)
            problems = parameters.check_parameters(params, config, case)
            if problems:
                raise ParameterError(f"point {label}: " + "; ".join(problems))
            runs.append({"folder": os.path.join("runs", label, f"rep{r}"), "point": label, "repetition": r,
                         "seed": seed, "values": point, "settings": settings})
    time_limit = spec.get("time_limit_s")
    return {"case": case_dir, "case_name": config.get("name", os.path.basename(case_dir)), "smoke": smoke,
            "repetitions": repetitions, "time_limit_s": time_limit, "swept": list(dict.fromkeys(k for p in points for k in p)),
            "fixed": fixed, "expected_wall_s": config.get("expected_wall_s"), "has_seed": has_seed,
            "slurm": spec.get("slurm", {}), "pool": spec.get("pool", {}), "runs": runs}


def run_command(plan, run, out):
    """The `railcosim run` command line of one run: the entry point, so that the launch environment is right
    however the campaign was started (railcosim campaign, tools/stability_map.py, a Slurm task). With
    RAILCOSIM_CAMPAIGN_DIRECT=1 the case runner itself, in the environment the campaign was given: a machine that
    cannot build railcosim but was given its runtime (benchmarks/gpu/run_sleeper_device.sh)."""
    if os.environ.get("RAILCOSIM_CAMPAIGN_DIRECT") == "1":
        entry = [sys.executable, os.path.join(ROOT, "tools", "run_case.py")]
    else:
        entry = [os.path.join(ROOT, "railcosim"), "run"]
    command = entry + [plan["case"], "--out", os.path.join(out, run["folder"])]
    if plan["smoke"]:
        command.append("--smoke")
    if plan["time_limit_s"] is not None:
        command += ["--time-limit", str(plan["time_limit_s"])]
    for key, value in run["settings"].items():
        command += ["--set", f"{key}={value}"]
    return command


def run_identity(plan, run):
    """What makes two runs the same run: a finished folder is reused only when this is unchanged."""
    return {"case": plan["case"], "smoke": plan["smoke"], "settings": run["settings"]}


def read_summary(folder):
    try:
        with open(os.path.join(folder, "summary.json")) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def is_finished(out, run):
    summary = read_summary(os.path.join(out, run["folder"]))
    return summary is not None and summary.get("status") in FINISHED_STATUSES


def write_json_atomic(path, data):
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        json.dump(data, f, indent=2)
    os.replace(temporary, path)


def prepare(plan, out, fresh=False):
    """Writes OUT/plan.json and clears the folders of runs that must run again: those not finished, and
    finished ones whose settings differ from the previous plan's (every run when fresh). Returns the runs to do."""
    os.makedirs(out, exist_ok=True)
    previous = {}
    try:
        with open(os.path.join(out, PLAN_FILE)) as f:
            previous = {r["folder"]: r["identity"] for r in json.load(f)["runs"]}
    except (OSError, ValueError, KeyError):
        pass
    todo = []
    for run in plan["runs"]:
        run["identity"] = run_identity(plan, run)
        folder = os.path.join(out, run["folder"])
        if not fresh and is_finished(out, run) and previous.get(run["folder"]) == run["identity"]:
            continue
        clear_run(folder)
        todo.append(run)
    write_json_atomic(os.path.join(out, PLAN_FILE), {**plan, "out": out})
    return todo


def clear_run(folder):
    """Removes a run's folder and its unfinished OUT.partial-* siblings (run_case.py's, e.g. after a SIGKILL)."""
    for old in [folder] + glob.glob(folder + ".partial-*"):
        shutil.rmtree(old, ignore_errors=True)


def default_jobs():
    """Runs at a time in the local pool: the cores this process may use, PROCESSES_PER_RUN per run, at least 1."""
    cores = len(os.sched_getaffinity(0))
    return max(1, cores // PROCESSES_PER_RUN), cores


class Progress:
    """Runs done / running / failed with an ETA from the mean wall time of the runs finished so far."""

    def __init__(self, total, skipped, jobs):
        self.total, self.skipped, self.jobs = total, skipped, jobs
        self.done = self.failed = self.running = 0
        self.durations = []
        self.start = time.monotonic()
        self.last = 0.0

    def line(self):
        remaining = self.total - self.skipped - self.done - self.failed
        if self.durations and remaining:
            mean = sum(self.durations) / len(self.durations)
            eta = f"ETA {format_seconds(mean * math.ceil(remaining / self.jobs))}"
        else:
            eta = "ETA –" if remaining else "finished"
        skipped = f" ({self.skipped} skipped: finished before)" if self.skipped else ""
        return (f"[campaign] {self.skipped + self.done}/{self.total} done{skipped}, {self.running} running, "
                f"{self.failed} failed, {format_seconds(time.monotonic() - self.start)} elapsed, {eta}")

    def show(self, force=False):
        now = time.monotonic()
        if force or now - self.last >= PROGRESS_EVERY_S:
            self.last = now
            print(self.line(), flush=True)


def format_seconds(seconds):
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


class Interrupted(BaseException):
    def __init__(self, signum):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


def run_local(plan, out, todo, jobs, quiet=False, lock=None):
    """Runs `todo` in a pool of `jobs` `railcosim run` processes, each in its own session with its output in
    OUT/runs/POINT/repR.log. SIGINT, SIGTERM or SIGHUP stops every run (run_case.py records it as
    interrupted: not finished) and raises Interrupted once all have stopped. Returns {folder: exit code}."""
    progress = Progress(len(plan["runs"]), len(plan["runs"]) - len(todo), jobs)
    pending, active, codes = list(todo), {}, {}
    stop = []

    def handle(signum, frame):
        if not stop:
            stop.append(signum)

    previous = {s: signal.signal(s, handle) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    progress.show(force=True)
    try:
        while pending or active:
            while pending and len(active) < jobs and not stop:
                run = pending.pop(0)
                folder = os.path.join(out, run["folder"])
                os.makedirs(os.path.dirname(folder), exist_ok=True)
                log = open(folder + ".log", "w")
                # Each run holds the campaign's lock too: runs left behind by a campaign killed with SIGKILL
                # keep the folder locked until they end, so a new campaign cannot clear them mid-run.
                process = subprocess.Popen(run_command(plan, run, out), stdout=log, stderr=subprocess.STDOUT,
                                           stdin=subprocess.DEVNULL, start_new_session=True,
                                           pass_fds=(lock.fileno(),) if lock else ())
                log.close()
                active[process] = (run, time.monotonic())
                progress.running = len(active)
            if stop:
                stop_runs(active)
            for process in [p for p in active if p.poll() is not None]:
                run, started = active.pop(process)
                codes[run["folder"]] = process.returncode
                if is_finished(out, run):
                    progress.done += 1
                    progress.durations.append(time.monotonic() - started)
                elif not stop:
                    progress.failed += 1
                    print(f"[campaign] {run['folder']}: {describe_failure(out, run, process.returncode)}", flush=True)
                progress.running = len(active)
                progress.show(force=not quiet)
            if stop and not active:
                break
            progress.show()
            time.sleep(POLL_S)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    if quiet or stop or not todo:
        progress.show(force=True)
    if stop:
        raise Interrupted(stop[0])
    return codes


def stop_runs(active):
    """SIGTERM to each run's session (run_case.py stops its solvers and writes an 'interrupted' summary),
    SIGKILL to those still there after RUN_STOP_GRACE_S; waits for all."""
    deadline = time.monotonic() + RUN_STOP_GRACE_S
    for process in active:
        if process.poll() is None and not getattr(process, "railcosim_stopped", False):
            process.railcosim_stopped = True
            try:
                os.killpg(process.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
    while any(p.poll() is None for p in active) and time.monotonic() < deadline:
        time.sleep(0.05)
    for process in active:
        if process.poll() is None:
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            process.wait()


def describe_failure(out, run, code):
    summary = read_summary(os.path.join(out, run["folder"]))
    if summary is None:
        return f"exit {code}, no summary (see {run['folder']}.log)"
    return f"{summary.get('status')}: {summary.get('error', 'see its summary.json')}"


def run_task(out, index):
    """One run of a campaign's plan, by its index in plan.json (a Slurm array task): clears its folder and runs
    it in the foreground; returns run_case.py's exit code."""
    with open(os.path.join(out, PLAN_FILE)) as f:
        plan = json.load(f)
    run = plan["runs"][index]
    folder = os.path.join(out, run["folder"])
    if is_finished(out, run):
        return 0
    clear_run(folder)
    os.makedirs(os.path.dirname(folder), exist_ok=True)
    process = subprocess.Popen(run_command(plan, run, out))
    while True:
        try:
            return process.wait()
        except KeyboardInterrupt:
            continue  # run_case.py got the signal too (same process group) and ends by itself


# --- Slurm -----------------------------------------------------------------------------------------------

def slurm_script(plan, out, indices):
    """The sbatch script of a job array over `indices` (positions in plan.json), resources from [slurm]."""
    slurm = plan["slurm"]
    unknown = sorted(set(slurm) - set(SLURM_KEYS))
    if unknown:
        raise CampaignError(f"campaign file [slurm]: unknown entries {', '.join(unknown)}"
                            f"{parameters.nearest(unknown[0], SLURM_KEYS)}; the entries are {', '.join(SLURM_KEYS)}")
    logs = os.path.join(out, "slurm")
    array = compress_indices(indices) + (f"%{slurm['max_parallel']}" if slurm.get("max_parallel") else "")
    lines = ["#!/bin/bash", f"#SBATCH --job-name=railcosim-{plan['case_name']}", f"#SBATCH --array={array}",
             f"#SBATCH --output={logs}/%A_%a.out", f"#SBATCH --cpus-per-task={slurm.get('cpus_per_task', PROCESSES_PER_RUN)}",
             "#SBATCH --ntasks=1", f"#SBATCH --chdir={out}"]
    for key, option in (("partition", "partition"), ("account", "account"), ("time", "time"), ("mem", "mem"),
                        ("qos", "qos"), ("constraint", "constraint")):
        if slurm.get(key):
            lines.append(f"#SBATCH --{option}={slurm[key]}")
    if slurm.get("time") is None and plan["expected_wall_s"]:
        # The run's own default time limit (20 x expected_wall_s, at least 600 s) plus start-up.
        minutes = math.ceil(max(600.0, 20.0 * float(plan["expected_wall_s"])) / 60) + 5
        lines.append(f"#SBATCH --time={minutes}")
    lines += [f"#SBATCH {option}" for option in slurm.get("options", [])]
    lines += ["set -eo pipefail"]
    if slurm.get("modules"):
        lines.append("module load " + " ".join(shlex.quote(m) for m in slurm["modules"]))
    lines += list(slurm.get("setup", []))
    lines.append(f"exec {shlex.quote(os.path.join(ROOT, 'railcosim'))} campaign --task {shlex.quote(out)} "
                 "\"$SLURM_ARRAY_TASK_ID\"")
    return "\n".join(lines) + "\n"


def compress_indices(indices):
    """[0, 1, 2, 5] -> '0-2,5' (sbatch --array)."""
    parts, indices = [], sorted(indices)
    for _, group in itertools.groupby(enumerate(indices), lambda pair: pair[1] - pair[0]):
        group = [i for _, i in group]
        parts.append(str(group[0]) if len(group) == 1 else f"{group[0]}-{group[-1]}")
    return ",".join(parts)


def run_slurm(plan, out, todo, wait=True):
    """Submits `todo` as one job array (sbatch), then, when wait, follows it until no task is pending or running."""
    if not todo:
        return None
    for tool in ("sbatch", "squeue"):
        if shutil.which(tool) is None:
            raise CampaignError(f"--scheduler slurm: {tool} is not on PATH (on this machine: tools/local_slurm.sh start)")
    positions = {r["folder"]: i for i, r in enumerate(plan["runs"])}
    os.makedirs(os.path.join(out, "slurm"), exist_ok=True)
    script = os.path.join(out, "slurm", "job.sh")
    with open(script, "w") as f:
        f.write(slurm_script(plan, out, [positions[r["folder"]] for r in todo]))
    result = subprocess.run(["sbatch", "--parsable", script], capture_output=True, text=True)
    if result.returncode != 0:
        raise CampaignError(f"sbatch {script} failed ({result.returncode}): {result.stderr.strip()}")
    job = result.stdout.strip().split(";")[0]
    write_json_atomic(os.path.join(out, "slurm", ACTIVE_JOB_FILE), {"job": job, "runs": len(todo)})
    print(f"[campaign] submitted {len(todo)} runs as Slurm job array {job} ({script})", flush=True)
    if not wait:
        return job
    try:
        follow_slurm(plan, out, todo, job)
    except KeyboardInterrupt:
        print(f"\n[campaign] no longer following job array {job}: it goes on (scancel {job} stops it); "
              "`railcosim campaign FILE --collect` writes the index", flush=True)
        raise Interrupted(signal.SIGINT) from None
    return job


def queued_states(job):
    """States of the job array's tasks still queued or running ([] once all ended), or None if squeue fails."""
    queue = subprocess.run(["squeue", "--noheader", "--array", "--jobs", job, "--format=%T"],
                           capture_output=True, text=True)
    if queue.returncode != 0:
        # squeue refuses a job id it no longer knows (MinJobAge after the end): the job has ended.
        return [] if "Invalid job id" in queue.stderr else None
    return queue.stdout.split()


def refuse_if_submitted(out):
    """A job array of this campaign that is still queued or running would be run twice: refused."""
    try:
        with open(os.path.join(out, "slurm", ACTIVE_JOB_FILE)) as f:
            job = json.load(f)["job"]
    except (OSError, ValueError, KeyError):
        return
    if shutil.which("squeue") and queued_states(job):
        raise CampaignError(f"Slurm job array {job} of this campaign is still queued or running; wait for it "
                            f"(squeue --jobs {job}) or stop it (scancel {job}), then run the campaign again")


def follow_slurm(plan, out, todo, job):
    """Progress of the job array from the runs' folders until squeue lists no task of it."""
    progress = Progress(len(plan["runs"]), len(plan["runs"]) - len(todo), 1)
    poll = float(plan["slurm"].get("poll_s", 5))
    failures = 0
    while True:
        states = queued_states(job)
        failures = failures + 1 if states is None else 0
        if failures * poll > SQUEUE_PATIENCE_S:
            raise CampaignError(f"squeue has failed for {SQUEUE_PATIENCE_S:.0f} s; job array {job} goes on "
                                "(scancel stops it); `railcosim campaign FILE --collect` writes the index")
        finished = sum(is_finished(out, r) for r in todo)
        progress.done = finished
        ended = [r for r in todo if os.path.isfile(os.path.join(out, r["folder"], "summary.json"))]
        progress.failed = len(ended) - finished
        progress.running = (states or []).count("RUNNING")
        progress.jobs = max(1, progress.running)
        # The runs' own wall times (from their summaries) give the ETA: the queue wait is not known.
        progress.durations = [s["total_wall_time_s"] for s in map(read_summary, (os.path.join(out, r["folder"]) for r in ended))
                              if s and numeric(s.get("total_wall_time_s"))]
        if states == []:
            break
        progress.show()
        time.sleep(poll)
    progress.show(force=True)


# --- Results ---------------------------------------------------------------------------------------------

def flatten(prefix, value, into):
    if isinstance(value, dict):
        for key, inner in value.items():
            flatten(f"{prefix}.{key}", inner, into)
    elif isinstance(value, (list, tuple)):
        into[prefix] = json.dumps(value)
    else:
        into[prefix] = value


def collect(plan, out):
    """One row per run of the plan: parameters (the run's resolved ones when it ran), seed, status, wall time,
    checks, metrics ('metrics.NAME'). Writes OUT/campaign.csv; returns the rows."""
    rows = []
    for run in plan["runs"]:
        summary = read_summary(os.path.join(out, run["folder"])) or {}
        row = {"run": run["folder"], "point": run["point"], "repetition": run["repetition"], "seed": run["seed"],
               "status": summary.get("status", "missing")}
        checks = summary.get("checks", [])
        # The checks of an unfinished run were not made: neither passed nor failed.
        row["checks_passed"] = all(c.get("passed") for c in checks) if row["status"] in FINISHED_STATUSES else None
        row["wall_time_s"] = summary.get("wall_time_s")
        resolved = summary.get("parameters", {})
        for key in plan["swept"]:
            name = key.rpartition(".")[2]
            row[key] = resolved.get(name, run["values"].get(key))
        for name, value in resolved.items():
            if name not in row and name not in ("case_dir", "seed"):
                row[name] = value
        flatten("metrics", summary.get("metrics", {}), metrics := {})
        row.update(metrics)
        # The case's errors against its reference (a closed form, a direct run): the speed-vs-error plot's y.
        flatten("relative_error", summary.get("relative_error", {}), errors := {})
        row.update(errors)
        rows.append(row)
    write_csv(os.path.join(out, INDEX_FILE), rows)
    return rows


def write_csv(path, rows):
    columns = list(dict.fromkeys(k for row in rows for k in row))
    temporary = path + ".tmp"
    with open(temporary, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if row.get(k) is None else row.get(k) for k in columns})
    os.replace(temporary, path)


def numeric(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def aggregate(plan, rows, out):
    """Per parameter point, over its finished repetitions: n and mean, std (sample, n-1; 0 for one run), min,
    max of the wall time and of every numeric metric. Writes OUT/aggregates.csv; returns the rows."""
    metric_names = list(dict.fromkeys(k for r in rows for k in r if k.startswith(("metrics.", "relative_error."))))
    result = []
    for point in dict.fromkeys(r["point"] for r in rows):
        members = [r for r in rows if r["point"] == point]
        finished = [r for r in members if r["status"] in FINISHED_STATUSES]
        entry = {"point": point, **{k: members[0].get(k) for k in plan["swept"]},
                 "runs": len(members), "finished": len(finished)}
        for name in ["wall_time_s"] + metric_names:
            values = [r[name] for r in finished if numeric(r.get(name))]
            stats = statistics(values)
            for stat, value in stats.items():
                entry[f"{name}.{stat}"] = value
        result.append(entry)
    write_csv(os.path.join(out, AGGREGATES_FILE), result)
    return result


def statistics(values):
    if not values:
        return {"mean": None, "std": None, "min": None, "max": None}
    mean = sum(values) / len(values)
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1)) if len(values) > 1 else 0.0
    return {"mean": mean, "std": std, "min": min(values), "max": max(values)}


def plot(plan, aggregates, out):
    """OUT/plots/METRIC.png: one panel per swept parameter, the mean over repetitions against it with a
    ± std band, one line per combination of the other swept parameters. Returns the files written."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    swept = plan["swept"]
    if not swept or not aggregates:
        return []
    names = sorted({k[: -len(".mean")] for a in aggregates for k, v in a.items()
                    if k.endswith(".mean") and k.startswith("metrics.") and numeric(v)})
    folder = os.path.join(out, "plots")
    os.makedirs(folder, exist_ok=True)
    written = []
    for name in names:
        fig, axes = plt.subplots(1, len(swept), figsize=(5.2 * len(swept), 4.2), squeeze=False)
        for ax, key in zip(axes[0], swept):
            others = [k for k in swept if k != key]
            series = dict.fromkeys(tuple(a.get(k) for k in others) for a in aggregates)
            categorical = not all(numeric(a.get(key)) for a in aggregates)
            categories = list(dict.fromkeys(str(a.get(key)) for a in aggregates))
            for n, values in enumerate(series):
                points = [a for a in aggregates if tuple(a.get(k) for k in others) == values and numeric(a.get(f"{name}.mean"))]
                position = (lambda a: categories.index(str(a.get(key)))) if categorical else (lambda a: a.get(key))
                points.sort(key=position)
                if not points:
                    continue
                xs = [position(a) for a in points]
                mean = [a[f"{name}.mean"] for a in points]
                std = [a[f"{name}.std"] or 0.0 for a in points]
                label = ", ".join(f"{k}={v}" for k, v in zip(others, values)) or name
                ax.plot(xs, mean, "o-", color=f"C{n}", label=label)
                ax.fill_between(xs, [m - s for m, s in zip(mean, std)], [m + s for m, s in zip(mean, std)],
                                color=f"C{n}", alpha=0.2)
            if categorical:
                ax.set_xticks(range(len(categories)), categories)
            ax.set_xlabel(key)
            ax.set_ylabel(name.removeprefix("metrics."))
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(f"{plan['case_name']}: mean ± std over {plan['repetitions']} repetition(s)")
        fig.tight_layout()
        path = os.path.join(folder, re.sub(r"[^A-Za-z0-9._-]", "_", name.removeprefix("metrics.")) + ".png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def plot_speed_vs_error(plan, aggregates, out):
    """OUT/plots/speed_vs_error_NAME.png for every error the case reports against its reference: one point per
    parameter point, wall time (mean over repetitions) against the error (mean, ± std bars), labelled with the
    point. Log scales where every value is positive. Returns the files written."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = sorted({k[: -len(".mean")] for a in aggregates for k, v in a.items()
                    if k.startswith("relative_error.") and k.endswith(".mean") and numeric(v)})
    folder = os.path.join(out, "plots")
    written = []
    for name in names:
        points = [a for a in aggregates if numeric(a.get(f"{name}.mean")) and numeric(a.get("wall_time_s.mean"))]
        if not points:
            continue
        os.makedirs(folder, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6.4, 4.6))
        for n, a in enumerate(points):
            ax.errorbar(a["wall_time_s.mean"], a[f"{name}.mean"], xerr=a["wall_time_s.std"] or 0.0,
                        yerr=a[f"{name}.std"] or 0.0, fmt="o", color=f"C{n % 10}", capsize=3)
            ax.annotate(a["point"], (a["wall_time_s.mean"], a[f"{name}.mean"]), fontsize=7,
                        xytext=(4, 4), textcoords="offset points")
        if all(a["wall_time_s.mean"] > 0 for a in points):
            ax.set_xscale("log")
        if all(a[f"{name}.mean"] > 0 for a in points):
            ax.set_yscale("log")
        ax.set_xlabel("wall time per run [s]")
        ax.set_ylabel(f"{name.removeprefix('relative_error.')} (relative error)")
        ax.grid(alpha=0.3, which="both")
        ax.set_title(f"{plan['case_name']}: speed against error, mean ± std over {plan['repetitions']} repetition(s)",
                     fontsize=9)
        fig.tight_layout()
        path = os.path.join(folder, "speed_vs_error_" + re.sub(r"[^A-Za-z0-9._-]", "_", name.removeprefix("relative_error.")) + ".png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def report(plan, out, make_plots=True):
    """Index, aggregates and plots of the runs in OUT; returns the index rows."""
    rows = collect(plan, out)
    aggregates = aggregate(plan, rows, out)
    if make_plots:
        plot(plan, aggregates, out)
        plot_speed_vs_error(plan, aggregates, out)
    return rows


# --- The whole campaign ----------------------------------------------------------------------------------

def execute(spec, jobs=None, scheduler="local", wait=True, only_collect=False, fresh=False):
    """Builds the plan of a campaign spec (a dict as load_spec returns), runs what is not finished and writes
    the index, aggregates and plots. Returns (exit code, plan, out, index rows)."""
    plan = build_plan(spec)
    out = os.path.abspath(spec["out"])
    os.makedirs(out, exist_ok=True)
    lock = open(os.path.join(out, LOCK_FILE), "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise CampaignError(f"another campaign, or runs of one that was killed, are running in {out}") from None
    if only_collect:
        rows = report(plan, out)
        return exit_code(rows), plan, out, rows
    refuse_if_submitted(out)
    todo = prepare(plan, out, fresh)
    skipped = len(plan["runs"]) - len(todo)
    seeds = f", seeds {plan['runs'][0]['seed']}..{plan['runs'][0]['seed'] + plan['repetitions'] - 1}" if plan["has_seed"] else \
        " (the case has no seed parameter: repetitions repeat the same run)"
    print(f"[campaign] {plan['case_name']}: {len(plan['runs']) // plan['repetitions']} points x {plan['repetitions']} "
          f"repetitions{seeds}; {len(todo)} to run, {skipped} finished before; folder {out}", flush=True)
    if scheduler == "slurm":
        try:
            job = run_slurm(plan, out, todo, wait=wait)
        except Interrupted as stop:
            return 128 + stop.signum, plan, out, None
        if job is not None and not wait:
            print(f"[campaign] not waiting: `railcosim campaign FILE --collect` writes the index once job {job} ends")
            return 0, plan, out, None
    else:
        default, cores = default_jobs()
        if jobs is None:
            jobs = default
            if todo:
                print(f"[campaign] local pool: {jobs} run(s) at a time ({cores} cores, {PROCESSES_PER_RUN} "
                      "solver processes per coupled run; --jobs N to change)", flush=True)
        try:
            run_local(plan, out, todo, jobs, lock=lock)
        except Interrupted as stop:
            rows = report(plan, out, make_plots=False)
            done = sum(r["status"] in FINISHED_STATUSES for r in rows)
            print(f"[campaign] stopped by {stop}: {done}/{len(rows)} runs finished; run the same command to go on",
                  flush=True)
            return 128 + stop.signum, plan, out, rows
    rows = report(plan, out)
    print(f"[campaign] index: {os.path.join(out, INDEX_FILE)}  aggregates: "
          f"{os.path.join(out, AGGREGATES_FILE)}  plots: {os.path.join(out, 'plots')}", flush=True)
    return exit_code(rows), plan, out, rows


def exit_code(rows):
    if any(r["status"] not in FINISHED_STATUSES for r in rows):
        return EXIT_FAILED
    return EXIT_CHECKS if any(r["checks_passed"] is False for r in rows) else 0
