#!/usr/bin/python3
"""Plots error against time per run for each scheme and rotation test of one or more benchmark JSON files.

USAGE: /usr/bin/python3 plot_rotation_benchmark.py output.png results.json [more.json ...]
Samples without a time (NaN) are left out of the plot. Only merge files measured on the same machine.
"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {"zhaoVanWachem": "Zhao-van Wachem", "rk4": "RK4 (Munjiza)", "direct": "direct"}


def main(target, sources):
    samples = []
    for source in sources:
        with open(source) as handle:
            samples += json.load(handle)["samples"]
    tests = sorted({s["test"] for s in samples if not math.isnan(s["cpuSeconds"])})  # untimed tests: table only
    schemes = list(dict.fromkeys(s["scheme"] for s in samples))
    markers = "os^vDP*X"
    figure, axes = plt.subplots(1, len(tests), figsize=(5.5 * len(tests), 4.4), squeeze=False)
    for axis, test in zip(axes[0], tests):
        for index, scheme in enumerate(schemes):
            points = sorted((s["cpuSeconds"], s["error"]) for s in samples if s["test"] == test
                            and s["scheme"] == scheme and not math.isnan(s["cpuSeconds"]))
            if not points:
                continue
            style = ("-" if not scheme.startswith("yade:") else "--") + markers[index % len(markers)]
            axis.loglog([p[0] for p in points], [max(p[1], 1e-16) for p in points], style,
                        label=LABELS.get(scheme, scheme))
        measure = next(s["errorMeasure"] for s in samples if s["test"] == test)
        axis.set_title(test)
        axis.set_xlabel("CPU time per run [s] (= wall time on an idle core)")
        axis.set_ylabel(measure)
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(target, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) < 3 or not sys.argv[1].endswith(".png"):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
