#!/usr/bin/env python3
"""Packings and particle resolution of the sleeper case: mean ± std of settlement and sensor pressures per stone count,
from campaign indexes (campaign.csv of `railcosim campaign`, e.g. the GPU machine's repetitions_gpu.toml and
resolution_gpu.toml). Writes a Markdown table and a plot beside the first index.

Usage: benchmarks/gpu/sleeper_repetitions_table.py INDEX.csv [INDEX.csv ...] [--out PREFIX]
"""
import argparse
import csv
import json
import os
import statistics

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LEVELS = ("132kN_before", "132kN_after")


def runs_of(paths):
    """Finished runs of the indexes: one dict per run (stones, seed, settlements in mm, pressures)."""
    runs = []
    for path in paths:
        if not os.path.isfile(path):
            raise SystemExit(f"no campaign index {path} (a campaign.csv of railcosim campaign)")
        with open(path) as f:
            for row in csv.DictReader(f):
                if row["status"] != "ok":
                    continue
                runs.append({"stones": int(row["stones"]), "count": int(float(row["metrics.stones"])),
                             "seed": int(row["seed"]),
                             "settlement_mm": 1e3 * float(row["metrics.settlement_m"]),
                             "after_cycles_mm": 1e3 * float(row["metrics.settlement_after_cycles_m"]),
                             "pressures": {level: json.loads(row[f"metrics.sensor_pressure_kPa.{level}"])
                                           for level in LEVELS},
                             "source": os.path.basename(path)})
    # stones = 0 is the seed's gradation in the seed's box: the count follows from the packing, so such runs are
    # labelled by their mean count
    seed_scale = [r for r in runs if r["stones"] == 0]
    for r in seed_scale:
        r["stones"] = round(statistics.fmean(s["count"] for s in seed_scale))
    return runs


def spread(values):
    """(mean, sample std or nan for one value, count)."""
    return statistics.fmean(values), statistics.stdev(values) if len(values) > 1 else float("nan"), len(values)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("indexes", nargs="+")
    parser.add_argument("--out", help="prefix of the .md and .png written (default: beside the first index)")
    args = parser.parse_args()
    runs = runs_of(args.indexes)
    if not runs:
        raise SystemExit("no finished runs in " + ", ".join(args.indexes))
    prefix = args.out or os.path.join(os.path.dirname(os.path.abspath(args.indexes[0])), "packings_and_resolution")
    counts = sorted({r["stones"] for r in runs})
    lines = ["| stones | runs (seeds) | settlement final [mm] | after the cycles [mm] | sensor mean at 132 kN "
             "before / after [kPa] |", "|---|---|---|---|---|"]
    for n in counts:
        group = [r for r in runs if r["stones"] == n]
        final, cycles = spread([r["settlement_mm"] for r in group]), spread([r["after_cycles_mm"] for r in group])
        sensor = {level: spread([statistics.fmean(r["pressures"][level]) for r in group]) for level in LEVELS}
        seeds = ", ".join(str(r["seed"]) for r in group)
        lines.append(f"| {n} | {len(group)} ({seeds}) | {final[0]:.1f} ± {final[1]:.1f} | {cycles[0]:.1f} ± "
                     f"{cycles[1]:.1f} | {sensor[LEVELS[0]][0]:.0f} ± {sensor[LEVELS[0]][1]:.0f} / "
                     f"{sensor[LEVELS[1]][0]:.0f} ± {sensor[LEVELS[1]][1]:.0f} |")
    lines.append("")
    lines.append("± is the sample standard deviation over the runs (nan: one run). Indexes: "
                 + ", ".join(os.path.basename(p) for p in args.indexes) + ".")
    with open(prefix + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for n in counts:
        group = [r for r in runs if r["stones"] == n]
        left.plot([n] * len(group), [r["settlement_mm"] for r in group], "o", color="C0", alpha=0.5)
        mean, std, _ = spread([r["settlement_mm"] for r in group])
        left.errorbar([n * 1.04], [mean], yerr=[0 if std != std else std], fmt="s", color="C3", capsize=4)
    left.set_xscale("log")
    left.set_xlabel("stones in the desk slice")
    left.set_ylabel("final settlement [mm]")
    left.set_title("runs (circles), mean ± std (squares)")
    width = 0.8 / len(counts)
    for k, n in enumerate(counts):
        group = [r for r in runs if r["stones"] == n]
        for s in range(5):
            values = [r["pressures"][LEVELS[0]][s] for r in group]
            mean, std, _ = spread(values)
            right.bar(s + (k - (len(counts) - 1) / 2) * width, mean, width, yerr=0 if std != std else std,
                      color=f"C{k}", capsize=2, label=f"{n} stones ({len(group)} runs)" if s == 0 else None)
    right.set_xticks(range(5), [f"sensor {s + 1}" for s in range(5)])
    right.set_ylabel("pressure at 132 kN, before the cycles [kPa]")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + ".png", dpi=110)
    print(f"wrote {prefix}.md and {prefix}.png")


if __name__ == "__main__":
    main()
