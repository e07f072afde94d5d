"""Sphere-cluster construction, union mass properties, enclosing sphere, shape library and EN 13450 sampler checks."""
import math
import os
import sys
import unittest

import numpy as np
from numpy.polynomial import Polynomial

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "yade_engines", "clusters"))
import ballast_clusters as bc  # noqa: E402

# Column integration at 400 columns: the single-sphere error measured 1e-5 (volume) and 2e-5 (inertia),
# converging ~h^2.5 (1.6e-4 at 100, 2.4e-5 at 200). 1e-4 is the accuracy the module states.
UNION_TOLERANCE = 1e-4


def rotation_about(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def two_sphere_closed_form(radius, distance):
    """Union of two equal spheres with centres at z = +-d/2: volume and (axial, transverse) inertia.

    Each half is a sphere cut by the plane z = 0; with u the coordinate from its own centre, u in [-d/2, R],
    the cross-section is a disc of radius^2 = R^2 - u^2. Polynomials are integrated exactly.
    """
    u = Polynomial([0.0, 1.0])
    disc = radius ** 2 - u ** 2
    a, b = -0.5 * distance, radius

    def integral(p):
        q = p.integ()
        return q(b) - q(a)

    volume = 2 * math.pi * integral(disc)
    axial = 2 * math.pi / 2 * integral(disc ** 2)
    transverse = 2 * math.pi * integral(disc * (disc / 4 + (u + 0.5 * distance) ** 2))
    return volume, axial, transverse


class SphereUnionMassProperties(unittest.TestCase):
    def test_single_sphere_matches_closed_form(self):
        radius, density, centre = 0.7, 2700.0, np.array([0.3, -0.2, 0.1])
        p = bc.sphereUnionMassProperties([[*centre, radius]], density)
        mass = density * 4.0 / 3.0 * math.pi * radius ** 3
        self.assertLess(abs(p["mass"] / mass - 1), UNION_TOLERANCE)
        self.assertLess(np.linalg.norm(p["centroid"] - centre), UNION_TOLERANCE * radius)
        expected = 0.4 * mass * radius ** 2
        self.assertLess(np.max(np.abs(np.linalg.eigvalsh(p["inertia"]) / expected - 1)), 3 * UNION_TOLERANCE)

    def test_overlapping_pair_counts_the_overlap_once(self):
        radius, distance = 1.0, 1.2
        volume, axial, transverse = two_sphere_closed_form(radius, distance)
        # Sanity of the oracle itself: volume = two spheres minus the lens (two caps of height R - d/2).
        h = radius - distance / 2
        lens = 2 * math.pi * h ** 2 * (3 * radius - h) / 3
        self.assertAlmostEqual(volume, 2 * 4 / 3 * math.pi - lens, places=12)
        rotation = rotation_about([1.0, 2.0, -0.5], 0.8)
        axis = rotation @ np.array([0.0, 0.0, 1.0])
        offset = np.array([0.2, 0.1, -0.3])
        spheres = [[*(offset + 0.5 * distance * axis), radius], [*(offset - 0.5 * distance * axis), radius]]
        p = bc.sphereUnionMassProperties(spheres)
        self.assertLess(abs(p["volume"] / volume - 1), UNION_TOLERANCE)
        self.assertLess(np.linalg.norm(p["centroid"] - offset), UNION_TOLERANCE)
        moments, axes = bc.principalFrame(p["inertia"])
        self.assertLess(abs(moments[0] / axial - 1), 3 * UNION_TOLERANCE)
        self.assertLess(np.max(np.abs(moments[1:] / transverse - 1)), 3 * UNION_TOLERANCE)
        # The long (minimum-inertia) principal axis is the line of centres.
        self.assertGreater(abs(axes[:, 0] @ axis), 1 - 1e-6)

    def test_disjoint_pair_matches_parallel_axis_sum(self):
        radius, distance = 0.5, 3.0
        p = bc.sphereUnionMassProperties([[0, 0, -distance / 2, radius], [0, 0, distance / 2, radius]])
        sphere_volume = 4 / 3 * math.pi * radius ** 3
        transverse = 2 * (0.4 * sphere_volume * radius ** 2 + sphere_volume * (distance / 2) ** 2)
        self.assertLess(abs(p["volume"] / (2 * sphere_volume) - 1), UNION_TOLERANCE)
        self.assertLess(abs(p["inertia"][0, 0] / transverse - 1), 3 * UNION_TOLERANCE)


class PolyhedronAndEnclosingSphere(unittest.TestCase):
    def test_box_mass_properties_are_exact(self):
        corners = np.array([[x, y, z] for x in (0, 2) for y in (0, 1) for z in (0, 3)], float)
        stone = bc.ConvexStone(corners)
        self.assertAlmostEqual(stone.volume, 6.0, places=12)
        np.testing.assert_allclose(stone.centroid, [1.0, 0.5, 1.5], atol=1e-12)
        np.testing.assert_allclose(np.diag(stone.inertia), [6 * 10 / 12, 6 * 13 / 12, 6 * 5 / 12], rtol=1e-12)
        # The square aperture of a 2x1x3 box travelling along its 3-long axis is its larger other side: 2.
        self.assertAlmostEqual(bc.sieveSize(stone), 2.0, places=6)

    def test_enclosing_sphere_is_exact_for_two_and_encloses_many(self):
        centre, radius = bc.enclosingSphere([[0, 0, 0, 1.0], [4, 0, 0, 0.5]])
        np.testing.assert_allclose(centre, [1.75, 0, 0], atol=1e-12)
        self.assertAlmostEqual(radius, 2.75, places=12)
        rng = np.random.default_rng(3)
        for _ in range(50):
            spheres = np.column_stack([rng.normal(size=(12, 3)), rng.uniform(0.1, 0.8, size=12)])
            centre, radius = bc.enclosingSphere(spheres)
            reach = np.linalg.norm(spheres[:, :3] - centre, axis=1) + spheres[:, 3]
            self.assertTrue(np.all(reach <= radius * (1 + 1e-12)))
            # A valid bound cannot be smaller than half the largest outer span.
            spans = np.linalg.norm(spheres[:, None, :3] - spheres[None, :, :3], axis=2) + \
                spheres[:, None, 3] + spheres[None, :, 3]
            self.assertGreaterEqual(radius, 0.5 * spans.max() - 1e-12)


class DilatedPolyhedra(unittest.TestCase):
    """Steiner's measures of a convex stone and the core scale that keeps a dilated stone's volume, against the
    rounded box's volume summed part by part: the box, a slab on each face, a quarter cylinder along each edge and
    an eighth of a ball at each corner."""

    @staticmethod
    def rounded_box_volume(a, b, c, r):
        return (a * b * c + 2 * r * (a * b + b * c + c * a) + math.pi * r * r * (a + b + c)
                + 4.0 / 3.0 * math.pi * r ** 3)

    def test_box_measures_match_the_rounded_box(self):
        a, b, c, r = 2.0, 1.0, 3.0, 0.25
        stone = bc.ConvexStone(np.array([[x, y, z] for x in (0, a) for y in (0, b) for z in (0, c)], float))
        feret, volume, area, curvature = bc.steinerMeasures(stone.vertices, stone.triangles)
        self.assertAlmostEqual(feret, math.sqrt(a * a + b * b + c * c), places=12)
        # the triangulated faces' diagonals are flat edges: they must add no curvature
        steiner = volume + area * r + curvature * r * r + 4.0 / 3.0 * math.pi * r ** 3
        self.assertAlmostEqual(steiner, self.rounded_box_volume(a, b, c, r), places=10)

    def test_core_scale_keeps_the_volume(self):
        a, b, c, r = 2.0, 1.0, 3.0, 0.1
        stone = bc.ConvexStone(np.array([[x, y, z] for x in (0, a) for y in (0, b) for z in (0, c)], float))
        k = bc.dilatedCoreScale(stone.vertices, stone.triangles, r)
        self.assertTrue(0.0 < k < 1.0)
        # bisection to 2^-60 in c: the volume matches to rounding
        self.assertAlmostEqual(self.rounded_box_volume(k * a, k * b, k * c, r), a * b * c, places=10)

    def test_core_scale_refuses_bad_dilations(self):
        stone = bc.ConvexStone(np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float))
        for bad in (0.0, -0.1, float("nan"), float("inf"), 0.7):  # 0.7: a ball of 1.44 outweighs the unit cube
            with self.assertRaises(ValueError):
                bc.dilatedCoreScale(stone.vertices, stone.triangles, bad)


