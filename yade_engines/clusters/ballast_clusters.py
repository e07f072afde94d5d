"""Ballast stones as convex polyhedra and as rigid sphere clusters (Irazábal 2017 §5.3.4–5.3.5), plus EN 13450 grading.

Plain numpy/scipy (Debian python3-numpy, python3-scipy), so it runs under /usr/bin/python3 and inside YADE.

Pipeline (Irazábal 2017 §5.9, with a mesh-free integration instead of a tetrahedral mesh):
  stone surface (closed convex triangle mesh) -> greedy maximal-inscribed-sphere cover of the requested size
  -> common radius inflation that minimises the symmetric-difference volume with the stone
  -> exact-in-z column integration of the sphere union (overlaps counted once): volume, centre of mass,
     inertia -> spheres expressed in principal axes -> enclosing sphere (eqs. 5.58-5.63, corrected).
The angular construction (fitAngularCluster) puts a sphere in every corner before the greedy cover and leaves out
the inflation.

Units: whatever the caller uses (the shape library is stored at unit sieve size, see sieveSize()).
"""

import json
import math
import os

import numpy as np
from scipy.spatial import ConvexHull

# --------------------------------------------------------------------------------------------------
# Convex stone surfaces
# --------------------------------------------------------------------------------------------------


def steinerMeasures(vertices, triangles):
    """Feret diameter (largest vertex distance), volume, area and integral of mean curvature of a convex core:
    the Steiner formula V(r) = V + A r + M r^2 + 4/3 pi r^3 gives the dilated volume (Ullrich 2022 eq. 2.5),
    with M = 1/2 sum over edges of length x exterior dihedral angle."""
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, int)
    feret = max(float(np.max(np.linalg.norm(v - p, axis=1))) for p in v)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * float(np.sum(np.linalg.norm(cross, axis=1)))
    normals = cross / np.linalg.norm(cross, axis=1)[:, None]
    volume = float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0
    faces_of_edge = {}
    for face, tri in enumerate(t):
        for k in range(3):
            edge = tuple(sorted((tri[k], tri[(k + 1) % 3])))
            faces_of_edge.setdefault(edge, []).append(face)
    curvature = 0.0
    for (i, j), faces in faces_of_edge.items():
        if len(faces) == 2:
            cosine = float(np.clip(np.dot(normals[faces[0]], normals[faces[1]]), -1.0, 1.0))
            curvature += 0.5 * np.linalg.norm(v[i] - v[j]) * math.acos(cosine)
    return feret, abs(volume), area, curvature


def dilatedCoreScale(vertices, triangles, relativeDilation):
    """c such that the convex stone (vertices, triangles) scaled by c about the origin and dilated by a ball of radius
    relativeDilation has the stone's own volume: the root in (0, 1) of V c^3 + A c^2 r + M c r^2 + 4/3 pi r^3 = V
    (Steiner's formula, steinerMeasures), found by bisection since the left side grows with c. The stone's units are
    the dilation's (the shape library: unit sieve size)."""
    _, volume, area, curvature = steinerMeasures(vertices, triangles)
    r = float(relativeDilation)
    if not r > 0.0 or not math.isfinite(r):
        raise ValueError("dilatedCoreScale: the dilation must be positive and finite, got %r" % relativeDilation)
    if 4.0 / 3.0 * math.pi * r ** 3 >= volume:
        raise ValueError("dilatedCoreScale: a ball of radius %g alone has at least the stone's volume %g: no core is "
                         "left" % (r, volume))
    low, high = 0.0, 1.0
    for _ in range(60):  # 2^-60: the double's resolution of c
        c = 0.5 * (low + high)
        if volume * c ** 3 + area * c * c * r + curvature * c * r * r + 4.0 / 3.0 * math.pi * r ** 3 > volume:
            high = c
        else:
            low = c
    return low


