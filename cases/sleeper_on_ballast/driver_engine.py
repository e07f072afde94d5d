"""The standalone driver of the sleeper-on-ballast case: the bed's bodies as stones of the polyhedra library without
YADE (railcosim.polyhedra_driver, ctypes). DriverStage is preparation.StageBase on it (`python3 bed.py`); dem_driver.py
runs the coupled load run on it. The same interface as yade_engine.py, so that one bed file serves both.
"""
import numpy as np

from railcosim.polyhedra_driver import PolyhedraBed

import preparation as prep
import scene as sc

DRIVER = "standalone"


def polyhedra_bed(scene, bed, p, time_step):
    """A PolyhedraBed with the bed's bodies as stones (in the bed's order) and the stones' material, gravity and
    candidate lists of yade_engine.polyhedra_engine."""
    stone, _ = prep.stone_material(scene)
    engine = PolyhedraBed(time_step, stone, gravity=(0, 0, -sc.GRAVITY), max_neighbours=prep.neighbour_limit(scene, bed),
                          max_wall_neighbours=prep.WALL_NEIGHBOURS, large_body_ratio=prep.large_body_ratio(scene, bed),
                          backend=p["polyhedra_backend"])
    density = scene["material"]["density"]
    for i in range(len(bed)):
        engine.add_stone(bed.core(scene, i), bed.dilation[i], density, bed.position[i], bed.orientation[i],
                         bed.velocity[i], bed.angular_velocity[i])
    return engine


class DriverStage(prep.StageBase):
    """A preparation stage as one PolyhedraBed: box walls and plate triangles (frictionless), the bed's stones."""

    DRIVER = DRIVER

    def __init__(self, scene, bed, p, time_step, plate_box=None, wall_top=None):
        super().__init__(scene, bed, p, plate_box)
        _, wall = prep.stone_material(scene)
        length, width, _ = scene["bed"]
        corners = prep.box_corners(length, width, wall_top if wall_top is not None else 1.1 * scene["bed"][2])
        self.plate = []
        if plate_box:
            self.plate = list(range(len(corners), len(corners) + 2))
            corners = np.concatenate([corners, prep.plate_corners(plate_box)])
        self.engine = polyhedra_bed(scene, bed, p, time_step or 1e-6)
        self.engine.set_walls(corners, np.zeros(len(corners), np.int32), [wall])
        self.engine.initialize()
        if time_step is None:  # the first stage: sized by the contact law for the design loads
            design = sc.design_contact_loads(p, scene, "preparation")
            self.engine.dt = p["critical_step_fraction"] * self.engine.critical_time_step(design["contact_force_n"],
                                                                                          design["impact_speed_m_s"])

    @property
    def dt(self):
        return self.engine.dt

    @property
    def time(self):
        return self.engine.time

    @property
    def mean_contacts(self):
        return self.engine.mean_contacts

    def _batch(self):
        self.engine.step(prep.SYNC_INTERVAL)

    def states(self):
        return self.engine.states()[:4]

    def set_plate_velocity(self, velocity):
        self.engine.set_wall_velocity(self.plate, (0.0, 0.0, velocity))

    def plate_force(self):
        return self.engine.wall_force(self.plate)[2]
