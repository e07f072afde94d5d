# DEM run of the small-strain triaxial case (DEM only): clusters of three ballast shapes of the shape library in a
# periodic cell at void ratio 0.70, confined isotropically by a stress servo on the cell (or, with boundary =
# "platens", laterally by the servo and axially between two frictionless platens of the paper's linear contacts), then
# probed axially in quasi-static strain steps to 0.1 % and unloaded (Tolomeo & McDowell 2022 §3). Run by
# `railcosim run` as:
# railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR (DEM-only case: the endpoint is not used)
import math
import os
import sys
import time

import numpy as np

from railcosim import bedcache
from railcosim.dem import StandaloneDem, run_steps

dem = StandaloneDem()
p = dem.parameters
out = dem.out
sys.path.insert(0, os.path.join(os.environ["RAILCOSIM_ROOT"], "yade_engines", "clusters"))
import ballast_clusters  # noqa: E402
import pack_ballast  # noqa: E402

MODELS = {"hertz": (0.0, False), "pohrt_popov": (p["roughness_rms"], False),
          "pohrt_popov_plastic": (p["roughness_rms"], True)}
rms, plastic = MODELS[p["normal_model"]]
pressure = 1e3 * p["confining_pressure_kPa"]
platens = p["boundary"] == "platens"


# 1. Material (Tolomeo & McDowell 2022 Table 1, §2.3): granite E = 60 GPa, ν = 0.25, μ = 0.7; the normal law is the
#    one the run names (hertz: roughnessRms = 0; the Pohrt–Popov laws: D_f = 2.13, h = 26.1 µm, plastic unloading for
#    the elasto-plastic one); tangential stiffness k_r k_n (k_r = 2(1-ν)/(2-ν), eq. 7, which the Hertz–Mindlin
#    tangent 8G*a equals for like materials). No contact dashpot (restitution 1): the paper damps with Cundall's
#    local damping only (α = 0.7, NewtonIntegrator.damping).
def ballast_material(friction, roughness, plastic_unloading):
    return BallastMat(young=p["particle_young"], poisson=p["particle_poisson"], density=p["particle_density"],
                      frictionAngle=math.atan(friction), restitution=1.0, roughnessRms=roughness,
                      roughnessFractalDim=p["roughness_fractal_dim"], plasticUnloading=plastic_unloading)


def engines(servoed=True, with_platens=False, contact_radius=None):
    """The engines; with_platens adds the platens' boxes and their contacts: linear springs of platen_stiffness,
    frictionless (Ip2_FrictMat_FrictMat_FrictPhys with a constant k_n, Cundall-Strack law; the paper's platen-grain
    contacts, §2.4). The boxes span the periodic cell laterally many times over (allowBiggerThanPeriod).
    contact_radius: the contacts' R* (0: R1R2/(R1+R2)); None: the run's."""
    radius = p["contact_radius"] if contact_radius is None else contact_radius
    box = with_platens  # short for the engine lists below
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()] + ([Bo1_Box_Aabb()] if box else []), verletDist=-0.1,
                              allowBiggerThanPeriod=box),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()] + ([Ig2_Box_Sphere_ScGeom()] if box else []),
                        [Ip2_BallastMat_BallastMat_BallastPhys(fixedEffectiveRadius=radius)] +
                        ([Ip2_FrictMat_FrictMat_FrictPhys(kn=MatchMaker(algo="val", val=p["platen_stiffness"]),
                                                          ks=MatchMaker(algo="val", val=p["platen_stiffness"]))]
                         if box else []),
                        [Law2_ScGeom_BallastPhys_Ballast()] + ([Law2_ScGeom_FrictPhys_CundallStrack()] if box else [])),
    ] + ([PyRunner(iterPeriod=p["servo_steps"], command="servo_step()")] if servoed else []) + [
        NewtonIntegrator(damping=p["local_damping"], gravity=(0, 0, 0)),
    ]
    O.dt = p["dem_dt"]


