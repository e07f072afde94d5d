"""YADE's driver of the sleeper-on-ballast case: the bed's bodies as YADE bodies advanced by one PolyhedraGpuEngine.

YadeStage is preparation.StageBase on YADE (bed.py under `railcosim yade`); the helpers below also build dem.py's
load-run scene. The standalone driver (driver_engine.py) implements the same interface on the polyhedra library
without YADE.
"""
import math

import numpy as np

from yade import *  # noqa: F401,F403  (O, utils, the engines and materials)
from yade import utils
from yade.minieigenHP import Quaternion, Vector3

from railcosim.dem import run_steps

import preparation as prep
import scene as sc

DRIVER = "yade"


def materials(scene):
    """(stones' material, walls' material) as YADE FrictMats (preparation.stone_material's values: the friction as
    an angle, the walls frictionless), appended to O.materials."""
    m = scene["material"]
    stone = FrictMat(young=m["young"], poisson=m["poisson"], density=m["density"], frictionAngle=math.atan(m["friction"]),
                     label="ballast")
    wall = FrictMat(young=m["young"], poisson=m["poisson"], density=m["density"], frictionAngle=0.0, label="walls")
    O.materials.append(stone)
    O.materials.append(wall)
    return stone, wall


def facets(corners, material):
    """Facet bodies of the triangles `corners` (n, 3, 3): each at the world origin with its corners as vertices, so
    that the polyhedra engine meets the very corner coordinates the standalone driver is given. Returns their ids."""
    ids = []
    for triangle in corners:
        body = utils.facet([Vector3(*c) for c in triangle], material=material)
        body.state.pos = Vector3(0, 0, 0)
        body.shape.vertices = [Vector3(*c) for c in triangle]
        ids.append(O.bodies.append(body))
    return ids


def polyhedra_engine(scene, bed, p, **attributes):
    """The PolyhedraGpuEngine of the bed: gravity, restitution, candidate lists long enough for its largest bodies."""
    return PolyhedraGpuEngine(restitution=scene["material"]["restitution"], gravity=(0, 0, -sc.GRAVITY),
                              maxNeighbours=prep.neighbour_limit(scene, bed), maxWallNeighbours=prep.WALL_NEIGHBOURS,
                              largeBodyRatio=prep.large_body_ratio(scene, bed), backend=p["polyhedra_backend"], label="poly",
                              **attributes)


def add_bodies(scene, bed, material, engine):
    """The bed's bodies as YADE spheres of their bounding radius, each registered with `engine` as a stone with its
    core and dilation; returns their ids (in the bed's order)."""
    ids = []
    for i in range(len(bed)):
        body = utils.sphere(tuple(bed.position[i]), bed.bounding_radius(scene, i), material=material)
        body.state.ori = Quaternion(*bed.orientation[i])
        body.state.vel = Vector3(*bed.velocity[i])
        body.state.angVel = Vector3(*bed.angular_velocity[i])
        b = O.bodies.append(body)
        engine.addStone(b, [Vector3(*v) for v in bed.core(scene, i)], float(bed.dilation[i]))
        ids.append(b)
    return ids


def states(ids):
    """Body-frame positions, orientations (w,x,y,z), velocities, angular velocities of the bodies `ids`."""
    n = len(ids)
    p, q, v, w = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros((n, 3)), np.zeros((n, 3))
    for k, b in enumerate(ids):
        s = O.bodies[b].state
        p[k], v[k], w[k] = tuple(s.pos), tuple(s.vel), tuple(s.angVel)
        q[k] = (s.ori[3], s.ori[0], s.ori[1], s.ori[2])  # minieigen: index 0..2 the vector part, 3 the scalar
    return p, q, v, w


def contacts(engine, index_of_body):
    """The engine's contacts as preparation's drivers report them: {first, second (bed indices; the wall triangle
    for wall contacts), wall, point, normal, force (on second), overlap}."""
    records = engine.contacts()
    n = len(records)
    first, second, wall = np.zeros(n, np.int32), np.zeros(n, np.int32), np.zeros(n, bool)
    point, normal, force, overlap = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    for k, c in enumerate(records):
        first[k] = index_of_body[c["id1"]]
        wall[k] = c["id2"] < 0
        second[k] = c["triangle"] if wall[k] else index_of_body[c["id2"]]
        point[k], normal[k], force[k], overlap[k] = tuple(c["point"]), tuple(c["normal"]), tuple(c["force"]), c["overlap"]
    return {"first": first, "second": second, "wall": wall, "point": point, "normal": normal, "force": force,
            "overlap": overlap}


class YadeClock:
    """A preparation stage's step and time on YADE's clock (O.dt, O.time since the stage's `start`): YadeStage's and
    cluster_engine.ClusterStage's."""

    @property
    def dt(self):
        return O.dt

    @property
    def time(self):
        return O.time - self.start


class YadeStage(YadeClock, prep.StageBase):
    """A preparation stage as a YADE scene (O.reset() first): facets, spheres, one PolyhedraGpuEngine."""

    DRIVER = DRIVER

    def __init__(self, scene, bed, p, time_step, plate_box=None, wall_top=None):
        super().__init__(scene, bed, p, plate_box)
        O.reset()
        self.material, wall = materials(scene)
        length, width, _ = scene["bed"]
        facets(prep.box_corners(length, width, wall_top if wall_top is not None else 1.1 * scene["bed"][2]), wall)
        self.plate = facets(prep.plate_corners(plate_box), wall) if plate_box else []
        self.engine = polyhedra_engine(scene, bed, p, syncInterval=prep.SYNC_INTERVAL)
        self.ids = add_bodies(scene, bed, self.material, self.engine)
        O.engines = [self.engine]
        O.dt = time_step or 1e-6
        self.engine.initialize()
        if time_step is None:  # the first stage: sized by the contact law for the design loads
            design = sc.design_contact_loads(p, scene, "preparation")
            O.dt = p["critical_step_fraction"] * self.engine.criticalTimeStep(design["contact_force_n"],
                                                                              design["impact_speed_m_s"])
        self.start = O.time

    @property
    def mean_contacts(self):
        return self.engine.meanContacts

    def _batch(self):
        run_steps(prep.SYNC_INTERVAL)

    def states(self):
        return states(self.ids)

    def set_plate_velocity(self, velocity):
        self.engine.setWallVelocity(self.plate, (0, 0, velocity))

    def plate_force(self):
        return self.engine.wallForce(self.plate)[2]
