"""Results of a case run: the DEM recorder and dem_info.json, JSON/CSV reading, HDF5 time series, history plots,
and the figures every case reports (participant summary, interface energy, force fluctuation)."""
import csv
import json
import operator
import os

import numpy as np

# The trapezoidal rule under either name: Debian bookworm's NumPy 1.24 has trapz only, the GPU machine's NumPy 2
# no trapz.
trapezoid = getattr(np, "trapezoid", None) or np.trapz


def coupling_info(coupling):
    """The coupling engine's figures every case writes to dem_info.json: exchanges, costs, scheme,
    interface work, for the implicit scheme the passes over the windows, and the wall time of restart checkpoints."""
    return {"subcycles": coupling.subcycles, "exchanges": coupling.exchanges, "scheme": coupling.scheme,
            "bridge_time_s": coupling.bridgeTime, "mapping_time_s": coupling.mappingTime, "wait_time_s": coupling.waitTime,
            "interface_work_dem_j": coupling.interfaceWorkDem, "interface_work_fem_j": coupling.interfaceWorkFem,
            "implicit_passes": coupling.implicitPasses, "max_window_passes": coupling.maxWindowPasses,
            "unconverged_windows": coupling.unconvergedWindows, "checkpoint_time_s": coupling.checkpointTime,
            "restart_checkpoint_time_s": coupling.checkpointWriteTime}


def force_fluctuation(times, force, span, reference):
    """Oscillation of a window-sampled interface force: rms about its mean over the final `span` seconds
    and over the span before it, both relative to `reference` (the load or weight), and their ratio.
    A coupling that is stable in the mean but pumps energy into the contacts shows as a large or
    growing fluctuation (stability criterion of tools/stability_map.py)."""
    times, force = np.asarray(times, float), np.asarray(force, float)
    final = times >= times[-1] - span
    before = (times >= times[-1] - 2 * span) & ~final
    rms = lambda values: float(np.std(values)) if len(values) > 1 else 0.0
    last, previous = rms(force[final]) / abs(reference), rms(force[before]) / abs(reference)
    return {"final": last, "previous": previous, "growth": last / previous if previous > 0 else None}


def bed_on_structure_checks(coupled, direct, same_load, interface_force, weight, deflection_tolerance):
    """The checks of a particle bed at rest on a coupled structure (beam, sleeper): the coupled deflection against
    the direct FEM run under the bed's weight as a uniform pressure (the case's goal, `deflection_tolerance`) and
    against a static FEM run under the coupled run's mean nodal forces (1 %: what remains is the residual motion of
    bed and structure), and the interface force against the particles' weight (frictionless walls: the structure
    carries all of it; 1 % leaves room for residual motion). Returns (relative errors by name, checks)."""
    errors = {"coupled_vs_direct_fem": abs(coupled - direct) / direct,
              "coupled_vs_same_load_fem": abs(coupled - same_load) / same_load,
              "interface_force_vs_weight": abs(interface_force - weight) / weight}
    checks = [
        {"name": "coupled vs direct FEM deflection", "value": errors["coupled_vs_direct_fem"],
         "limit": deflection_tolerance},
        {"name": "coupled vs static FEM under the coupled run's mean nodal forces",
         "value": errors["coupled_vs_same_load_fem"], "limit": 0.01},
        {"name": "interface force vs particle weight", "value": errors["interface_force_vs_weight"], "limit": 0.01},
    ]
    return errors, checks


def interface_energy_error(dem):
    """|W_DEM - W_FEM| / max(|W_DEM|, |W_FEM|): disagreement of the two sides' interface work."""
    a, b = dem["interface_work_dem_j"], dem["interface_work_fem_j"]
    scale = max(abs(a), abs(b))
    return abs(a - b) / scale if scale > 0 else 0.0


def interface_work_panel(series):
    """History panel of the interface energy audit: the work of the interface forces seen by each side."""
    return {"x": series["time"], "y": series["interface_work_dem"], "label": "interface work, DEM side (F·v dt per DEM step)",
            "ylabel": "interface work [J]", "lines": [],
            "more": [(series["interface_work_fem"], "interface work, FEM side (F·ΔP per window)")]}


