#!/usr/bin/python3
"""results/clusters.png: the clusters' angles of repose (results/clusters.csv, the README's runs of
campaigns/clusters.toml at 10 kg and of the coarse clusters at 30 kg) against the thesis's (Irazábal 2017 §6.2.2,
Table 6.5: T2 and T4).

Usage: /usr/bin/python3 cases/angle_of_repose/clusters_plot.py
"""
import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with open(os.path.join(HERE, "results", "clusters.csv")) as f:
        rows = list(csv.DictReader(f))
    labels = [f"{r['cluster_level']}, {float(r['ballast_mass_kg']):g} kg\n{r['friction_model'].replace('_', '-')} μ"
              for r in rows]
    x = range(len(rows))
    fig, ax = plt.subplots(figsize=(8.0, 4.2))
    ax.bar([i - 0.2 for i in x], [float(r["thesis_angle_deg"]) for r in rows], 0.4, color="0.7",
           label="thesis (T2, T4)")
    ax.bar([i + 0.2 for i in x], [float(r["angle_deg"]) for r in rows], 0.4,
           yerr=[float(r["spread_deg"]) for r in rows], color="C0",
           label="this case: one layer, no pile, at every amount run")
    ax.set_xticks(list(x), labels, fontsize=9)
    ax.set_ylabel("angle of repose [deg]")
    ax.set_ylim(0, 45)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("sphere clusters of the shape library", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "results", "clusters.png"), dpi=110)


if __name__ == "__main__":
    main()
