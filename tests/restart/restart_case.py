#!/usr/bin/python3
"""Restart of a case against its uninterrupted run: run it; run it again with --checkpoint-every, SIGKILL both
solvers (each whole process group) once the first checkpoint is complete, resume the run with --resume; the resumed
run's results must equal the uninterrupted run's (tests/restart/compare_runs.py, bit for bit unless --tolerance).

Usage: restart_case.py RAILCOSIM CASE WORK [--checkpoint-every S] [--tolerance T] [--reference DIR] [RUN OPTIONS...]
  RUN OPTIONS (e.g. --smoke, --set k=v) go to every run; --reference takes an existing uninterrupted run instead;
  --checkpoint-every defaults to a quarter of the run's duration_s, so that the first checkpoint lands early.
"""
import argparse
import glob
import json
import os
import shutil
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(os.path.dirname(HERE)), "python")]
import compare_runs  # noqa: E402
from railcosim import parameters  # noqa: E402
from railcosim.case import load_case  # noqa: E402

# The first checkpoint lands a few seconds into a smoke run; this is the wait for it on a loaded machine.
CHECKPOINT_WAIT_S = 120.0
# A complete checkpoint is a folder named window-NNNNNNNN (its staging folder ends in .partial).
COMPLETE = "window-" + "[0-9]" * 8


def run(command, **kwargs):
    print("$ " + " ".join(command), flush=True)
    started = time.monotonic()
    done = subprocess.run(command, **kwargs)
    print(f"  exit {done.returncode} after {time.monotonic() - started:.1f} s", flush=True)
    return done.returncode


def children(pid):
    """Processes whose parent is pid (the runner's solvers, each the leader of its own process group)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry))
    return found


def kill_groups(pids):
    """SIGKILL to each process group; one that ended between the listing and the kill (e.g. a solver that saw its
    peer die) is already what the kill aims at."""
    for pid in pids:
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def interrupt(railcosim, case, out, every, options):
    """Runs with checkpoints and SIGKILLs both solvers' process groups once a checkpoint is complete; returns the
    interrupted run's results folder and the checkpoint that had landed."""
    command = [railcosim, "run", case, "--out", out, "--checkpoint-every", str(every)] + options
    print("$ " + " ".join(command), flush=True)
    runner = subprocess.Popen(command, start_new_session=True)
    deadline = time.monotonic() + CHECKPOINT_WAIT_S
    landed = []
    while not landed and runner.poll() is None and time.monotonic() < deadline:
        landed = glob.glob(os.path.join(out + ".partial-*", "checkpoints", COMPLETE, "manifest.json"))
        time.sleep(0.01)
    if not landed:
        runner.kill()
        raise SystemExit(f"FAIL: no checkpoint was complete within {CHECKPOINT_WAIT_S:.0f} s "
                         f"(runner exit {runner.poll()})")
    solvers = children(runner.pid)
    kill_groups(solvers)
    print(f"  SIGKILL to the process groups of {solvers} after {os.path.dirname(landed[0])} landed", flush=True)
    code = runner.wait(timeout=60)
    print(f"  runner exit {code}", flush=True)
    if code == 0:
        raise SystemExit("FAIL: the run finished although both solvers were killed")
    return out, os.path.basename(os.path.dirname(landed[0]))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("railcosim")
    parser.add_argument("case")
    parser.add_argument("work")
    parser.add_argument("--checkpoint-every", type=float)
    parser.add_argument("--tolerance", type=float, default=0.0)
    parser.add_argument("--reference")
    args, options = parser.parse_known_args()
    if args.checkpoint_every is None:
        # The case's own duration, as the runner resolves it for these options (--smoke, --set).
        sets = [options[k + 1] for k, option in enumerate(options[:-1]) if option == "--set"]
        config, case = load_case(os.path.abspath(args.case))
        args.checkpoint_every = case.duration_s(parameters.resolve_parameters(config, "--smoke" in options, sets)) / 4
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    reference = args.reference
    if not reference:
        reference = os.path.join(args.work, "uninterrupted")
        if run([args.railcosim, "run", args.case, "--out", reference] + options) != 0:
            raise SystemExit("FAIL: the uninterrupted run failed")
    interrupted, landed = interrupt(args.railcosim, args.case, os.path.join(args.work, "interrupted"),
                                    args.checkpoint_every, options)
    if run([args.railcosim, "run", args.case, "--resume", interrupted] + options) != 0:
        raise SystemExit("FAIL: the resumed run failed")
    worst = compare_runs.print_report(compare_runs.compare(reference, interrupted))
    with open(os.path.join(interrupted, "summary.json")) as f:
        resumed = json.load(f)["resumed_from"]
    complete = glob.glob(os.path.join(interrupted, "checkpoints", COMPLETE))
    sizes = [sum(os.path.getsize(p) for p in glob.glob(os.path.join(folder, "*"))) for folder in complete]
    print(f"killed after {landed}; resumed from {resumed['checkpoint']} (window {resumed['window']}, "
          f"t = {resumed['time_s']:g} s); {len(complete)} complete checkpoints kept, "
          f"{max(sizes, default=0) / 1e6:.2f} MB each at most")
    print(f"largest relative difference of the resumed run: {worst:.3e} (tolerance {args.tolerance:g})")
    if worst > args.tolerance:
        raise SystemExit("FAIL: the resumed run differs from the uninterrupted one")
    print("OK")


if __name__ == "__main__":
    main()
