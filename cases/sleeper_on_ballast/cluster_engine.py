"""YADE's driver of the sleeper-on-ballast case with sphere clusters (particle_shape = "cluster").

Every stone of the bed is the shape library's cluster of its library stone (cluster_level "coarse": 7-16 spheres,
"fine": 29-45), a YADE clump advanced by QuaternionIntegrator (Zhao & van Wachem 2013), the contacts those of
BallastMat (Hertz-Mindlin with the restitution's viscous damping, Thornton et al. 2013: the law of the polyhedra
kernels and of FemCouplingEngine's mesh contacts). The five sensors are dynamic Box bodies of the ballast's
material (Ig2_Box_Sphere_ScGeom: a box is a flat surface to BallastPhys), the box walls and plates facets.

ClusterStage is preparation.StageBase on these bodies (bed.py with particle_shape = "cluster"); the helpers below
also build dem_cluster.py's load-run scene. A bed body keeps the polyhedron's frame (preparation.Bed: position and
orientation of the library stone's frame); YADE moves a clump in its own centroid and principal axes, so each clump
carries the fixed transform between the two (`offsets`).
"""
import math

import numpy as np

from yade import *  # noqa: F401,F403  (O, utils, the engines and materials)
from yade import utils
from yade.minieigenHP import Quaternion, Vector3

from railcosim.dem import run_steps

import preparation as prep
import yade_engine as ye  # YadeClock
import scene as sc  # also puts the shape library (yade_engines/clusters) on the path
import pack_ballast  # noqa: E402  (the shape library's clump builder)

DRIVER = "yade"


def materials(scene):
    """(stones' material, walls' material) as BallastMats (the ballast's E, nu, density, restitution, friction; the
    walls frictionless), appended to O.materials."""
    m = scene["material"]
    common = dict(young=m["young"], poisson=m["poisson"], density=m["density"], restitution=m["restitution"])
    stone = BallastMat(frictionAngle=math.atan(m["friction"]), label="ballast", **common)
    wall = BallastMat(frictionAngle=0.0, label="walls", **common)
    O.materials.append(stone)
    O.materials.append(wall)
    return stone, wall


def add_bodies(scene, bed, material, level):
    """The bed's stones as clumps of their clusters and its sensors as dynamic boxes of the ballast's material, in the
    bed's order. Returns (ids, offsets): offsets[k] = (arm, rotation) of the bed frame in the clump's frame (None for a
    box, whose frame is the bed's)."""
    ids, offsets = [], []
    for i in range(len(bed)):
        rotation = sc.rotation_matrix(bed.orientation[i])
        if bed.kind[i] == prep.SENSOR:
            body = utils.box(tuple(bed.position[i]), tuple(0.5 * s for s in sc.SENSOR_SIZE), fixed=False,
                             material=material)
            body.state.ori = Quaternion(*bed.orientation[i])
            b = O.bodies.append(body)
            offsets.append(None)
        else:
            spheres, mass, inertia = sc.cluster_of(scene, level, bed.shape[i], bed.size[i])
            b = pack_ballast.addClusterStone({"rotation": rotation, "spheres": spheres, "mass": mass,
                                              "principalInertia": inertia}, bed.position[i], material)
            state = O.bodies[b].state
            clump_rotation = sc.rotation_matrix(_wxyz(state.ori))
            arm = clump_rotation.T @ (bed.position[i] - np.array(tuple(state.pos)))
            offsets.append((arm, clump_rotation.T @ rotation))
        state = O.bodies[b].state
        omega = np.asarray(bed.angular_velocity[i], float)
        lever = np.array(tuple(state.pos)) - bed.position[i]
        state.vel = Vector3(*(np.asarray(bed.velocity[i], float) + np.cross(omega, lever)))
        state.angVel = Vector3(*omega)
        ids.append(b)
    return ids, offsets


def facets(corners, material):
    """Facet bodies of the triangles `corners` (n, 3, 3) as utils.facet makes them (the body at the triangle's
    inscribed-circle centre: Ig2_Facet_Sphere_ScGeom's edge tests assume it; yade_engine.facets' bodies at the origin
    serve the polyhedra engine only). Returns their ids."""
    return [O.bodies.append(utils.facet([Vector3(*c) for c in triangle], material=material)) for triangle in corners]


def _wxyz(q):
    return (q[3], q[0], q[1], q[2])  # minieigen: index 0..2 the vector part, 3 the scalar


