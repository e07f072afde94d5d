"""Snapshots of a run for ParaView: DIR/fields.xdmf (one file, a time series) over DIR/fields.h5.

A run with `snapshot_every_s` > 0 (simulated seconds between snapshots; the default -1 means "about
AUTO_SNAPSHOTS over a default run, none in a smoke run") writes while it goes
  DIR/dem_snapshots.h5      the YADE side (DemSnapshots): particles, the coupled interface, walls, boxes
  DIR/fem/snapshots/        the FreeFEM side (freefem_scripts/lib/snapshots.idp): mesh.txt, step_K.txt
both at every snapshot_windows(p)-th coupling window, numbered K = 1, 2, ... on both sides. After the run,
assemble() gathers them into fields.h5 and fields.xdmf and removes the raw files. Each time step of the XDMF
is a spatial collection of the grids that exist:
  particles   points: position, velocity, radius, orientation (w, x, y, z), contact_force (sum of |F| of the
              particle's contacts) [SI]
  structure   tetrahedra at their deformed position: displacement, velocity, von_mises [m, m/s, Pa]
  interface   the coupled surface's triangles: force (nodal force the particles exert on the structure) [N]
  walls       fixed or moving facets that are not the interface; boxes: cuboid bodies (e.g. sensors)
ParaView opens fields.xdmf in one step (File > Open, "Xdmf Reader"); docs/output.md says more.
"""
import glob
import os
import re

import numpy as np