DEM_SERIES_FILE = "dem_timeseries.h5"


class DemRecorder:
    """Per-window DEM time series written to OUT/dem_timeseries.h5 while the run goes on.

    `append(name=value, ...)` once per window, the same names every time; each series becomes a float64
    dataset of shape (windows, *value shape). Only one block of windows is held in memory, so the YADE
    process stays flat however long the run: Python lists of every window's node tuples grew it by 36 kB
    per window (181 MB -> 397 MB over 3 s simulated in the beam case, 3.6 GB at 30 s). Each full block is
    written and flushed, so an interrupted run keeps what it recorded up to its last block.
    """

    # 256 windows of 63 nodes x 3 float64 = 0.39 MB: one HDF5 chunk, inside h5py's 1 MB chunk cache per dataset.
    BLOCK_WINDOWS = 256

    def __init__(self, out, block_windows=BLOCK_WINDOWS, resume_windows=None):
        """`resume_windows`: a resumed run appends to the file a restart checkpoint put back, which holds that many
        windows (anything after them, left by the interrupted run, is cut)."""
        import h5py
        self.path = os.path.join(out, DEM_SERIES_FILE)
        self.file = h5py.File(self.path, "w" if resume_windows is None else "r+")
        self.file.attrs["units"] = "SI (m, s, N, J)"
        self.block_windows = block_windows
        self.blocks = {}    # name -> float64 array (block_windows, *shape), the windows not yet written
        self.pending = 0    # windows in self.blocks
        self.windows = 0    # windows appended in all
        self.last = {}      # name -> value of the latest window, for progress lines and final figures
        if resume_windows is not None:
            self.windows = resume_windows
            for name, dataset in self.file.items():
                if len(dataset) < resume_windows:
                    raise ValueError(f"{self.path}: series {name} has {len(dataset)} windows, the checkpoint "
                                     f"{resume_windows}")
                dataset.resize(resume_windows, axis=0)
                self.blocks[name] = np.empty((self.block_windows, *dataset.shape[1:]))
                if resume_windows > 0:
                    self.last[name] = dataset[resume_windows - 1]  # as recorded (arrays for vectors)

    def __len__(self):
        return self.windows

    def append(self, **values):
        rows = {name: plain_components(value) for name, value in values.items()}
        if not self.blocks:
            for name, row in rows.items():
                shape = np.shape(np.asarray(row, dtype=float))
                self.blocks[name] = np.empty((self.block_windows, *shape))
                self.file.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape), dtype="f8",
                                         chunks=(self.block_windows, *shape), compression="gzip", shuffle=True)
        elif rows.keys() != self.blocks.keys():
            raise ValueError(f"DemRecorder.append: window {self.windows} records {sorted(rows)}, "
                             f"the first window recorded {sorted(self.blocks)}; record the same series every window")
        for name, row in rows.items():
            self.blocks[name][self.pending] = row
        self.last.update(values)
        self.pending += 1
        self.windows += 1
        if self.pending == self.block_windows:
            self.flush()

    def flush(self):
        if self.pending == 0:
            return
        for name, block in self.blocks.items():
            dataset = self.file[name]
            dataset.resize(self.windows, axis=0)
            dataset[self.windows - self.pending:self.windows] = block[:self.pending]
        self.pending = 0
        self.file.flush()

    def close(self, **arrays):
        """Writes the last windows and `arrays` (per-run data such as the surface triangles, dtype kept)."""
        self.flush()
        for name, value in arrays.items():
            self.file.create_dataset(name, data=np.asarray(value))
        self.file.close()


def plain_components(value):
    """A YADE vector, or a list of them, as tuples of floats. numpy reads a Vector3 by iterating it, which ends
    on an IndexError raised through Boost.Python (5 us a vector, 0.9 ms a window of the beam's three 63-node
    fields); fetching the components by index costs a tenth of that. Numbers and arrays pass unchanged."""
    if isinstance(value, (np.ndarray, str)) or not hasattr(value, "__len__") or len(value) == 0:
        return value
    if not hasattr(value[0], "__len__"):
        return tuple(value[j] for j in range(len(value)))
    width = len(value[0])
    if width < 2:  # itemgetter of a single index returns the component, not a tuple
        return [tuple(v[j] for j in range(width)) for v in value]
    return list(map(operator.itemgetter(*range(width)), value))