def cell_size():
    return np.array([O.cell.hSize[i, i] for i in range(3)])


# The platens (boundary = "platens"): frictionless steel (the paper's, §2.4), boxes 10 mm thick whose faces bound the
# specimen, in a periodic cell three specimens tall, so that no grain meets the other platen through the empty third.
# They span the cell ten times over laterally, so every grain's image meets them however the cell strains.
platen_ids = []  # bottom, top
PLATEN_HALF_THICKNESS = 0.005  # m


def add_platens(size, gap):
    """The two platens, their faces at z = gap and 2 gap in a cell of size[0] x size[1] x 3 gap."""
    O.cell.hSize = Matrix3(size[0], 0, 0, 0, size[1], 0, 0, 0, 3.0 * gap)
    steel = O.materials.append(FrictMat(young=p["particle_young"], poisson=p["particle_poisson"], density=7800.0,
                                        frictionAngle=0.0))
    half = Vector3(10.0 * size[0], 10.0 * size[1], PLATEN_HALF_THICKNESS)
    for face, side in ((gap, -1.0), (2.0 * gap, 1.0)):
        centre = (0.5 * size[0], 0.5 * size[1], face + side * PLATEN_HALF_THICKNESS)
        platen_ids.append(O.bodies.append(utils.box(centre, half, fixed=True, material=O.materials[steel])))


def platen_face(pid):
    """Height of a platen's face towards the specimen [m]."""
    return float(O.bodies[pid].state.pos[2]) + (PLATEN_HALF_THICKNESS if pid == platen_ids[0] else
                                                -PLATEN_HALF_THICKNESS)


def platen_gap():
    return platen_face(platen_ids[1]) - platen_face(platen_ids[0])


def is_platen_contact(i):
    return i.id1 in platen_ids or i.id2 in platen_ids


# 2. The sample, the same for the three normal laws (the paper's design): clusters of three library shapes in equal
#    numbers, sizes from the middle of the EN 13450 band, random orientations, placed without overlap in a periodic
#    cell (a square prism of specimen_height_m at the target, or a cube) at a solid fraction of 0.12 (the enclosing
#    spheres fill 0.28), then shrunk isotropically with frictionless Hertz contacts to the target void ratio and left
#    to come to rest at that volume: stress-free (the paper expands the clumps to e, stress-free). Between platens the
#    cell is periodic laterally only: the clusters are placed between the platens, which close in with the cell's
#    width, so that the specimen's ends lie flat on them. It depends only on the parameters below, so it is kept in a
#    cache and reused by every normal law and pressure.
SAMPLE_PARAMETERS = ("clusters", "cluster_shapes", "cluster_level", "void_ratio", "particle_density", "particle_young",
                     "particle_poisson", "preparation_time_s", "dem_dt", "local_damping", "seed")
# specimen_height_m and the platens join the key only where they are set, so that the periodic cubes keep their keys
tall = {"specimen_height_m": p["specimen_height_m"]} if p["specimen_height_m"] > 0 else {}
between = {"boundary": p["boundary"], "platen_stiffness": p["platen_stiffness"]} if platens else {}
cache = bedcache.path("triaxial_small_strain", {**{k: p[k] for k in SAMPLE_PARAMETERS}, **tall, **between},
                      name="sample", fallback=os.path.join(out, "cache"))


