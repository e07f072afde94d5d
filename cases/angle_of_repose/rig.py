"""The angle-of-repose rig without YADE: the hopper, the starting lattice, the fixed base and the spheres' sizes, the one
scene description of both DEM drivers (dem.py on YADE for spheres and clusters, polyhedra_dem.py on the polyhedra
library for polyhedra and spheres, the GPU machine's path).

The floor is z = 0. The hopper is a square funnel with walls at hopper_wall_angle_deg to the horizontal, narrowing to
the square aperture (side hopper_aperture) at drop_height above the floor, and a vertical square bin on top of it that
holds the starting lattice; its axis is the z axis (Irazábal 2017 §6.2.1)."""
import math

import numpy as np

import ballast_clusters


def sphere_diameters(p, rng, density, wheat=False):
    """Sphere diameters [m] drawn until their mass reaches ballast_mass_kg: sieve sizes from the middle of the EN 13450
    band (Irazábal 2017 Table 2.1), or for wheat uniform in [grain_diameter_min, grain_diameter_max]."""
    diameters, mass = [], 0.0
    while mass < p["ballast_mass_kg"]:
        d = (rng.uniform(p["grain_diameter_min"], p["grain_diameter_max"]) if wheat else
             1e-3 * ballast_clusters.sampleSieveSizes(rng, 1)[0])
        diameters.append(d)
        mass += density * math.pi / 6.0 * d ** 3
    return np.array(diameters)


class Hopper:
    def __init__(self, p):
        self.aperture, self.z0 = p["hopper_aperture"], p["drop_height"]
        self.slope = math.radians(p["hopper_wall_angle_deg"])
        self.z1 = self.z0 + p["hopper_height"]
        self.top_half = 0.5 * self.aperture + p["hopper_height"] / math.tan(self.slope)

    def funnel_half_width(self, z):
        """Half the width of the hopper's square section at height z."""
        return 0.5 * self.aperture + (min(z, self.z1) - self.z0) / math.tan(self.slope)

    def lattice(self, reaches, rng):
        """Starting centres of particles reaching `reaches` [m] from their centres: a jittered square lattice filling
        the hopper from the aperture up, spaced 2.1 times the largest reach, the particles spread over it at random
        (not sorted by height). Returns (centres (n, 3) in the order of `reaches`, the lattice's top + one spacing, the
        particles in the lattice's order: bottom row first)."""
        count = len(reaches)
        spacing = 2.0 * 1.05 * float(np.max(reaches))
        jitter = 0.02 * spacing
        centres, z = [], self.z0 + 0.5 * spacing
        while len(centres) < count:
            half = (self.funnel_half_width(z) - 0.5 * spacing / math.sin(self.slope) if z < self.z1
                    else self.top_half - 0.5 * spacing)
            n = max(1, int(2.0 * half / spacing) + 1)
            offsets = (np.arange(n) - 0.5 * (n - 1)) * spacing
            for x in offsets:
                for y in offsets:
                    if len(centres) < count:
                        centres.append((x + rng.uniform(-jitter, jitter), y + rng.uniform(-jitter, jitter), z))
            z += spacing
        order = rng.permutation(count)
        placed = np.zeros((count, 3))
        placed[order] = np.array(centres)
        return placed, max(c[2] for c in centres) + spacing, order

    def walls(self, bin_top):
        """The hopper's walls as quadrilaterals (4 corners each, counter-clockwise seen from outside the hopper: their
        normals point away from the axis): the funnel's four, then the bin's four up to bin_top."""
        a, corners = self.aperture, [(-1, -1), (1, -1), (1, 1), (-1, 1)]
        quads = []
        for k in range(4):
            (sx0, sy0), (sx1, sy1) = corners[k], corners[(k + 1) % 4]
            low = [(sx0 * 0.5 * a, sy0 * 0.5 * a, self.z0), (sx1 * 0.5 * a, sy1 * 0.5 * a, self.z0)]
            high = [(sx0 * self.top_half, sy0 * self.top_half, self.z1),
                    (sx1 * self.top_half, sy1 * self.top_half, self.z1)]
            top = [(c[0], c[1], bin_top) for c in high]
            quads.append((low[0], low[1], high[1], high[0]))
            quads.append((high[0], high[1], top[1], top[0]))
        return quads

    def gate(self):
        """The hopper's sliding gate (hopper_gate_s > 0): a square plate at the aperture's height, 1.5 apertures wide,
        as two triangles counter-clockwise seen from above (normal up), and how far it slides along +x to clear the
        aperture."""
        h, z = 0.75 * self.aperture, self.z0
        triangles = [[(-h, -h, z), (h, -h, z), (h, h, z)], [(-h, -h, z), (h, h, z), (-h, h, z)]]
        return triangles, 2.0 * h


def base_lattice(base_radius, d_base):
    """Centres (x, y) of the fixed base's spheres of diameter d_base touching on a hexagonal lattice inside a disc of
    base_radius (the fixed-base test, e.g. ISO 4324: a base with glued grains)."""
    rows = int(base_radius / (0.5 * math.sqrt(3.0) * d_base)) + 1
    points = []
    for j in range(-rows, rows + 1):
        for i in range(-rows - 1, rows + 2):
            x, y = (i + 0.5 * (j % 2)) * d_base, j * 0.5 * math.sqrt(3.0) * d_base
            if math.hypot(x, y) <= base_radius - 0.5 * d_base:
                points.append((x, y))
    return points
