#!/usr/bin/python3
"""result_polyhedra_size.png and the README's table "Polyhedra": the polyhedra library's direct shear runs
(dem_driver = "standalone", one results folder per run under RECORDS, each with summary.json and dem_timeseries.h5)
against the stone size (size_scale: 1 is the laboratory's scaled grading). Left: τ at 20 mm per normal stress, each
packing a point, the mean of the packings a line; right: τ and the plate's rise against the shear displacement of
the laboratory-size runs. Prints one table row per run and the means per size.

Usage: /usr/bin/python3 cases/direct_shear/polyhedra_plot.py [RECORDS] [OUT.png]
(default: benchmarks/results/direct_shear_gpu/h200_2026-11-30 and cases/direct_shear/result_polyhedra_size.png)
"""
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path[:0] = [HERE, os.path.join(ROOT, "python")]
from case import split_tests  # noqa: E402
from railcosim import results  # noqa: E402

RECORDS = os.path.join(ROOT, "benchmarks", "results", "direct_shear_gpu", "h200_2026-11-30")


def runs(records):
    """[(size_scale, seed, summary, [(test, series)])] of the runs under `records` that finished and passed their
    checks, by size then seed (the others are named and left out)."""
    found = []
    for name in sorted(os.listdir(records)):
        folder = os.path.join(records, name)
        path = os.path.join(folder, "summary.json")
        if not os.path.isfile(path):
            continue
        summary = results.read_json(path)
        failed = [c["name"] for c in summary.get("checks", []) if not c.get("passed")]
        if summary.get("status") != "ok" or failed:
            print(f"left out: {name} ({summary.get('status')}; failed: {', '.join(failed) or '-'})")
            continue
        info = results.read_json(os.path.join(folder, "dem_info.json"))
        tests = split_tests(results.read_dem_series(folder), info)
        p = summary["parameters"]
        found.append((float(p["size_scale"]), int(p["seed"]), summary, tests))
    return sorted(found, key=lambda r: (-r[0], r[1]))


def table(found):
    print("| size_scale, seed | stones | void ratio under 27 / 51 / 75 kPa | peak τ [kPa] | at [mm] | "
          "τ(20 mm) [kPa] | plate rise at 37 mm [mm] | φ, c | checks: plate, balance, overlap | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    f = lambda values, digits=1: " / ".join(f"{v:.{digits}f}" for v in values)  # noqa: E731
    for scale, seed, s, _ in found:
        m = s["metrics"]
        checks = ", ".join(f"{c['value']:.3g}" for c in s["checks"])
        print(f"| × {scale:g}, {seed} | {m['stones']} | {f(m['void_ratio'], 3)} | {f(m['peak_shear_stress_kPa'])} | "
              f"{f(m['peak_displacement_mm'])} | {f(m['shear_stress_at_20mm_kPa'])} | {f(m['dilation_at_end_mm'])} | "
              f"{m['peak_friction_angle_deg']:.1f}°, {m['mohr_coulomb_cohesion_kPa']:.1f} kPa | {checks} | "
              f"{m['dem_wall_time_s']:.0f} |")
    print()
    print("| size_scale | packings | τ(20 mm) mean ± standard deviation at 27 / 51 / 75 kPa [kPa] | "
          "peak τ mean [kPa] | void ratio mean |")
    print("|---|---|---|---|---|")
    for scale in sorted({r[0] for r in found}, reverse=True):
        group = [r[2]["metrics"] for r in found if r[0] == scale]
        t20 = np.array([m["shear_stress_at_20mm_kPa"] for m in group])
        peak = np.array([m["peak_shear_stress_kPa"] for m in group])
        e = np.array([m["void_ratio"] for m in group])
        spread = " / ".join(f"{a:.1f} ± {b:.1f}" for a, b in zip(t20.mean(0), t20.std(0, ddof=1) if len(group) > 1
                                                                    else np.zeros(t20.shape[1])))
        print(f"| × {scale:g} | {len(group)} | {spread} | {' / '.join(f'{x:.1f}' for x in peak.mean(0))} | "
              f"{e.mean():.3f} |")


def plot(found, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.8))
    stresses = found[0][2]["metrics"]["normal_stresses_kPa"]
    colours = dict(zip(stresses, ("tab:blue", "tab:orange", "tab:green")))
    scales = sorted({r[0] for r in found})
    for k, sigma in enumerate(stresses):
        points = [(r[0], r[2]["metrics"]["shear_stress_at_20mm_kPa"][k]) for r in found]
        a1.plot([x for x, _ in points], [y for _, y in points], "o", color=colours[sigma], alpha=0.6)
        a1.plot(scales, [np.mean([y for x, y in points if x == s]) for s in scales], "-", color=colours[sigma],
                label=f"σ_n = {sigma:g} kPa (mean of the packings)")
    a1.set_xlabel("stone size / the laboratory's (size_scale)")
    a1.set_ylabel("τ at 20 mm [kPa]")
    a1.set_title("Polyhedra on an H200 (2026-11-30): τ(20 mm) against stone size", fontsize=10)
    a1.set_xticks(scales)
    a1.legend(fontsize=8)
    a3 = a2.twinx()
    for scale, seed, _, tests in found:
        if scale != 1.0:
            continue
        for test, s in tests:
            sigma = test["normal_stress_Pa"] / 1e3
            style = {1: "-", 2: "--"}.get(seed, ":")
            a2.plot(1e3 * s["shear_displacement"], s["shear_stress"] / 1e3, style, color=colours[sigma],
                    label=f"σ_n = {sigma:g} kPa, packing {seed}")
            a3.plot(1e3 * s["shear_displacement"], 1e3 * s["dilation"], style, color=colours[sigma], alpha=0.35)
    a2.set_xlabel("shear displacement [mm]")
    a2.set_ylabel("shear stress τ [kPa] (bold)")
    a3.set_ylabel("plate rise [mm] (faint; + dilation)")
    a2.set_title("The laboratory's stone sizes (× 1), 0.1 m/s, 2.5 µs", fontsize=10)
    a2.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


def main():
    records = sys.argv[1] if len(sys.argv) > 1 else RECORDS
    if not os.path.isdir(records):
        raise SystemExit(f"polyhedra_plot.py: {records} is not a folder of run folders (usage: [RECORDS] [OUT.png])")
    path = sys.argv[2] if len(sys.argv) > 2 else os.path.join(HERE, "result_polyhedra_size.png")
    found = runs(records)
    if not found:
        raise SystemExit(f"polyhedra_plot.py: no finished run (summary.json with status ok) under {records}")
    table(found)
    plot(found, path)


if __name__ == "__main__":
    main()
