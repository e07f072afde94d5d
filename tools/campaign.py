#!/usr/bin/python3
"""Runs a campaign: one case over a grid and/or list of --set values with repetitions (docs/campaigns.md).

Usage: railcosim campaign FILE.toml [--jobs N] [--scheduler local|slurm] [--no-wait] [--out DIR] [--collect] [--fresh]
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

EXIT_REFUSED = 2


def positive_int(text):
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text}: expected a whole number >= 1")
    return value


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
    parser.add_argument("--fresh", action="store_true", help="run every run again, finished ones too")
    args = parser.parse_args(argv)
    spec = campaign.load_spec(args.file)
    if args.out:
        spec["out"] = os.path.abspath(args.out)
    code, _, _, _ = campaign.execute(spec, args.jobs, args.scheduler, not args.no_wait, args.collect, args.fresh)
    return code


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (campaign.CampaignError, CaseError, ParameterError) as e:
        for line in str(e).splitlines():
            print(f"railcosim campaign: {line}", file=sys.stderr)
        sys.exit(EXIT_REFUSED)