def prepare_sample():
    rng = np.random.default_rng(p["seed"])
    library = ballast_clusters.loadShapeLibrary()
    library["shapes"] = [s for s in library["shapes"] if s["name"] in p["cluster_shapes"]]
    stones = []
    for k in range(p["clusters"]):  # equal numbers of each shape, as the paper's 747 clumps of 3 scans
        one = {"shapes": [library["shapes"][k % len(library["shapes"])]]}
        stones += ballast_clusters.sampleBallastStones(one, rng, 1e-12, level=p["cluster_level"],
                                                       density=p["particle_density"])
    solid = sum(s["mass"] for s in stones) / p["particle_density"]
    volume = solid * (1.0 + p["void_ratio"])  # at the target void ratio; a square prism of the given height
    aspect = p["specimen_height_m"] ** 1.5 / math.sqrt(volume) if p["specimen_height_m"] > 0 else 1.0
    side = (solid / 0.12 / aspect) ** (1.0 / 3.0) * np.array([1.0, 1.0, aspect])
    reaches = np.array([s["enclosingRadius"] for s in stones])
    target = (volume / aspect) ** (1.0 / 3.0)
    if 2.0 * reaches.max() > target:  # a cluster would meet its own periodic image, with which it has no contact
        raise ValueError(f"triaxial sample: the cell would be {target:.3f} m wide at the target void ratio, less than "
                         f"the largest cluster ({2.0 * reaches.max():.3f} m): more clusters, or a lower "
                         f"specimen_height_m")
    periodic = np.array([1.0, 1.0, 0.0 if platens else 1.0])  # the axes the placement wraps
    centres = np.zeros((len(stones), 3))
    for n, k in enumerate(np.argsort(-reaches)):  # random sequential placement of the enclosing spheres
        for attempt in range(20000):
            c = rng.uniform(0.0, 1.0, 3) * side
            if platens:  # between the platens' faces at z = side and 2 side
                c[2] = side[2] + reaches[k] + (side[2] - 2.0 * reaches[k]) * c[2] / side[2]
            d = centres[:n] - c
            d -= periodic * side * np.round(d / side)
            if n == 0 or np.all(np.linalg.norm(d, axis=1) >= reaches[np.argsort(-reaches)[:n]] + reaches[k]):
                centres[n] = c
                break
        else:
            raise RuntimeError(f"triaxial sample: could not place cluster {n} of {len(stones)} in a cell of "
                               f"{side[0]:.3f} x {side[1]:.3f} x {side[2]:.3f} m")
    order = np.argsort(-reaches)
    O.periodic = True
    O.cell.hSize = Matrix3(side[0], 0, 0, 0, side[1], 0, 0, 0, side[2])
    if platens:
        add_platens(side, side[2])
    material = O.materials.append(ballast_material(0.0, 0.0, False))
    ids = [pack_ballast.addClusterStone(stones[k], centres[n], O.materials[material]) for n, k in enumerate(order)]
    engines(servoed=False, with_platens=platens, contact_radius=0.0)  # the sample does not depend on the run's R*
    rate = math.log(target / side[0]) / p["preparation_time_s"]
    O.cell.velGrad = Matrix3(rate, 0, 0, 0, rate, 0, 0, 0, 0.0 if platens else rate)
    if platens:  # the gap closes to aspect × target at a constant speed over the same time
        speed = 0.5 * (side[2] - aspect * target) / p["preparation_time_s"]
        O.bodies[platen_ids[0]].state.vel = Vector3(0, 0, speed)
        O.bodies[platen_ids[1]].state.vel = Vector3(0, 0, -speed)
    steps = int(round(p["preparation_time_s"] / O.dt))
    O.run(steps - 1, True)
    O.cell.velGrad = Matrix3.Zero
    O.run(1, True)
    for b in O.bodies:  # exactly the target volume, then at rest
        b.state.vel = Vector3.Zero
        b.state.angVel = Vector3.Zero
    O.run(int(round(0.2 * p["preparation_time_s"] / O.dt)), True)
    members = np.array([(b.clumpId, *b.state.pos, b.shape.radius) for b in O.bodies if b.isClumpMember])
    clumps = [(i, O.bodies[i].state.mass, *O.bodies[i].state.inertia) for i in ids]
    size = cell_size()
    if platens:  # kept with the bottom face at z = gap, the frame of add_platens
        size[2] = platen_gap()
        members[:, 3] += size[2] - platen_face(platen_ids[0])
        del platen_ids[:]
    return members, np.array(clumps), size, solid


