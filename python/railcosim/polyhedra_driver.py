"""The dilated-polyhedra DEM without YADE: ctypes over librailcosim_polyhedra_driver.so (PolyhedraDriver.h).

A `PolyhedraBed` holds stones given in their own body frames, triangle walls (some of them plates moved with
set_wall_velocity) and, once connected, a FEM surface coupled through the bridge, advanced one window at a time
(`window()`) as YADE's FemCouplingEngine with contactModel 'polyhedra' advances it (docs/polyhedra-driver.md):

    bed = PolyhedraBed(time_step=1e-5, stone_material=(E, nu, e, mu), max_neighbours=64)
    bed.add_stone(core_vertices, dilation, density, position, orientation)     # per stone
    bed.set_walls(corners, material_of_triangle, materials)                   # (n, 3, 3) corners
    bed.step(100); bed.states()                                               # body-frame states
    bed.connect(endpoint, scheme="implicit", surface_material=(...)); bed.window()
    # restart checkpoints: bed.set_restart(**restart_settings()) before connect; after a window with
    # bed.checkpoint_pending, bed.complete_checkpoint(files, state); resumed: bed.resumed_state() after connect

The library is looked for in RAILCOSIM_POLYHEDRA_DRIVER (a file), else in RAILCOSIM_BUILD (default ./build) under
yade_engines/polyhedra/driver. numpy only: runs wherever the library does, without YADE.
"""
import ctypes
import os

import numpy as np

LIBRARY_NAME = "librailcosim_polyhedra_driver.so"
FIGURES = ("window_length", "subcycles", "windows", "surface_nodes", "surface_triangles", "total_force_x",
           "total_force_y", "total_force_z", "surface_force_x", "surface_force_y", "surface_force_z",
           "interface_work_dem", "interface_work_fem", "implicit_passes", "last_window_passes", "max_window_passes",
           "unconverged_windows", "last_residual", "surface_contacts", "polyhedra_time", "mapping_time",
           "bridge_time", "wait_time", "checkpoint_time", "time", "restart_checkpoint_time", "restart_checkpoints")


class DriverError(RuntimeError):
    """A call of the library failed; the message is the library's."""


