#!/usr/bin/python3
"""Stability map of a case: runs it over a grid of settings and tabulates stability, errors and wall time.

Usage: railcosim-env python3 tools/stability_map.py CASE [--smoke] --grid KEY=V1,V2 [--grid ...]
           [--point KEY=V,KEY=V ...] [--set KEY=VALUE ...] [--reference KEY=V,KEY=V --reference-metric NAME]
           [--out DIR] [--jobs N] [--resume]
The map is a campaign of one repetition (python/railcosim/campaign.py, docs/campaigns.md): each grid point is
one `railcosim run CASE --set ...` in DIR/runs/POINT/rep0, indexed in DIR/campaign.csv; --point adds single
extra points (e.g. one Aitken-off run) to the grid. The last --grid axis is the x axis of the plot (usually
fem_dt); the others form the series. Every run is made afresh unless --resume (finished runs with unchanged
settings are kept); --jobs 1 by default, since the map compares wall times.

A run is *stable* when it finished, its interface force averaged over the final span (or over a load hold:
relative_error interface_force_at_hold) is within 5 % of the weight or load it must carry, and the window-sampled interface force oscillates by at most 10 % (rms over
the final span, relative to that weight or load). The first rule catches couplings that launch or drop the
structure, the second those that stay right in the mean while pumping energy into the contacts (a weak
instability: its oscillation grows from span to span, listed as "growth"). A case without a carried load
(an impact) reports an energy balance instead: stable when it finished and the energy after the event
is within 10 % of the energy before (an unstable coupling creates energy).
With --reference, the record matching those settings is the converged reference: every run's metric NAME
(a key of summary.json "metrics") is compared with it ("error vs reference").
Writes DIR/stability_map.json, DIR/stability_map.md, DIR/stability_map.png.
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python"))
from railcosim import campaign  # noqa: E402  (the package of this repository, found by the path above)
from railcosim.case import CaseError  # noqa: E402
from railcosim.parameters import ParameterError  # noqa: E402

STABLE_FORCE_ERROR = 0.05
STABLE_FLUCTUATION = 0.10
STABLE_ENERGY_ERROR = 0.10


def parse_point(text):
    """"KEY=V,KEY=V" -> {KEY: V}; SystemExit naming the bad item otherwise."""
    items = [item for item in text.split(",") if item]
    bad = [item for item in items if "=" not in item or not item.split("=", 1)[0]]
    if bad or not items:
        sys.exit(f"stability_map.py: '{text}' is not KEY=VALUE[,KEY=VALUE...] (bad part: {bad[0] if bad else 'empty'})")
    return dict(item.split("=", 1) for item in items)


def record_of(summary):
    """The figures of one run's summary.json that the map judges and tabulates ({'status': 'failed'} without one)."""
    if summary is None:
        return {"status": "failed"}
    errors, metrics, coupling = summary.get("relative_error", {}), summary.get("metrics", {}), summary.get("coupling", {})
    return {"status": summary["status"], "wall_time_s": summary.get("wall_time_s"),
            # the carried weight (a bed on a structure) or, for a loaded structure, the applied load over a hold
            "interface_force_error": errors.get("interface_force_vs_weight", errors.get("interface_force_at_hold")),
            "force_fluctuation": errors.get("interface_force_fluctuation"),
            "fluctuation_growth": metrics.get("force_fluctuation_growth"),
            "interface_energy_error": errors.get("interface_energy"),
            "energy_balance_error": errors.get("energy_balance"),
            "deflection_error": errors.get("coupled_vs_direct_fem"),
            "passes_per_window": coupling.get("passes_per_window"),
            "unconverged_windows": coupling.get("unconverged_windows"),
            "metrics": metrics}


def is_stable(record):
    if record["status"] != "ok":
        return False
    force, fluctuation, energy = (record.get("interface_force_error"), record.get("force_fluctuation"),
                                  record.get("energy_balance_error"))
    if force is None and energy is None:
        return False  # the case reports nothing to judge stability by
    return bool((force is None or force <= STABLE_FORCE_ERROR) and (fluctuation is None or fluctuation <= STABLE_FLUCTUATION)
                and (energy is None or energy <= STABLE_ENERGY_ERROR))


