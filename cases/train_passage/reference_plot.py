#!/usr/bin/python3
"""reference.png: the default runs' peak sleeper settlements and sleeper lags (default_runs.csv, the README's
"Results" tables) against Irazábal (2017) §7.2.2-7.2.3: about 0.7 mm on compacted ballast, about 2 mm over the loose
zone, and the lag spacing / speed = 0.0072 s.

Usage: /usr/bin/python3 cases/train_passage/reference_plot.py
"""
import csv
import os
import sys
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(os.path.dirname(os.path.dirname(HERE)), "python")]
from case import THESIS_LAG_S, THESIS_LOOSE_SETTLEMENT_M, THESIS_SETTLEMENT_M  # noqa: E402


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with open(os.path.join(HERE, "default_runs.csv")) as f:
        runs = list(csv.DictReader(f))
    with open(os.path.join(HERE, "case.toml"), "rb") as f:
        lag_tolerance = tomllib.load(f)["parameters"]["lag_tolerance"]
    sleepers = [1, 2, 3, 4, 5]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    width = 0.35
    drawn = [r for r in runs if r["settlement_S1_mm"]]
    for k, run in enumerate(drawn):
        values = [float(run[f"settlement_S{s}_mm"]) for s in sleepers]
        a.bar([s + (k - 0.5) * width for s in sleepers], values, width, label=f"{run['run']} (seed {run['seed']})")
    a.hlines(THESIS_SETTLEMENT_M * 1e3, 0.5, 5.5, colors="k", linestyles="--", label="thesis, compacted: 0.7 mm (T9)")
    a.hlines(THESIS_LOOSE_SETTLEMENT_M * 1e3, 1.5, 3.5, colors="r", linestyles="--",
             label="thesis, over the loose zone: 2 mm (T10)")
    a.set_xticks(sleepers, [f"S{s}" for s in sleepers])
    a.set_ylabel("peak sleeper settlement [mm]")
    a.set_title("peak settlement per sleeper (grains x 3)")
    a.set_ylim(0, 13)
    a.legend(fontsize=8, loc="upper left", ncol=2)
    a.grid(axis="y", alpha=0.3)
    labels = [f"{r['run']}\nseed {r['seed']}" for r in runs]
    b.plot(range(len(runs)), [float(r["sleeper_lag_s"]) * 1e3 for r in runs], "o", color="C2", ms=8,
           label="this case", zorder=3)
    b.axhspan(THESIS_LAG_S * 1e3 * (1 - lag_tolerance), THESIS_LAG_S * 1e3 * (1 + lag_tolerance), color="0.85",
              label=f"the check's {lag_tolerance:.0%}")
    b.axhline(THESIS_LAG_S * 1e3, color="k", ls="--", label="spacing / speed = 7.2 ms (thesis)")
    b.set_xticks(range(len(runs)), labels, fontsize=8)
    b.set_xlim(-0.5, len(runs) - 0.5)
    b.set_ylim(0, 12)
    b.set_ylabel("sleeper_lag_s [ms]")
    b.set_title("lag between successive sleepers")
    b.legend(fontsize=8, loc="lower center")
    b.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "reference.png"), dpi=110)


if __name__ == "__main__":
    main()