class Quaternions(unittest.TestCase):
    def test_matrix_round_trip_including_half_turns(self):
        """quaternionFromRotation inverts rotationFromQuaternions to rounding, half turns about the axes included (where
        w = 0 and a formula dividing by w fails), with the sign convention w >= 0; the vectorised form matches the
        single one."""
        rng = np.random.default_rng(5)
        turns = [bc.randomRotation(rng) for _ in range(200)]
        turns += [rotation_about(axis, math.pi) for axis in np.eye(3)]
        turns.append(rotation_about([1.0, 1.0, 0.0], math.pi))
        for rotation in turns:
            q = bc.quaternionFromRotation(rotation)
            self.assertAlmostEqual(float(np.linalg.norm(q)), 1.0, places=14)
            self.assertGreaterEqual(q[0], 0.0)
            np.testing.assert_allclose(bc.rotationFromQuaternions(q), rotation, atol=1e-14)
        qs = np.array([bc.quaternionFromRotation(r) for r in turns[:5]])
        np.testing.assert_allclose(bc.rotationFromQuaternions(qs), np.array(turns[:5]), atol=1e-14)
        # a quarter turn about z: (cos 45°, 0, 0, sin 45°)
        np.testing.assert_allclose(bc.quaternionFromRotation(rotation_about([0, 0, 1], math.pi / 2)),
                                   [math.sqrt(0.5), 0, 0, math.sqrt(0.5)], atol=1e-15)