def stability_measure(record):
    """The largest of the measures the stability rules bound, each relative to its own limit scale."""
    values = [record.get(k) for k in ("interface_force_error", "force_fluctuation", "energy_balance_error")]
    values = [v for v in values if v is not None]
    return max(values) if values else None


def main(argv):
    parser = argparse.ArgumentParser(prog="stability_map.py")
    parser.add_argument("case")
    parser.add_argument("--smoke", action="store_true")
    parser.add_argument("--grid", action="append", required=True, metavar="KEY=V1,V2")
    parser.add_argument("--point", action="append", default=[], metavar="KEY=V,KEY=V")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--reference", default=None, metavar="KEY=V,KEY=V")
    parser.add_argument("--reference-metric", default=None)
    parser.add_argument("--out", default=None)
    # The wall times are part of the map: by default the runs do not compete for the cores.
    parser.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1: wall times are compared)")
    parser.add_argument("--resume", action="store_true", help="keep finished runs with unchanged settings")
    args = parser.parse_args(argv)
    if bool(args.reference) != bool(args.reference_metric):
        parser.error("--reference and --reference-metric go together")
    name = os.path.basename(os.path.abspath(args.case).rstrip("/"))
    out = os.path.abspath(args.out or os.path.join("results", f"{name}-stability"))
    os.makedirs(out, exist_ok=True)
    if any("=" not in item or not item.split("=", 1)[1] for item in args.grid):
        parser.error("--grid needs KEY=V1,V2,...")
    axes = [(item.split("=", 1)[0], item.split("=", 1)[1].split(",")) for item in args.grid]
    keys = [k for k, _ in axes]
    extra_points = []
    for extra in args.point:
        point = parse_point(extra)
        if not all(k in point for k in keys):
            parser.error(f"--point {extra}: give a value for every grid key ({', '.join(keys)}) and optionally others")
        extra_points.append(point)
    fixed = dict(item.split("=", 1) for item in args.set if "=" in item)
    # The map is a campaign of one repetition (railcosim.campaign): one run folder per point under DIR/runs,
    # DIR/campaign.csv and aggregates.csv beside the map's own files.
    spec = {"case": os.path.abspath(args.case), "smoke": args.smoke, "out": out, "repetitions": 1,
            "grid": dict(axes), "points": extra_points,
            "set": {k: v for k, v in fixed.items() if k != "seed"}}
    if "seed" in fixed:
        spec["seed"] = int(fixed["seed"])
    try:
        code, plan, out, _ = campaign.execute(spec, jobs=args.jobs, fresh=not args.resume)
    except (campaign.CampaignError, CaseError, ParameterError) as e:
        sys.exit(f"stability_map.py: {e}")
    if code >= 128:
        return code
    records = []
    for run in plan["runs"]:
        record = {**run["values"], **record_of(campaign.read_summary(os.path.join(out, run["folder"])))}
        record["stable"] = is_stable(record)
        records.append(record)
        pct = lambda v: "–" if v is None else f"{v:.2%}"
        print(f"[map] {run['point']}: {'stable' if record['stable'] else 'UNSTABLE'}  force error {pct(record.get('interface_force_error'))}"
              f"  oscillation {pct(record.get('force_fluctuation'))}  wall {record.get('wall_time_s')} s", flush=True)
    reference = None
    if args.reference:
        wanted = parse_point(args.reference)
        matches = [r for r in records if all(str(r.get(k)) == v for k, v in wanted.items())]
        if not matches or args.reference_metric not in matches[0].get("metrics", {}):
            sys.exit(f"stability_map.py: no finished run matches --reference {args.reference} with metric {args.reference_metric}")
        reference = matches[0]["metrics"][args.reference_metric]
        for r in records:
            value = r.get("metrics", {}).get(args.reference_metric)
            r["reference_error"] = None if value is None or r is matches[0] else abs(value - reference) / abs(reference)
    extra_keys = sorted({k for p in extra_points for k in p} - set(keys))  # settings named only by --point
    with open(os.path.join(out, "stability_map.json"), "w") as f:
        json.dump({"case": name, "smoke": args.smoke,
                   "criterion": f"finished; interface force within {STABLE_FORCE_ERROR:.0%} of the weight/load and its rms "
                                f"oscillation at most {STABLE_FLUCTUATION:.0%} of it, over the final span",
                   "reference": {"settings": args.reference, "metric": args.reference_metric, "value": reference},
                   "records": records}, f, indent=2)
    write_table(records, keys + extra_keys, reference is not None, os.path.join(out, "stability_map.md"))
    plot(records, keys, extra_keys, reference is not None, args.reference_metric, os.path.join(out, "stability_map.png"))
    return 0


