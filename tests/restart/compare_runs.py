#!/usr/bin/python3
"""Compares the results of two runs of a case: summary.json, dem_info.json and fem/fem_summary.json value by value,
timeseries.h5 dataset by dataset and a stand-in solver's result file as text, leaving out what measures the machine (wall times, costs) or the run's history
(solvers, checkpoints, resumption). Prints the largest relative difference per file and the keys that differ.

Usage: compare_runs.py REFERENCE_DIR OTHER_DIR [--tolerance T]   (exit 1 when a value differs by more than T, default 0)
"""
import argparse
import json
import math
import os
import sys

# Keys whose values are wall-clock measurements or describe how the run went, not what it computed.
NOT_RESULTS = {"wall_time_s", "total_wall_time_s", "time_limit_s", "solvers", "checkpoints", "resumed_from", "error",
               "bridge_time_s", "dem_bridge_time_s", "fem_bridge_time_s", "force_mapping_time_s",
               "bridge_time_per_exchange_s", "checkpoint_time_s", "restart_checkpoint_time_s", "mapping_time_s",
               "wait_time_s", "polyhedra_time_s", "script_time_s",
               "assemblySeconds", "factorisationSeconds", "meanStepSeconds", "bridgeSeconds", "waitSeconds"}


# Dotted paths of the same kind: whether the case's bed came from the bed cache (summary.json and dem_info.json). A
# reference run on a fresh machine prepares the bed that the run compared with it then reuses.
NOT_RESULT_PATHS = {"metrics.bed_reused", "bed.reused"}


def flatten(value, prefix=""):
    """{dotted key: leaf value} of a JSON tree, without the NOT_RESULTS keys."""
    if isinstance(value, dict):
        items = {}
        for key, item in value.items():
            if key not in NOT_RESULTS:
                items.update(flatten(item, f"{prefix}{key}."))
        return items
    if isinstance(value, list):
        items = {}
        for k, item in enumerate(value):
            items.update(flatten(item, f"{prefix}{k}."))
        return items
    return {prefix.rstrip("."): value}


def relative(a, b):
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return 0.0 if a == b else math.inf
    if a == b or (math.isnan(a) and math.isnan(b)):
        return 0.0
    return abs(a - b) / max(abs(a), abs(b))


def compare_json(path_a, path_b):
    with open(path_a) as f:
        a = flatten(json.load(f))
    with open(path_b) as f:
        b = flatten(json.load(f))
    differences = {key: relative(a.get(key), b.get(key)) for key in sorted((set(a) | set(b)) - NOT_RESULT_PATHS)}
    return {key: d for key, d in differences.items() if d > 0}


def compare_h5(path_a, path_b):
    import h5py
    import numpy as np
    differences = {}
    with h5py.File(path_a, "r") as fa, h5py.File(path_b, "r") as fb:
        names_a, names_b = [], []
        fa.visit(lambda n: names_a.append(n) if isinstance(fa[n], h5py.Dataset) else None)
        fb.visit(lambda n: names_b.append(n) if isinstance(fb[n], h5py.Dataset) else None)
        for name in sorted(set(names_a) | set(names_b)):
            if name not in names_a or name not in names_b:
                differences[name] = math.inf
                continue
            x, y = np.asarray(fa[name][()], dtype=float), np.asarray(fb[name][()], dtype=float)
            if x.shape != y.shape:
                differences[name] = math.inf
            elif not np.array_equal(x, y, equal_nan=True):
                scale = max(float(np.max(np.abs(x))), float(np.max(np.abs(y))), 1e-300)
                differences[name] = float(np.max(np.abs(x - y))) / scale
    return differences


def compare_text(path_a, path_b):
    with open(path_a) as f, open(path_b) as g:
        return {} if f.read() == g.read() else {"text": math.inf}


# The result files a run may have (a stand-in solver's exact figures among them); one absent from both is skipped.
RESULTS = {"summary.json": compare_json, "dem_info.json": compare_json,
           os.path.join("fem", "fem_summary.json"): compare_json, "timeseries.h5": compare_h5,
           "fem_result.txt": compare_text, "dem_result.txt": compare_text}


def compare(reference, other):
    """{file: {key: relative difference}} for the result files of two results folders (only the keys that differ)."""
    report = {}
    for name, compare_file in RESULTS.items():
        a, b = os.path.join(reference, name), os.path.join(other, name)
        if not os.path.exists(a) and not os.path.exists(b):
            continue
        report[name] = compare_file(a, b) if os.path.exists(a) and os.path.exists(b) else {"present": math.inf}
    return report


def print_report(report):
    """Prints compare()'s report, file by file; returns the largest relative difference of all."""
    worst = 0.0
    for name, differences in report.items():
        largest = max(differences.values(), default=0.0)
        worst = max(worst, largest)
        print(f"{name}: {'bit for bit' if not differences else f'largest relative difference {largest:.3e}'}")
        for key, d in sorted(differences.items(), key=lambda item: -item[1])[:10]:
            print(f"  {key}: {d:.3e}")
    return worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference")
    parser.add_argument("other")
    parser.add_argument("--tolerance", type=float, default=0.0)
    args = parser.parse_args()
    worst = print_report(compare(args.reference, args.other))
    print(f"largest relative difference: {worst:.3e} (tolerance {args.tolerance:g})")
    return 0 if worst <= args.tolerance else 1


if __name__ == "__main__":
    sys.exit(main())
