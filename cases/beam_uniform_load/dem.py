# DEM participant of the beam case: particles (spheres, sphere clusters or dilated polyhedra) settle on the coupled top
# face of the FEM beam. Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import math
import os
import random
import sys

import numpy as np

from railcosim.dem import CoupledDem, hertz_mindlin_contacts

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters
L, W, H = p["beam_length"], p["beam_width"], p["beam_height"]
R = p["sphere_radius"]
shape = p["particle_shape"]

# 1. Materials: the walls are frictionless so that all the weight of the bed rests on the beam.
particle_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                           frictionAngle=math.atan(p["friction"]), label="particles"))
wall_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["particle_density"],
                                       frictionAngle=0.0, label="walls"))
beam_mat = O.materials.append(FrictMat(young=p["particle_young"], poisson=0.3, density=p["beam_density"],
                                       frictionAngle=math.atan(p["friction"]), label="beam"))

# 2. Side walls around the top face (they do not touch the beam, which lies below z = H). The polyhedra engine meets
#    Facet walls only: for polyhedra each side is two facets, added once the bed's height is known (step 3).
if shape != "polyhedron":
    for axis, position, sense in ((0, 0.0, 1), (0, L, -1), (1, 0.0, 1), (1, W, -1)):
        O.bodies.append(utils.wall(position=position, axis=axis, sense=sense, material=wall_mat))

# 3. Layers of particles above the beam, each layer shifted by half a spacing so that its particles sit in the hollows
#    of the one below (a stacked square lattice would stand in precarious columns that keep collapsing long after the
#    bed looks settled); jittered; density fitted so the total mass is exact.
rng = random.Random(p["seed"])


def lattice_line(length, shift, reach, spacing):
    """Centres along one side, centred so that the slack is shared by both walls (a gap at one end only
    would leave that end of the beam less loaded once the bed has settled)."""
    n = int((length - 2 * reach) / spacing) + 1
    first = 0.5 * (length - (n - 1) * spacing) + shift
    return [first + k * spacing for k in range(n) if first + k * spacing <= length - reach]


def lattice(count, reach, box=None):
    """`count` jittered centres, layer by layer from the top face up: for spheres within `reach` of their centre, in the
    hollows of the layer below; for stones held in the axis-aligned half-extents `box`, on a shifted box lattice."""
    spacing = 2.0 * reach * 1.05
    layer_height = spacing * math.sqrt(0.5)  # centre rise of a sphere resting in a square hollow
    steps = (spacing, spacing)
    if box is not None:
        steps = (2.0 * box[0] * 1.05, 2.0 * box[1] * 1.05)
        layer_height = 2.0 * box[2] * 1.05
    jitter = 0.05 * reach
    centres, layer = [], 0
    while len(centres) < count:
        shifts = (0.5 * steps[0] * (layer % 2), 0.5 * steps[1] * (layer % 2))
        z = H + (reach if box is None else box[2]) * 1.02 + layer * layer_height
        for x in lattice_line(L, shifts[0], reach if box is None else box[0], steps[0]):
            for y in lattice_line(W, shifts[1], reach if box is None else box[1], steps[1]):
                if len(centres) == count:
                    break
                dx, dy = (rng.uniform(-jitter, jitter) for _ in range(2))
                limit = (reach, reach) if box is None else box[:2]
                centres.append((min(max(x + dx, limit[0]), L - limit[0]), min(max(y + dy, limit[1]), W - limit[1]), z))
        layer += 1
    return centres


def particle_sizes(mean, volume_of):
    """Sizes [m] drawn until their solid volume (volume_of(size, k) for particle k) reaches the bed's, from a normal
    of relative standard deviation size_std clipped to [size_min, size_max] times the mean; all `mean` when
    size_std = 0. Returns the sizes and their total volume."""
    target = p["particle_mass_kg"] / p["particle_density"]
    sizes, volume = [], 0.0
    while True:
        size = mean
        if p["size_std"] > 0:
            size = min(max(rng.gauss(mean, p["size_std"] * mean), p["size_min"] * mean), p["size_max"] * mean)
        step = volume_of(size, len(sizes))
        if volume + 0.5 * step > target:  # the count whose volume is nearest the target
            return sizes, volume
        sizes.append(size)
        volume += step


