"""Figures and tables of the README from finished runs: the default run with constant and with stress-dependent
friction (shear stress and dilation against displacement, peak envelopes) and the rate / time-step study.

    /usr/bin/python3 cases/direct_shear/report.py --constant DIR --stress-dependent DIR [--study DIR ...]

DIR is a run's results folder (summary.json, dem_timeseries.h5, dem_info.json); figures go next to this file."""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))
sys.path.insert(0, HERE)
from railcosim import results  # noqa: E402
from case import split_tests, at  # noqa: E402


def load(folder):
    summary = results.read_json(os.path.join(folder, "summary.json"))
    info = results.read_json(os.path.join(folder, "dem_info.json"))
    return summary, split_tests(results.read_dem_series(folder), info)


def compare(runs, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, len(runs), figsize=(5.5 * len(runs), 7.5), sharex="col", squeeze=False)
    for col, (label, (summary, tests)) in enumerate(runs.items()):
        for k, (test, s) in enumerate(tests):
            name = f"σ_n = {test['normal_stress_Pa'] / 1e3:g} kPa"
            axes[0, col].plot(1e3 * s["shear_displacement"], s["shear_stress"] / 1e3, color=f"C{k}", label=name)
            axes[1, col].plot(1e3 * s["shear_displacement"], 1e3 * s["dilation"], color=f"C{k}", label=name)
        m = summary["metrics"]
        axes[0, col].set_title(f"{label}: φ_p = {m['peak_friction_angle_deg']:.1f}°, c = {m['mohr_coulomb_cohesion_kPa']:.1f} kPa")
        axes[1, col].axhline(0.0, color="0.5", lw=0.5)
        axes[1, col].set_xlabel("shear displacement [mm]")
    axes[0, 0].set_ylabel("shear stress τ [kPa]")
    axes[1, 0].set_ylabel("plate displacement [mm] (+ dilation)")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def envelopes(runs, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for k, (label, (summary, tests)) in enumerate(runs.items()):
        m = summary["metrics"]
        sigma = np.array(m["normal_stress_at_peak_kPa"])
        tau = np.array(m["peak_shear_stress_kPa"])
        s = np.linspace(0.0, 1.1 * sigma.max(), 50)
        ax.plot(sigma, tau, "o", color=f"C{k}")
        ax.plot(s, m["mohr_coulomb_cohesion_kPa"] + s * math.tan(math.radians(m["peak_friction_angle_deg"])), "-",
                color=f"C{k}", label=f"{label}: φ = {m['peak_friction_angle_deg']:.1f}°, c = {m['mohr_coulomb_cohesion_kPa']:.1f} kPa")
    ax.set_xlabel("normal stress at the peak [kPa]")
    ax.set_ylabel("peak shear stress [kPa]")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--constant")
    parser.add_argument("--stress-dependent")
    parser.add_argument("--study", nargs="*", default=[])
    a = parser.parse_args()
    runs = {}
    if a.constant:
        runs["constant μ"] = load(a.constant)
    if a.stress_dependent:
        runs["stress-dependent μ, γ = −0.15"] = load(a.stress_dependent)
    if runs:
        compare(runs, os.path.join(HERE, "shear_curves.png"))
        envelopes(runs, os.path.join(HERE, "envelopes.png"))
        for label, (summary, tests) in runs.items():
            m = summary["metrics"]
            print(f"{label}: peaks {[round(x, 1) for x in m['peak_shear_stress_kPa']]} kPa at "
                  f"{[round(x, 1) for x in m['peak_displacement_mm']]} mm, secant {[round(x, 1) for x in m['peak_friction_angles_deg']]} deg, "
                  f"envelope {m['peak_friction_angle_deg']:.1f} deg c {m['mohr_coulomb_cohesion_kPa']:.1f} kPa, tau(20 mm) "
                  f"{[round(x, 1) for x in m['shear_stress_at_20mm_kPa']]}, dilation end {[round(x, 2) for x in m['dilation_at_end_mm']]} mm, "
                  f"min {[round(x, 2) for x in m['min_dilation_mm']]} mm, e {[round(x, 3) for x in m['void_ratio']]}, "
                  f"shear wall {[round(x) for x in m['shear_wall_time_s']]} s, total {summary.get('wall_time_s')} s, checks "
                  + ", ".join(f"{c['name']}: {c['value']:.4f}" for c in summary["checks"]))
        if len(runs) == 2:
            (_, (_, c)), (_, (_, d)) = runs.items()
            for (tc, sc), (_, sd) in zip(c, d):
                for u in (0.010, 0.020, 0.030):
                    a0, a1 = at(sc, u, "shear_stress"), at(sd, u, "shear_stress")
                    print(f"sigma {tc['normal_stress_Pa'] / 1e3:g} kPa, u {u * 1e3:g} mm: constant {a0 / 1e3:.1f}, SDF {a1 / 1e3:.1f} kPa, "
                          f"reduction {100 * (1 - a1 / a0):.1f} %")
    for folder in a.study:
        summary, tests = load(folder)
        test, s = tests[0]
        p = summary["parameters"]
        tau5 = at(s, 0.005, "shear_stress")
        mean = float(np.mean(s["shear_stress"][s["shear_displacement"] >= 0.005]))
        print(f"| {p['shear_velocity']:g} | {p['dem_dt'] * 1e6:g} | {tau5 / 1e3:.1f} | {mean / 1e3:.1f} | "
              f"{summary['metrics']['peak_shear_stress_kPa'][0]:.1f} | {1e3 * s['dilation'][-1]:.2f} | "
              f"{summary['metrics']['shear_wall_time_s'][0]:.0f} | {summary['wall_time_s']:.0f} | "
              + ", ".join(f"{c['value']:.3f}" for c in summary["checks"]) + " |")


if __name__ == "__main__":
    main()
