"""Shared result I/O for case post-processing: JSON/CSV reading, HDF5 time series, history plots."""
import csv
import json
import os

import numpy as np


def read_json(path):
    if not os.path.isfile(path):
        raise FileNotFoundError(f"expected result file {path} is missing; the solver that writes it did not finish")
    with open(path) as f:
        return json.load(f)


def read_csv_columns(path):
    """CSV with a header row -> {column: numpy array}."""
    if not os.path.isfile(path):
        raise FileNotFoundError(f"expected result file {path} is missing; the solver that writes it did not finish")
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = [h.strip() for h in rows[0]]
    data = np.array([[float(x) for x in r] for r in rows[1:] if r], dtype=float).reshape(-1, len(header))
    return {name: data[:, i] for i, name in enumerate(header)}


def write_timeseries(path, groups):
    """{group: {dataset: array}} -> HDF5 file, one group per participant, SI units."""
    import h5py
    with h5py.File(path, "w") as f:
        f.attrs["units"] = "SI (m, s, N, J)"
        for group, datasets in groups.items():
            g = f.create_group(group)
            for name, values in datasets.items():
                g.create_dataset(name, data=np.asarray(values), compression="gzip")


def plot_history(path, title, panels):
    """Stacked time-history panels; each panel {x, y, label, ylabel, lines: [(value, label)]}."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 3.2 * len(panels)), sharex=True, squeeze=False)
    for ax, panel in zip(axes[:, 0], panels):
        ax.plot(panel["x"], panel["y"], label=panel["label"], lw=1.2)
        for k, (value, label) in enumerate(panel.get("lines", [])):
            ax.axhline(value, ls="--", lw=1.0, color=f"C{k + 1}", label=label)
        ax.set_ylabel(panel["ylabel"])
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