class ConvexStone:
    """A closed convex triangulated surface: vertices (n,3), outward-oriented triangles (m,3), face planes."""

    def __init__(self, vertices, triangles=None):
        vertices = np.asarray(vertices, dtype=float)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) < 4:
            raise ValueError("ConvexStone: need an (n, 3) vertex array with n >= 4, got shape %s" % (vertices.shape,))
        hull = ConvexHull(vertices)
        if triangles is None:
            # Keep only hull vertices and re-index, so interior points of the input never reach the mesh.
            used = np.unique(hull.simplices)
            remap = -np.ones(len(vertices), dtype=int)
            remap[used] = np.arange(len(used))
            vertices = vertices[used]
            triangles = remap[hull.simplices]
            hull = ConvexHull(vertices)
            triangles = hull.simplices
        triangles = np.asarray(triangles, dtype=int)
        self.vertices = vertices
        self.triangles = _orientOutward(vertices, triangles)
        # Facet planes n.x <= d; qhull merges coplanar triangles' planes to round-off, duplicates are harmless.
        self.planeNormals = hull.equations[:, :3]
        self.planeOffsets = -hull.equations[:, 3]
        properties = polyhedronMassProperties(self.vertices, self.triangles)
        self.volume = properties["volume"]
        self.centroid = properties["centroid"]
        self.inertia = properties["inertia"]

    def signedDistance(self, points):
        """Distance to the surface, positive inside (exact inside a convex body, a lower bound outside)."""
        points = np.atleast_2d(points)
        return np.min(self.planeOffsets[None, :] - points @ self.planeNormals.T, axis=1)

    def boundingBox(self):
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def transformed(self, rotation, translation):
        """Stone with vertices R (x - t): rotation columns are the new axes expressed in the old frame."""
        return ConvexStone((self.vertices - translation) @ rotation, self.triangles)

    def scaled(self, factor):
        return ConvexStone(self.vertices * factor, self.triangles)


def _orientOutward(vertices, triangles):
    centre = vertices.mean(axis=0)
    a, b, c = vertices[triangles[:, 0]], vertices[triangles[:, 1]], vertices[triangles[:, 2]]
    normals = np.cross(b - a, c - a)
    inward = np.einsum("ij,ij->i", normals, a - centre) < 0.0
    oriented = triangles.copy()
    oriented[inward] = oriented[inward][:, [0, 2, 1]]
    return oriented


def polyhedronMassProperties(vertices, triangles):
    """Exact volume, centroid and inertia tensor (unit density, about the centroid) of a closed polyhedron.

    Sum over signed tetrahedra (origin, a, b, c): the second-moment tensor of a tetrahedron with one vertex at
    the origin is det(A)/120 * A (J + 1) A^T with A = [a b c] (columns), J the all-ones matrix.
    """
    a, b, c = vertices[triangles[:, 0]], vertices[triangles[:, 1]], vertices[triangles[:, 2]]
    determinants = np.einsum("ij,ij->i", a, np.cross(b, c))
    volume = determinants.sum() / 6.0
    if not volume > 0.0:
        raise ValueError("polyhedronMassProperties: non-positive volume %g; the surface must be closed and "
                         "outward oriented" % volume)
    centroid = (determinants[:, None] * (a + b + c)).sum(axis=0) / (24.0 * volume)
    matrices = np.stack([a, b, c], axis=2)  # (m, 3, 3), columns a, b, c
    canonical = np.ones((3, 3)) + np.eye(3)
    second = np.einsum("m,mij,jk,mlk->il", determinants, matrices, canonical, matrices) / 120.0
    second -= volume * np.outer(centroid, centroid)  # move to the centroid (parallel axis)
    inertia = np.trace(second) * np.eye(3) - second
    return {"volume": volume, "centroid": centroid, "inertia": inertia}


def principalFrame(inertia):
    """Principal moments (ascending) and a proper rotation whose columns are the principal axes."""
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    # Fix the sign of each axis deterministically (largest component positive) so data files are reproducible.
    for k in range(2):
        if axes[np.argmax(np.abs(axes[:, k])), k] < 0.0:
            axes[:, k] = -axes[:, k]
            axes[:, 2] = -axes[:, 2]
    return moments, axes


def sieveSize(stone, angleCount=180):
    """Smallest square aperture the stone passes through when it travels along its long (minimum-inertia) axis.

    The cross-section is the projection on the plane of the two other principal axes; the aperture is the
    smallest side of a square enclosing it, minimised over the square's rotation (1/angleCount of 90°).
    """
    _, axes = principalFrame(stone.inertia)
    projected = (stone.vertices - stone.centroid) @ axes[:, 1:]
    best = math.inf
    for angle in np.linspace(0.0, 0.5 * math.pi, angleCount, endpoint=False):
        u = np.array([math.cos(angle), math.sin(angle)])
        v = np.array([-math.sin(angle), math.cos(angle)])
        side = max(np.ptp(projected @ u), np.ptp(projected @ v))
        best = min(best, side)
    return best


def principalDimensions(stone):
    """Extents (L >= I >= S) of the stone along its principal axes."""
    _, axes = principalFrame(stone.inertia)
    extents = np.ptp((stone.vertices - stone.centroid) @ axes, axis=0)
    return np.sort(extents)[::-1]


