"""The load run of the sleeper-on-ballast case, written once for both DEM drivers (dem.py on YADE, dem_driver.py
without it): the walls, materials and time step of the bed under the FEM sleeper, and what each window records (the
interface force, the sensors' top-face forces and heights). A driver hands Sensors.record an object with
frames(indices) (body-frame positions and orientations w,x,y,z of those bed bodies), contacts() (preparation's
contact arrays, bed indices; at least every contact of a sensor), interface_force (the force sent to the FEM side, 3)
and surface_force (the stones' force on the surface, 3)."""
import json
import math
import os

import numpy as np

import preparation as prep
import scene as sc


def prepared_bed(p, out):
    """(scene, bed record, bed, bed file attributes) of a load run from the bed bed.py left in `out` (bed.json); sets
    p["duration_s"] to the windows of the pattern (and any rest after it)."""
    scene = sc.build(p)
    with open(os.path.join(out, "bed.json")) as f:
        bed_record = json.load(f)
    bed, attrs = prep.load(bed_record["path"])
    p["duration_s"] = sc.load_run_duration(p)
    return scene, bed_record, bed, attrs


def sleeper_material(p):
    """(E, nu, restitution, friction) of the sleeper's surface: timber's E and nu (its elasticity is FreeFEM's, this
    sets the contact), the ballast's friction and restitution."""
    return (p["sleeper_young"], p["sleeper_poisson"], p["restitution"], math.tan(math.atan(p["friction"])))


def wall_corners(scene, seat):
    """The box's triangles, walls up to 0.1 m above the sleeper's top."""
    length, width, _ = scene["bed"]
    return prep.box_corners(length, width, seat + sc.SLEEPER_SIZE[2] + 0.1)


def time_step(p, scene, critical_time_step):
    """(DEM step, critical step, design loads): critical_step_fraction x the contact law's critical step for the load
    run's design loads (scene.design_contact_loads), `critical_time_step(force, speed)` the driver's; the connection
    then fits the step to fem_dt / subcycles."""
    design = sc.design_contact_loads(p, scene, "load")
    critical = critical_time_step(design["contact_force_n"], design["impact_speed_m_s"])
    return p["critical_step_fraction"] * critical, critical, design


class Sensors:
    """The five sensor blocks (x order) and their readings: pressure = vertical force on the top face / its area
    (Ullrich 2022: the load on the sensor's top face). A contact is on the top face when its point, in the sensor's
    frame, lies within the top face's dilation layer. Read every sensor_period_s (a whole number of windows)."""

    def __init__(self, p, scene, bed):
        sensors = np.flatnonzero(bed.kind == prep.SENSOR)
        self.indices = sensors[np.argsort(bed.position[sensors, 0], kind="stable")]
        self.slot = np.full(len(bed), -1)
        self.slot[self.indices] = np.arange(len(self.indices))
        self.every = max(1, int(round(p["sensor_period_s"] / p["fem_dt"])))  # windows between readings
        self.half_height = 0.5 * sc.SENSOR_SIZE[2]
        self.layer = 2.0 * scene["sensors"]["dilation"]

    def top_forces(self, contacts, positions, orientations):
        """Downward force [N] on each sensor's top face from `contacts` (the sensors' frames: positions,
        orientations in x order)."""
        forces = np.zeros(len(self.indices))
        stones = ~contacts["wall"]
        # `force` acts on `second`; `first` receives the opposite. A wall contact's `second` is a triangle.
        for column, sign, valid in (("second", 1.0, stones), ("first", -1.0, np.ones_like(stones))):
            slots = np.full(len(stones), -1)
            slots[valid] = self.slot[contacts[column][valid]]
            for c in np.flatnonzero(slots >= 0):
                k = slots[c]
                rotation = sc.rotation_matrix(orientations[k])
                if rotation[:, 2] @ (contacts["point"][c] - positions[k]) >= self.half_height - self.layer:
                    forces[k] -= sign * contacts["force"][c][2]
        return forces

    def record(self, driver, window):
        """What window `window` (1, 2, ... since the load run started) records: interface and surface force, the
        sensors' top-face forces and heights (in the first window and every `every` windows, NaN between: reading
        the sensors' frames brings every stone's state back from a GPU)."""
        readings = np.full(len(self.indices), np.nan)
        heights = np.full(len(self.indices), np.nan)
        if window % self.every == 0 or window == 1:
            positions, orientations = driver.frames(self.indices)
            heights = positions[:, 2].copy()
            if window % self.every == 0:
                readings = self.top_forces(driver.contacts(), positions, orientations)
        return dict(interface_force=np.asarray(driver.interface_force, float),
                    surface_force=np.asarray(driver.surface_force, float), sensor_top_force=readings,
                    sensor_height=heights)