class ClusterConstruction(unittest.TestCase):
    def test_cluster_is_in_principal_axes_and_fills_the_stone(self):
        stone = bc.randomConvexStone(7, (1.0, 0.75, 0.6), 16, 0.12)
        cluster = bc.buildCluster(stone, 10, density=2.0)
        self.assertEqual(len(cluster["spheres"]), 10)
        check = bc.sphereUnionMassProperties(cluster["spheres"], 2.0)
        scale = cluster["enclosingRadius"]
        # Re-integrated in the cluster frame: centre of mass at the origin, inertia diagonal, to the
        # integration accuracy (relative 1e-4 of the size / of the largest moment).
        self.assertLess(np.linalg.norm(check["centroid"]), UNION_TOLERANCE * scale)
        off_diagonal = check["inertia"] - np.diag(np.diag(check["inertia"]))
        self.assertLess(np.max(np.abs(off_diagonal)), UNION_TOLERANCE * cluster["principalInertia"].max())
        np.testing.assert_allclose(np.diag(check["inertia"]), cluster["principalInertia"], rtol=3 * UNION_TOLERANCE)
        self.assertAlmostEqual(check["mass"], cluster["mass"], delta=UNION_TOLERANCE * cluster["mass"])
        # Stated construction accuracy (library: |volume error| <= 17 %, symmetric difference <= 30 % at the
        # coarse level); a broken cover or inflation would miss by far more.
        self.assertLess(abs(cluster["volumeError"]), 0.2)
        self.assertLess(cluster["symmetricDifference"], 0.35)
        self.assertLess(cluster["integrationAccuracy"], 1e-3)
        reach = np.linalg.norm(cluster["spheres"][:, :3] - cluster["enclosingCentre"], axis=1) + \
            cluster["spheres"][:, 3]
        self.assertTrue(np.all(reach <= cluster["enclosingRadius"] * (1 + 1e-12)))