started = time.monotonic()
with bedcache.exclusive(cache) as found:
    if not found:
        members, clumps, size, solid = prepare_sample()
        partial = f"{cache}.{os.getpid()}.npz"
        np.savez(partial, members=members, clumps=clumps, size=size, solid=solid)
        os.replace(partial, cache)  # whole or not at all
        O.reset()
        print(f"sample prepared in {time.monotonic() - started:.0f} s: {cache}", flush=True)
preparation_s = time.monotonic() - started
with np.load(cache) as saved:
    members, clumps, size, solid = saved["members"], saved["clumps"], saved["size"], float(saved["solid"])

# 3. The scene of this run: the sample with the run's normal law and μ = confinement_friction, at rest, stress-free
#    (size: the cell's edges, or its width and the platens' gap).
O.periodic = True
O.cell.hSize = Matrix3(size[0], 0, 0, 0, size[1], 0, 0, 0, size[2])
material = O.materials.append(ballast_material(p["confinement_friction"], rms, plastic))
clump_ids = []
for old, mass, i1, i2, i3 in clumps:
    rows = members[members[:, 0] == old]
    spheres = [utils.sphere(tuple(r[1:4]), float(r[4]), material=O.materials[material]) for r in rows]
    cid, _ = O.bodies.appendClumped(spheres, discretization=30)
    state = O.bodies[cid].state
    moments = np.empty(3)
    mine = np.array([state.inertia[0], state.inertia[1], state.inertia[2]])
    moments[np.argsort(mine)] = np.sort([i1, i2, i3])
    state.mass, state.inertia = float(mass), Vector3(*moments)
    clump_ids.append(cid)
if platens:
    add_platens(size, size[2])
engines(with_platens=platens)
count = len(clump_ids)
print(f"{count} clusters ({len(members)} spheres), {'platens' if platens else 'cell'} {size[0]:.4f} x {size[1]:.4f} x "
      f"{size[2]:.4f} m, e = {np.prod(size) / solid - 1.0:.4f}, normal law {p['normal_model']}, "
      f"dt {O.dt:.2e} s (P-wave step {utils.PWaveTimeStep():.2e} s)", flush=True)


# 4. Measurements. The stress is the paper's (Christoffersen et al.): σ = (1/V) Σ f ⊗ l over all contacts, l the branch
#    vector between the clusters' centroids (utils.getStress, positive in tension; here compression positive).
#    With platens the specimen is the platens' gap times the cell's cross-section; its axial stress is the platens'
#    mean force over that section (the boundary's measure, equal to the branch-vector average in equilibrium: the
#    frictionless platens' contacts carry axial force only), and the platens' contacts are left out of the sum.
def dims():
    """The specimen's edges [m]: the cell's, or its width and the platens' gap."""
    d = cell_size()
    if platens:
        d[2] = platen_gap()
    return d


def specimen_volume():
    return float(np.prod(dims())) if platens else O.cell.volume  # the sheared cell's volume is its determinant


def platen_terms(volume, with_love_weber):
    """With platens: (the terms getStress gives the platens' contacts, with branch vectors to the boxes' centres; the
    Love-Weber terms of those contacts, f on the grain ⊗ (the contact point projected on the platen's face - the
    cluster's centroid; zero unless with_love_weber)), each / volume, tension positive as getStress."""
    h = O.cell.hSize
    given, love_weber = np.zeros((3, 3)), np.zeros((3, 3))
    for pid in platen_ids:
        for i in O.interactions.withBody(pid):
            if not i.isReal:
                continue
            a, b = (O.bodies[O.bodies[k].clumpId] if O.bodies[k].isClumpMember else O.bodies[k] for k in (i.id1, i.id2))
            force = np.array(i.phys.normalForce + i.phys.shearForce)  # YADE's phys force acts on id2, -force on id1
            shift = np.array(h * Vector3(*i.cellDist))
            given += np.outer(force, np.array(a.state.pos - b.state.pos) - shift)
            if not with_love_weber:  # the servo's stress, every few steps, needs only the first
                continue
            grain, on_grain = (i.id2, force) if i.id1 == pid else (i.id1, -force)
            member = O.bodies[grain]
            centre = np.array(O.bodies[member.clumpId].state.pos)
            # the force acts on the platen's face (the specimen's boundary, which defines its volume), not at the
            # contact point halfway into the soft contact's overlap: the two differ by δ/H, about 1e-3
            point = np.array(i.geom.contactPoint)
            point[2] = platen_face(pid)
            # the contact point lies in the frame of id1; the grain's image is shifted when it is id2
            offset = centre + (shift if grain == i.id2 else 0.0)
            love_weber += np.outer(on_grain, point - offset)
    return given / volume, love_weber / volume


