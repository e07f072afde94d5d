#!/usr/bin/python3
"""Tables and plot of the angle-of-repose campaigns (campaigns/*.toml) for the case's README.

Usage: /usr/bin/python3 cases/angle_of_repose/summarise.py [RESULTS]   (RESULTS: default ./results)
Reads RESULTS/angle_of_repose-*/runs/*/rep*/summary.json (every finished run of the campaigns). Of the ballast runs it
writes cases/angle_of_repose/results/runs.csv (one row per run: the settings that differ from the case's defaults, the
angle, its spread over the flanks, particles, simulated and wall time) and angle_of_repose.png (the angle against
η_r, E, time step and amount of ballast, with the thesis' 40° ± 2°); of the wheat runs (material = "wheat",
campaigns/wheat.toml) results/wheat.csv and wheat.png (the angle against μ with the seed's points, Ullrich 2022
sec. 5.3); each only when such runs are there. Prints the rows as Markdown tables.
"""
import csv
import glob
import json
import os
import sys
import math
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))
sys.path.insert(0, HERE)
import case  # noqa: E402  (this case's case.py: the angle measurement)
from railcosim import results as run_files  # noqa: E402
# The seed's angles of wheat as spheres without rolling resistance (Ullrich 2022 sec. 5.3, Fig. 5.2): {μ: angle [deg]},
# the saturation it reports for large μ, and the angle of the wheat measured.
SEED_WHEAT = {0.17: 15.0, 1.0: 22.0}
SEED_WHEAT_SATURATION_DEG = 23.0
WHEAT_MEASURED_DEG = 26.0
SWEPT = ("rolling_friction", "particle_young", "dem_dt", "ballast_mass_kg", "particle_shape", "cluster_level",
         "friction_model", "cluster_dt", "drop_height")


def main(results):
    with open(os.path.join(HERE, "case.toml"), "rb") as f:
        defaults = tomllib.load(f)["parameters"]
    rows, wheat = [], []
    for path in sorted(glob.glob(os.path.join(results, "angle_of_repose-*", "runs", "*", "rep*", "summary.json"))):
        with open(path) as f:
            summary = json.load(f)
        if summary["status"] != "ok" or summary.get("smoke"):
            continue
        p, m = summary["parameters"], summary["metrics"]
        if p.get("material", "ballast") == "wheat":
            # measured again from the run's final spheres with the case's present measurement (case.measure_pile)
            folder = os.path.dirname(path)
            measured = case.measure_pile(run_files.read_dem_series(folder)["spheres"],
                                         run_files.read_json(os.path.join(folder, "dem_info.json")), p)
            height = measured["height_m"]
            wheat.append({"friction": p["friction"], "angle_deg": round(measured["angle_deg"], 2),
                          "spread_deg": round(float(np.std(measured["sector_angles_deg"])), 2),
                          "sector_angles_deg": " ".join(f"{a:.1f}" for a in measured["sector_angles_deg"]),
                          "base_cone_angle_deg": round(math.degrees(math.atan(height / p["base_radius"])), 2),
                          "pile_height_m": round(height, 4), "particles": m["particles"],
                          "on_base": m["particles"] - m.get("left_particles", 0),
                          "base_radius_m": p["base_radius"], "simulated_s": round(m["simulated_s"], 3),
                          "at_rest": m["at_rest"], "energy_gain_fraction": m["energy_gain_fraction"],
                          "floor_reaction_over_weight": round(m["floor_reaction_over_weight"], 5),
                          "dem_steps": m["dem_steps"], "wall_time_s": round(summary["wall_time_s"], 1)})
            continue
        changed = {k: p[k] for k in SWEPT if p.get(k) != defaults.get(k)}
        rows.append({"campaign": path.split(os.sep)[-5].replace("angle_of_repose-", ""),
                     "settings": ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in changed.items())
                     or "default", **{k: p[k] for k in SWEPT},
                     "angle_deg": round(m["angle_of_repose_deg"], 2), "spread_deg": round(m["angle_spread_deg"], 2),
                     "pile_height_m": round(m["pile_height_m"], 3), "particles": m["particles"], "spheres": m["spheres"],
                     "simulated_s": round(m["simulated_s"], 3), "dem_steps": m["dem_steps"],
                     "wall_time_s": round(summary["wall_time_s"], 1)})
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    if wheat:
        summarise_wheat(sorted(wheat, key=lambda r: (-r["base_radius_m"], r["friction"])))
    if not rows:
        return
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


def summarise_wheat(rows):
    """results/wheat.csv and wheat.png: the angle of the wheat piles against the grain-grain μ, with the seed's."""
    with open(os.path.join(HERE, "results", "wheat.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("| base radius [mm] | μ | angle [deg] | flanks [deg] | height / base radius [deg] | the seed [deg] | "
          "grains on the base / poured | pile height [mm] | simulated [s] | at rest | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        seed = SEED_WHEAT.get(r["friction"])
        print(f"| {r['base_radius_m'] * 1e3:g} | {r['friction']:g} | {r['angle_deg']:.1f} ± {r['spread_deg']:.1f} | "
              f"{r['sector_angles_deg']} | "
              f"{r['base_cone_angle_deg']:.1f} | {'–' if seed is None else f'{seed:g}'} | {r['on_base']} / {r['particles']} | "
              f"{r['pile_height_m'] * 1e3:.1f} | {r['simulated_s']:.2f} | {'yes' if r['at_rest'] else 'no'} | "
              f"{r['wall_time_s']:.0f} |")
    import math
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(10, 4.2))
    # the sweep (the base radius with most runs) as lines, the size check's other bases as single markers
    radii = sorted({r["base_radius_m"] for r in rows}, key=lambda b: -sum(r["base_radius_m"] == b for r in rows))
    for k, radius in enumerate(radii):
        mine = [r for r in rows if r["base_radius_m"] == radius]
        size = f"base {radius * 1e3:g} mm"
        ax.errorbar([r["friction"] for r in mine], [r["angle_deg"] for r in mine], yerr=[r["spread_deg"] for r in mine],
                    fmt="o-" if k == 0 else "os"[k % 2], color="C0" if k == 0 else f"C{4 + k}", capsize=3, mfc=None if k == 0 else "none",
                    label=f"here, {size}: the flanks' line fits (bars: spread over the four)")
        ax.plot([r["friction"] for r in mine], [r["base_cone_angle_deg"] for r in mine], "^--" if k == 0 else "^",
                color="C2" if k == 0 else f"C{4 + k}", label=f"here, {size}: atan(pile height / base radius)")
    ax.plot(list(SEED_WHEAT), list(SEED_WHEAT.values()), "s", color="C3", ms=8, label="the seed (Ullrich 2022 Fig. 5.2)")
    ax.axhline(SEED_WHEAT_SATURATION_DEG, color="C3", ls=":", lw=1, label="the seed's saturation, ≈ 23°")
    ax.axhline(WHEAT_MEASURED_DEG, color="k", ls="--", lw=1, label="wheat, measured: 26°")
    mu = [0.1 + 0.01 * k for k in range(141)]
    ax.plot(mu, [math.degrees(math.atan(m)) for m in mu], color="0.6", lw=0.8, label="tan θ = μ (Eq. 2.25)")
    ax.set_xlabel("grain-grain friction μ")
    ax.set_ylabel("angle of repose [deg]")
    ax.set_ylim(0, 45)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "results", "wheat.png"), dpi=110)


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
