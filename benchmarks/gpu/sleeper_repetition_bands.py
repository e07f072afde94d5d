#!/usr/bin/python3
"""Mean ± std bands over the packings of a sleeper-case campaign: the sleeper's settlement and the five sensor
pressures against time, from each run's timeseries.h5 (the repetitions of one campaign point share one time grid:
same load pattern, same coupling window). A sensor is read every few windows and its pressure rattles from one
reading to the next, so each run's pressures are first averaged over the readings within --smooth windows (a
running mean: 10 windows is 1 ms at the case's 1e-4-s window, a tenth of a load cycle at 50x). Writes PREFIX.png
and PREFIX.csv (every --smooth-th window: time, load, settlement mean/std, smoothed pressure mean/std per sensor).

Usage: benchmarks/gpu/sleeper_repetition_bands.py CAMPAIGN_DIR [--point default] [--smooth 10] [--out PREFIX]
"""
import argparse
import glob
import os

import h5py
import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def series(paths):
    """Stacked histories of the runs: time, load [N], settlement [m] (runs x windows), pressures [Pa]
    (runs x windows x sensors). Runs of another length than the first are refused (not the same point)."""
    time, load, settlement, pressure = None, None, [], []
    for path in paths:
        with h5py.File(path, "r") as f:
            missing = [name for name in ("fem/time", "fem/applied_load", "fem/settlement", "dem/sensor_pressure")
                       if name not in f]
            if missing:
                raise SystemExit(f"{path}: no {', '.join(missing)} (not a sleeper_on_ballast run's timeseries.h5)")
            t = f["fem/time"][1:]  # the FEM's history starts at t = 0, the DEM's at the end of the first window
            if time is None:
                time, load = t, f["fem/applied_load"][1:]
            elif len(t) != len(time) or not np.allclose(t, time):
                raise SystemExit(f"{path}: its time grid differs from the first run's ({len(t)} vs {len(time)} "
                                 "windows): not a repetition of the same point")
            settlement.append(f["fem/settlement"][1:])
            pressure.append(f["dem/sensor_pressure"][:])
    return time, load, np.array(settlement), np.array(pressure)


def running_mean(x, width):
    """Running mean over `width` samples that skips NaN (the windows in which a sensor was not read)."""
    kernel = np.ones(width)
    read = ~np.isnan(x)
    total = np.convolve(np.where(read, x, 0.0), kernel, mode="same")
    count = np.convolve(read.astype(float), kernel, mode="same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign")
    parser.add_argument("--point", default="default")
    parser.add_argument("--smooth", type=int, default=10, help="windows of the running mean of the pressures")
    parser.add_argument("--out", help="prefix of the .png and .csv written (default CAMPAIGN/repetition_bands)")
    args = parser.parse_args()
    paths = sorted(glob.glob(os.path.join(args.campaign, "runs", args.point, "rep*", "timeseries.h5")))
    if len(paths) < 2:
        raise SystemExit(f"need at least two finished runs under {args.campaign}/runs/{args.point}, found {len(paths)}")
    time, load, settlement, pressure = series(paths)
    runs = len(paths)
    if args.smooth > 1:
        pressure = np.apply_along_axis(running_mean, 1, pressure, args.smooth)
    s_mean, s_std = settlement.mean(0), settlement.std(0, ddof=1)
    p_mean, p_std = pressure.mean(0), pressure.std(0, ddof=1)
    prefix = args.out or os.path.join(args.campaign, "repetition_bands")
    sensors = pressure.shape[2]
    header = ["time_s", "load_N", "settlement_mean_m", "settlement_std_m"]
    header += [f"sensor{k + 1}_{q}_Pa" for k in range(sensors) for q in ("mean", "std")]
    columns = [time, load, s_mean, s_std] + [c for k in range(sensors) for c in (p_mean[:, k], p_std[:, k])]
    np.savetxt(prefix + ".csv", np.column_stack(columns)[::max(args.smooth, 1)], delimiter=",", header=",".join(header), comments="")

    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    axes[0].plot(time, load / 1e3, color="k")
    axes[0].set_ylabel("load on the sleeper [kN]")
    axes[0].set_title(f"{runs} packings: mean ± 1 std (bands), each run (thin lines)")
    for s in settlement:
        axes[1].plot(time, 1e3 * s, lw=0.5, color="C0", alpha=0.5)
    axes[1].fill_between(time, 1e3 * (s_mean - s_std), 1e3 * (s_mean + s_std), color="C0", alpha=0.3)
    axes[1].plot(time, 1e3 * s_mean, color="C0")
    axes[1].set_ylabel("sleeper settlement [mm]")
    for k in range(sensors):
        axes[2].fill_between(time, (p_mean[:, k] - p_std[:, k]) / 1e3, (p_mean[:, k] + p_std[:, k]) / 1e3,
                             color=f"C{k}", alpha=0.2)
        axes[2].plot(time, p_mean[:, k] / 1e3, color=f"C{k}", lw=0.8, label=f"sensor {k + 1}")
    axes[2].set_ylabel(f"sensor pressure [kPa], mean of {args.smooth} windows")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(fontsize=8, ncol=sensors)
    fig.tight_layout()
    fig.savefig(prefix + ".png", dpi=110)
    end = -1
    print(f"{runs} runs; final settlement {1e3 * s_mean[end]:.1f} ± {1e3 * s_std[end]:.1f} mm "
          f"(largest std over the run {1e3 * s_std.max():.1f} mm at t = {time[s_std.argmax()]:.3f} s)")
    print(f"wrote {prefix}.png and {prefix}.csv")


if __name__ == "__main__":
    main()