class AngularClusters(unittest.TestCase):
    CUBE = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])

    def test_corner_spheres_of_a_cube_touch_its_three_faces(self):
        # Closed form: the sphere of radius r tangent to the three faces at the corner (±1, ±1, ±1) of the cube
        # [-1, 1]^3 has its centre at (±(1 - r), ±(1 - r), ±(1 - r)).
        spheres = bc.cornerSpheres(bc.ConvexStone(self.CUBE), 0.2)
        self.assertEqual(len(spheres), 8)
        np.testing.assert_allclose(np.sort(np.abs(spheres[:, :3]), axis=0), 0.8 * np.ones((8, 3)), atol=1e-12)
        np.testing.assert_allclose(spheres[:, 3], 0.2, atol=1e-12)
        for bad in (0.0, float("inf"), float("nan"), 2.5):  # 2.5: the corner centres would lie outside the cube
            with self.assertRaises(ValueError):
                bc.cornerSpheres(bc.ConvexStone(self.CUBE), bad)

    def test_corner_sphere_where_four_faces_meet(self):
        # The apex (0, 0, 1) of the square pyramid over [-1, 1]^2 meets four faces, the planes ±x + z = 1 and
        # ±y + z = 1: by symmetry the sphere r inside all four lies on the axis, at z = 1 - r sqrt(2), and touches
        # all four. An asymmetric apex of four faces has no such sphere: the least-squares centre then stands
        # back from some faces, and the sphere still touches its nearest one and stays inside.
        pyramid = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 1]], float)
        stone = bc.ConvexStone(pyramid)
        apex = bc.cornerSpheres(stone, 0.1)[np.argmax(stone.vertices[:, 2])]
        np.testing.assert_allclose(apex, [0.0, 0.0, 1.0 - 0.1 * math.sqrt(2.0), 0.1], atol=1e-12)
        skewed = bc.ConvexStone(np.array([[-1, -1, 0], [1.5, -1, 0], [1, 1.3, 0], [-1, 1, 0], [0.2, -0.1, 1]], float))
        spheres = bc.cornerSpheres(skewed, 0.1)
        depth = skewed.signedDistance(spheres[:, :3])  # the distance to the nearest face
        self.assertTrue(np.all(depth >= spheres[:, 3] - 1e-12))  # inside
        self.assertTrue(np.all(np.isclose(depth, spheres[:, 3], atol=1e-12) | (spheres[:, 3] == 0.1)))  # touching
        self.assertTrue(np.all(spheres[:, 3] > 0.0))

    def test_bad_requests_are_refused(self):
        stone = bc.ConvexStone(self.CUBE)
        with self.assertRaises(ValueError):
            bc.fitAngularCluster(stone, 0, 0.2)
        with self.assertRaises(ValueError):
            bc.buildCluster(stone)  # neither a sphere count nor spheres
        with self.assertRaises(ValueError):
            bc.buildCluster(stone, 4, spheres=np.array([[0.0, 0.0, 0.0, 1.0]]))

    def test_angular_cube_stands_on_four_corners_of_each_face(self):
        # No sphere reaches beyond the surface, and on every face the four corner spheres touch the face's plane:
        # the cluster stands on a square of side 2(1 - r) around the centre of mass, as the cube stands on its face.
        # A common inflation (fitSphereCluster) would make the central sphere the one that touches.
        # The fill is the cube's inscribed sphere (an odd candidate grid has the centre), touching each face's middle.
        stone = bc.ConvexStone(self.CUBE)
        spheres = bc.fitAngularCluster(stone, 1, cornerRadius=0.2, candidateResolution=9, sampleResolution=10)
        self.assertEqual(len(spheres), 9)
        np.testing.assert_allclose(spheres[8], [0.0, 0.0, 0.0, 1.0], atol=1e-12)
        self.assertTrue(np.all(stone.signedDistance(spheres[:, :3]) >= spheres[:, 3] - 1e-12))
        for axis in range(3):
            for sign in (-1.0, 1.0):
                reach = sign * spheres[:8, axis] + spheres[:8, 3]  # the corner spheres' reach towards the face
                touching = spheres[:8][np.abs(reach - 1.0) < 1e-9]
                self.assertEqual(len(touching), 4)
                plane = [k for k in range(3) if k != axis]
                np.testing.assert_allclose(np.abs(touching[:, plane]), 0.8, atol=1e-12)

    def test_library_angular_clusters_stay_inside_their_stones(self):
        for shape in bc.loadShapeLibrary()["shapes"]:
            stone = bc.ConvexStone(shape["vertices"], shape["triangles"])
            cluster = shape["clusters"]["angular"]
            # back to the stone's frame: x_stone = rotation @ x_cluster + centreOfMass
            centres = cluster["spheres"][:, :3] @ cluster["rotation"].T + cluster["centreOfMass"]
            self.assertTrue(np.all(stone.signedDistance(centres) >= cluster["spheres"][:, 3] - 1e-9), shape["name"])
            # one corner sphere per hull vertex, touching its nearest face (its radius is that distance), within
            # 0.08 of a sieve size; the centre sits farther from the vertex the sharper the corner: 0.08 sqrt(3) for
            # three faces at right angles, 0.20 at the library's sharpest (the wedge). A sphere that drifted off its
            # corner would be much farther than 0.25.
            corners = centres[:len(shape["vertices"])]
            radii = cluster["spheres"][:len(shape["vertices"]), 3]
            np.testing.assert_allclose(radii, np.minimum(0.08, stone.signedDistance(corners)), atol=1e-9)
            self.assertLess(np.max(np.linalg.norm(corners - shape["vertices"], axis=1)), 0.25, shape["name"])