def randomConvexStone(seed, semiAxes, pointCount, radialJitter):
    """Hull of random points near an ellipsoid: an angular, crushed-rock-like convex polyhedron.

    Directions are uniform on the sphere, radii jittered by +-radialJitter (relative), axes scaled by semiAxes.
    """
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(pointCount, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    radii = 1.0 + radialJitter * rng.uniform(-1.0, 1.0, size=pointCount)
    return ConvexStone(directions * radii[:, None] * np.asarray(semiAxes, dtype=float)[None, :])


# --------------------------------------------------------------------------------------------------
# Mass properties of a union of spheres (overlaps counted once)
# --------------------------------------------------------------------------------------------------


def sphereUnionMassProperties(spheres, density=1.0, columns=400, chunkRows=40):
    """Volume, mass, centroid and inertia tensor (about the centroid) of the union of spheres.

    Integrates over an n x n grid of columns parallel to z (midpoint rule in x and y). Along each column the
    union of the spheres' chords is formed exactly (sorted sweep) and 1, z, z^2 are integrated in closed form,
    so only the two transverse directions are discretised. Accuracy: relative error below 1e-4 in volume and
    principal inertia for columns = 400 (checked against one- and two-sphere closed forms in the tests).
    """
    spheres = np.asarray(spheres, dtype=float)
    centres, radii = spheres[:, :3], spheres[:, 3]
    if np.any(radii <= 0.0):
        raise ValueError("sphereUnionMassProperties: every radius must be positive, got %s" % radii)
    lower = (centres - radii[:, None]).min(axis=0)
    upper = (centres + radii[:, None]).max(axis=0)
    hx = (upper[0] - lower[0]) / columns
    hy = (upper[1] - lower[1]) / columns
    xs = lower[0] + hx * (np.arange(columns) + 0.5)
    ys = lower[1] + hy * (np.arange(columns) + 0.5)
    far = 1e30  # empty chords sit at +far, sort last and add nothing (far^k - far^k == 0 exactly)
    totals = np.zeros(10)  # V, Sx, Sy, Sz, Sxx, Syy, Szz, Sxy, Sxz, Syz
    for start in range(0, columns, chunkRows):
        x = xs[start:start + chunkRows]
        X, Y = np.meshgrid(x, ys, indexing="ij")
        X = X.ravel()
        Y = Y.ravel()
        halfChordSquared = radii[None, :] ** 2 - (X[:, None] - centres[None, :, 0]) ** 2 - \
            (Y[:, None] - centres[None, :, 1]) ** 2
        hit = halfChordSquared > 0.0
        halfChord = np.sqrt(np.where(hit, halfChordSquared, 0.0))
        low = np.where(hit, centres[None, :, 2] - halfChord, far)
        high = np.where(hit, centres[None, :, 2] + halfChord, far)
        order = np.argsort(low, axis=1)
        low = np.take_along_axis(low, order, axis=1)
        high = np.take_along_axis(high, order, axis=1)
        # Intervals sorted by start: the new part of interval k is [max(a_k, M), max(b_k, M)], M = max end so far.
        runningEnd = np.maximum.accumulate(high, axis=1)
        previousEnd = np.concatenate([np.full((len(X), 1), -far), runningEnd[:, :-1]], axis=1)
        segmentLow = np.maximum(low, previousEnd)
        segmentHigh = np.maximum(high, previousEnd)
        length = (segmentHigh - segmentLow).sum(axis=1)
        firstMoment = 0.5 * (segmentHigh ** 2 - segmentLow ** 2).sum(axis=1)
        secondMoment = ((segmentHigh ** 3 - segmentLow ** 3) / 3.0).sum(axis=1)
        totals += np.array([length.sum(), (X * length).sum(), (Y * length).sum(), firstMoment.sum(),
                            (X * X * length).sum(), (Y * Y * length).sum(), secondMoment.sum(),
                            (X * Y * length).sum(), (X * firstMoment).sum(), (Y * firstMoment).sum()])
    totals *= hx * hy
    volume = totals[0]
    centroid = totals[1:4] / volume
    second = np.array([[totals[4], totals[7], totals[8]],
                       [totals[7], totals[5], totals[9]],
                       [totals[8], totals[9], totals[6]]])
    second -= volume * np.outer(centroid, centroid)
    inertia = density * (np.trace(second) * np.eye(3) - second)
    return {"volume": volume, "mass": density * volume, "centroid": centroid, "inertia": inertia}


# --------------------------------------------------------------------------------------------------
# Enclosing sphere (Irazábal 2017 eqs. 5.58-5.63 with corrected indices)
# --------------------------------------------------------------------------------------------------


def enclosingSphere(spheres):
    """Centre and radius of a sphere enclosing every sphere of the cluster (valid, not always minimal).

    Start from the two spheres whose outer points are farthest apart (5.58-5.61); if a sphere still sticks
    out, move the centre towards its outer point by the current radius (5.62-5.63) and take the radius to the
    farthest cluster point, which encloses all spheres by construction.
    """
    spheres = np.asarray(spheres, dtype=float)
    centres, radii = spheres[:, :3], spheres[:, 3]
    if len(spheres) == 1:
        return centres[0].copy(), float(radii[0])
    separation = np.linalg.norm(centres[:, None, :] - centres[None, :, :], axis=2)
    spans = separation + radii[:, None] + radii[None, :]
    np.fill_diagonal(spans, -1.0)
    i, j = np.unravel_index(np.argmax(spans), spans.shape)
    direction = centres[i] - centres[j]
    length = np.linalg.norm(direction)
    unit = direction / length if length > 0.0 else np.array([1.0, 0.0, 0.0])
    outerI = centres[i] + radii[i] * unit
    outerJ = centres[j] - radii[j] * unit
    centre = 0.5 * (outerI + outerJ)
    radius = 0.5 * np.linalg.norm(outerI - outerJ)
    reach = np.linalg.norm(centres - centre, axis=1) + radii
    k = int(np.argmax(reach))
    if reach[k] > radius * (1.0 + 1e-12):
        offset = centres[k] - centre
        outer = centres[k] + radii[k] * offset / np.linalg.norm(offset)
        towardsCentre = centre - outer
        centre = outer + radius * towardsCentre / np.linalg.norm(towardsCentre)
    radius = float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))
    return centre, radius


