"""The README's figure and tables from results folders of the case: E(ε_a) of the three normal laws side by side, and a
study table (what changed, E0, Z, wall time).

    /usr/bin/python3 cases/triaxial_small_strain/report.py FIGURE.png LABEL=RESULTS_DIR [LABEL=RESULTS_DIR ...]
"""
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "..", "python"))
from case import E0_STRAIN, PAPER_E0_MPA, after_hold, phase, tangent_modulus  # noqa: E402
from railcosim import results  # noqa: E402


def main(figure, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    print("| run | normal law | boundary (height) | clusters | dt [s] | E0 [MPa] | paper E0 [MPa] | Z | Z pairs | e "
          "| E/E0 at ε_a = 1e-5, 1e-4, 1e-3 "
          "| unloading E [MPa] | ε_a at q0 after unloading [%] | DEM wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    top = 0.0
    for k, (label, out) in enumerate(runs):
        summary = json.load(open(os.path.join(out, "summary.json")))
        p = summary["parameters"]
        m = summary["metrics"]
        series = results.read_dem_series(out)
        start, loading = after_hold(phase(series, "loading"), "probe")
        unloading = phase(series, "unloading")
        mid, modulus = tangent_modulus(start, loading)
        colour = f"C{k}"
        a.semilogx(mid * 100, modulus / 1e6, "o-", ms=3, color=colour, label=f"{label}: E0 = {m['E0_MPa']:.0f} MPa")
        paper = PAPER_E0_MPA[p["normal_model"]]
        if paper and not any(l == p["normal_model"] for l, _ in runs[:k]):
            a.plot([E0_STRAIN * 100], [paper], "*", ms=11, color=colour, mec="k")
        eps = np.concatenate([[0.0], loading["axial_strain"], unloading["axial_strain"]])
        q = np.concatenate([[start[1]], loading["q"], unloading["q"]])
        b.plot(eps * 100, (q - start[1]) / 1e3, "o-", ms=2, color=colour, label=label)
        ratios = ", ".join(f"{m.get('E_over_E0', {}).get(k, float('nan')):.2f}" for k in ("1e-05", "0.0001", "0.001"))
        # Unloading: the secant over the first tenth of the peak strain given back, and where q is back at q0.
        eu, qu = unloading["axial_strain"], unloading["q"]
        peak_eps, peak_q = float(loading["axial_strain"][-1]), float(loading["q"][-1])
        tenth = eu <= 0.9 * peak_eps * (1 + 1e-6)
        unload_e = (peak_q - float(qu[tenth][0])) / (peak_eps - float(eu[tenth][0])) if tenth.any() else float("nan")
        below = np.nonzero(qu <= start[1])[0]
        if len(below) and below[0] > 0:
            k0 = below[0]
            residual = float(np.interp(start[1], [qu[k0], qu[k0 - 1]], [eu[k0], eu[k0 - 1]]))
        else:
            residual = float("nan")
        top = max(top, m["E0_MPa"])
        boundary = p.get("boundary", "periodic")
        height = f"{boundary} ({m['specimen_height_m']:.3f} m)" if "specimen_height_m" in m else boundary
        print(f"| {label} | {p['normal_model']} | {height} | {m['clusters']} | {p['dem_dt']:g} | {m['E0_MPa']:.0f} | "
              f"{paper if paper else '-'} | {m['coordination_number']:.2f} | {m['pair_coordination_number']:.2f} | "
              f"{m['void_ratio']:.3f} | {ratios} | {unload_e / 1e6:.0f} | {residual * 100:.3f} | "
              f"{m['dem_wall_time_s']:.0f} |")
    a.axvline(E0_STRAIN * 100, color="0.7", lw=0.8)
    a.set_ylim(0, 1.6 * top)  # a contact slip or a tangential release shows as one far-off tangent; the axis keeps E0
    a.set_xlabel("axial strain ε_a [%]")
    a.set_ylabel("tangent Young's modulus E [MPa]")
    a.set_title("E(ε_a); stars: the paper's E0 (elastic PP 90, elasto-plastic 128 MPa)", fontsize=9)
    a.legend(fontsize=7)
    b.set_xlabel("axial strain ε_a [%]")
    b.set_ylabel("q - q0 [kPa]")
    b.set_title("loading to 0.1 % and unloading", fontsize=9)
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(figure, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], [tuple(a.split("=", 1)) for a in sys.argv[2:]])
