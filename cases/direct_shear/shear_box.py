"""What both DEM drivers of the direct shear case share (YADE-free): the test's settings from the parameters, the
box's dimensions and the loose column the stones are placed in before they fall into the box (Irazábal 2017
§6.3.2)."""
import numpy as np


def settings(p):
    """(normal stresses [Pa], sieve sizes [mm] times size_scale, passing [%]) of the parameters."""
    stresses = [1e3 * float(s) for s in p["normal_stresses_kPa"].split(",")]
    sieves = np.array([float(s) for s in p["grading_sieves_mm"].split(",")]) * p["size_scale"]
    passing = np.array([float(s) for s in p["grading_passing"].split(",")])
    return stresses, sieves, passing


def dimensions(p):
    """(L, B, H, split height, wall thickness, solid volume [m^3]) of the box. x: the shear, z: up; the inside is
    [0, L] x [0, B] x [0, H], split at z = H/2. The walls reach t beyond the inside, more than the shear distance:
    as the lower half moves by u along x, the top of its end wall covers the gap it opens under the upper half
    (x in [0, u]), the bottom of the upper half's end wall the lower sample that passes under it (x in [L, L + u])."""
    L, B, H = p["box_length"], p["box_width"], p["box_height"]
    t = max(0.05, p["shear_distance"] + 0.01)
    return L, B, H, 0.5 * H, t, L * B * H / (1.0 + p["void_ratio"])


def place(p, reaches, rng):
    """Random sequential placement of the stones' enclosing spheres (radii `reaches` [m]), largest first, in a column
    over the box, without overlap: a loose cloud that settles in a short fall. Returns the centres (n, 3) and the
    column's top [m]. Raises ValueError when a stone cannot be placed."""
    L, B, H = p["box_length"], p["box_width"], p["box_height"]
    if 2.0 * reaches.max() >= min(L, B):
        raise ValueError(f"direct_shear: the largest stone (reach {reaches.max():.3f} m) does not fit across the "
                         f"{L} x {B} m box; size_scale {p['size_scale']} is too large for the box")
    order = np.argsort(-reaches)
    centres = np.zeros((len(reaches), 3))
    top = max(H, 2.2 * reaches.max())
    for count, k in enumerate(order):
        r = reaches[k]
        for attempt in range(4000):
            if attempt and attempt % 200 == 0:
                top *= 1.05
            c = np.array([rng.uniform(r, L - r), rng.uniform(r, B - r), rng.uniform(r, top - r)])
            if count == 0 or np.all(np.linalg.norm(centres[order[:count]] - c, axis=1) >= reaches[order[:count]] + r):
                centres[k] = c
                break
        else:
            raise ValueError(f"direct_shear: cannot place stone {count} of {len(reaches)} (reach {r:.3f} m) in a "
                               f"{L} x {B} m box; size_scale {p['size_scale']} is too large for the box")
    return centres, top
