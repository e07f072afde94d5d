#!/usr/bin/python3
"""sdf_reduction.png: how much stress-dependent friction lowers the shear stress at 20 mm, in the default runs
(default_runs.csv, the README's "Results" table: γ = −0.15) and over five packings with γ = −0.05 (packings.csv: τ at
20 mm of each packing with constant μ and with γ = −0.05; mean ± standard deviation of the per-packing falls), against
the only figures of the thesis's text (Irazábal 2017 §6.3.4: ≈ 16 / 10 / 6 % at 27 / 51 / 75 kPa with γ = −0.05).
Prints the five-packing table of the README.

Usage: /usr/bin/python3 cases/direct_shear/reference_plot.py
"""
import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))
# Irazábal 2017 §6.3.4 (reference digest T3b): the fall of τ at 20 mm from Hertz to SDF with γ = −0.05, per σ_n [kPa].
THESIS_REDUCTION_GAMMA_005_PCT = {27: 16.0, 51: 10.0, 75: 6.0}


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with open(os.path.join(HERE, "default_runs.csv")) as f:
        rows = list(csv.DictReader(f))
    sigma = [float(r["normal_stress_kPa"]) for r in rows]
    at_20 = [100 * (1 - float(r["tau_20mm_stress_dependent_kPa"]) / float(r["tau_20mm_constant_kPa"])) for r in rows]
    at_10 = [float(r["reduction_10mm_stress_dependent_pct"]) for r in rows]
    with open(os.path.join(HERE, "packings.csv")) as f:
        packings = list(csv.DictReader(f))
    falls = {}  # σ_n → per-packing fall [%]
    for r in packings:
        fall = 100 * (1 - float(r["tau_20mm_gamma_005_kPa"]) / float(r["tau_20mm_constant_kPa"]))
        falls.setdefault(float(r["normal_stress_kPa"]), []).append(fall)
    mean = {n: sum(v) / len(v) for n, v in falls.items()}
    std = {n: (sum((x - mean[n]) ** 2 for x in v) / (len(v) - 1)) ** 0.5 for n, v in falls.items()}
    for n in sorted(falls):
        print(f"{n:.0f} kPa: falls {', '.join(f'{x:.1f}' for x in falls[n])} %; mean {mean[n]:.1f} ± {std[n]:.1f} % "
              f"(standard error {std[n] / len(falls[n]) ** 0.5:.1f} %, {len(falls[n])} packings)")
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(sigma, at_20, "o-", label="this case, γ = −0.15, at 20 mm (seed 1)")
    ax.plot(sigma, at_10, "s:", color="C0", alpha=0.6, label="this case, γ = −0.15, at 10 mm (seed 1)")
    count = len(packings) // len(falls)
    ax.errorbar(sorted(falls), [mean[n] for n in sorted(falls)], yerr=[std[n] for n in sorted(falls)], fmt="D-",
                color="C1", capsize=4, label=f"this case, γ = −0.05, {count} packings, mean ± std")
    ax.plot(list(THESIS_REDUCTION_GAMMA_005_PCT), list(THESIS_REDUCTION_GAMMA_005_PCT.values()), "k^--",
            label="thesis, γ = −0.05, at 20 mm (§6.3.4)")
    ax.set_xlabel("normal stress σ_n [kPa]")
    ax.set_ylabel("fall of τ from constant to stress-dependent μ [%]")
    ax.set_xticks(sigma)
    low = min(mean[n] - std[n] for n in falls) - 5
    ax.set_ylim(min(-20.0, low), max(45.0, max(mean[n] + std[n] for n in falls) + 5))
    ax.axhline(0, color="0.5", lw=0.8)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("stress-dependent friction: the fall of τ at 20 mm against the thesis", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "sdf_reduction.png"), dpi=110)


if __name__ == "__main__":
    main()
