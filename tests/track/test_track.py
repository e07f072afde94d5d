"""railcosim.track without YADE or FreeFEM: the Winkler closed form against the laws it must obey, and the sum of the
interface's nodal forces per sleeper."""
import os
import sys
import unittest

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "python"))
from railcosim import results, track  # noqa: E402

Q = 150e3          # N
MODULUS = 17.6e6   # N/m^2, the default run's support modulus
EI = 210e9 * 3038.3e-8  # N m^2, UIC60


class WinklerTest(unittest.TestCase):
    def test_foundation_carries_the_load(self):
        """Vertical equilibrium of the infinite beam: the foundation's reaction k w integrated over x is Q. The tail
        beyond 20/beta is below exp(-20); the trapezoid on 2e5 intervals is exact to 1e-8: tolerance 1e-6."""
        beta = (MODULUS / (4 * EI)) ** 0.25
        x = np.linspace(-20 / beta, 20 / beta, 200001)
        reaction = results.trapezoid(MODULUS * track.winkler_deflection(x, Q, MODULUS, EI), x)
        self.assertAlmostEqual(reaction / Q, 1.0, delta=1e-6)

    def test_beam_equation_away_from_the_load(self):
        """EI w'''' + k w = 0 where no load acts (Hetényi 1946, eq. 1): fourth differences at h = 0.01/beta carry a
        truncation error of order (beta h)^2 = 1e-4 of k w: tolerance 1e-3 of k w(0)."""
        beta = (MODULUS / (4 * EI)) ** 0.25
        h = 0.01 / beta
        x = np.arange(0.5 / beta, 4 / beta, h)
        w = track.winkler_deflection(x, Q, MODULUS, EI)
        fourth = (w[4:] - 4 * w[3:-1] + 6 * w[2:-2] - 4 * w[1:-3] + w[:-4]) / h ** 4
        residual = EI * fourth + MODULUS * w[2:-2]
        w0 = track.winkler_deflection(np.array([0.0]), Q, MODULUS, EI)[0]
        self.assertLess(np.max(np.abs(residual)) / (MODULUS * w0), 1e-3)

    def test_periodic_images_carry_one_load_per_period(self):
        """With a load every P (the quarter's planes of symmetry at 0 and P/2), the half period [0, P/2] carries Q/2,
        and the line is flat at both planes (w' = 0). Images beyond +-6 periods of 3 m weigh exp(-16): 1e-6."""
        period = 3.0
        x = np.linspace(0.0, period / 2, 20001)
        w = track.winkler_deflection(x, Q, MODULUS, EI, period=period)
        self.assertAlmostEqual(results.trapezoid(MODULUS * w, x) / (Q / 2), 1.0, delta=1e-6)
        slope_end = (w[-1] - w[-2]) / (x[-1] - x[-2])
        self.assertLess(abs(slope_end) * period / w[0], 1e-3)


    def test_mirrored_track_carries_its_loads(self):
        """The half track's ends (-0.3 m, 3.9 m) as mirror planes, two wheels of 84.4 kN at 0.5 m and 3.5 m (one near
        each end): the track carries both loads (the foundation's reaction over the track is their sum: each image of
        a load falls in an image of the track) and the line is flat at both ends (w' = 0 by symmetry). Images beyond
        +-6 periods of 8.4 m weigh exp(-40); the trapezoid on 2e4 intervals: tolerance 1e-6; one-sided slope over
        h = 0.21 mm against w(0)/L: 1e-3."""
        start, end = -0.3, 3.9
        loads = [(0.5, 84.4e3), (3.5, 84.4e3)]
        x = np.linspace(start, end, 20001)
        w = track.winkler_mirrored(x, loads, MODULUS, EI, start, end)
        self.assertAlmostEqual(results.trapezoid(MODULUS * w, x) / (2 * 84.4e3), 1.0, delta=1e-6)
        h = x[1] - x[0]
        for slope in ((w[1] - w[0]) / h, (w[-1] - w[-2]) / h):
            self.assertLess(abs(slope) * (end - start) / np.max(w), 1e-3)