def save_dem_outputs(out, recorder, info, **arrays):
    """What every case's dem.py leaves for its post-processing: the recorder's dem_timeseries.h5, closed
    with `arrays` added, and dem_info.json."""
    recorder.close(**arrays)
    with open(os.path.join(out, "dem_info.json"), "w") as f:
        json.dump(info, f, indent=2)


def read_dem_series(out):
    """{name: array} of a DEM run's time series and per-run arrays (dem_timeseries.h5, or the .npz that
    results folders written before the recorder hold)."""
    path = os.path.join(out, DEM_SERIES_FILE)
    if not os.path.isfile(path) and os.path.isfile(os.path.join(out, "dem_timeseries.npz")):
        return dict(np.load(os.path.join(out, "dem_timeseries.npz")))
    if not os.path.isfile(path):
        raise FileNotFoundError(f"expected result file {path} is missing; the DEM solver that writes it did not finish")
    import h5py
    with h5py.File(path, "r") as f:
        return {name: f[name][()] for name in f}


def read_coupled_run(out):
    """(dem, fem, monitor, series) of a coupled run's folder: dem_info.json, fem/fem_summary.json,
    fem/fem_monitor.csv (columns) and the DEM time series (read_dem_series)."""
    return (read_json(os.path.join(out, "dem_info.json")), read_json(os.path.join(out, "fem", "fem_summary.json")),
            read_csv_columns(os.path.join(out, "fem", "fem_monitor.csv")), read_dem_series(out))


def final_span(times, span):
    """Mask of the records in the final `span` seconds (the span averaged figures are taken over)."""
    return times >= times[-1] - span


def participant_summary(dem, fem):
    """The run-contract fields 'dem', 'fem' and 'coupling' of summary.json from dem_info.json and
    fem_summary.json (bridge time = encoding + transfer on both sides; force lumping listed apart)."""
    bridge = dem["bridge_time_s"] + fem.get("bridgeSeconds", 0.0)
    summary = {
        "dem": {"steps": dem["steps"], "dt": dem["dt"], "particles": dem["particles"]},
        "fem": {"steps": fem.get("steps"), "dt": fem.get("dt"), "nodes": fem.get("nodes")},
        "coupling": {"scheme": dem["scheme"], "exchanges": dem["exchanges"], "subcycles": dem["subcycles"],
                     "dem_bridge_time_s": dem["bridge_time_s"], "fem_bridge_time_s": fem.get("bridgeSeconds", 0.0),
                     "force_mapping_time_s": dem.get("mapping_time_s", 0.0), "bridge_time_s": bridge,
                     "bridge_time_per_exchange_s": bridge / max(1, dem["exchanges"])},
    }
    if dem["scheme"] == "implicit":
        # Passes per window and the cost of repeating windows (scene checkpoints, FEM re-solves).
        summary["coupling"].update({"implicit_passes": dem["implicit_passes"],
                                    "passes_per_window": dem["implicit_passes"] / max(1, dem["exchanges"]),
                                    "max_window_passes": dem["max_window_passes"],
                                    "unconverged_windows": dem["unconverged_windows"],
                                    "checkpoint_time_s": dem["checkpoint_time_s"], "fem_solves": fem.get("solves")})
    return summary


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
    """Stacked time-history panels; each panel {x, y, label, ylabel, lines: [(value, label)],
    more: [(y, label)] further curves over the same x (optional)}."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 3.2 * len(panels)), sharex=True, squeeze=False)
    for ax, panel in zip(axes[:, 0], panels):
        ax.plot(panel["x"], panel["y"], label=panel["label"], lw=1.2)
        for y, label in panel.get("more", []):
            ax.plot(panel["x"], y, label=label, lw=1.2, ls="-.")
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