class ShapeLibrary(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.library = bc.loadShapeLibrary()

    def test_library_has_six_or_more_closed_stones_with_every_level(self):
        shapes = self.library["shapes"]
        self.assertGreaterEqual(len(shapes), 6)
        for shape in shapes:
            triangles = shape["triangles"]
            edges = {}
            for t in triangles:
                for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                    edges[(a, b)] = edges.get((a, b), 0) + 1
            # Closed, consistently oriented: every directed edge once, and its reverse once.
            self.assertTrue(all(count == 1 and edges.get((b, a)) == 1 for (a, b), count in edges.items()))
            self.assertEqual(len(shape["vertices"]) - len(edges) // 2 + len(triangles), 2)  # Euler, genus 0
            stone = bc.ConvexStone(shape["vertices"], shape["triangles"])
            self.assertAlmostEqual(bc.sieveSize(stone), 1.0, places=6)
            self.assertAlmostEqual(stone.volume, shape["volume"], places=8)
            coarse, fine = shape["clusters"]["coarse"], shape["clusters"]["fine"]
            angular = shape["clusters"]["angular"]
            self.assertTrue(7 <= len(coarse["spheres"]) <= 16, shape["name"])
            self.assertTrue(29 <= len(fine["spheres"]) <= 45, shape["name"])
            self.assertTrue(28 <= len(angular["spheres"]) <= 55, shape["name"])
            for cluster in (coarse, fine, angular):
                quick = bc.sphereUnionMassProperties(cluster["spheres"], columns=200)
                # 200 columns: accuracy ~3e-5 (single-sphere convergence above); 1e-3 catches a stale file.
                self.assertLess(abs(quick["volume"] / cluster["volume"] - 1), 1e-3)
            for cluster in (coarse, fine):  # the angular clusters under-fill the edges: -11 % to -31 %
                self.assertLess(abs(cluster["volumeError"]), 0.2)
            self.assertLess(abs(angular["volumeError"]), 0.35)
            self.assertLess(fine["symmetricDifference"], coarse["symmetricDifference"])

    def test_ballast_sampler_fills_the_volume_with_library_stones(self):
        stones = bc.sampleBallastStones(self.library, np.random.default_rng(5), 0.01)
        volume = sum(s["mass"] for s in stones) / 2700.0
        self.assertGreaterEqual(volume, 0.01)
        for s in stones:
            self.assertTrue(0.0224 <= s["sieveSize"] <= 0.063)
            np.testing.assert_allclose(s["rotation"] @ s["rotation"].T, np.eye(3), atol=1e-12)


class Grading(unittest.TestCase):
    def test_sampled_mass_grading_meets_en13450(self):
        rng = np.random.default_rng(1)
        sizes = bc.sampleSieveSizes(rng, 40000)
        masses = sizes ** 3  # one shape, so mass is proportional to d^3
        report = bc.gradingReport(sizes, masses)
        self.assertTrue(report["compliant"], report)
        # Number sampling reproduces the MASS target: with 40000 stones the sampling error of a passing
        # percentage is about 0.5 % (binomial on mass-weighted counts); 2 % bounds it.
        np.testing.assert_allclose(report["passing"], bc.DEFAULT_TARGET_PASSING, atol=2.0)
        self.assertTrue(np.all((sizes >= 22.4) & (sizes <= 63.0)))

    def test_non_compliant_grading_is_detected(self):
        sizes = np.full(100, 35.0)  # everything between 31.5 and 40 mm: 0 % passes 31.5, 100 % passes 40
        report = bc.gradingReport(sizes, np.ones(100))
        self.assertFalse(report["compliant"])


if __name__ == "__main__":
    unittest.main()