class SeatForcesTest(unittest.TestCase):
    def test_forces_summed_per_sleeper(self):
        """Nodes on the sleepers' bases (z = 0) go to the nearest sleeper's sum; nodes on subgrade layers (z = base)
        are left out; the sleepers' sums add up to the sleeper nodes' total (conservation, exact)."""
        p = {"sleeper_spacing": 0.6, "sleepers": 3}
        positions = np.array([[0.0, 0.5, 0.0], [0.14, 0.7, 0.0], [0.55, 0.2, -0.001], [0.66, 1.0, 0.0],
                              [1.25, 0.3, 0.0], [0.3, 0.5, -0.3], [1.0, 1.0, -0.3]])
        forces = np.zeros((2, len(positions), 3))
        forces[:, :, 2] = [[1, 2, 3, 4, 5, -60, -70], [10, 20, 30, 40, 50, -600, -700]]
        seats = track.seat_forces(forces, positions, p, base_z=-0.3)
        np.testing.assert_array_equal(seats, [[3, 7, 5], [30, 70, 50]])


if __name__ == "__main__":
    unittest.main()


class BedStructureTest(unittest.TestCase):
    def lattice(self, basis, cells, spacing, radius):
        """Rows (x, y, z, r) of a lattice of cells^3 cubic cells with the given basis (fractions of a cell)."""
        grid = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        centres = (grid[:, None, :] + np.asarray(basis)[None, :, :]).reshape(-1, 3) * spacing
        return np.column_stack([centres, np.full(len(centres), radius)])

    def test_simple_cubic_lattice(self):
        """Spheres of radius a/2 (1 % overlap so that neighbours count as touching) on a simple cubic lattice of
        spacing a: solid fraction (4/3)pi r^3 / a^3 less the six caps' double counting, 6 neighbours each. The
        interior lies away from the lattice's faces, where it repeats exactly; 200,000 points give a sampling error
        of 0.11 %: tolerance 0.5 %."""
        a, r = 1.0, 0.505
        bed = self.lattice([[0, 0, 0]], 10, a, r)
        porosity, coordination = track.bed_structure(bed)
        h = r - a / 2                                       # each cap's height: half the overlap
        cap = np.pi * h ** 2 * (3 * r - h) / 3
        solid = (4 / 3 * np.pi * r ** 3 - 6 * cap) / a ** 3
        self.assertAlmostEqual(porosity, 1 - solid, delta=0.005)
        self.assertEqual(coordination, 6.0)

    def test_face_centred_cubic_lattice(self):
        """Touching spheres (0.1 % overlap) on a face-centred cubic lattice: solid fraction pi / (3 sqrt 2) = 0.7405
        (the densest packing; the overlaps remove 2e-5 of it), 12 neighbours each. Tolerance 0.5 % as above."""
        a = 1.0
        r = 1.001 * a / (2 * np.sqrt(2))
        bed = self.lattice([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]], 8, a, r)
        porosity, coordination = track.bed_structure(bed)
        self.assertAlmostEqual(porosity, 1 - np.pi / (3 * np.sqrt(2)), delta=0.005)
        self.assertEqual(coordination, 12.0)

    def test_sampled_porosity_of_regions(self):
        """One sphere of radius R in its bounding cube: solid fraction pi/6, so porosity 1 - pi/6 (200,000 points:
        sampling error 0.11 %, tolerance 0.5 %); a region inside the sphere is solid (0 exactly), one outside it void
        (1 exactly), and a region no point falls in is refused."""
        R = 0.3
        bed = np.array([[0.0, 0.0, 0.0, R]])
        low, high = [-R] * 3, [R] * 3
        self.assertAlmostEqual(track.sampled_porosity(bed, low, high), 1 - np.pi / 6, delta=0.005)
        centre_distance = lambda points: np.linalg.norm(points, axis=1)
        self.assertEqual(track.sampled_porosity(bed, low, high, lambda q: centre_distance(q) < 0.5 * R), 0.0)
        self.assertEqual(track.sampled_porosity(bed, low, high, lambda q: centre_distance(q) > 1.01 * R), 1.0)
        with self.assertRaisesRegex(ValueError, "no sample point"):
            track.sampled_porosity(bed, low, high, lambda q: q[:, 0] > R)

    def test_too_small_a_bed_is_refused(self):
        """A bed less than two largest radii across has no interior: a ValueError that says so."""
        bed = self.lattice([[0, 0, 0]], 1, 1.0, 0.5)
        with self.assertRaisesRegex(ValueError, "too small"):
            track.bed_structure(bed)


