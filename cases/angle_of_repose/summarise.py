#!/usr/bin/python3
"""Tables and plot of the angle-of-repose campaigns (campaigns/*.toml) for the case's README.

Usage: /usr/bin/python3 cases/angle_of_repose/summarise.py [RESULTS]   (RESULTS: default ./results)
Reads RESULTS/angle_of_repose-*/runs/*/rep*/summary.json (every finished run of the campaigns), writes
cases/angle_of_repose/results/runs.csv (one row per run: the settings that differ from the case's defaults, the
angle, its spread over the flanks, particles, simulated and wall time) and angle_of_repose.png (the angle against
η_r, E, time step and amount of ballast, with the thesis' 40° ± 2°), and prints the rows as a Markdown table.
"""
import csv
import glob
import json
import os
import sys
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
SWEPT = ("rolling_friction", "particle_young", "dem_dt", "ballast_mass_kg", "particle_shape", "cluster_level",
         "friction_model", "cluster_dt", "drop_height")


def main(results):
    with open(os.path.join(HERE, "case.toml"), "rb") as f:
        defaults = tomllib.load(f)["parameters"]
    rows = []
    for path in sorted(glob.glob(os.path.join(results, "angle_of_repose-*", "runs", "*", "rep*", "summary.json"))):
        with open(path) as f:
            summary = json.load(f)
        if summary["status"] != "ok" or summary.get("smoke"):
            continue
        p, m = summary["parameters"], summary["metrics"]
        changed = {k: p[k] for k in SWEPT if p.get(k) != defaults.get(k)}
        rows.append({"campaign": path.split(os.sep)[-5].replace("angle_of_repose-", ""),
                     "settings": ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in changed.items())
                     or "default", **{k: p[k] for k in SWEPT},
                     "angle_deg": round(m["angle_of_repose_deg"], 2), "spread_deg": round(m["angle_spread_deg"], 2),
                     "pile_height_m": round(m["pile_height_m"], 3), "particles": m["particles"], "spheres": m["spheres"],
                     "simulated_s": round(m["simulated_s"], 3), "dem_steps": m["dem_steps"],
                     "wall_time_s": round(summary["wall_time_s"], 1)})
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "runs.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("| campaign | settings | angle [deg] | flank spread [deg] | particles | simulated [s] | steps | wall [s] |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['campaign']} | {r['settings']} | {r['angle_deg']:.1f} | {r['spread_deg']:.1f} | {r['particles']} | "
              f"{r['simulated_s']:.2f} | {r['dem_steps']} | {r['wall_time_s']:.0f} |")
    plot(rows, defaults)


def scaled_step(row, defaults):
    """The E study's step: the case's step scaled as E^-0.4, the critical step of the damped Hertz impact."""
    return defaults["dem_dt"] * (row["particle_young"] / defaults["particle_young"]) ** -0.4


def plot(rows, defaults):
    # The E, time-step and amount studies ran at the thesis' η_r = 0.2, before the calibration chose the default.
    defaults = dict(defaults, rolling_friction=0.2)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    spheres = [r for r in rows if r["particle_shape"] == "sphere"]
    panels = [("rolling_friction", "η_r (sphere-sphere)", 1.0),
              ("particle_young", "E [GPa]", 1e-9), ("dem_dt", "time step [µs]", 1e6),
              ("ballast_mass_kg", "ballast [kg]", 1.0)]
    fig, axes = plt.subplots(1, len(panels), figsize=(13, 3.6), sharey=True)
    for ax, (key, label, scale) in zip(axes, panels):
        # One line per amount of ballast (the studies run at 30 kg, the default at 60 kg), the other settings at default.
        # E and the step change together in the E study (the step follows the critical step).
        coupled = ("dem_dt",) if key == "particle_young" else ()
        others = [k for k, _, _ in panels if k not in (key, "ballast_mass_kg") + coupled]
        masses = sorted({r["ballast_mass_kg"] for r in spheres}) if key != "ballast_mass_kg" else [None]
        for mass in masses:
            chosen = sorted((r for r in spheres if all(r[k] == defaults[k] for k in others) and
                             (mass is None or r["ballast_mass_kg"] == mass) and
                             (not coupled or abs(r["dem_dt"] / scaled_step(r, defaults) - 1) < 0.02)),
                            key=lambda r: r[key])
            if len(chosen) < (1 if mass is None else 2):
                continue
            ax.errorbar([r[key] * scale for r in chosen], [r["angle_deg"] for r in chosen],
                        yerr=[r["spread_deg"] for r in chosen], fmt="o-", capsize=3,
                        label=f"{mass:g} kg" if mass is not None else "η_r = 0.2, 2.4 GPa")
        ax.axhspan(38, 42, color="0.85", label="thesis 40° ± 2°")
        ax.axvline(defaults[key] * scale, color="0.5", lw=0.8, ls=":")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("angle of repose [deg]")
    fig.suptitle("Angle of repose of spheres with BROF (one seed each; bars: spread over the four flanks)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "results", "angle_of_repose.png"), dpi=110)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.getcwd(), "results"))