particle_ids = []  # the YADE bodies that move: spheres, clumps, or the polyhedra engine's stones
if shape == "sphere" and p["size_std"] == 0:
    sphere_volume = 4.0 / 3.0 * math.pi * R ** 3
    count = max(1, round(p["particle_mass_kg"] / (p["particle_density"] * sphere_volume)))
    centres = lattice(count, R)
    density = p["particle_mass_kg"] / (count * sphere_volume)
    O.materials[particle_mat].density = density
    particle_ids = [O.bodies.append(utils.sphere(c, R, material=particle_mat)) for c in centres]
    smallest = R
elif shape == "sphere":
    sizes, volume = particle_sizes(2.0 * R, lambda d, k: math.pi / 6.0 * d ** 3)
    centres = lattice(len(sizes), 0.5 * max(sizes))
    O.materials[particle_mat].density = p["particle_mass_kg"] / volume
    particle_ids = [O.bodies.append(utils.sphere(c, 0.5 * d, material=particle_mat)) for c, d in zip(centres, sizes)]
    smallest = 0.5 * min(sizes)
else:
    sys.path.insert(0, os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"))
    import ballast_clusters
    import pack_ballast

    library = ballast_clusters.loadShapeLibrary()
    if shape == "cluster":
        # Library clusters at unit sieve size, in their principal axes: (spheres, volume, inertia) per shape.
        templates = [(s["clusters"][p["cluster_level"]]["spheres"], s["clusters"][p["cluster_level"]]["volume"],
                      s["clusters"][p["cluster_level"]]["principalInertia"]) for s in library["shapes"]]
        extent_of = [np.max(np.abs(t[0][:, :3]) + t[0][:, 3:4], axis=0) for t in templates]
    else:
        # Convex cores at unit sieve size about their centroids: the library stones, or random crushed-rock hulls (a
        # fifth of them per seed, as many as the library has). The core is shrunk by 1 - 2 dilation_ratio so that with
        # r_d = dilation_ratio x size the dilated stone keeps about the stone's size.
        if p["polyhedron_shapes"] == "library":
            stones = [ballast_clusters.ConvexStone(s["vertices"], s["triangles"]) for s in library["shapes"]]
        else:
            stones = [ballast_clusters.randomConvexStone(1000 * p["seed"] + k, (0.5, 0.4, 0.3), 16, 0.2)
                      for k in range(len(library["shapes"]))]
            stones = [s.scaled(1.0 / ballast_clusters.sieveSize(s)) for s in stones]
        ratio = p["dilation_ratio"]
        cores = [(s.vertices - s.centroid) * (1.0 - 2.0 * ratio) for s in stones]
        # The dilated volume at unit size, from the engine's own Steiner formula; it scales with size^3.
        templates = [(core, PolyhedraGpuEngine.dilatedVolume([Vector3(*v) for v in core], ratio)) for core in cores]
        reach_of = [max(np.linalg.norm(t[0], axis=1)) + ratio for t in templates]
        extent_of = [np.max(np.abs(t[0]), axis=0) + ratio for t in templates]
    kinds = []

    def stone_volume(size, k):
        kinds.append(rng.randrange(len(templates)))
        return templates[kinds[-1]][1] * size ** 3

    sizes, volume = particle_sizes(p["particle_size"], stone_volume)
    kinds = kinds[:len(sizes)]
    # The stones lie with their principal axes along y, x, z (longest across the beam, so that the stones at the end
    # walls reach as close to the beam's ends as they can), each turned by a random half turn about one axis, which
    # keeps its box: a lattice of boxes packs them twice as densely as their enclosing spheres.
    box = np.max([extent_of[k][[1, 0, 2]] * d for k, d in zip(kinds, sizes)], axis=0)
    centres = lattice(len(sizes), 0.5 * min(sizes), box)
    across = Quaternion((0, 0, 1), 0.5 * math.pi)
    half_turns = [Quaternion.Identity, Quaternion((1, 0, 0), math.pi), Quaternion((0, 1, 0), math.pi),
                  Quaternion((0, 0, 1), math.pi)]
    turns = [across * half_turns[rng.randrange(4)] for _ in sizes]
    density = p["particle_mass_kg"] / volume
    O.materials[particle_mat].density = density
    smallest = 0.5 * min(sizes)
    if shape == "cluster":
        for centre, kind, size, turn in zip(centres, kinds, sizes, turns):
            spheres, unit_volume, inertia = templates[kind]
            rotation = np.array([[turn.toRotationMatrix()[i, j] for j in range(3)] for i in range(3)])
            stone = {"rotation": rotation, "spheres": spheres * size,
                     "mass": density * unit_volume * size ** 3, "principalInertia": density * inertia * size ** 5}
            particle_ids.append(pack_ballast.addClusterStone(stone, centre, O.materials[particle_mat]))
    else:
        stone_cores = []  # (body, core vertices in the body frame, dilation radius) of each stone
        for centre, kind, size, turn in zip(centres, kinds, sizes, turns):
            b = O.bodies.append(utils.sphere(centre, reach_of[kind] * size, material=particle_mat))
            O.bodies[b].state.ori = turn
            stone_cores.append((b, [Vector3(*v) * size for v in templates[kind][0]], p["dilation_ratio"] * size))
            particle_ids.append(b)
        # Frictionless side walls of facets, counter-clockwise seen from inside, up to above the bed.
        top = max(c[2] for c in centres) + 2.0 * max(sizes)
        corners = [Vector3(0, 0, H), Vector3(L, 0, H), Vector3(L, W, H), Vector3(0, W, H)]
        for k in range(4):
            a, b = corners[k], corners[(k + 1) % 4]
            lifted = [Vector3(c[0], c[1], top) for c in (a, b)]
            O.bodies.append(utils.facet((a, lifted[1], b), material=wall_mat))
            O.bodies.append(utils.facet((a, lifted[0], lifted[1]), material=wall_mat))

        def polyhedra_engine():
            """The stones' engine. Neighbour lists: stones land at up to 2.5 m/s; a skin of one dilation radius rebuilt
            every 5 steps covers two stones closing on each other at that speed (2 x 2.5 m/s x 5 dt <= r_d / 2 for
            dt <= r_d / 50 m/s; dt here is a fifth of that). A stone near a surface node has up to 8 triangles of the
            beam's face and 2 of a wall within reach."""
            mean_dilation = p["dilation_ratio"] * p["particle_size"]
            engine = PolyhedraGpuEngine(dilationRadius=mean_dilation, restitution=p["restitution"], gravity=(0, 0, -9.81),
                                        backend=p["polyhedra_backend"], rebuildInterval=5, neighbourSkin=mean_dilation,
                                        maxNeighbours=32, maxWallNeighbours=16, label="polyhedra")
            for body, core, dilation in stone_cores:
                engine.addStone(body, core, dilation)
            return engine
count = len(particle_ids)

# 4. Engines. Spheres and clusters: YADE's contact loop and integrator, the coupling engine between them; Hertz-Mindlin
#    with viscous damping from the restitution coefficient (Thornton 2013), so that the bed comes to rest by
#    dissipation in its contacts, not by numerical damping. Spheres touch the beam through facets, clusters through
#    the mesh contacts (one contact per member and surface patch, the kernels' Hertz-Mindlin). Polyhedra: the
#    coupling engine drives the polyhedra engine one window at a time, the beam's face one of its walls.
def yade_engines(coupling):
    return [
        *hertz_mindlin_contacts(p["restitution"], walls=True),
    ] + ([coupling] if coupling else []) + [
        (NewtonIntegrator if shape == "sphere" else QuaternionIntegrator)(damping=p["local_damping"], gravity=(0, 0, -9.81)),
    ]


if shape == "sphere":
    O.dt = dem.time_step()
else:
    # A contact on a cluster member or a dilated corner moves the whole stone: its P-wave step is that of the sphere of
    # the stone's size, not of its smallest member or of its dilation.
    O.dt = p["dem_dt"] if "dem_dt" in p else p["dem_dt_safety"] * smallest * math.sqrt(density / p["particle_young"])

# 4b. Stones: a bed of angular stones starts about three times as tall as one of spheres (the boxes of the lattice hold
#     40 % stone against 64 % for spheres) and would still be landing at the end of the coupled run. They first settle
#     for deposition_s on a rigid floor in place of the beam's face, uncoupled (the FEM waits); the floor then gives
#     way to the coupled beam.
if shape != "sphere" and p["deposition_s"] > 0:
    if shape == "cluster":
        floor = [O.bodies.append(utils.wall(position=H, axis=2, sense=1, material=beam_mat))]
        O.engines = yade_engines(None)
    else:
        floor = [O.bodies.append(utils.facet((corners[0], corners[1], corners[2]), material=beam_mat)),
                 O.bodies.append(utils.facet((corners[0], corners[2], corners[3]), material=beam_mat))]
        O.engines = [polyhedra_engine()]
        O.engines[0].syncInterval = 50
    O.run(50 * max(1, int(round(p["deposition_s"] / O.dt / 50))), True)
    for b in floor:
        O.bodies.erase(b)
    settled = utils.kineticEnergy()
    print(f"deposited for {O.time:.3f} s: kinetic energy {settled:.3e} J", flush=True)

model = p["contact_model"]
if model == "auto":
    model = {"sphere": "facets", "cluster": "meshContacts", "polyhedron": "polyhedra"}[shape]
coupling = dem.coupling_engine(material=O.materials[beam_mat], restitution=p["restitution"], contactModel=model)
if shape == "polyhedron":
    poly = polyhedra_engine()
    O.engines = [coupling, poly]
else:
    O.engines = yade_engines(coupling)
dem.connect()  # receives the beam's top surface, inserts its facets, sets O.dt = fem_dt / subcycles
if shape == "polyhedron":
    poly.initialize()  # the stones' bodies get their dilated mass
total_mass = sum(O.bodies[i].state.mass for i in particle_ids)
members = sum(1 for b in O.bodies if b.isClumpMember)
if shape == "sphere":
    print(f"{count} spheres, {total_mass:.3f} kg, radius {R} m", flush=True)
else:
    print(f"{count} {shape} stones{f' ({members} spheres)' if members else ''}, {total_mass:.3f} kg, sizes "
          f"{min(sizes):.4f}-{max(sizes):.4f} m, O.dt {O.dt:.3e} s", flush=True)


# 5. Run the windows, one record per window: interface force, kinetic energy, nodal forces and kinematics.
def particles_below_surface():
    """Particles whose centre fell below the top face (spheres: by more than their radius): they passed through."""
    if shape == "sphere" and p["size_std"] == 0:
        return sum(1 for i in particle_ids if O.bodies[i].state.pos[2] < H - R)
    return sum(1 for i in particle_ids if O.bodies[i].state.pos[2] < H)


def record():
    return dict(interface_force=coupling.totalForce, kinetic_energy=utils.kineticEnergy(),
                nodal_forces=coupling.nodalForces, node_positions=coupling.nodePositions,
                node_velocities=coupling.nodeVelocities, particles_below_surface=particles_below_surface())


dem.run(record, progress=lambda last: f"interface Fz={last['interface_force'][2]:.2f} N (weight {total_mass * 9.81:.2f} N)  "
                                      f"kinetic energy {last['kinetic_energy']:.3e} J")
# 6. What the post-processing reads (dem_info.json): the bed, its final state, and the surface triangles.
extra = {} if shape == "sphere" else {"particle_shape": shape, "cluster_spheres": members,
                                      "smallest_size_m": min(sizes), "largest_size_m": max(sizes)}
if shape == "polyhedron":
    extra.update(polyhedra_backend=poly.activeBackend, polyhedra_time_s=coupling.polyhedraTime)
dem.save(particles=count, total_particle_mass_kg=total_mass, final_kinetic_energy_j=utils.kineticEnergy(),
         particles_below_surface=particles_below_surface(),
         arrays={"triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int)}, **extra)