SCENE = {"sleepers": 2, "sleeper_spacing": 0.6, "sleeper_length": 2.52, "sleeper_width": 0.30, "shoulder_width": 0.40,
         "ballast_depth": 0.30, "size_scale": 3.0, "seed": 1}


class StandaloneSceneTest(unittest.TestCase):
    """railcosim.track_driver's geometry, without the library (the packing itself runs in the case's tests)."""

    def test_walls_face_the_bed(self):
        """Each wall triangle winds counter-clockwise seen from the stones (the library's convention): its normal
        (b - a) x (c - a) points from the triangle into the box, towards the box's centre. The walls reach beyond
        the box (WALL_MARGIN), so that every wall covers the whole face it closes."""
        from railcosim import track_driver
        corners, parts = track_driver.walls(SCENE, -0.3, 0.5, plate=0.1)
        centre = np.array([0.5 * track.end_x(SCENE), 0.5 * track.bed_width(SCENE), 0.05])
        for name, triangles in parts.items():
            for k in triangles:
                a, b, c = corners[k]
                normal = np.cross(b - a, c - a)
                self.assertGreater(float(np.dot(normal, centre - (a + b + c) / 3)), 0.0, f"{name} triangle {k}")
        base = corners[parts["base"]].reshape(-1, 3)
        self.assertLessEqual(base[:, 0].min(), 0.0)
        self.assertGreaterEqual(base[:, 0].max(), track.end_x(SCENE))
        self.assertGreaterEqual(base[:, 1].max(), track.bed_width(SCENE))

    def test_cloud_is_loose_inside_the_box_and_graded(self):
        """The cloud: no two grains overlap, all inside the box over the floor, at the solid fraction asked
        (CLOUD_SOLID_FRACTION, to the largest grain's volume), and its mass passing each EN 13450 sieve is the grading's
        (Irazábal 2017 Table 2.1 mid-points, times size_scale): about 450 grains drawn by mass, whose passing
        fractions scatter by about 3 points (a few large grains carry most of the mass): tolerance 8 points."""
        from railcosim import track_driver
        sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "yade_engines", "clusters"))
        grains, floor, top = track_driver.cloud(SCENE, np.random.default_rng(1))
        centres, radii = grains[:, :3], grains[:, 3]
        from scipy.spatial import cKDTree
        pairs = np.array(sorted(cKDTree(centres).query_pairs(2 * radii.max())), dtype=int).reshape(-1, 2)
        gaps = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) - radii[pairs].sum(axis=1)
        self.assertGreaterEqual(gaps.min(), -1e-12)
        low = np.array([0.0, 0.0, floor])
        high = np.array([track.end_x(SCENE), track.bed_width(SCENE), top])
        self.assertTrue(np.all(centres - radii[:, None] >= low - 1e-12) and np.all(centres + radii[:, None] <= high))
        volume = 4.0 / 3.0 * np.pi * radii ** 3
        box = float(np.prod(high - low))
        self.assertAlmostEqual(volume.sum() / box, track.CLOUD_SOLID_FRACTION, delta=volume.max() / box)
        sizes, passing, _ = track.grading(SCENE["size_scale"])
        for sieve, share in zip(sizes[1:-1], passing[1:-1]):
            self.assertAlmostEqual(volume[2 * radii <= sieve].sum() / volume.sum(), share, delta=0.08, msg=sieve)
