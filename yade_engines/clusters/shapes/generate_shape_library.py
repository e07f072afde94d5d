#!/usr/bin/python3
"""Generates the ballast shape library: stone surfaces (OBJ + JSON) and two sphere-cluster levels per stone.

USAGE:   /usr/bin/python3 yade_engines/clusters/shapes/generate_shape_library.py [--check]
OUTPUTS: library.json (every stone and cluster) and <name>.obj (stone surfaces) next to this script.
         --check regenerates into memory and fails if library.json differs (reproducibility check).

Each stone is the convex hull of random points near an ellipsoid (fixed seeds), moved to its centroid and
principal axes (x = long axis) and scaled to unit sieve size (smallest square aperture, see
ballast_clusters.sieveSize). Cluster levels follow the thesis (Irazábal 2017 §5.3.4): "coarse" 7-16 and
"fine" 29-45 spheres per stone; "angular" puts a small sphere in every corner of the stone and fills the rest with
inscribed spheres, growing none (28-55 spheres), so that nothing bulges out of a face and the cluster tips over small
corners as the stone does. Runtime: about one minute.
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import ballast_clusters as bc  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))

# name, seed, ellipsoid semi-axes (L, I, S ratios), hull points, radial jitter, coarse and fine sphere counts.
# Few hull points and large jitter give sharp, crushed-rock angularity; more points give sub-angular stones.
# Ratios span the ballast range: elongation I/L 0.6-0.9, flatness S/I 0.55-0.9 (one flaky-leaning stone).
SHAPES = [
    ("blocky_a", 11, (1.00, 0.85, 0.72), 16, 0.12, 10, 32),
    ("blocky_b", 12, (1.00, 0.90, 0.80), 22, 0.10, 8, 30),
    ("elongated", 13, (1.00, 0.62, 0.50), 18, 0.12, 14, 42),
    ("flat", 14, (1.00, 0.80, 0.45), 18, 0.12, 13, 40),
    ("wedge", 20, (1.00, 0.85, 0.60), 10, 0.20, 12, 36),
    ("tetrahedral", 16, (1.00, 0.80, 0.70), 8, 0.15, 11, 34),
    ("subangular", 17, (1.00, 0.80, 0.65), 40, 0.06, 12, 38),
    ("prismatic", 18, (1.00, 0.70, 0.60), 12, 0.18, 15, 45),
]


# The "angular" level: a sphere of at most this radius (in sieve sizes) in every corner of the hull, and ANGULAR_FILL
# inscribed spheres filling the rest (ballast_clusters.fitAngularCluster): 28-55 spheres per stone.
ANGULAR_CORNER_RADIUS = 0.08
ANGULAR_FILL = 20


def round_nested(value, digits=10):
    if isinstance(value, float):
        return round(value, digits)
    if isinstance(value, (list, tuple)):
        return [round_nested(v, digits) for v in value]
    if isinstance(value, dict):
        return {k: round_nested(v, digits) for k, v in value.items()}
    return value


def to_plain(value):
    if isinstance(value, np.ndarray):
        return to_plain(value.tolist())
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, dict):
        return {k: to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    return value


def build_library():
    shapes = []
    for name, seed, semi_axes, points, jitter, coarse, fine in SHAPES:
        raw = bc.randomConvexStone(seed, semi_axes, points, jitter)
        _, axes = bc.principalFrame(raw.inertia)
        # principalFrame sorts moments ascending: the first axis (smallest moment) is the long axis.
        stone = raw.transformed(axes, raw.centroid)
        stone = stone.scaled(1.0 / bc.sieveSize(stone))
        dimensions = bc.principalDimensions(stone)
        entry = {
            "name": name,
            "seed": seed,
            "vertices": stone.vertices,
            "triangles": stone.triangles,
            "volume": stone.volume,
            "principalInertia": np.diag(stone.inertia),  # unit density, principal axes by construction
            "dimensions": dimensions,  # L, I, S at unit sieve size
            "elongation": dimensions[1] / dimensions[0],
            "flatness": dimensions[2] / dimensions[1],
            "sieveSize": bc.sieveSize(stone),
            "clusters": {},
        }
        for level, count in (("coarse", coarse), ("fine", fine)):
            cluster = bc.buildCluster(stone, count)
            cluster.pop("density")
            entry["clusters"][level] = cluster
        angular = bc.fitAngularCluster(stone, ANGULAR_FILL, ANGULAR_CORNER_RADIUS)
        entry["clusters"]["angular"] = bc.buildCluster(stone, spheres=angular)
        entry["clusters"]["angular"].pop("density")
        shapes.append(entry)
    return {
        "description": "railcosim ballast shape library: convex stone surfaces at unit sieve size in principal "
                       "axes, and sphere clusters (coarse 7-16, fine 29-45 spheres; angular: corner spheres and "
                       "inscribed fill, 28-55 spheres) in the principal axes of "
                       "their sphere union, at unit density. Scale lengths by the sieve size d, masses by "
                       "density*d^3, inertia by density*d^5. Generated by generate_shape_library.py.",
        "units": "lengths in sieve sizes; volume, mass, inertia at unit density",
        "shapes": shapes,
    }


def write_obj(path, stone):
    with open(path, "w") as handle:
        handle.write("# railcosim ballast stone %s: unit sieve size, principal axes, outward triangles\n"
                     % stone["name"])
        for v in stone["vertices"]:
            handle.write("v %.10f %.10f %.10f\n" % tuple(v))
        for t in stone["triangles"]:
            handle.write("f %d %d %d\n" % tuple(np.asarray(t) + 1))


def main():
    library = round_nested(to_plain(build_library()))
    text = json.dumps(library, indent=1, sort_keys=True) + "\n"
    target = os.path.join(HERE, "library.json")
    if "--check" in sys.argv:
        with open(target) as handle:
            stored = handle.read()
        if stored != text:
            sys.exit("library.json differs from a fresh generation: regenerate it with this script")
        print("library.json is reproducible")
        return
    with open(target, "w") as handle:
        handle.write(text)
    for shape in library["shapes"]:
        write_obj(os.path.join(HERE, shape["name"] + ".obj"), shape)
    for shape in library["shapes"]:
        clusters = shape["clusters"]
        print("%-12s L:I:S = 1 : %.2f : %.2f  " % (shape["name"], shape["dimensions"][1] / shape["dimensions"][0],
                                                  shape["dimensions"][2] / shape["dimensions"][0])
              + "  ".join("%s %2d spheres volume error %+.1f%% (sym. diff %.1f%%)"
                          % (level, clusters[level]["sphereCount"], 100 * clusters[level]["volumeError"],
                             100 * clusters[level]["symmetricDifference"]) for level in ("coarse", "fine", "angular")))


if __name__ == "__main__":
    main()
