"""The lateral resistance case's bed (dem.py builds it, case.py measures it). x along the sleeper (the push), y along
the track, z up from the concrete slab; the sleeper's centre at x = y = 0."""
import numpy as np


def crest(p):
    """Height of the ballast surface [m]: crib and shoulder level with the sleeper top, less crest_drop_m."""
    return p["ballast_depth"] + p["sleeper_height"] - p["crest_drop_m"]


def profile_x(p, z):
    """Outer edge of the bed at height z [m] (a number or an array): the crest, then the shoulder slope
    (horizontal : vertical)."""
    shoulder_x = 0.5 * p["sleeper_length"] + p["shoulder_width"]
    return shoulder_x + p["shoulder_slope"] * np.maximum(0.0, crest(p) - np.asarray(z, dtype=float))


def porosities(p, bed, sleeper_z, samples=400000, seed=0):
    """Porosity of a packed bed (rows x, y, z, r) with the sleeper's centre at height sleeper_z, as fractions:
    {"bed": the whole bed, between the slab, the mirror walls, the crest and the slopes, less the sleeper's column (the
    sleeper and the space above it up to the crest, where no grain is rained); "under_sleeper": the layer under the
    sleeper's base, over the sleeper's length and the whole width between the mirror walls; "crib_shoulder":
    everything else, crib and shoulders down to the slab}. Random points (railcosim.track.sampled_porosities; 400,000
    in the box: about 0.2 % sampling error in the smallest region). The walls' and the surface's looser layers count,
    as a packed volume's porosity counts them."""
    from railcosim import track
    top, half_y = crest(p), 0.5 * p["sleeper_spacing"]
    base = sleeper_z - 0.5 * p["sleeper_height"]  # the sleeper's base, on the highest grain under it
    low, high = (-float(profile_x(p, 0.0)), -half_y, 0.0), (float(profile_x(p, 0.0)), half_y, top)

    def in_bed(q):
        sleeper = ((np.abs(q[:, 0]) < 0.5 * p["sleeper_length"]) & (np.abs(q[:, 1]) < 0.5 * p["sleeper_width"]) &
                   (q[:, 2] > base))
        return (np.abs(q[:, 0]) <= profile_x(p, q[:, 2])) & ~sleeper

    under = lambda q: in_bed(q) & (np.abs(q[:, 0]) < 0.5 * p["sleeper_length"]) & (q[:, 2] < base)
    above = lambda q: in_bed(q) & ~((np.abs(q[:, 0]) < 0.5 * p["sleeper_length"]) & (q[:, 2] < base))
    return track.sampled_porosities(bed, low, high, {"bed": in_bed, "under_sleeper": under, "crib_shoulder": above},
                                    samples, seed)
