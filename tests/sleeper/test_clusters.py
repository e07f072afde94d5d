"""The sleeper case's clusters (cases/sleeper_on_ballast/scene.py, particle_shape = "cluster") without YADE: every
library cluster, at the scale the case gives it, lies inside the dilated polyhedron of its stone, so that a bed of
polyhedra whose stones do not overlap becomes a bed of clusters that do not either."""
import os
import sys
import unittest

import numpy as np
from scipy.optimize import nnls

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "cases", "sleeper_on_ballast"))
import scene as sc  # noqa: E402  (puts the shape library on the path)
import ballast_clusters  # noqa: E402

FRACTIONS = (0.05, 0.1, 0.25)  # dilation_fraction: a thin, the case's, and the largest allowed (case.toml limits)


def distance_to_hull(point, vertices):
    """Euclidean distance from `point` to the convex hull of `vertices`: min |V^T l - p| over l >= 0, sum l = 1, by
    non-negative least squares with the sum as a heavily weighted row (Lawson & Hanson 1974, ch. 23)."""
    weight = 1e6
    weights, _ = nnls(np.vstack([vertices.T, weight * np.ones(len(vertices))]), np.concatenate([point, [weight]]))
    return float(np.linalg.norm(vertices.T @ weights - point))


class ContainmentTest(unittest.TestCase):
    def test_members_inside_the_dilated_polyhedron(self):
        """Points on every member's surface (the 6 axis directions and 194 random ones, in the stone's frame) lie
        within r_d of the core: inside it (every face plane) or at a distance (to the hull of its vertices) of at most
        r_d. The case fits the scale with the exact criterion for whole balls, this samples their surfaces. Tolerance:
        the case's bisection tolerance (1e-6 of the size) plus round-off."""
        rng = np.random.default_rng(7)
        directions = np.vstack([np.eye(3), -np.eye(3), rng.normal(size=(194, 3))])
        directions /= np.linalg.norm(directions, axis=1)[:, None]
        for level in ("coarse", "fine"):
            for fraction in FRACTIONS:
                scene = {"dilation_fraction": fraction, "material": {"density": 1.0}, "triangles_per_stone": 0}
                for shape, stone in enumerate(sc.library()):
                    core, dilation = sc.stone_core(scene, shape, 1.0)
                    polytope = ballast_clusters.ConvexStone(core, stone["triangles"])
                    spheres, _, _ = sc.cluster_of(scene, level, shape, 1.0)
                    points = (spheres[:, None, :3] + spheres[:, None, 3:4] * directions[None]).reshape(-1, 3)
                    outside = points[polytope.signedDistance(points) < 0]
                    worst = max([distance_to_hull(q, core) for q in outside], default=0.0)
                    with self.subTest(level=level, fraction=fraction, shape=stone["name"]):
                        self.assertLessEqual(worst - dilation, 2e-6)

    def test_clusters_keep_the_stone_size(self):
        """At the case's dilation (0.1) the clusters keep the size of their stone's hull to within 2 %: the library's
        clusters are fitted inside the stones (ballast_clusters: maximal inscribed spheres, inflated), so they need
        little shrinking to fit the polyhedra's rounded corners."""
        scene = {"dilation_fraction": 0.1, "material": {"density": 1.0}, "triangles_per_stone": 0}
        for level in ("coarse", "fine"):
            for shape, stone in enumerate(sc.library()):
                spheres, _, _ = sc.cluster_of(scene, level, shape, 1.0)
                unscaled = np.asarray(stone["clusters"][level]["spheres"]) / stone["feret"]
                with self.subTest(level=level, shape=stone["name"]):
                    self.assertGreaterEqual(float(spheres[0, 3] / unscaled[0, 3]), 0.98)


if __name__ == "__main__":
    unittest.main()