AUTO_SNAPSHOTS = 20
DEM_SNAPSHOTS = "dem_snapshots.h5"
FEM_SNAPSHOTS = os.path.join("fem", "snapshots")
FIELDS_H5 = "fields.h5"
FIELDS_XDMF = "fields.xdmf"
# VTK/XDMF hexahedron corner order of a box with half-extents e: bottom face counter-clockwise, then the top.
BOX_CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                        [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


def snapshot_interval_s(p):
    """Simulated seconds between snapshots (0: none): snapshot_every_s, its default -1 resolved as described above."""
    every = float(p.get("snapshot_every_s", -1.0))
    if every < 0:
        return 0.0 if p.get("smoke") else p["duration_s"] / AUTO_SNAPSHOTS
    return every


def snapshot_windows(p):
    """Coupling windows between two snapshots (0: none), the same count on both sides of the run."""
    every = snapshot_interval_s(p)
    return max(1, int(round(every / p["fem_dt"]))) if every > 0 else 0


def rotate(quaternion, vectors):
    """Rotates rows of `vectors` by the unit quaternion (w, x, y, z)."""
    w, axis = quaternion[0], np.asarray(quaternion[1:], dtype=float)
    vectors = np.asarray(vectors, dtype=float)
    t = 2.0 * np.cross(axis, vectors)
    return vectors + w * t + np.cross(axis, t)


class DemSnapshots:
    """The YADE side's snapshots, appended to DIR/dem_snapshots.h5 (one group per snapshot K)."""

    def __init__(self, out, coupling=None, polyhedra=None, append=False):
        """`append`: a resumed run adds to the snapshots its interrupted part wrote."""
        import h5py
        self.file = h5py.File(os.path.join(out, DEM_SNAPSHOTS), "a" if append else "w")
        self.file.attrs["units"] = "SI (m, s, N)"
        self.coupling = coupling
        self.polyhedra = polyhedra
        self.count = 0

    def _contact_forces(self, count):
        """Sum of |F| over the contacts of each body id < count: YADE interactions, and the polyhedra system's."""
        from yade import O
        total = np.zeros(count)
        for i in O.interactions:
            if not i.isReal or not hasattr(i.phys, "normalForce"):
                continue
            magnitude = (i.phys.normalForce + i.phys.shearForce).norm()
            total[i.id1] += magnitude
            total[i.id2] += magnitude
        if self.polyhedra is not None and hasattr(self.polyhedra, "contacts"):
            for contact in self.polyhedra.contacts():
                magnitude = np.linalg.norm(np.asarray(contact["force"], dtype=float))
                for key in ("id1", "id2"):
                    if 0 <= contact[key] < count:
                        total[contact[key]] += magnitude
        return total

    def write(self, index, time):
        """Snapshot K = index at simulated time `time` [s] (the FEM side numbers its own the same way)."""
        from yade import O, wrapper
        if f"{index:06d}" in self.file:  # written after the checkpoint a resumed run went back to
            del self.file[f"{index:06d}"]
        group = self.file.create_group(f"{index:06d}")
        group.attrs["time"] = time
        interface_ids = set(self.coupling.facetIds) if self.coupling is not None else set()
        spheres, walls, boxes = [], [], []
        for b in O.bodies:
            if b is None:
                continue
            if isinstance(b.shape, wrapper.Sphere):
                spheres.append(b)
            elif isinstance(b.shape, wrapper.Facet) and b.id not in interface_ids:
                walls.append(b)
            elif isinstance(b.shape, wrapper.Box):
                boxes.append(b)
        if spheres:
            forces = self._contact_forces(len(O.bodies))
            particles = group.create_group("particles")
            particles["id"] = np.array([b.id for b in spheres], dtype=np.int64)
            particles["position"] = np.array([tuple(b.state.pos) for b in spheres])
            particles["velocity"] = np.array([tuple(b.state.vel) for b in spheres])
            particles["radius"] = np.array([b.shape.radius for b in spheres])
            particles["orientation"] = np.array([_wxyz(b.state.ori) for b in spheres])
            particles["contact_force"] = forces[particles["id"][()]]
        if walls:
            corners = [rotate(_wxyz(b.state.ori), [tuple(v) for v in b.shape.vertices]) + tuple(b.state.pos)
                       for b in walls]
            group.create_group("walls")["position"] = np.concatenate(corners)
        if boxes:
            corners = [rotate(_wxyz(b.state.ori), BOX_CORNERS * tuple(b.shape.extents)) + tuple(b.state.pos)
                       for b in boxes]
            box_group = group.create_group("boxes")
            box_group["position"] = np.concatenate(corners)
            box_group["velocity"] = np.repeat([tuple(b.state.vel) for b in boxes], 8, axis=0)
        if self.coupling is not None and len(self.coupling.triangles):
            interface = group.create_group("interface")
            interface["position"] = np.array([tuple(x) for x in self.coupling.nodePositions])
            interface["force"] = np.array([tuple(f) for f in self.coupling.nodalForces])
            interface["triangles"] = np.array([tuple(t) for t in self.coupling.triangles], dtype=np.int64)
        self.file.flush()
        self.count += 1

    def close(self):
        self.file.close()


def _wxyz(q):
    """(w, x, y, z) of a YADE Quaternion (its Python sequence order is x, y, z, w)."""
    return (q[3], q[0], q[1], q[2])


def _read_fem_snapshots(folder):
    """(points, tetrahedra, {K: (time, fields (vertices, 7))}) of the FreeFEM side, or None without snapshots."""
    mesh_path = os.path.join(folder, "mesh.txt")
    if not os.path.isfile(mesh_path):
        return None
    with open(mesh_path) as f:
        vertices, tetrahedra = (int(x) for x in f.readline().split())
        points = np.loadtxt(f, max_rows=vertices, ndmin=2)
        cells = np.loadtxt(f, max_rows=tetrahedra, ndmin=2, dtype=np.int64)
    if points.shape != (vertices, 3) or cells.shape != (tetrahedra, 4):
        raise ValueError(f"{mesh_path}: expected {vertices} vertices and {tetrahedra} tetrahedra, read "
                         f"{points.shape} and {cells.shape}")
    steps = {}
    for path in glob.glob(os.path.join(folder, "step_*.txt")):
        index = int(re.search(r"step_(\d+)\.txt$", path).group(1))
        with open(path) as f:
            time, count = f.readline().split()
            fields = np.loadtxt(f, ndmin=2)
        if int(count) != vertices or fields.shape != (vertices, 7):
            raise ValueError(f"{path}: {fields.shape} values for a mesh of {vertices} vertices")
        steps[index] = (float(time), fields)
    return points, cells, steps


def assemble(out):
    """Gathers the raw snapshots of the run in `out` into fields.h5 + fields.xdmf and removes them. Returns
    {"file", "snapshots", "grids"} for the summary, or None when the run wrote no snapshots."""
    import h5py
    dem_path = os.path.join(out, DEM_SNAPSHOTS)
    fem = _read_fem_snapshots(os.path.join(out, FEM_SNAPSHOTS))
    if not os.path.isfile(dem_path) and fem is None:
        return None
    steps = {}  # K -> {"time": t, grid: {name: array}}
    if os.path.isfile(dem_path):
        with h5py.File(dem_path, "r") as dem:
            for name, group in dem.items():
                step = steps.setdefault(int(name), {"time": float(group.attrs["time"])})
                for grid, datasets in group.items():
                    step[grid] = {key: value[()] for key, value in datasets.items()}
    if fem is not None:
        points, cells, fem_steps = fem
        for index, (time, fields) in fem_steps.items():
            step = steps.setdefault(index, {"time": time})
            step["structure"] = {"position": points + fields[:, 0:3], "displacement": fields[:, 0:3],
                                 "velocity": fields[:, 3:6], "von_mises": fields[:, 6]}
    h5_path = os.path.join(out, FIELDS_H5)
    with h5py.File(h5_path, "w") as f:
        f.attrs["units"] = "SI (m, s, N, Pa)"
        if fem is not None:
            f["structure_tetrahedra"] = cells
        for index in sorted(steps):
            group = f.create_group(f"{index:06d}")
            group.attrs["time"] = steps[index]["time"]
            for grid, datasets in steps[index].items():
                if grid != "time":
                    for key, value in datasets.items():
                        group[f"{grid}/{key}"] = value
    with open(os.path.join(out, FIELDS_XDMF), "w") as f:
        f.write(_xdmf(steps, FIELDS_H5, None if fem is None else fem[1].shape[0]))
    if os.path.isfile(dem_path):
        os.remove(dem_path)
    if fem is not None:
        for path in glob.glob(os.path.join(out, FEM_SNAPSHOTS, "*.txt")):
            os.remove(path)
        os.rmdir(os.path.join(out, FEM_SNAPSHOTS))
    grids = sorted({g for s in steps.values() for g in s if g != "time"})
    return {"file": FIELDS_XDMF, "snapshots": len(steps), "grids": grids}


def _item(h5, path, shape, number="Float", precision=8):
    dims = " ".join(str(n) for n in shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="{precision}" Format="HDF">'
            f"{h5}:{path}</DataItem>")


def _attribute(h5, path, name, value):
    kind = "Vector" if value.ndim == 2 and value.shape[1] == 3 else ("Scalar" if value.ndim == 1 else "Matrix")
    return (f'<Attribute Name="{name}" AttributeType="{kind}" Center="Node">'
            f"{_item(h5, path, value.shape)}</Attribute>")


def _grid(h5, path, name, topology, data, skip=("position", "triangles", "id")):
    points = data["position"]
    parts = [f'<Grid Name="{name}" GridType="Uniform">', topology,
             f'<Geometry GeometryType="XYZ">{_item(h5, path + "/position", points.shape)}</Geometry>']
    parts += [_attribute(h5, f"{path}/{key}", key, value) for key, value in data.items() if key not in skip]
    return "".join(parts) + "</Grid>"


def _consecutive_cells(kind, corners, data):
    """Topology of cells whose corners are consecutive points (each wall triangle or box has its own)."""
    n = len(data["position"]) // corners
    indices = " ".join(str(i) for i in range(corners * n))
    return (f'<Topology TopologyType="{kind}" NumberOfElements="{n}">'
            f'<DataItem Dimensions="{n} {corners}" NumberType="Int" Format="XML">{indices}</DataItem></Topology>')


def _xdmf(steps, h5, tetrahedra):
    """XDMF 3 text: a temporal collection whose every step is a spatial collection of the grids present."""
    lines = ['<?xml version="1.0" ?>', '<Xdmf Version="3.0">', "<Domain>",
             '<Grid Name="run" GridType="Collection" CollectionType="Temporal">']
    for index in sorted(steps):
        step = steps[index]
        base = f"/{index:06d}"
        lines.append(f'<Grid Name="snapshot {index}" GridType="Collection" CollectionType="Spatial">'
                     f'<Time Value="{step["time"]!r}"/>')
        if "particles" in step:
            n = len(step["particles"]["position"])
            lines.append(_grid(h5, base + "/particles", "particles",
                               f'<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1"/>',
                               step["particles"]))
        if "structure" in step:
            topology = (f'<Topology TopologyType="Tetrahedron" NumberOfElements="{tetrahedra}">'
                        f'{_item(h5, "/structure_tetrahedra", (tetrahedra, 4), "Int")}</Topology>')
            lines.append(_grid(h5, base + "/structure", "structure", topology, step["structure"]))
        if "interface" in step:
            triangles = step["interface"]["triangles"]
            topology = (f'<Topology TopologyType="Triangle" NumberOfElements="{len(triangles)}">'
                        f'{_item(h5, base + "/interface/triangles", triangles.shape, "Int")}</Topology>')
            lines.append(_grid(h5, base + "/interface", "interface", topology, step["interface"]))
        for grid, (kind, corners) in (("walls", ("Triangle", 3)), ("boxes", ("Hexahedron", 8))):
            if grid in step:
                lines.append(_grid(h5, f"{base}/{grid}", grid, _consecutive_cells(kind, corners, step[grid]),
                                   step[grid]))
        lines.append("</Grid>")
    lines += ["</Grid>", "</Domain>", "</Xdmf>", ""]
    return "\n".join(lines)