def stress(branch=False):
    """The specimen's stress tensor, compression positive. With platens the axial stress is the platens' mean force
    over the section, or (branch = True) the Love-Weber average over the grains with the platens' contacts' branch
    vectors to the platens' faces: the two agree in equilibrium (a check of case.py)."""
    if not platens:
        return -np.array(utils.getStress())
    volume = specimen_volume()
    given, love_weber = platen_terms(volume, with_love_weber=branch)
    s = np.array(utils.getStress(volume)) - given
    if branch:
        return -(s + love_weber)
    area = float(np.prod(cell_size()[:2]))
    s[2, 2] = 0.5 * (O.forces.f(platen_ids[0])[2] - O.forces.f(platen_ids[1])[2]) / area  # tension positive
    return -s


def contact_census():
    """Contacts carrying force: member contacts, distinct cluster pairs, and (elasto-plastic law) how many are on the
    virgin curve (F = F_max) and how many on the Hertzian unloading/reloading branch (F < F_max); how many slide
    (at the Coulomb limit in the last step)."""
    contacts, pairs, virgin, ratios, sliding = 0, set(), 0, [], 0
    for i in O.interactions:
        if not i.isReal or i.phys.normalForce.norm() <= 0.0 or is_platen_contact(i):
            continue
        contacts += 1
        sliding += bool(i.phys.isSliding)
        pairs.add((O.bodies[i.id1].clumpId, O.bodies[i.id2].clumpId))
        if plastic:
            ratios.append(i.phys.normalForce.norm() / i.phys.maxNormalForce)
            virgin += ratios[-1] >= 1.0 - 1e-9
    return contacts, len(pairs), virgin, float(np.mean(ratios)) if ratios else 1.0, sliding


def strains():
    s = dims()
    return (reference_size - s) / reference_size  # compression positive, from the confined state (the paper's ΔH/H0)


# 5. Servo on the specimen (the stress boundary: the periodic cell has no membrane; without platens it takes the
#    axial strain too), a PyRunner every servo_steps steps before the integrator: each stress-controlled axis strains
#    by gain × (σ - goal)/M over the next servo_steps steps (homothetic motion of the cell and of the clusters'
#    centroids, Cell.homoDeform; between platens the axial strain moves the platens); the axial axis follows its
#    strain schedule. M is the affine (upper-bound) stiffness of the contact network,
#    M_i = (1/V) Σ [k_n n_i² + k_t (1 - n_i²)] l_i²: the cell's immediate response to its own strain, so the loop is
#    stable for gain < 1; the particles' relaxation then lowers the stress further, and the loop converges over a few
#    relaxation times.
def affine_modulus():
    h = O.cell.hSize
    m = np.zeros(3)
    for i in O.interactions:
        if not i.isReal or is_platen_contact(i):
            continue
        a, b = O.bodies[O.bodies[i.id1].clumpId], O.bodies[O.bodies[i.id2].clumpId]
        l = np.array(b.state.pos - a.state.pos + h * Vector3(*i.cellDist))
        n = np.array(i.geom.normal)
        m += (i.phys.kn * n ** 2 + i.phys.ks * (1.0 - n ** 2)) * l ** 2
    return np.maximum(m / specimen_volume(), p["servo_modulus_floor_over_p"] * pressure)


