# YADE check: the cases' DEM recorder keeps the process flat: 1e5 windows of beam-sized node arrays, no solver.
# Run: ./railcosim yade yade_engines/checks/recorder_memory.py [WINDOWS]   (about 15 s; exit 0 when it passes)
import math
import os
import shutil
import sys
import tempfile
import time

import numpy as np

from railcosim import results

WINDOWS = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
NODES = 63        # interface nodes of the beam case's top face (20x2 P2 grid)
STATES = 64       # distinct window states, cycled: building 1e5 x 189 fresh Vector3 would dominate the run time
WARM_UP = 2 * results.DemRecorder.BLOCK_WINDOWS  # buffers, datasets and chunk caches exist after two blocks
# Growth allowed after the warm-up. The list-based recorder it replaces kept every window's three node fields
# as 63 tuples of 3 floats, 3 x 63 x (64 B tuple + 3 x 24 B float + 8 B list slot) = 27 kB per window by
# count; this check measured 32.5 kB per window with it, 3.1 GB over 1e5 windows (the beam case: 36 kB per
# window). The HDF5 recorder holds one 256-window block per series and h5py's chunk cache (<= 1 MB per
# dataset); what still grows is HDF5's chunk index (~400 chunks per dataset) and allocator noise: 1.9 MB
# measured. 16 MB leaves room for other allocators and is 190x below the old recorder's growth.
GROWTH_LIMIT_KB = 16 * 1024
if WINDOWS <= WARM_UP:
    print(f"FAIL: WINDOWS must exceed the warm-up of {WARM_UP} windows")
    sys.exit(2)


def resident_kb():
    with open("/proc/self/status") as f:
        fields = dict(line.split(":", 1) for line in f)
    return int(fields["VmRSS"].split()[0])


def window_state(k):
    """Node positions, velocities and forces of a beam vibrating in its first mode, as the engine gives them."""
    phase = 2 * math.pi * k / STATES
    shape = [math.sin(math.pi * (i % 21) / 20) for i in range(NODES)]
    positions = [Vector3(0.05 * (i % 21), 0.05 * (i // 21), 0.1 + 1e-6 * s * math.cos(phase)) for i, s in enumerate(shape)]
    velocities = [Vector3(0, 0, -3e-3 * s * math.sin(phase)) for s in shape]
    forces = [Vector3(1e-3 * s, -1e-3 * s, -8.0 * s * (1 + 0.1 * math.sin(phase))) for s in shape]
    return positions, velocities, forces


states = [window_state(k) for k in range(STATES)]
out = tempfile.mkdtemp(prefix="railcosim-recorder-")
failures = []
try:
    recorder = results.DemRecorder(out)
    started = time.monotonic()
    for k in range(WINDOWS):
        positions, velocities, forces = states[k % STATES]
        recorder.append(time=k * 5e-4, interface_force=Vector3(0, 0, -500.0 - k % STATES), interface_work_dem=1e-3 * k,
                        interface_work_fem=1e-3 * k, kinetic_energy=1.0 / (1 + k), nodal_forces=forces,
                        node_positions=positions, node_velocities=velocities, particles_below_surface=0)
        if k + 1 == WARM_UP:
            warm_kb = resident_kb()
        if (k + 1) % (WINDOWS // 4) == 0:
            print(f"window {k + 1}: VmRSS {resident_kb() / 1024:.1f} MB, {time.monotonic() - started:.1f} s", flush=True)
    growth_kb = resident_kb() - warm_kb
    results.save_dem_outputs(out, recorder, {"windows": WINDOWS}, triangles=np.arange(6).reshape(2, 3))
    print(f"{WINDOWS} windows: VmRSS grew {growth_kb / 1024:.1f} MB after the warm-up "
          f"({growth_kb * 1024 / (WINDOWS - WARM_UP):.1f} B per window; limit {GROWTH_LIMIT_KB / 1024:.0f} MB)", flush=True)
    if growth_kb > GROWTH_LIMIT_KB:
        failures.append(f"resident memory grew {growth_kb / 1024:.1f} MB over {WINDOWS} windows "
                        f"(limit {GROWTH_LIMIT_KB / 1024:.0f} MB): the recorder keeps windows in memory")

    # What the post-processing reads back is what was recorded, in order, as float64 (triangles as given).
    series = results.read_dem_series(out)
    for name, shape in (("time", (WINDOWS,)), ("interface_force", (WINDOWS, 3)), ("node_positions", (WINDOWS, NODES, 3)),
                        ("particles_below_surface", (WINDOWS,))):
        if series[name].shape != shape or series[name].dtype != np.float64:
            failures.append(f"{name}: read back as {series[name].shape} {series[name].dtype}, expected {shape} float64")
    for k in (0, 1, WARM_UP, WINDOWS // 2 + 7, WINDOWS - 1):
        positions, velocities, forces = states[k % STATES]
        expected = {"time": k * 5e-4, "nodal_forces": [tuple(f) for f in forces],
                    "node_velocities": [tuple(v) for v in velocities], "interface_force": (0, 0, -500.0 - k % STATES)}
        for name, value in expected.items():
            if not np.array_equal(series[name][k], np.asarray(value, float)):
                failures.append(f"{name}: window {k} read back differs from what was recorded")
    if series["triangles"].dtype.kind != "i" or series["triangles"].tolist() != [[0, 1, 2], [3, 4, 5]]:
        failures.append(f"triangles read back as {series['triangles'].dtype}: {series['triangles'].tolist()}")
finally:
    shutil.rmtree(out, ignore_errors=True)

for failure in failures:
    print("FAIL:", failure)
print("recorder_memory:", "FAILED" if failures else "passed")
sys.exit(1 if failures else 0)