def write_table(records, keys, with_reference, path):
    pct = lambda v: "–" if v is None else f"{v:.2%}"
    columns = keys + ["stable", "force error", "oscillation (growth)", "energy balance", "interface energy error",
                      "deflection error vs direct FEM"]
    columns += ["error vs reference"] if with_reference else []
    columns += ["passes/window", "wall [s]"]
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in records:
        growth = r.get("fluctuation_growth")
        cells = [str(r.get(k, "")) for k in keys] + [
            "yes" if r["stable"] else "**no**", pct(r.get("interface_force_error")),
            pct(r.get("force_fluctuation")) + ("" if growth is None else f" (×{growth:.1f})"),
            pct(r.get("energy_balance_error")), pct(r.get("interface_energy_error")), pct(r.get("deflection_error"))]
        if with_reference:
            cells.append("reference" if r.get("reference_error") is None and r["status"] == "ok" else pct(r.get("reference_error")))
        passes = r.get("passes_per_window")
        cells += ["–" if passes is None else f"{passes:.2f}" + (f" ({r['unconverged_windows']} unconv.)" if r.get("unconverged_windows") else ""),
                  "–" if r.get("wall_time_s") is None else f"{r['wall_time_s']:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def plot(records, keys, extra_keys, with_reference, metric, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x_key, series_keys = keys[-1], keys[:-1]
    series_of = lambda r: ", ".join(f"{k}={r[k]}" for k in series_keys + extra_keys if k in r) or "runs"
    panels = 3 if with_reference else 2
    fig, ax = plt.subplots(1, panels, figsize=(5.2 * panels, 4.4))
    for k, label in enumerate(dict.fromkeys(series_of(r) for r in records)):
        rows = sorted((r for r in records if series_of(r) == label and stability_measure(r) is not None),
                      key=lambda r: float(r[x_key]))
        if not rows:
            continue
        xs = [float(r[x_key]) for r in rows]
        worst = [max(stability_measure(r), 1e-5) for r in rows]
        ax[0].plot(xs, worst, "o-", color=f"C{k}", label=label)
        ax[1].plot(xs, [r["wall_time_s"] for r in rows], "o-", color=f"C{k}", label=label)
        for r, y in zip(rows, worst):
            if not r["stable"]:
                ax[0].plot(float(r[x_key]), y, "x", color="k", ms=10)
        if with_reference:
            pts = [(r["wall_time_s"], r["reference_error"]) for r in rows if r.get("reference_error") is not None and r["stable"]]
            if pts:
                ax[2].plot(*zip(*pts), "o", color=f"C{k}", label=label)
    ax[0].axhline(STABLE_FLUCTUATION, ls="--", color="grey", label="stability limit (oscillation, energy)")
    ax[0].set_ylabel("max(force error, oscillation, energy balance)")
    ax[0].set_title("stability (x: unstable)")
    ax[1].set_ylabel("coupled wall time [s]")
    for a in ax[:2]:
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel(x_key)
    if with_reference:
        ax[2].set_yscale("log")  # wall times of one map span less than a decade: linear axis keeps its labels
        ax[2].set_xlabel("coupled wall time [s]")
        ax[2].set_ylabel(f"{metric}: error vs reference run")
        ax[2].set_title("speed vs error (stable runs)")
    from matplotlib.ticker import NullFormatter
    for a in ax:
        a.xaxis.set_minor_formatter(NullFormatter())  # minor labels of a short log axis overlap
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