reference_size = dims()
# goals: a stress [Pa] per axis, or None for the axis on a strain schedule: from strain_from at iteration
# start_iter to strain_to at end_iter, linearly; stress goals may ramp from goal_from over the same iterations.
servo = {"modulus": affine_modulus(), "goals": [0.0, 0.0, 0.0], "goal_from": None, "strain_from": 0.0,
         "strain_to": 0.0, "start_iter": 0, "end_iter": 0}


def servo_step():
    """PyRunner: the cell's strain rates for the next servo_steps steps (Cell.velGrad applies from the next step)."""
    n = p["servo_steps"]
    s = stress()
    eps = strains()
    span = max(1, servo["end_iter"] - servo["start_iter"])
    fraction = min(1.0, max(0.0, (O.iter + n - servo["start_iter"]) / span))
    rates = []
    for axis in range(3):
        goal = servo["goals"][axis]
        if goal is None:
            target = servo["strain_from"] + (servo["strain_to"] - servo["strain_from"]) * fraction
            rates.append(-(target - eps[axis]) * reference_size[axis] / (dims()[axis] * n * O.dt))
        else:
            if servo["goal_from"] is not None:
                goal = servo["goal_from"] + (goal - servo["goal_from"]) * fraction
            strain = p["servo_gain"] * (s[axis, axis] - goal) / servo["modulus"][axis]
            rates.append(max(-p["servo_max_rate"], min(p["servo_max_rate"], strain / (n * O.dt))))
    g = np.zeros((3, 3))
    if platens:
        # The axial strain rate moves the two platens symmetrically (the cell keeps its height); the cell stays
        # rectangular (boxes need an unsheared cell), so the shear stresses are left to the frictionless platens.
        speed = 0.5 * rates[2] * dims()[2]
        O.bodies[platen_ids[0]].state.vel = Vector3(0, 0, -speed)
        O.bodies[platen_ids[1]].state.vel = Vector3(0, 0, speed)
        rates[2] = 0.0
    else:
        # Shear stresses to zero (frictionless platens and membrane carry none): ε̇_ij = gain σ_ij/(2G n dt), 2G
        # taken as the mean affine M (above the affine 2G of a contact network: stable).
        for i, j in ((0, 1), (0, 2), (1, 2)):
            g[i, j] = g[j, i] = max(-p["servo_max_rate"], min(p["servo_max_rate"], p["servo_gain"] * s[i, j] /
                                                               (np.mean(servo["modulus"]) * n * O.dt)))
    O.cell.velGrad = Matrix3(rates[0], g[0, 1], g[0, 2], g[1, 0], rates[1], g[1, 2], g[2, 0], g[2, 1], rates[2])


def settle(goals, tolerance, max_steps):
    """Runs in windows of check_steps until the controlled stresses are within tolerance [Pa] of their goals and no
    stress changed by more than tolerance over the last two windows; returns the steps taken and the largest
    remaining error or drift [Pa]."""
    history, taken = [stress()], 0
    while True:
        run_steps(p["check_steps"])
        taken += p["check_steps"]
        now = stress()
        history.append(now)
        error = max([abs(now[a, a] - goals[a]) for a in range(3) if goals[a] is not None] +
                    ([] if platens else [abs(now[0, 1]), abs(now[0, 2]), abs(now[1, 2])]))
        drift = max(np.max(np.abs(now - h)) for h in history[-3:-1])
        if (len(history) > 2 and error < tolerance and drift < tolerance) or taken >= max_steps:
            return taken, max(error, drift)