# --------------------------------------------------------------------------------------------------
# Sphere-cluster construction
# --------------------------------------------------------------------------------------------------


def _gridInside(stone, count):
    lower, upper = stone.boundingBox()
    spacing = np.max(upper - lower) / count
    axes = [np.arange(lower[k] + 0.5 * spacing, upper[k], spacing) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return grid, spacing


def _inscribedCover(stone, sphereCount, candidateResolution, sampleResolution, given=None):
    """Greedy cover of the stone's interior by maximal inscribed spheres: candidates on a grid inside the stone, each
    with its inscribed radius; repeatedly the one covering the most still-uncovered interior sample points (the
    reduced-Hubbard idea of covering the medial region, without the medial-axis mesh). Sample points inside `given`
    spheres (k, 4) count as covered from the start. Returns centres (n, 3) and radii (n,)."""
    grid, _ = _gridInside(stone, candidateResolution)
    depth = stone.signedDistance(grid)
    candidates = grid[depth > 0.0]
    candidateRadii = depth[depth > 0.0]
    samplesAll, _ = _gridInside(stone, sampleResolution)
    samples = samplesAll[stone.signedDistance(samplesAll) > 0.0]
    covers = np.zeros((len(candidates), len(samples)), dtype=np.float32)
    for start in range(0, len(candidates), 256):
        block = slice(start, start + 256)
        distance = np.linalg.norm(candidates[block, None, :] - samples[None, :, :], axis=2)
        covers[block] = distance <= candidateRadii[block, None]
    uncovered = np.ones(len(samples), dtype=np.float32)
    for sphere in ([] if given is None else given):
        uncovered[np.linalg.norm(samples - sphere[:3], axis=1) <= sphere[3]] = 0.0
    chosen = []
    for _ in range(sphereCount):
        gain = covers @ uncovered
        if chosen:
            gain[chosen] = -1.0
        best = int(np.argmax(gain))
        if gain[best] <= 0.0:
            # Everything already covered at this sampling: add the largest remaining sphere instead.
            remaining = np.setdiff1d(np.arange(len(candidates)), chosen)
            best = int(remaining[np.argmax(candidateRadii[remaining])])
        chosen.append(best)
        uncovered *= 1.0 - covers[best]
    return candidates[chosen], candidateRadii[chosen]


def fitSphereCluster(stone, sphereCount, candidateResolution=24, sampleResolution=40):
    """Spheres (k, 4: x, y, z, r) that fill a convex stone, in the stone's frame.

    1. Candidates: grid points inside the stone, each carrying its maximal inscribed sphere.
    2. Greedy cover: repeatedly add the candidate sphere that covers the most still-uncovered interior
       sample points (the reduced-Hubbard idea of covering the medial region, without the medial-axis mesh).
    3. All radii are multiplied by the factor s >= 1 that minimises the symmetric-difference volume between
       the stone and the union; inscribed spheres alone under-fill the corners of an angular stone.
    Deterministic: fixed grids and first-index tie breaking.
    """
    if sphereCount < 1:
        raise ValueError("fitSphereCluster: sphereCount must be >= 1, got %d" % sphereCount)
    centres, radii = _inscribedCover(stone, sphereCount, candidateResolution, sampleResolution)

    # Inflation factor: symmetric difference on a grid over the stone's box widened by the largest radius.
    lower, upper = stone.boundingBox()
    margin = radii.max()
    spacing = np.max(upper - lower + 2 * margin) / sampleResolution
    axes = [np.arange(lower[k] - margin + 0.5 * spacing, upper[k] + margin, spacing) for k in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = stone.signedDistance(points) > 0.0
    ratio = np.full(len(points), np.inf)
    for centre, radius in zip(centres, radii):
        ratio = np.minimum(ratio, np.linalg.norm(points - centre, axis=1) / radius)
    best, bestError = 1.0, math.inf
    for factor in np.linspace(1.0, 1.6, 121):
        covered = ratio <= factor
        error = np.count_nonzero(covered != inside)
        if error < bestError:
            best, bestError = factor, error
    return np.column_stack([centres, radii * best])


def cornerSpheres(stone, radius):
    """One sphere (k, 4) per hull vertex, its centre `radius` inside the face planes through the vertex: exactly where
    three faces meet, in the least-squares sense where more do (no sphere touches four general planes). Its radius is
    the distance from that centre to the nearest face, at most `radius`: every corner sphere touches a face near its
    corner, and none reaches beyond the surface."""
    if not (math.isfinite(radius) and radius > 0.0):
        raise ValueError("cornerSpheres: the corner radius must be positive and finite, got %r" % (radius,))
    v, t = stone.vertices, stone.triangles
    normals = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    spheres = []
    for i in range(len(v)):
        faces = np.unique(np.round(normals[(t == i).any(axis=1)], 9), axis=0)  # coplanar triangles: one face
        # n_f . (c - v_i) = -radius for every face through the vertex
        centre = v[i] + np.linalg.lstsq(faces, -radius * np.ones(len(faces)), rcond=None)[0]
        spheres.append([*centre, min(radius, stone.signedDistance(centre)[0])])
    spheres = np.array(spheres)
    if np.any(spheres[:, 3] <= 0.0):
        raise ValueError("cornerSpheres: a corner radius of %g leaves some corner centres outside the stone; take a "
                         "smaller one" % radius)
    return spheres


def fitAngularCluster(stone, fillCount, cornerRadius, candidateResolution=24, sampleResolution=40):
    """Spheres (k, 4) for an angular stone: the corner spheres (cornerSpheres) and `fillCount` >= 1 maximal inscribed
    spheres covering the rest of the interior (fitSphereCluster's greedy cover), none grown beyond the surface.

    fitSphereCluster's common inflation makes the largest sphere bulge furthest beyond the faces it touches and rounds
    the corners with large spheres: such clusters rock on that sphere and roll over their corners where the stone lies
    still (cases/angle_of_repose/README.md). Here nothing bulges, and the corners are small spheres at the stone's
    extremities, over which the cluster tips as the stone does. Where more than three faces meet, the corner sphere
    stands back from some of them, so a face rests on fewer points than it has corners. The price is volume: the union
    under-fills the edges between the corners.
    """
    if fillCount < 1:
        raise ValueError("fitAngularCluster: fillCount must be >= 1, got %d" % fillCount)
    corners = cornerSpheres(stone, cornerRadius)
    centres, radii = _inscribedCover(stone, fillCount, candidateResolution, sampleResolution, given=corners)
    return np.vstack([corners, np.column_stack([centres, radii])])


def buildCluster(stone, sphereCount=None, density=1.0, columns=400, spheres=None):
    """A sphere cluster for `stone` with its mass properties, in the principal axes of the sphere union: of
    fitSphereCluster(stone, sphereCount), or of the given `spheres` (k, 4) in the stone's frame (fitAngularCluster).

    Returns a dict: spheres (k, 4) in principal axes about the centre of mass; mass, volume, principal inertia
    (ascending, density-weighted); rotation (columns = principal axes in the stone frame) and centreOfMass
    (stone frame), so that x_stone = rotation @ x_cluster + centreOfMass; volumeError =
    (V_union - V_stone)/V_stone; symmetricDifference = |stone xor union| / V_stone; enclosing sphere;
    integrationAccuracy = largest relative change of volume and principal moments between `columns` and
    columns/2 (an estimate of the column-integration error at `columns`, conservative for a convergent rule).
    """
    if (sphereCount is None) == (spheres is None):
        raise ValueError("buildCluster: give either sphereCount (fitSphereCluster) or spheres, not both or neither")
    if spheres is None:
        spheres = fitSphereCluster(stone, sphereCount)
    spheres = np.asarray(spheres, dtype=float)
    properties = sphereUnionMassProperties(spheres, density, columns)
    coarse = sphereUnionMassProperties(spheres, density, columns // 2)
    moments, rotation = principalFrame(properties["inertia"])
    coarseMoments, _ = principalFrame(coarse["inertia"])
    accuracy = max(abs(coarse["volume"] / properties["volume"] - 1.0),
                   float(np.max(np.abs(coarseMoments / moments - 1.0))))
    centreOfMass = properties["centroid"]
    principalSpheres = np.column_stack([(spheres[:, :3] - centreOfMass) @ rotation, spheres[:, 3]])
    symmetricDifference = _symmetricDifference(stone, spheres)
    boundCentre, boundRadius = enclosingSphere(principalSpheres)
    return {
        "sphereCount": len(spheres),
        "spheres": principalSpheres,
        "density": density,
        "mass": properties["mass"],
        "volume": properties["volume"],
        "principalInertia": moments,
        "rotation": rotation,
        "centreOfMass": centreOfMass,
        "stoneVolume": stone.volume,
        "volumeError": properties["volume"] / stone.volume - 1.0,
        "symmetricDifference": symmetricDifference,
        "enclosingCentre": boundCentre,
        "enclosingRadius": boundRadius,
        "integrationAccuracy": accuracy,
    }


def _symmetricDifference(stone, spheres, resolution=60):
    lower, upper = stone.boundingBox()
    lower = np.minimum(lower, (spheres[:, :3] - spheres[:, 3:]).min(axis=0))
    upper = np.maximum(upper, (spheres[:, :3] + spheres[:, 3:]).max(axis=0))
    spacing = np.max(upper - lower) / resolution
    axes = [np.arange(lower[k] + 0.5 * spacing, upper[k], spacing) for k in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = stone.signedDistance(points) > 0.0
    covered = np.zeros(len(points), dtype=bool)
    for sphere in spheres:
        covered |= np.linalg.norm(points - sphere[:3], axis=1) <= sphere[3]
    return np.count_nonzero(inside != covered) * spacing ** 3 / stone.volume


# --------------------------------------------------------------------------------------------------
# EN 13450 grading (Irazábal 2017 Table 2.1): cumulative mass % passing, 22.4-63 mm
# --------------------------------------------------------------------------------------------------

EN13450_SIEVES_MM = np.array([22.4, 31.5, 40.0, 50.0, 63.0])
EN13450_PASSING_MIN = np.array([0.0, 0.0, 30.0, 70.0, 100.0])
EN13450_PASSING_MAX = np.array([3.0, 25.0, 65.0, 100.0, 100.0])
EN13450_MIN_FRACTION_32_50 = 50.0  # mass % retained between the 32 and 50 mm sieves

# Default target: the middle of each band, with nothing below 22.4 mm (the sampler draws within 22.4-63 mm).
DEFAULT_TARGET_PASSING = np.array([0.0, 12.5, 47.5, 85.0, 100.0])


def _passingAt(sizeMillimetres, sieves, passing):
    """Cumulative % passing, interpolated linearly in log(size) between sieves."""
    return np.interp(np.log(sizeMillimetres), np.log(sieves), passing)


def sampleSieveSizes(rng, count, targetPassing=DEFAULT_TARGET_PASSING, sieves=EN13450_SIEVES_MM):
    """`count` stone sieve sizes [mm] whose MASS distribution follows the target grading curve.

    Stones are drawn by number, so the number density is the mass density divided by the stone mass (∝ d³):
    p_n(d) ∝ (dP/d ln d) / d³, tabulated on a fine log grid and inverted.
    """
    targetPassing = np.asarray(targetPassing, dtype=float)
    if np.any(np.diff(targetPassing) < 0.0) or targetPassing[-1] != 100.0:
        raise ValueError("sampleSieveSizes: target passing must be non-decreasing and end at 100 %%, got %s"
                         % targetPassing)
    logGrid = np.linspace(math.log(sieves[0]), math.log(sieves[-1]), 4001)
    passing = np.interp(logGrid, np.log(sieves), targetPassing)
    massDensity = np.diff(passing)  # mass per log-size cell
    centres = 0.5 * (logGrid[1:] + logGrid[:-1])
    numberWeights = massDensity / np.exp(3.0 * centres)
    cumulative = np.concatenate([[0.0], np.cumsum(numberWeights)])
    cumulative /= cumulative[-1]
    uniform = rng.uniform(size=count)
    return np.exp(np.interp(uniform, cumulative, logGrid))


def gradingReport(sizesMillimetres, masses, sieves=EN13450_SIEVES_MM):
    """Cumulative mass % passing at each sieve, the 32-50 mm fraction, and EN 13450 compliance."""
    sizes = np.asarray(sizesMillimetres, dtype=float)
    masses = np.asarray(masses, dtype=float)
    total = masses.sum()
    passing = np.array([masses[sizes <= s].sum() / total * 100.0 for s in sieves])
    fraction = masses[(sizes > 32.0) & (sizes <= 50.0)].sum() / total * 100.0
    within = bool(np.all(passing >= EN13450_PASSING_MIN - 1e-9) and np.all(passing <= EN13450_PASSING_MAX + 1e-9))
    return {"sieves": sieves, "passing": passing, "fraction32to50": fraction,
            "compliant": within and fraction >= EN13450_MIN_FRACTION_32_50}


def rotationFromQuaternions(q):
    """Rotation matrix (body to world) of the unit quaternion q = (w, x, y, z), or matrices (n, 3, 3) of quaternions
    (n, 4)."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    matrix = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                       [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                       [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return np.moveaxis(matrix, (0, 1), (-2, -1))


def quaternionFromRotation(rotation):
    """The unit quaternion (w, x, y, z), w >= 0, of a proper rotation matrix, by Shepperd's method: from the largest
    of 1 + trace and the diagonal terms' combinations, so that no division is by a small number (half turns
    included)."""
    m = np.asarray(rotation, dtype=float)
    t = m[0, 0] + m[1, 1] + m[2, 2]
    k = int(np.argmax([t, m[0, 0], m[1, 1], m[2, 2]]))
    if k == 0:
        w = 0.5 * math.sqrt(1.0 + t)
        q = [w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)]
    elif k == 1:
        x = 0.5 * math.sqrt(1.0 + 2 * m[0, 0] - t)
        q = [(m[2, 1] - m[1, 2]) / (4 * x), x, (m[0, 1] + m[1, 0]) / (4 * x), (m[0, 2] + m[2, 0]) / (4 * x)]
    elif k == 2:
        y = 0.5 * math.sqrt(1.0 + 2 * m[1, 1] - t)
        q = [(m[0, 2] - m[2, 0]) / (4 * y), (m[0, 1] + m[1, 0]) / (4 * y), y, (m[1, 2] + m[2, 1]) / (4 * y)]
    else:
        z = 0.5 * math.sqrt(1.0 + 2 * m[2, 2] - t)
        q = [(m[1, 0] - m[0, 1]) / (4 * z), (m[0, 2] + m[2, 0]) / (4 * z), (m[1, 2] + m[2, 1]) / (4 * z), z]
    q = np.array(q)
    q = q if q[0] >= 0.0 else -q  # q and -q are the same turn: the one with w >= 0
    return q / np.linalg.norm(q)


def randomRotation(rng):
    """Uniformly distributed rotation matrix (Shoemake's uniform unit quaternion)."""
    u1, u2, u3 = rng.uniform(size=3)
    w = math.sqrt(1.0 - u1) * math.sin(2.0 * math.pi * u2)
    x = math.sqrt(1.0 - u1) * math.cos(2.0 * math.pi * u2)
    y = math.sqrt(u1) * math.sin(2.0 * math.pi * u3)
    z = math.sqrt(u1) * math.cos(2.0 * math.pi * u3)
    return rotationFromQuaternions((w, x, y, z))

# --------------------------------------------------------------------------------------------------
# Shape library access and grading-conform stone sampling
# --------------------------------------------------------------------------------------------------

DEFAULT_LIBRARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "shapes", "library.json")


def loadShapeLibrary(path=DEFAULT_LIBRARY):
    """The stored shape library (shapes/library.json) with arrays as numpy arrays.

    Every stone is stored at unit sieve size in its own principal axes; each cluster level ("coarse": 7-16
    spheres, "fine": 29-45 spheres, "angular": corner spheres and inscribed fill, 28-55 spheres) in the principal
    axes of its sphere union at unit density.
    """
    with open(path) as handle:
        library = json.load(handle)
    for shape in library["shapes"]:
        shape["vertices"] = np.asarray(shape["vertices"], dtype=float)
        shape["triangles"] = np.asarray(shape["triangles"], dtype=int)
        for cluster in shape["clusters"].values():
            for key in ("spheres", "principalInertia", "rotation", "centreOfMass", "enclosingCentre"):
                cluster[key] = np.asarray(cluster[key], dtype=float)
    return library


def sampleDilatedStones(library, rng, totalSolidVolume, relativeDilation, density=2700.0,
                        targetPassing=DEFAULT_TARGET_PASSING, sieves=EN13450_SIEVES_MM):
    """The library's stones as dilated polyhedra (the polyhedra library's particle), drawn as sampleBallastStones draws
    clusters (shape, sieve size, turn; one call a stone, coarse level) until the hulls' solid volume reaches the target
    [m^3]. Each is its hull at its sieve size, the core shrunk about the centroid (the origin of the principal axes)
    and dilated by r_d = relativeDilation x size so that the dilated stone has the hull's volume (dilatedCoreScale:
    Steiner's formula, exact). Returns a dict of: sizes (n) [m], cores (list of (k, 3) body-frame vertices) [m],
    dilations (n) [m], orientations (n, 4) (w, x, y, z), inertia (n, 3) principal moments of the undilated hull at
    `density` [kg m^2], reaches (n) [m] (the farthest core vertex plus the dilation)."""
    shapes = {s["name"]: s for s in library["shapes"]}
    scales = {name: dilatedCoreScale(s["vertices"], s["triangles"], relativeDilation) for name, s in shapes.items()}
    drawn, volume = [], 0.0
    while volume < totalSolidVolume:
        # one stone a call: sampleBallastStones stops once its (cluster's) volume passes the target, the hull's here
        stone = sampleBallastStones(library, rng, 1e-12, level="coarse", density=density, targetPassing=targetPassing,
                                    sieves=sieves)[0]
        drawn.append(stone)
        volume += shapes[stone["shape"]]["volume"] * stone["sieveSize"] ** 3
    sizes = np.array([s["sieveSize"] for s in drawn])
    cores = [np.asarray(shapes[s["shape"]]["vertices"], float) * s["sieveSize"] * scales[s["shape"]] for s in drawn]
    dilations = relativeDilation * sizes
    return {"sizes": sizes, "cores": cores, "dilations": dilations,
            "orientations": np.array([quaternionFromRotation(s["rotation"]) for s in drawn]),
            "inertia": np.array([density * np.asarray(shapes[s["shape"]]["principalInertia"]) * s["sieveSize"] ** 5
                                 for s in drawn]),
            "reaches": np.array([np.linalg.norm(c, axis=1).max() + d for c, d in zip(cores, dilations)])}


def sampleBallastStones(library, rng, totalSolidVolume, level="fine", density=2700.0,
                        targetPassing=DEFAULT_TARGET_PASSING, sieves=EN13450_SIEVES_MM):
    """Stones for a bed: draws (shape, sieve size, orientation) until the solid volume reaches the target; sizes follow
    the grading targetPassing [%] at `sieves` [mm] (default: the middle of the EN 13450 band).

    Returns a list of dicts: shape name, sieveSize [m], scale (= sieve size, the library is at unit size),
    rotation (3x3, body -> world), spheres (k, 4) scaled, in body axes, mass [kg] and principal inertia
    [kg m^2] of the scaled cluster at `density` [kg/m^3], enclosingRadius [m].
    """
    if totalSolidVolume <= 0.0:
        raise ValueError("sampleBallastStones: totalSolidVolume must be positive [m^3], got %g" % totalSolidVolume)
    shapes = library["shapes"]
    stones = []
    volume = 0.0
    while volume < totalSolidVolume:
        sizeMillimetres = sampleSieveSizes(rng, 1, targetPassing, sieves)[0]
        shape = shapes[int(rng.integers(len(shapes)))]
        cluster = shape["clusters"][level]
        scale = sizeMillimetres * 1e-3
        spheres = cluster["spheres"] * scale
        stoneVolume = cluster["volume"] * scale ** 3
        stones.append({
            "shape": shape["name"],
            "sieveSize": scale,
            "scale": scale,
            "rotation": randomRotation(rng),
            "spheres": spheres,
            "mass": density * stoneVolume,
            "principalInertia": density * cluster["principalInertia"] * scale ** 5,
            "enclosingRadius": cluster["enclosingRadius"] * scale,
        })
        volume += stoneVolume
    return stones