def library_path():
    """Where the driver library is: RAILCOSIM_POLYHEDRA_DRIVER, else the build folder's."""
    explicit = os.environ.get("RAILCOSIM_POLYHEDRA_DRIVER")
    if explicit:
        return explicit
    root = os.environ.get("RAILCOSIM_ROOT", os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    build = os.environ.get("RAILCOSIM_BUILD", os.path.join(root, "build"))
    return os.path.join(build, "yade_engines", "polyhedra", "driver", LIBRARY_NAME)


_LIBRARY = None
_D = ctypes.POINTER(ctypes.c_double)
_I = ctypes.POINTER(ctypes.c_int32)


def _library():
    global _LIBRARY
    if _LIBRARY is None:
        path = library_path()
        if not os.path.isfile(path):
            raise DriverError(f"the polyhedra driver library {path} does not exist; build it (./railcosim build) or set "
                              "RAILCOSIM_POLYHEDRA_DRIVER")
        lib = ctypes.CDLL(path)
        p, i, d, s = ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_char_p
        signatures = {
            "rcp_last_error": (s, []), "rcp_create": (p, [d, _D, _D, i, i, i, d, i, d, s]), "rcp_destroy": (None, [p]),
            "rcp_add_stone": (i, [p, _D, i, d, d, _D, _D, _D, _D]), "rcp_set_walls": (i, [p, _D, i, _I, _D, i]),
            "rcp_set_rolling_friction": (i, [p, d, _D, i]),
            "rcp_initialize": (i, [p]), "rcp_critical_time_step": (d, [p, d, d]), "rcp_set_time_step": (i, [p, d]),
            "rcp_time_step": (d, [p]), "rcp_set_damping": (i, [p, d]), "rcp_set_wall_velocity": (i, [p, _I, i, _D]),
            "rcp_set_wall_node_velocities": (i, [p, _I, i, _D]), "rcp_step": (i, [p, i]),
            "rcp_wall_force": (i, [p, _I, i, _D]), "rcp_time": (d, [p]), "rcp_stone_count": (i, [p]),
            "rcp_templates": (i, [p]), "rcp_mean_contacts": (d, [p]),
            "rcp_step_counters": (i, [p, ctypes.POINTER(ctypes.c_int64)]), "rcp_backend": (i, [p, s, i]),
            "rcp_states": (i, [p, _I, i, _D, _D, _D, _D, _D]), "rcp_contact_count": (i, [p]),
            "rcp_contact_count_of": (i, [p, _I, i]),
            "rcp_contacts": (i, [p, _I, _I, _I, _D, _D, _D, _D]),
            "rcp_connect": (i, [p, s, s, s, d, d, i, d, d, i, d, i, _D]), "rcp_window": (i, [p]),
            "rcp_coupling_figures": (i, [p, _D]), "rcp_surface_triangles": (i, [p, _I]),
            "rcp_surface_state": (i, [p, _D, _D]), "rcp_finalize": (i, [p]),
            "rcp_set_restart": (i, [p, s, s, d, s]), "rcp_checkpoint_pending": (i, [p]),
            "rcp_complete_checkpoint": (i, [p, s, ctypes.c_char_p, ctypes.c_long]),
            "rcp_resumed_state": (ctypes.c_long, [p, ctypes.c_char_p, ctypes.c_long]),
        }
        for name, (result, arguments) in signatures.items():
            function = getattr(lib, name)
            function.restype, function.argtypes = result, arguments
        _LIBRARY = lib
    return _LIBRARY


def restart_settings(environment=os.environ):
    """set_restart's arguments from what `railcosim run --checkpoint-every / --resume` sets for both solvers
    (railcosim.checkpoints.solver_environment), or None when the run has no restart checkpoints."""
    folder, run, every, resume = (environment.get(f"RAILCOSIM_{name}", "") for name in
                                  ("CHECKPOINT_DIR", "CHECKPOINT_RUN", "CHECKPOINT_EVERY", "RESUME"))
    if not folder:
        return None
    return {"folder": folder, "run": run, "every": float(every) if every else 0.0, "resume_from": resume or None}


def window_recorder(bed, out, restart):
    """(recorder, first window, saved state) of a standalone driver's coupled run, after connect: a new DemRecorder
    (results.py) from window 0, or, resuming (restart_settings() with resume_from), the checkpoint's time series put
    back and appended to from the checkpoint's window, with the state the script saved there (its dict, unpickled;
    None for a new run). The script saves that dict with its checkpoint as {"windows_recorded": len(recorder), ...}."""
    import pickle

    from railcosim import results
    if not (restart and restart["resume_from"]):
        return results.DemRecorder(out), 0, None
    saved = pickle.loads(bed.resumed_state())  # puts the checkpoint's files back first
    figures = bed.figures()
    first = int(figures["windows"])
    print(f"resumed from {restart['resume_from']} at t={figures['time']:.4f} s, window {first}", flush=True)
    return results.DemRecorder(out, resume_windows=saved["windows_recorded"]), first, saved


def complete_pending_checkpoint(bed, recorder, window, **state):
    """After a coupled window: completes the restart checkpoint the window ordered, if any, with the recorder's time
    series file and {"windows_recorded": len(recorder), **state} (what window_recorder gives back on resume)."""
    if not bed.checkpoint_pending:
        return
    import pickle
    recorder.flush()
    bed.complete_checkpoint([recorder.path], pickle.dumps({"windows_recorded": len(recorder), **state}))
    print(f"checkpoint at t={bed.time:.4f} s, window {window}", flush=True)


def _doubles(values, count=None):
    array = np.ascontiguousarray(values, dtype=np.float64).ravel()
    if count is not None and array.size != count:
        raise ValueError(f"expected {count} values, got {array.size}")
    return array


def _pointer(array):
    return array.ctypes.data_as(_D) if array.dtype == np.float64 else array.ctypes.data_as(_I)


def rectangle(origin, u, v):
    """Two wall triangles of the rectangle origin + [0, 1] u + [0, 1] v, counter-clockwise seen from the side u x v
    points to (the stones' side)."""
    o, u, v = (np.asarray(a, float) for a in (origin, u, v))
    return [[o, o + u, o + u + v], [o, o + u + v, o + v]]


def assemble_walls(parts):
    """(corners (n, 3, 3) for set_walls, {part: its triangles' indices}) of {part: list of triangles}."""
    corners, indices = [], {}
    for name, triangles in parts.items():
        indices[name] = list(range(len(corners), len(corners) + len(triangles)))
        corners += triangles
    return np.array(corners, float), indices


class PolyhedraBed:
    """One polyhedra system driven without YADE (see the module's docstring). The arguments are PolyhedraSystem's
    Parameters: max_neighbours counts a stone's partners plus the large bodies in its reach, large_body_ratio the
    multiple of the median bounding radius above which a body stays out of the neighbour grid (<= 0: none)."""

    def __init__(self, time_step, stone_material, gravity=(0.0, 0.0, -9.81), max_neighbours=24, max_wall_neighbours=8,
                 rebuild_interval=10, neighbour_skin=-1.0, adaptive_rebuild=True, large_body_ratio=2.5,
                 backend="automatic"):
        self._lib = _library()
        self._gravity = _doubles(gravity, 3)
        self._material = _doubles(stone_material, 4)
        self._handle = self._lib.rcp_create(time_step, _pointer(self._gravity), _pointer(self._material), max_neighbours,
                                            max_wall_neighbours, rebuild_interval, neighbour_skin, int(adaptive_rebuild),
                                            large_body_ratio, backend.encode())
        if not self._handle:
            raise DriverError(self._lib.rcp_last_error().decode())

    def __del__(self):
        if getattr(self, "_handle", None):
            self._lib.rcp_destroy(self._handle)
            self._handle = None

    def _check(self, result):
        if result is None or (isinstance(result, (int, float)) and result < 0):
            raise DriverError(self._lib.rcp_last_error().decode())
        return result

    def set_rolling_friction(self, stones, walls=()):
        """Bounded rolling friction η_r [-] of the stones and of the first len(walls) wall materials (set_walls'
        order; the rest 0; one value more than set_walls' materials is the coupled surface's, connect's
        surface_material); a pair takes the larger of its two. It turns sphere stones only (one core vertex, the
        dilation its radius). Before the first add_stone."""
        w = _doubles(walls)
        self._check(self._lib.rcp_set_rolling_friction(self._handle, float(stones), _pointer(w), w.size))

    def add_stone(self, vertices, dilation, density, position, orientation, velocity=(0, 0, 0),
                  angular_velocity=(0, 0, 0)):
        """A stone: core vertices (n, 3) in its body frame [m], dilation radius [m], density [kg/m^3]; its body frame's
        origin [m], orientation (w, x, y, z), velocity [m/s], angular velocity [rad/s]. Returns its index."""
        v = _doubles(vertices)
        arrays = [_doubles(position, 3), _doubles(orientation, 4), _doubles(velocity, 3), _doubles(angular_velocity, 3)]
        return self._check(self._lib.rcp_add_stone(self._handle, _pointer(v), v.size // 3, float(dilation), float(density),
                                                   *[_pointer(a) for a in arrays]))

    def set_walls(self, corners, material_of_triangle, materials):
        """Fixed triangle walls: corners (n, 3, 3) [m], CCW seen from the stones; each triangle's index into
        `materials` [(E, nu, e, mu)]."""
        c = _doubles(corners)
        m = np.ascontiguousarray(material_of_triangle, dtype=np.int32)
        mats = _doubles(materials)
        self._check(self._lib.rcp_set_walls(self._handle, _pointer(c), c.size // 9, _pointer(m), _pointer(mats),
                                            mats.size // 4))

    def initialize(self):
        self._check(self._lib.rcp_initialize(self._handle))

    def critical_time_step(self, normal_force=0.0, impact_velocity=0.0):
        return self._check(self._lib.rcp_critical_time_step(self._handle, normal_force, impact_velocity))

    @property
    def dt(self):
        return self._lib.rcp_time_step(self._handle)

    @dt.setter
    def dt(self, value):
        self._check(self._lib.rcp_set_time_step(self._handle, float(value)))

    def set_damping(self, share):
        """Non-viscous damping of the stones' translation from the next step on (YADE's NewtonIntegrator.damping): a
        force component loses `share` [0, 1) while it accelerates its stone. For packings; 0 in a physical run."""
        self._check(self._lib.rcp_set_damping(self._handle, float(share)))

    @property
    def time(self):
        """Simulated time since the bed was made [s], advanced step by step."""
        return self._lib.rcp_time(self._handle)

    @property
    def mean_contacts(self):
        """Mean active contacts (stone-stone + stone-wall) over the last batch."""
        return self._lib.rcp_mean_contacts(self._handle)

    @property
    def step_counters(self):
        """{"core_overlaps": contact evaluations whose cores intersected (the dilated contact law no longer holds
        there), "dangerous_rebuilds": neighbour-list rebuilds after which a stone had moved more than half the skin
        (contacts may have been missed)}, since the bed was made."""
        counters = (ctypes.c_int64 * 2)()
        self._check(self._lib.rcp_step_counters(self._handle, counters))
        return {"core_overlaps": int(counters[0]), "dangerous_rebuilds": int(counters[1])}

    @property
    def stone_count(self):
        return self._lib.rcp_stone_count(self._handle)

    @property
    def templates(self):
        return self._lib.rcp_templates(self._handle)

    @property
    def backend(self):
        """("cpu" | "cuda", why)."""
        reason = ctypes.create_string_buffer(512)
        code = self._check(self._lib.rcp_backend(self._handle, reason, 512))
        return ("cuda" if code == 1 else "cpu"), reason.value.decode()

    def set_wall_velocity(self, triangles, velocity):
        t = np.ascontiguousarray(triangles, dtype=np.int32)
        v = _doubles(velocity, 3)
        self._check(self._lib.rcp_set_wall_velocity(self._handle, _pointer(t), t.size, _pointer(v)))

    def set_wall_node_velocities(self, triangles, velocities):
        """Velocities of the corners of wall triangles `triangles`, (count, 3, 3) [m/s]: constant over the following
        batches or coupling windows until set again (a turning flap: each window's chord velocities)."""
        t = np.ascontiguousarray(triangles, dtype=np.int32)
        v = _doubles(velocities, 9 * t.size)
        self._check(self._lib.rcp_set_wall_node_velocities(self._handle, _pointer(t), t.size, _pointer(v)))

    def step(self, steps):
        self._check(self._lib.rcp_step(self._handle, int(steps)))

    def wall_force(self, triangles):
        """Force of the stones on the wall triangles, mean over the last batch [N] (3)."""
        t = np.ascontiguousarray(triangles, dtype=np.int32)
        out = np.zeros(3)
        self._check(self._lib.rcp_wall_force(self._handle, _pointer(t), t.size, _pointer(out)))
        return out

    def states(self, indices=None):
        """Body-frame states of the stones `indices` (all if None): positions (n, 3), orientations (n, 4) w,x,y,z,
        velocities, angular velocities, masses (n)."""
        chosen = None if indices is None else np.ascontiguousarray(indices, dtype=np.int32)
        n = self.stone_count if chosen is None else chosen.size
        p, q, v, w, m = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
        self._check(self._lib.rcp_states(self._handle, None if chosen is None else _pointer(chosen),
                                         0 if chosen is None else chosen.size, *[_pointer(a) for a in (p, q, v, w, m)]))
        return p, q, v, w, m

    def contacts(self, indices=None):
        """Active contacts of the last force evaluation: {first, second (stone indices; the wall triangle when
        wall), wall (bool), point, normal, force (on second; (n, 3)), overlap}; with `indices`, only those that these
        stones take part in (selected on the GPU: a few stones' contacts without the whole bed's)."""
        if indices is None:
            n = self._check(self._lib.rcp_contact_count(self._handle))
        else:
            chosen = np.ascontiguousarray(indices, dtype=np.int32)
            n = self._check(self._lib.rcp_contact_count_of(self._handle, _pointer(chosen), chosen.size))
        first, second, wall = (np.zeros(n, np.int32) for _ in range(3))
        point, normal, force, overlap = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
        if n:
            self._check(self._lib.rcp_contacts(self._handle, *[_pointer(a) for a in (first, second, wall, point, normal,
                                                                                     force, overlap)]))
        return {"first": first, "second": second, "wall": wall.astype(bool), "point": point, "normal": normal,
                "force": force, "overlap": overlap}

    def connect(self, endpoint, scheme, surface_material, name="dem", timeout=60.0, heartbeat=1.0, subcycles=0,
                implicit_tolerance=1e-3, implicit_absolute_tolerance=1e-14, implicit_max_iterations=30,
                implicit_relaxation=0.5, aitken=True):
        """Handshake with the FEM participant; its surface joins the walls with `surface_material` (E, nu, e, mu).
        The DEM step becomes the window / subcycles (0: the fewest steps not longer than the current step)."""
        m = _doubles(surface_material, 4)
        return self._check(self._lib.rcp_connect(self._handle, endpoint.encode(), name.encode(), scheme.encode(),
                                                 timeout, heartbeat, int(subcycles), implicit_tolerance,
                                                 implicit_absolute_tolerance, int(implicit_max_iterations),
                                                 implicit_relaxation, int(aitken), _pointer(m)))

    def set_restart(self, folder, run, every=0.0, resume_from=None):
        """Restart checkpoints, before connect: into `folder`, identified by `run`, one every `every` seconds of
        simulated time (0: none), ordered at the exchange that ends a window; `resume_from` a checkpoint folder to go
        on from (connect() then restores the system, the scheme and the counters). What `railcosim run
        --checkpoint-every / --resume` sets gives them (restart_settings())."""
        self._check(self._lib.rcp_set_restart(self._handle, folder.encode(), run.encode(), float(every),
                                              (resume_from or "").encode()))

    @property
    def checkpoint_pending(self):
        """Whether the last window ordered a restart checkpoint, which complete_checkpoint() completes."""
        return bool(self._lib.rcp_checkpoint_pending(self._handle))

    def complete_checkpoint(self, files, state):
        """Completes the ordered checkpoint with `state` (bytes: the driving script's own, resumed_state() gives it
        back) and `files` (paths in the working folder, put back on resume)."""
        self._check(self._lib.rcp_complete_checkpoint(self._handle, "\n".join(files).encode(), state, len(state)))

    def resumed_state(self):
        """In a resumed run, after connect: puts the checkpoint's files back and returns the script's saved state."""
        size = self._check(self._lib.rcp_resumed_state(self._handle, None, 0))
        buffer = ctypes.create_string_buffer(max(size, 1))
        self._check(self._lib.rcp_resumed_state(self._handle, buffer, size))
        return buffer.raw[:size]

    def window(self):
        """One coupling window, repeated as the scheme orders until it stands."""
        self._check(self._lib.rcp_window(self._handle))

    def figures(self):
        """{name: value} of FIGURES: the coupling's window, forces, interface work, passes and timings."""
        out = np.zeros(len(FIGURES))
        self._check(self._lib.rcp_coupling_figures(self._handle, _pointer(out)))
        return dict(zip(FIGURES, out.tolist()))

    def coupling_info(self, scheme):
        """The coupling figures every case writes to dem_info.json, under the names of results.coupling_info (YADE's
        FemCouplingEngine), for the coupling `scheme`."""
        f = self.figures()
        return {"subcycles": int(f["subcycles"]), "exchanges": int(f["windows"]), "scheme": scheme,
                "bridge_time_s": f["bridge_time"], "mapping_time_s": f["mapping_time"], "wait_time_s": f["wait_time"],
                "interface_work_dem_j": f["interface_work_dem"], "interface_work_fem_j": f["interface_work_fem"],
                "implicit_passes": int(f["implicit_passes"]), "max_window_passes": int(f["max_window_passes"]),
                "unconverged_windows": int(f["unconverged_windows"]), "checkpoint_time_s": f["checkpoint_time"],
                "restart_checkpoint_time_s": f["restart_checkpoint_time"]}

    def surface_triangles(self):
        n = int(self.figures()["surface_triangles"])
        out = np.zeros(3 * n, np.int32)
        self._check(self._lib.rcp_surface_triangles(self._handle, _pointer(out)))
        return out.reshape(n, 3)

    def surface_state(self):
        """The surface's node positions now (the next window's start) and the nodal forces of the last exchange, (n, 3)
        each [m, N]."""
        n = int(self.figures()["surface_nodes"])
        positions, forces = np.zeros(3 * n), np.zeros(3 * n)
        self._check(self._lib.rcp_surface_state(self._handle, _pointer(positions), _pointer(forces)))
        return positions.reshape(n, 3), forces.reshape(n, 3)

    def finalize(self):
        self._check(self._lib.rcp_finalize(self._handle))