def record_state(phase, steps=0, residual=0.0):
    s = stress()
    eps = strains()
    contacts, pairs, virgin, ratio, sliding = contact_census()
    volume = specimen_volume()
    row = {"phase": phase, "axial_strain": float(eps[2]), "lateral_strain": float(0.5 * (eps[0] + eps[1])),
           "sigma_xx": s[0, 0], "sigma_yy": s[1, 1], "sigma_zz": s[2, 2], "sigma_xy": s[0, 1], "sigma_xz": s[0, 2],
           "sigma_yz": s[1, 2], "force_over_max": ratio, "q": s[2, 2] - 0.5 * (s[0, 0] + s[1, 1]),
           "sigma_zz_branch": stress(branch=True)[2, 2] if platens else s[2, 2],
           "mean_stress": np.trace(s) / 3.0, "void_ratio": volume / solid - 1.0, "specimen_height": dims()[2],
           "coordination_number": 2.0 * contacts / count, "pair_coordination_number": 2.0 * pairs / count,
           "contacts": contacts, "virgin_contacts": virgin, "sliding_contacts": sliding,
           "platen_contacts": sum(1 for k in platen_ids for i in O.interactions.withBody(k) if i.isReal) / 2.0,
           "unbalanced_force": utils.unbalancedForce(),
           "steps": steps, "residual_Pa": residual, "time": O.time, "wall_s": time.monotonic() - started}
    dem.recorder.append(**{k: v for k, v in row.items() if k != "phase"}, phase_code=PHASES.index(phase))
    print(f"{phase:>10} ε_a {row['axial_strain']:.3e}  q {row['q']:10.3f} Pa  p' {row['mean_stress'] / 1e3:8.3f} kPa  "
          f"Z {row['coordination_number']:.3f}  virgin {virgin}  sliding {sliding}  steps {steps}  "
          f"residual {residual:.2e} Pa  "
          f"{row['wall_s']:.0f} s", flush=True)
    return row


PHASES = ["confined", "loading", "unloading", "loop_loading", "loop_unloading", "confined_2", "probe_2"]
from railcosim import results  # noqa: E402
dem.recorder = results.DemRecorder(out)


def set_friction(mu):
    """μ of the ballast material (new contacts) and of every existing contact between grains (the platens' stay
    frictionless)."""
    O.materials[material].frictionAngle = math.atan(mu)
    for i in O.interactions:
        if i.isReal and not is_platen_contact(i):
            i.phys.tangensOfFrictionAngle = mu


def confine(goal):
    """The isotropic confinement at μ = confinement_friction: the goal ramps from the present mean stress to goal over
    confinement_ramp_s, then held until equilibrium (every stress within confinement_tolerance × goal of it and
    steady); then μ = friction on every contact, and equilibrium again. Contacts formed at the lower μ lie inside the
    Coulomb cone of the grains' μ: the small-strain probe starts from an elastic network, not from one at the
    verge of sliding everywhere (README: a sample confined at μ = 0.7 sits at Z ≈ 4, marginally stable)."""
    set_friction(p["confinement_friction"])
    steps, residual = confine_at(goal)
    set_friction(p["friction"])
    more, residual = confine_at(goal, ramp=False)
    return steps + more, residual


