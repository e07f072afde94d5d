"""The steel-sheet rig as one scene description, YADE-free: the grains, the walls, the flaps' motion and the counts of
the masses, shared by dem.py (YADE) and dem_driver.py (the polyhedra library, the GPU machine's path). Frame: the
sheet's (x from the clamped end, y across, z up from the sheet's bottom face). README "The rig"."""
import math

import numpy as np

GRAVITY = 9.81
Z_PARK = -0.05  # grains below this have left the sheet (parked by dem.py, in the catch tray of dem_driver.py)


class Rig:
    """The planes, the hopper's extent and the flaps of the parameters `p` (the case's)."""

    def __init__(self, p):
        self.p = p
        self.top = p["sheet_thickness"]                # the sheet's top face, z
        self.xo, self.width = p["outlet_x"], p["hopper_width"]
        self.z_flaps = self.top + p["fall_height"]     # the flaps' plane
        self.z_slides = self.z_flaps + p["gap"]        # the hand-slides' plane (the hopper's bottom)
        self.z_flow = self.z_flaps - p["flow_plane_depth"]  # the plane the mass flow rate is measured at
        self.x0, self.x1 = self.xo - 0.5 * p["hopper_length"], self.xo + 0.5 * p["hopper_length"]
        self.xa, self.xb = self.xo - 0.5 * p["outlet_length"], self.xo + 0.5 * p["outlet_length"]
        self.xf0, self.xf1 = self.xo - p["flap_length"], self.xo + p["flap_length"]
        if not (self.x0 <= self.xf0 < self.xa and self.xb < self.xf1 <= self.x1):
            raise ValueError(f"the flaps' hinges {self.xf0:.3f}, {self.xf1:.3f} m must lie outside the outlet "
                             f"{self.xa:.3f}-{self.xb:.3f} m and within the hopper {self.x0:.3f}-{self.x1:.3f} m "
                             f"(flap_length, outlet_length, hopper_length)")
        self.flap_rate = 0.5 * math.pi / p["flap_opening_s"]  # rad/s: 90° at a constant rate, then they stop
        self.z_top = None                              # the bin's top: set by grains()

    def grains(self, rng):
        """Diameters uniform in [diameter_min, diameter_max] until grain_mass_kg is reached, on a jittered lattice
        filling the bin upwards: (diameters, centres (n, 3))."""
        p = self.p
        diameters, mass = [], 0.0
        while mass < p["grain_mass_kg"]:
            diameters.append(rng.uniform(p["diameter_min"], p["diameter_max"]))
            mass += p["grain_density"] * math.pi / 6.0 * diameters[-1] ** 3
        spacing = 1.05 * p["diameter_max"]
        nx, ny = int((self.x1 - self.x0) / spacing), int(self.width / spacing)
        centres = []
        while len(centres) < len(diameters):
            z = self.z_slides + 0.5 * spacing + (len(centres) // (nx * ny)) * spacing
            for i in range(nx):
                for j in range(ny):
                    if len(centres) < len(diameters):
                        jitter = rng.uniform(-0.02, 0.02, 2) * spacing
                        centres.append((self.x0 + (i + 0.5) * (self.x1 - self.x0) / nx + jitter[0],
                                        (j + 0.5) * self.width / ny + jitter[1], z))
        self.z_top = max(c[2] for c in centres) + spacing
        return np.array(diameters), np.array(centres)

    def walls(self):
        """The rig's rectangles as (name, material, corners a-b-c-d), each two triangles a-b-c and a-c-d, in the order
        dem.py adds them: the clamp, the hand-slides, the bin's and the gap's ends, the sides, the smoke scene's tray,
        the two flaps ('flap_left', 'flap_right'). Materials: 'steel', 'frame', 'tray'. After grains()."""
        p, top, W = self.p, self.top, self.width
        x0, x1, xa, xb, xf0, xf1 = self.x0, self.x1, self.xa, self.xb, self.xf0, self.xf1
        zs, zf, zt = self.z_slides, self.z_flaps, self.z_top
        clamp = p["clamp_length"]
        quads = [("clamp", "steel", [(0, 0, top), (clamp, 0, top), (clamp, W, top), (0, W, top)]),
                 ("slide", "frame", [(x0, 0, zs), (xa, 0, zs), (xa, W, zs), (x0, W, zs)]),
                 ("slide", "frame", [(xb, 0, zs), (x1, 0, zs), (x1, W, zs), (xb, W, zs)]),
                 ("bin end", "frame", [(x0, 0, zs), (x0, W, zs), (x0, W, zt), (x0, 0, zt)]),
                 ("bin end", "frame", [(x1, 0, zs), (x1, W, zs), (x1, W, zt), (x1, 0, zt)]),
                 ("gap end", "frame", [(xf0, 0, zf), (xf0, W, zf), (xf0, W, zs), (xf0, 0, zs)]),
                 ("gap end", "frame", [(xf1, 0, zf), (xf1, W, zf), (xf1, W, zs), (xf1, 0, zs)])]
        for y in (0.0, W):
            quads += [("side", "frame", [(x0, y, zs), (x1, y, zs), (x1, y, zt), (x0, y, zt)]),
                      ("side", "frame", [(xf0, y, zf), (xf1, y, zf), (xf1, y, zs), (xf0, y, zs)])]
        if p["tray_height"] > 0:
            # The smoke scene's tray: frictionless walls standing on the sheet's free edges keep the grains (spheres
            # roll without end on a flat sheet) so that they come to rest; vertical and frictionless, they carry none
            # of their weight.
            L, h = p["sheet_length"], top + p["tray_height"]
            quads += [("tray", "tray", [(0, 0, top), (L, 0, top), (L, 0, h), (0, 0, h)]),
                      ("tray", "tray", [(0, W, top), (L, W, top), (L, W, h), (0, W, h)]),
                      ("tray", "tray", [(L, 0, top), (L, W, top), (L, W, h), (L, 0, h)])]
        quads += [("flap_left", "steel", [(xf0, 0, zf), (self.xo, 0, zf), (self.xo, W, zf), (xf0, W, zf)]),
                  ("flap_right", "steel", [(self.xo, 0, zf), (xf1, 0, zf), (xf1, W, zf), (self.xo, W, zf)])]
        return quads

    def flap_hinges(self):
        """{flap name: (hinge point, sense)}: each flap turns about the axis y through its hinge, the left one by
        +angle, the right one by -angle (both swing down)."""
        return {"flap_left": ((self.xf0, 0.0, self.z_flaps), 1.0), "flap_right": ((self.xf1, 0.0, self.z_flaps), -1.0)}

    def flap_angle(self, t):
        """The flaps' opening angle [rad] at time t [s] (t = 0: they start to turn)."""
        return self.flap_rate * min(max(t, 0.0), self.p["flap_opening_s"])

    def turned(self, points, flap, angle):
        """Points (n, 3) of flap `flap` in its closed position, turned by `angle` about its hinge (axis y)."""
        (hx, _, hz), sense = self.flap_hinges()[flap]
        c, s = math.cos(sense * angle), math.sin(sense * angle)
        points = np.asarray(points, dtype=float)
        dx, dz = points[:, 0] - hx, points[:, 2] - hz
        return np.column_stack([hx + c * dx + s * dz, points[:, 1], hz - s * dx + c * dz])

    def through_sheet(self, positions, nodes):
        """Mask of the grains (positions (n, 3)) that have passed through the sheet, whose coupled face's nodes are at
        `nodes` (m, 3): a grain centre more than a quarter of the smallest diameter below the lowest point of the
        deflected top face across its width (at the grain's x), inside the sheet's footprint less a grain radius and
        above the parking level."""
        p = self.p
        d_min, d_max = p["diameter_min"], p["diameter_max"]
        x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
        order = np.argsort(nodes[:, 0])
        # the grid's columns of nodes: x values more than 0.2 mm apart (the finest grid line spacing is 0.75 mm, the
        # in-plane displacements are below 0.1 mm)
        column_of = np.empty(len(nodes), dtype=int)
        column_of[order] = np.concatenate([[0], np.cumsum(np.diff(nodes[order, 0]) > 2e-4)])
        lowest = np.full(column_of.max() + 1, np.inf)
        np.minimum.at(lowest, column_of, nodes[:, 2])
        columns = np.array([nodes[column_of == c, 0].mean() for c in range(len(lowest))])
        inside = ((p["clamp_length"] + 0.5 * d_max < x) & (x < p["sheet_length"] - 0.5 * d_max) & (0.5 * d_max < y)
                  & (y < p["sheet_width"] - 0.5 * d_max))
        return inside & (Z_PARK < z) & (z < np.interp(x, columns, lowest) - 0.25 * d_min)

    def bulk_figures(self, t, positions, velocities, masses, nodes):
        """Masses above the flaps, past the flow plane, on the sheet, on the clamp and below the sheet (parked); the
        grains through the sheet (through_sheet), each of them printed (time t, where, how fast, the face's nearest
        node); the top speed. positions, velocities (n, 3) of the grains, masses (n), nodes (m, 3): the coupled face's
        node positions."""
        p, top, W = self.p, self.top, self.width
        x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
        lying = (top < z) & (z < top + 0.05) & (0.0 < y)
        over_sheet = lying & (y < p["sheet_width"]) & (p["clamp_length"] < x) & (x < p["sheet_length"])
        on_clamp = lying & (y < W) & (x <= p["clamp_length"])
        through = self.through_sheet(positions, nodes)
        for i in np.flatnonzero(through):
            near = nodes[np.argmin(np.abs(nodes[:, 0] - positions[i, 0]) + np.abs(nodes[:, 1] - positions[i, 1]))]
            print(f"t={t:.4f} s: grain {i} below the sheet at {np.round(positions[i], 4).tolist()} m, velocity "
                  f"{np.round(velocities[i], 3).tolist()} m/s; the face's nearest node at "
                  f"{np.round(near, 4).tolist()} m", flush=True)
        return dict(passed_mass=float(masses[z < self.z_flow].sum()), hopper_mass=float(masses[z > self.z_flaps].sum()),
                    sheet_mass=float(masses[over_sheet].sum()), clamp_mass=float(masses[on_clamp].sum()),
                    parked_mass=float(masses[z <= Z_PARK].sum()), through_sheet=int(np.count_nonzero(through)),
                    max_speed=float(np.sqrt((velocities ** 2).sum(axis=1)).max()))
