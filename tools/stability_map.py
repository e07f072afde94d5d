#!/usr/bin/python3
"""Stability map of a case: runs it over a grid of settings and tabulates stability, error and wall time.

Usage: railcosim-env python3 tools/stability_map.py CASE [--smoke] --grid KEY=V1,V2 [--grid ...]
                                                       [--set KEY=VALUE ...] [--out DIR]
Each grid point is one `railcosim run CASE --set ...`. A run is *stable* when it finished and its
interface force averaged over the final span is within 5 % of the particle weight (a bed at rest on
the structure must transfer its whole weight; an unstable coupling pumps energy into the bed and the
force departs from it by far more). Writes DIR/stability_map.json, DIR/stability_map.md, DIR/stability_map.png.
"""
import argparse
import itertools
import json
import os
import subprocess
import sys

STABLE_FORCE_ERROR = 0.05


def main(argv):
    parser = argparse.ArgumentParser(prog="stability_map.py")
    parser.add_argument("case")
    parser.add_argument("--smoke", action="store_true")
    parser.add_argument("--grid", action="append", required=True, metavar="KEY=V1,V2")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    name = os.path.basename(os.path.abspath(args.case).rstrip("/"))
    out = os.path.abspath(args.out or os.path.join("results", f"{name}-stability"))
    os.makedirs(out, exist_ok=True)
    axes = []
    for item in args.grid:
        key, values = item.split("=", 1)
        axes.append((key, values.split(",")))
    records = []
    for point in itertools.product(*[[(k, v) for v in values] for k, values in axes]):
        label = "_".join(f"{k}-{v}" for k, v in point)
        run_dir = os.path.join(out, label)
        command = [os.path.join(root, "railcosim"), "run", args.case, "--out", run_dir, "--force"]
        command += ["--smoke"] if args.smoke else []
        for key, value in list(point) + [tuple(s.split("=", 1)) for s in args.set]:
            command += ["--set", f"{key}={value}"]
        result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        record = dict(point)
        summary_path = os.path.join(run_dir, "summary.json")
        if os.path.isfile(summary_path):
            with open(summary_path) as f:
                summary = json.load(f)
            errors = summary.get("relative_error", {})
            record.update({"status": summary["status"], "wall_time_s": summary["wall_time_s"],
                           "interface_force_error": errors.get("interface_force_vs_weight"),
                           "deflection_error": errors.get("coupled_vs_direct_fem"),
                           "interface_work_dem_j": summary.get("metrics", {}).get("interface_work_dem_j"),
                           "interface_work_fem_j": summary.get("metrics", {}).get("interface_work_fem_j")})
        else:
            record.update({"status": "failed", "wall_time_s": None, "interface_force_error": None,
                           "deflection_error": None})
        force_error = record["interface_force_error"]
        record["stable"] = bool(record["status"] == "ok" and force_error is not None
                                and force_error <= STABLE_FORCE_ERROR)
        records.append(record)
        print(f"[map] {label}: {'stable' if record['stable'] else 'UNSTABLE'}  force error "
              f"{force_error if force_error is None else f'{force_error:.2%}'}  wall {record['wall_time_s']} s",
              flush=True)
    with open(os.path.join(out, "stability_map.json"), "w") as f:
        json.dump({"case": name, "smoke": args.smoke, "criterion": f"interface force within "
                   f"{STABLE_FORCE_ERROR:.0%} of the weight over the final span", "records": records}, f, indent=2)
    keys = [k for k, _ in axes]
    lines = ["| " + " | ".join(keys + ["stable", "force error", "deflection error vs direct FEM", "wall [s]"]) + " |",
             "|" + "---|" * (len(keys) + 4)]
    for r in records:
        fmt = lambda v: "–" if v is None else f"{v:.2%}"
        lines.append("| " + " | ".join([str(r[k]) for k in keys] + ["yes" if r["stable"] else "**no**",
                                        fmt(r["interface_force_error"]), fmt(r["deflection_error"]),
                                        "–" if r["wall_time_s"] is None else f"{r['wall_time_s']:.1f}"]) + " |")
    with open(os.path.join(out, "stability_map.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    plot(records, axes, os.path.join(out, "stability_map.png"))
    return 0


def plot(records, axes, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    series_key, x_key = axes[0][0], axes[-1][0]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    for k, value in enumerate(dict.fromkeys(r[series_key] for r in records)):
        rows = [r for r in records if r[series_key] == value and r["interface_force_error"] is not None]
        xs = [float(r[x_key]) for r in rows]
        top.plot(xs, [max(r["interface_force_error"], 1e-5) for r in rows], "o-", color=f"C{k}", label=str(value))
        bottom.plot(xs, [r["wall_time_s"] for r in rows], "o-", color=f"C{k}", label=str(value))
        for r in rows:
            if not r["stable"]:
                top.plot(float(r[x_key]), r["interface_force_error"], "x", color="k", ms=10)
    top.axhline(STABLE_FORCE_ERROR, ls="--", color="grey", label="stability limit")
    top.set_yscale("log")
    top.set_ylabel("interface force error vs weight")
    bottom.set_ylabel("coupled wall time [s]")
    for ax in (top, bottom):
        ax.set_xscale("log")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, title=series_key)
    bottom.set_xlabel(x_key)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
