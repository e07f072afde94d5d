#!/usr/bin/python3
"""Runs a campaign: one case over a grid and/or list of --set values with repetitions (docs/campaigns.md).

Usage: railcosim campaign FILE.toml [--jobs N] [--scheduler local|slurm] [--no-wait] [--out DIR] [--collect]
       railcosim campaign --task CAMPAIGN_DIR INDEX      (one run of a campaign's plan: a Slurm array task)

Every run is `railcosim run CASE --out CAMPAIGN/runs/POINT/repR --set ...` with seed = base + R, so each
has its own folder and summary.json. A re-run skips finished runs (status ok, checks passed or not) whose
settings are unchanged and runs the others again. At the end (and after --collect or Ctrl-C) it writes
CAMPAIGN/campaign.csv (one row per run), CAMPAIGN/aggregates.csv (per point: mean, std, min, max over the
repetitions) and CAMPAIGN/plots/METRIC.png.
Local pool: --jobs runs at a time, default (cores available) / 2 (a coupled run is two solver processes).
Exit codes: 0 every run finished with its checks passed, 3 every run finished but some checks failed,
1 a run did not finish, 2 refused (campaign file, parameters, sbatch), 130/143/129 stopped by a signal.
"""
import argparse
import os
import sys

from railcosim import campaign
from railcosim.case import CaseError
from railcosim.parameters import ParameterError

EXIT_FAILED, EXIT_REFUSED, EXIT_CHECKS = 1, 2, 3


def positive_int(text):
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text}: expected a whole number >= 1")
    return value


def execute(spec, jobs=None, scheduler="local", wait=True, only_collect=False):
    """Builds the plan of a campaign spec (a dict as load_spec returns), runs what is not finished and writes
    the index, aggregates and plots. Returns (exit code, plan, out, index rows)."""
    plan = campaign.build_plan(spec)
    out = os.path.abspath(spec["out"])
    if only_collect:
        rows = campaign.report(plan, out)
        return exit_code(rows), plan, out, rows
    todo = campaign.prepare(plan, out)
    skipped = len(plan["runs"]) - len(todo)
    seeds = f", seeds {plan['runs'][0]['seed']}..{plan['runs'][0]['seed'] + plan['repetitions'] - 1}" if plan["has_seed"] else \
        " (the case has no seed parameter: repetitions repeat the same run)"
    print(f"[campaign] {plan['case_name']}: {len(plan['runs']) // plan['repetitions']} points x {plan['repetitions']} "
          f"repetitions{seeds}; {len(todo)} to run, {skipped} finished before; folder {out}", flush=True)
    if scheduler == "slurm":
        job = campaign.run_slurm(plan, out, todo, wait=wait)
        if job is not None and not wait:
            print(f"[campaign] not waiting: `railcosim campaign FILE --collect` writes the index once job {job} ends")
            return 0, plan, out, None
    else:
        default, cores = campaign.default_jobs()
        if jobs is None:
            jobs = default
            if todo:
                print(f"[campaign] local pool: {jobs} run(s) at a time ({cores} cores, {campaign.PROCESSES_PER_RUN} "
                      "solver processes per coupled run; --jobs N to change)", flush=True)
        try:
            campaign.run_local(plan, out, todo, jobs)
        except campaign.Interrupted as stop:
            rows = campaign.report(plan, out, make_plots=False)
            done = sum(r["status"] in campaign.FINISHED_STATUSES for r in rows)
            print(f"[campaign] stopped by {stop}: {done}/{len(rows)} runs finished; run the same command to go on",
                  flush=True)
            return 128 + stop.signum, plan, out, rows
    rows = campaign.report(plan, out)
    print(f"[campaign] index: {os.path.join(out, campaign.INDEX_FILE)}  aggregates: "
          f"{os.path.join(out, campaign.AGGREGATES_FILE)}  plots: {os.path.join(out, 'plots')}", flush=True)
    return exit_code(rows), plan, out, rows


def exit_code(rows):
    if any(r["status"] not in campaign.FINISHED_STATUSES for r in rows):
        return EXIT_FAILED
    return EXIT_CHECKS if any(r["checks_passed"] is False for r in rows) else 0


def main(argv):
    if argv[:1] == ["--task"]:
        if len(argv) != 3:
            sys.exit("usage: railcosim campaign --task CAMPAIGN_DIR INDEX")
        return campaign.run_task(os.path.abspath(argv[1]), int(argv[2]))
    parser = argparse.ArgumentParser(prog="railcosim campaign", description="Run a campaign of coupled runs.")
    parser.add_argument("file", help="campaign file (TOML), e.g. docs/examples/template_campaign.toml")
    parser.add_argument("--jobs", type=positive_int, help="local pool: runs at a time (default: cores / 2)")
    parser.add_argument("--scheduler", choices=("local", "slurm"), default="local")
    parser.add_argument("--no-wait", action="store_true", help="slurm: submit and return")
    parser.add_argument("--out", help="campaign folder (default: the file's 'out', else results/FILE-NAME)")
    parser.add_argument("--collect", action="store_true", help="only write the index, aggregates and plots")
    args = parser.parse_args(argv)
    spec = campaign.load_spec(args.file)
    if args.out:
        spec["out"] = os.path.abspath(args.out)
    code, _, _, _ = execute(spec, args.jobs, args.scheduler, not args.no_wait, args.collect)
    return code


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (campaign.CampaignError, CaseError, ParameterError) as e:
        for line in str(e).splitlines():
            print(f"railcosim campaign: {line}", file=sys.stderr)
        sys.exit(EXIT_REFUSED)