def states(ids, offsets):
    """Bed-frame positions, orientations (w,x,y,z), velocities, angular velocities of the bodies `ids`."""
    n = len(ids)
    p, q, v, w = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros((n, 3)), np.zeros((n, 3))
    for k, (b, offset) in enumerate(zip(ids, offsets)):
        s = O.bodies[b].state
        position, velocity, omega = np.array(tuple(s.pos)), np.array(tuple(s.vel)), np.array(tuple(s.angVel))
        if offset is None:
            p[k], q[k], v[k], w[k] = position, _wxyz(s.ori), velocity, omega
            continue
        rotation = sc.rotation_matrix(_wxyz(s.ori))
        arm = rotation @ offset[0]
        p[k], v[k], w[k] = position + arm, velocity + np.cross(omega, arm), omega
        q[k] = sc._quaternion_of(rotation @ offset[1])
    return p, q, v, w


def engines(coupling=None, extra=()):
    """YADE's contact loop for clump members, facets and boxes with the BallastMat law, the coupling engine (load run)
    or `extra` engines, and the Zhao-van Wachem quaternion integrator without numerical damping."""
    return [ForceResetter(),
            InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb(), Bo1_Box_Aabb()]),
            InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                            [Ip2_BallastMat_BallastMat_BallastPhys()], [Law2_ScGeom_BallastPhys_Ballast()]),
            *([coupling] if coupling is not None else []), *extra,
            QuaternionIntegrator(scheme="zhaoVanWachem", damping=0.0, gravity=(0, 0, -sc.GRAVITY), label="integrator")]


def damping_ratio(scene):
    """The viscous damping ratio gamma of the ballast's contacts, as BallastPhys computes it from the restitution
    (Thornton et al. 2013): read off a probe contact of two ballast spheres in an otherwise empty scene (O.reset()
    before and after)."""
    O.reset()
    stone, _ = materials(scene)
    O.engines = engines()
    a = O.bodies.append(utils.sphere((0, 0, 0), 0.01, material=stone))
    b = O.bodies.append(utils.sphere((0, 0, 0.019), 0.01, material=stone))
    gamma = float(utils.createInteraction(a, b).phys.dampingRatio)
    O.reset()
    return gamma


def critical_time_step(scene, bed, level, gamma, force, speed):
    """Critical step of the clusters' contacts for contacts carrying `force` [N] and impacts at `speed` [m/s]
    (whichever are > 0), over the bed's stones: a member sphere of radius r at arm a from its clump's centre of mass
    (contact point at |a| + r) moves, under a contact force, with inverse inertia at most w = 1/M + (|a| + r)^2 / I_min
    (angle_of_repose README, "Clusters": 2.6-5.5 times 1/M over the library). For two equal stones (m* = 1 / (2 w),
    R* = r/2, E* = E / (2 (1 - nu^2))) and a stone on a wall of its material (m* = 1 / w, R* = r, E* = E / (1 - nu^2)):
    Hertz's tangent stiffness k = 2 E* sqrt(R* delta) at the overlap that carries the force (delta = (3F / (4 E*
    sqrt(R*)))^(2/3)) or at the largest overlap of the impact (delta = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5); Johnson
    1985), and the damped central-difference limit 2 sqrt(m*/k) (sqrt(1 + gamma^2) - gamma) (Belytschko et al. 2000;
    kernels/CriticalTimeStep.hpp, whose 3.5 k_t term is the solid sphere's rotation: here in w). The tangential
    spring (4 G*/E* = 2 (1 - nu) / (2 - nu) of k_n) is the softer one."""
    m = scene["material"]
    young, nu = m["young"], m["poisson"]
    smallest = math.inf
    for shape, size in sorted({(int(s), float(d)) for s, d, k in zip(bed.shape, bed.size, bed.kind) if k == prep.STONE}):
        spheres, mass, inertia = sc.cluster_of(scene, level, shape, size)
        reach = np.linalg.norm(spheres[:, :3], axis=1) + spheres[:, 3]
        for radius, arm in zip(spheres[:, 3], reach):
            w = 1.0 / mass + arm ** 2 / float(np.min(inertia))
            for effective_mass, effective_radius, effective_young in ((0.5 / w, 0.5 * radius, young / (2 * (1 - nu * nu))),
                                                                        (1.0 / w, radius, young / (1 - nu * nu))):
                overlaps = []
                if force > 0:
                    overlaps.append((3 * force / (4 * effective_young * math.sqrt(effective_radius))) ** (2.0 / 3.0))
                if speed > 0:
                    overlaps.append((15 * effective_mass * speed ** 2
                                     / (16 * effective_young * math.sqrt(effective_radius))) ** 0.4)
                stiffness = 2 * effective_young * math.sqrt(effective_radius * max(overlaps))
                step = 2 * math.sqrt(effective_mass / stiffness) * (math.sqrt(1 + gamma * gamma) - gamma)
                smallest = min(smallest, step)
    return smallest