def confine_at(goal, ramp=True):
    """Servo to the isotropic goal (ramped over confinement_ramp_s, or at once) and on to equilibrium."""
    ramp = max(10, int(round(p["confinement_ramp_s"] / O.dt))) if ramp else 0
    servo.update(goals=[goal] * 3, goal_from=stress().trace() / 3.0, start_iter=O.iter, end_iter=O.iter + ramp)
    for k in range(10 if ramp else 0):
        servo["modulus"] = affine_modulus()
        run_steps(ramp // 10)
    servo["goal_from"] = None
    taken = 0
    while True:  # the network stiffens as contacts form: its affine modulus again every quarter of the allowance
        servo["modulus"] = affine_modulus()
        more, residual = settle([goal] * 3, p["confinement_tolerance"] * goal, p["confinement_max_steps"] // 4)
        taken += more
        if residual < p["confinement_tolerance"] * goal or taken >= p["confinement_max_steps"]:
            return ramp + taken, residual


def strain_levels(first, last, per_decade):
    count = int(round(per_decade * math.log10(last / first)))
    return [first * 10.0 ** (k / per_decade) for k in range(count + 1)]


def probe(phase, levels, goal):
    """Quasi-static axial strain steps: each step moves the axial strain to the next level over ramp_steps steps (the
    lateral stresses servo-held at goal), then settles until every stress is steady within the step's tolerance:
    probe_tolerance × (the step's expected Δq at E = 600 p), no less than probe_tolerance_floor_Pa."""
    rows = []
    for target in levels:
        now = strains()[2]
        servo["modulus"] = affine_modulus()
        servo.update(goals=[goal, goal, None], goal_from=None, strain_from=now, strain_to=target, start_iter=O.iter,
                     end_iter=O.iter + p["ramp_steps"])
        run_steps(p["ramp_steps"])
        tolerance = max(p["probe_tolerance"] * 600.0 * goal * abs(target - now), p["probe_tolerance_floor_Pa"])
        taken, residual = settle([goal, goal, None], tolerance, p["probe_max_steps"])
        rows.append(record_state(phase, p["ramp_steps"] + taken, residual))
    return rows


# 6. Confinement to p, then the probe: loading to probe_strain, unloading until q is back to its value at the start.
#    The probe starts with a hold at ε_a = 0 under its own control (lateral stresses servo-held, axial strain
#    prescribed): switching from the confinement's control moves q by a few Pa before any strain (between platens
#    up to 4 Pa, the increment of q at ε_a = 5e-8), which is not the specimen's response. E is read from the hold on.
steps, residual = confine(pressure)
confined = record_state("confined", steps, residual)
reference_size = dims()
O.saveTmp("confined")
levels = strain_levels(p["first_strain"], p["probe_strain"], p["levels_per_decade"])
loading = probe("loading", [0.0] + levels, pressure)
q0 = loading[0]["q"]
peak = levels[-1]
unload_levels = [peak - d for d in strain_levels(p["first_strain"], peak, p["levels_per_decade"])[:-1]] + [0.0]
for target in unload_levels:
    row = probe("unloading", [target], pressure)[0]
    if row["q"] <= q0:
        break

# 7. The small-strain loop from the confined state (hysteresis: none for elastic normal laws, a loop for the
#    elasto-plastic one), then (elastic laws) the same sample confined at pressure_factor × p for the E0 scaling
#    with p.
O.loadTmp("confined")
reference_size = dims()
loop_levels = strain_levels(p["first_strain"], p["loop_strain"], p["levels_per_decade"])
# The loop starts with a hold at ε_a = 0 under the probe's control, as the probe (section 6): the switch from the
# confinement's control moved q by 7 Pa of the elastic loop's 196 Pa on the periodic cube. It returns to this start.
probe("loop_loading", [0.0] + loop_levels, pressure)
probe("loop_unloading", [p["loop_strain"] - d for d in strain_levels(p["first_strain"], p["loop_strain"],
                                                                      p["levels_per_decade"])[:-1]] + [0.0], pressure)
# The scaling check is for elastic networks, and for the packing's own strain only: the platens' linear contacts add
# a compliance that does not scale with p (case.py)
if p["pressure_factor"] > 0 and not plastic and not platens:
    O.loadTmp("confined")
    reference_size = dims()
    steps, residual = confine(p["pressure_factor"] * pressure)
    record_state("confined_2", steps, residual)
    reference_size = dims()
    probe("probe_2", strain_levels(p["first_strain"], p["scaling_strain"], p["levels_per_decade"]),
          p["pressure_factor"] * pressure)

dem.wall_time_s = time.monotonic() - started
dem.save(clusters=count, spheres=int(len(members)), solid_volume_m3=solid, sample_cache=cache,
         sample_preparation_s=preparation_s, phases=PHASES, confined_q_Pa=q0)