def sensor_contacts(sensor_ids, index_of_body):
    """The sensors' contacts as preparation's drivers report them (loadrun.Sensors reads these): {first, second (bed
    indices), wall (False: a box meets no facet), point, normal, force (on second), overlap}. BallastPhys's force acts
    on id2 (Law2_ScGeom_BallastPhys_Ballast applies -F on id1, F on id2); a clump member counts as its clump."""
    rows = []
    for s in sensor_ids:
        for i in O.bodies[s].intrs():
            if not i.isReal:
                continue
            ends = []
            for b in (i.id1, i.id2):
                body = O.bodies[b]
                ends.append(index_of_body[body.clumpId if body.isClumpMember else b])
            rows.append((ends[0], ends[1], tuple(i.geom.contactPoint), tuple(i.geom.normal),
                         tuple(i.phys.normalForce + i.phys.shearForce), float(i.geom.penetrationDepth)))
    n = len(rows)
    return {"first": np.array([r[0] for r in rows], np.int32), "second": np.array([r[1] for r in rows], np.int32),
            "wall": np.zeros(n, bool), "point": np.array([r[2] for r in rows]).reshape(n, 3),
            "normal": np.array([r[3] for r in rows]).reshape(n, 3), "force": np.array([r[4] for r in rows]).reshape(n, 3),
            "overlap": np.array([r[5] for r in rows])}


def mechanical_energy(ids):
    """Kinetic (translation and rotation in the principal axes) plus gravitational energy of the bodies `ids` [J]."""
    energy = 0.0
    for b in ids:
        s = O.bodies[b].state
        spin = s.ori.conjugate() * s.angVel
        energy += (0.5 * s.mass * s.vel.squaredNorm() + 0.5 * sum(s.inertia[j] * spin[j] ** 2 for j in range(3))
                   + s.mass * sc.GRAVITY * s.pos[2])
    return energy


def contact_elastic_energy():
    """Upper bound of the elastic energy held by the scene's contacts [J]: a Hertz contact at force F and overlap delta
    holds 2/5 F delta, its tangential spring at most mu^2 F^2 / (2 k_t) with k_t = 2 (1 - nu) / (2 - nu) x 3F / (2 delta)
    (Johnson 1985): with mu <= 1 and nu >= 0 that is at most F delta / 3; 0.8 F delta in all bounds both."""
    total = 0.0
    for i in O.interactions:
        if i.isReal:
            total += 0.8 * float(i.phys.normalForce.norm()) * max(0.0, float(i.geom.penetrationDepth))
    return total


class ClusterStage(ye.YadeClock, prep.StageBase):
    """A preparation stage as a YADE scene of clumps (O.reset() first): facets, clumps, sensor boxes, the BallastMat
    law, QuaternionIntegrator; the plate's force is summed over every step of a batch (its mean, as the polyhedra
    library reports it)."""

    DRIVER = DRIVER

    def __init__(self, scene, bed, p, time_step, plate_box=None, wall_top=None):
        super().__init__(scene, bed, p, plate_box)
        gamma = damping_ratio(scene) if time_step is None else None
        O.reset()
        self.material, wall = materials(scene)
        length, width, _ = scene["bed"]
        facets(prep.box_corners(length, width, wall_top if wall_top is not None else 1.1 * scene["bed"][2]), wall)
        self.plate = facets(prep.plate_corners(plate_box), wall) if plate_box else []
        self.ids, self.offsets = add_bodies(scene, bed, self.material, p["cluster_level"])
        self.force_sum, self.force_steps = 0.0, 0
        self.batch_force = 0.0
        import __main__
        __main__.cluster_stage_plate_force = self._add_plate_force  # PyRunner's commands run in __main__
        extra = [PyRunner(command="cluster_stage_plate_force()", iterPeriod=1)] if self.plate else []
        O.engines = engines(extra=extra)
        if time_step is None:  # the first stage: sized by the contact law for the design loads
            design = sc.design_contact_loads(p, scene, "preparation")
            time_step = p["critical_step_fraction"] * critical_time_step(
                scene, bed, p["cluster_level"], gamma, design["contact_force_n"], design["impact_speed_m_s"])
        O.dt = time_step
        self.start = O.time

    def _add_plate_force(self):
        self.force_sum += sum(O.forces.f(b)[2] for b in self.plate)
        self.force_steps += 1

    @property
    def mean_contacts(self):
        return O.interactions.countReal()

    def _batch(self):
        self.force_sum, self.force_steps = 0.0, 0
        run_steps(prep.SYNC_INTERVAL)
        self.batch_force = self.force_sum / max(1, self.force_steps)

    def states(self):
        return states(self.ids, self.offsets)

    def stone_volumes(self):
        """Volume of each bed body's cluster [m^3] (0 for the sensors): the clusters' mass / density."""
        density = self.scene["material"]["density"]
        return np.array([0.0 if o is None else O.bodies[b].state.mass / density for b, o in zip(self.ids, self.offsets)])

    def set_plate_velocity(self, velocity):
        for b in self.plate:
            O.bodies[b].state.vel = Vector3(0, 0, velocity)

    def plate_force(self):
        return self.batch_force
