"""Bed preparation of the sleeper-on-ballast case (Ullrich 2022 Fig. 6.4), written once for every DEM driver.

generate, settle, compact, trim, sensors, second layer, compact, trim, seat: the stages of scene.preparation_stages,
each on a fresh polyhedra system (a `Stage`) built from the previous stage's bodies. A Stage is made by the driver
that runs the bed: YADE's PolyhedraGpuEngine (yade_engine.YadeStage, in `railcosim yade bed.py`) or the polyhedra
library without YADE (driver_engine.DriverStage, by ctypes: `python3 bed.py`, the GPU machine's path); both implement
the small interface of StageBase, and every decision of the preparation (when a layer has landed, where the plate
goes, what is trimmed) is made here, from the states the stage reports. Given the same stones, both drivers give the
same bed, bit for bit, on the CPU reference with one thread (tests/drivers/driver_equivalence.py).
A cluster bed (particle_shape = "cluster": cluster_engine.ClusterStage, YADE's clumps) is made from the polyhedra bed
of the same parameters by prepare_clusters: its stones replaced by their clusters, then the stages settle and seat.
numpy and h5py only.
"""
import json
import math
import os
import sys
import time

import numpy as np

CASE_DIR = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, CASE_DIR)
import scene as sc  # noqa: E402
from railcosim import bedcache  # noqa: E402  (scene.py put it on the path)

STONE, SENSOR = 0, 1
# Wall candidates per stone: a large stone at a box corner under the sleeper meets the walls' and the sleeper's
# triangles (the sleeper's bottom face is 80 triangles of 0.11-0.15 x 0.1 m).
WALL_NEIGHBOURS = 32
# Bodies larger than every stone by this factor stay out of the polyhedra system's neighbour grid (PolyhedraSystem's
# largeBodyRatio, large_body_ratio below): the sensor blocks (3-8 x the largest stone's bounding radius), which would
# otherwise set the grid's cell size. The factor only covers the roundoff between this module's and the library's radii.
LARGE_BODY_MARGIN = 1.05
SYNC_INTERVAL = 100      # DEM steps per batch of the polyhedra engine (the plates are steered once per batch)
CHUNK_S = 0.01           # simulated time between settling checks and progress lines [s]
# Plates (compaction, seating) are steered by a force servo once per batch (PlateServo).
SERVO_BATCHES = 4             # time constant of the servo [batches]: a 20 Hz cycle spans 12 of them at 1e-5 s steps
SERVO_TRAVEL = 0.01           # m: the softest bed assumed builds the target force over this travel
PLATE_SPEED = 0.5             # m/s, fastest servo motion and lift-off
APPROACH_SPEED = 1.0          # m/s, plate speed down until it bears 5 % of its first target (stones hit at most
                              # this much faster than they fall, below the time step's design impact speed)
APPROACH_LIMIT = 0.5          # s: the pattern starts after this long even if the plate has not reached its first target


def parameters_from_command_line(argv):
    """(p, out) from PARAMETERS.json OUTDIR, or from case.toml with --smoke and --set name=value (out: None)."""
    if len(argv) == 3 and argv[1].endswith(".json"):
        with open(argv[1]) as f:
            return json.load(f), argv[2]
    import tomllib
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(CASE_DIR)), "python"))
    from railcosim import parameters
    with open(os.path.join(CASE_DIR, "case.toml"), "rb") as f:
        config = tomllib.load(f)
    words = [a for a in argv[1:] if a != "--set"]
    p = parameters.resolve_parameters(config, "--smoke" in words, [w for w in words if w != "--smoke"])
    problems = parameters.check_parameters(p, config) + sc.check(p)
    if problems:
        raise SystemExit("bed.py: " + "; ".join(problems))
    return p, None


class Bed:
    """The bodies between stages: kind (stone/sensor), library shape, size, dilation and the kinematic state
    of each body frame (position, orientation w,x,y,z, velocity, angular velocity)."""

    FIELDS = ("kind", "shape", "size", "dilation", "position", "orientation", "velocity", "angular_velocity")

    def __init__(self):
        self.kind = np.zeros(0, int)
        self.shape = np.zeros(0, int)
        self.size = np.zeros(0)
        self.dilation = np.zeros(0)
        self.position = np.zeros((0, 3))
        self.orientation = np.zeros((0, 4))
        self.velocity = np.zeros((0, 3))
        self.angular_velocity = np.zeros((0, 3))

    def __len__(self):
        return len(self.kind)

    def add(self, kind, shape, size, dilation, positions, orientations):
        n = len(positions)
        self.kind = np.concatenate([self.kind, np.full(n, kind)])
        self.shape = np.concatenate([self.shape, np.asarray(shape, int)])
        self.size = np.concatenate([self.size, np.asarray(size, float)])
        self.dilation = np.concatenate([self.dilation, np.asarray(dilation, float)])
        self.position = np.vstack([self.position, positions])
        self.orientation = np.vstack([self.orientation, orientations])
        self.velocity = np.vstack([self.velocity, np.zeros((n, 3))])
        self.angular_velocity = np.vstack([self.angular_velocity, np.zeros((n, 3))])

    def keep(self, mask):
        for field in self.FIELDS:
            setattr(self, field, getattr(self, field)[mask])

    def core(self, scene, i):
        if self.kind[i] == SENSOR:
            return sc.sensor_core(scene)[0]
        return sc.stone_core(scene, self.shape[i], self.size[i])[0]

    def bounding_radius(self, scene, i):
        return float(np.max(np.linalg.norm(self.core(scene, i), axis=1))) + self.dilation[i]

    def top(self, scene, where=None):
        """Highest point of the bodies' bounding spheres, over the footprint where=(x0, x1, y0, y1) if given."""
        return max(self.position[i][2] + self.bounding_radius(scene, i) for i in range(len(self))
                   if where is None or (where[0] <= self.position[i][0] <= where[1]
                                        and where[2] <= self.position[i][1] <= where[3]))

    def exact_top(self, scene, where):
        """Highest point of the dilated bodies centred over the footprint where=(x0, x1, y0, y1): highest rotated core
        vertex + r_d."""
        top = -1e300
        for i in range(len(self)):
            x, y = self.position[i][:2]
            if where[0] <= x <= where[1] and where[2] <= y <= where[3]:
                row = sc.rotation_matrix(self.orientation[i])[2]
                top = max(top, self.position[i][2] + float(np.max(self.core(scene, i) @ row)) + self.dilation[i])
        return top


class StageBase:
    """One stage's polyhedra system: the box walls (frictionless, up to `wall_top`), an optional plate (two triangles
    facing down over plate_box = (x0, x1, y0, y1, z)), every body of the bed as a stone. A driver implements
    __init__ (building it: the first stage, time_step None, sizes the step by the contact law for the design loads,
    scene.design_contact_loads x critical_step_fraction), `dt`, `time` (since the stage began), _batch() (one batch of
    SYNC_INTERVAL steps), states() (body-frame positions, orientations w,x,y,z, velocities, angular velocities of the
    bed's bodies, in its order), `mean_contacts`, set_plate_velocity(vz) and plate_force() (vertical force of the
    stones on the plate, mean over the last batch [N]). The plate's height is followed here: it moves at the velocity
    set for whole batches, as the library moves it."""

    def __init__(self, scene, bed, p, plate_box):
        self.scene, self.bed, self.p = scene, bed, p
        self.plate_z = plate_box[4] if plate_box else None
        self.plate_velocity = 0.0

    def run(self, duration):
        """Advances about `duration` seconds, in whole batches (at least one)."""
        self.run_steps(max(SYNC_INTERVAL, int(round(duration / self.dt / SYNC_INTERVAL)) * SYNC_INTERVAL))

    def run_steps(self, steps):
        for _ in range(steps // SYNC_INTERVAL):
            self._batch()
            if self.plate_z is not None:
                self.plate_z += self.plate_velocity * (SYNC_INTERVAL * self.dt)

    def steer_plate(self, velocity):
        self.plate_velocity = velocity
        self.set_plate_velocity(velocity)

    def speeds(self):
        velocities = self.states()[2]
        return np.linalg.norm(velocities[self.bed.kind == STONE], axis=1)

    def finish(self):
        """Copies the bodies' state back into the bed."""
        self.bed.position, self.bed.orientation, self.bed.velocity, self.bed.angular_velocity = self.states()


def box_corners(length, width, height):
    """Floor and four side walls of the box as triangles (10, 3, 3), normals into the box."""
    c = np.array([(0, 0, 0), (length, 0, 0), (length, width, 0), (0, width, 0)], float)
    t = c + (0, 0, height)
    triangles = [(c[0], c[1], c[2]), (c[0], c[2], c[3])]
    for k in range(4):
        a, b = k, (k + 1) % 4
        triangles += [(c[a], t[b], c[b]), (c[a], t[a], t[b])]
    return np.array(triangles)


def plate_corners(box):
    """A horizontal plate over x0..x1, y0..y1 at height z, facing down: triangles (2, 3, 3)."""
    x0, x1, y0, y1, z = box
    c = np.array([(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)], float)
    return np.array([(c[0], c[2], c[1]), (c[0], c[3], c[2])])


def stone_material(scene):
    """(E, nu, restitution, friction coefficient) of the stones, and of the smooth box walls and plates (frictionless:
    mirror planes of a slice, the box's unknown wall friction left out). The friction coefficient goes through
    tan(atan(mu)), as YADE's FrictMat stores an angle."""
    m = scene["material"]
    stone = (m["young"], m["poisson"], m["restitution"], math.tan(math.atan(m["friction"])))
    return stone, (m["young"], m["poisson"], m["restitution"], math.tan(0.0))


def large_body_ratio(scene, bed, radii=None):
    """PolyhedraSystem's largeBodyRatio for the bed: just above its largest stone over the median bounding radius, so
    that only bodies larger than every stone (the sensor blocks) are large. A fixed ratio would put a wide
    gradation's largest stones out of the grid as well (the piecewise one's reach 3.6 x the median), and every stone
    would list them all: a 222,000-stone layer ran the H100 out of memory with a ratio of 2.5."""
    if radii is None:
        radii = np.array([bed.bounding_radius(scene, i) for i in range(len(bed))])
    stones = radii[bed.kind == STONE]
    return LARGE_BODY_MARGIN * float(np.max(stones)) / float(np.median(radii)) if len(stones) else 0.0


def neighbour_limit(scene, bed):
    """Candidate list length of the bed. The polyhedra system keeps one length for all stones. Bodies above
    large_body_ratio x the median bounding radius (the sensor blocks) are large: they
    list no stones, each stone lists the large bodies within its reach. The largest other body lists up to every stone
    within its bounding sphere plus theirs: 1.5 x the stones of mean size that fit, at the assumed porosity, in the
    shell between that body and the sphere of its bounding radius plus a mean stone's; plus every large body."""
    radii = np.array([bed.bounding_radius(scene, i) for i in range(len(bed))])
    large = radii > large_body_ratio(scene, bed, radii) * np.median(radii)
    largest = int(np.argmax(np.where(large, -1.0, radii)))
    own = math.prod(sc.SENSOR_SIZE) if bed.kind[largest] == SENSOR else sc.stone_volume(scene, bed.shape[largest],
                                                                                          bed.size[largest])
    shell = 4.0 / 3.0 * math.pi * (radii[largest] + np.mean(radii[bed.kind == STONE])) ** 3 - own
    return int(max(24, 1.5 * (1 - sc.ASSUMED_POROSITY) * shell / sc.mean_stone_volume(scene) + np.sum(large)))


def say(text):
    print(f"[bed {time.monotonic() - WALL_START:7.1f} s] {text}", flush=True)


# ---------------------------------------------------------------------------------------------------
# The stages
# ---------------------------------------------------------------------------------------------------
def generate(Stage, scene, bed, rng, z_high, p, time_step, log, name):
    """Adds the stones of a layer up to z_high above the current bed, lets everything settle."""
    length, width, _ = scene["bed"]
    floor = 0.0 if len(bed) == 0 else bed.top(scene)
    z_low = 0.0 if len(bed) == 0 else scene["first_trim"]
    stones = sc.layer_stones(scene, rng, z_low, z_high)
    cloud = sc.place_cloud(scene, stones, (0.0, length, 0.0, width, floor + 1e-3), rng)
    dilations = [sc.stone_core(scene, s, d)[1] for s, d in stones]
    bed.add(STONE, [s for s, _ in stones], [d for _, d in stones], dilations, cloud["positions"], cloud["orientations"])
    say(f"{name}: {len(stones)} stones generated in a cloud from z = {floor:.3f} to {cloud['top']:.3f} m "
        f"({len(bed)} bodies in all)")
    stage = Stage(scene, bed, p, time_step, wall_top=cloud["top"] + 0.05)
    settle(stage, p["settle_max_s"], p["settle_speed_m_s"], log, name)
    stage.finish()
    return stage


def settle(stage, longest, speed, log, name):
    """Runs until the stones' mean speed is below `speed` (after at least 0.05 s) or for `longest` seconds."""
    start, wall = stage.time, time.monotonic()
    while True:
        stage.run(CHUNK_S)
        v = stage.speeds()
        elapsed = stage.time - start
        if int(round(elapsed / CHUNK_S)) % 5 == 0:
            say(f"{name}: t = {elapsed:.3f} s, mean speed {np.mean(v):.4f} m/s, max {np.max(v):.3f} m/s, "
                f"contacts/stone {2 * stage.mean_contacts / max(1, len(v)):.2f}")
        if (elapsed >= 0.05 and np.mean(v) < speed) or elapsed >= longest:
            break
    log.append({"stage": name, "simulated_s": stage.time - start, "wall_s": time.monotonic() - wall, "bodies": len(stage.bed),
                "mean_speed_m_s": float(np.mean(v)), "max_speed_m_s": float(np.max(v))})


class PlateServo:
    """Force control of a plate: v = -(F_target - F) / (K tau), |v| <= PLATE_SPEED, with K the bed's stiffness under the
    plate estimated on the way (secant dF/dz of the last batches, smoothed; at least the stiffness that builds the
    target over SERVO_TRAVEL) and tau = SERVO_BATCHES batches, so that the plate closes the gap in about tau
    whatever the bed's stiffness, loose or dense."""

    def __init__(self, scale):
        self.stiffness = scale / SERVO_TRAVEL
        self.floor = self.stiffness
        self.previous = None

    def velocity(self, height, force, target, dt):
        if self.previous is not None:
            dz, df = height - self.previous[0], force - self.previous[1]
            if dz < -1e-7 and df > 0:
                self.stiffness = max(self.floor, 0.7 * self.stiffness + 0.3 * df / -dz)
        self.previous = (height, force)
        speed = (target - force) / (self.stiffness * SERVO_BATCHES * SYNC_INTERVAL * dt)
        return -max(-PLATE_SPEED, min(PLATE_SPEED, speed))


def drive_plate(stage, target, duration, log, name, settle_tolerance=None):
    """Lowers the plate at APPROACH_SPEED to the first contact and on with PlateServo until it carries F_target(0), then
    follows F_target(tau) (tau: time since then) with PlateServo for `duration` s (or, with settle_tolerance, until the force stays within that fraction
    of a constant target with the plate at rest for 10 batches). Returns the plate's height and its history
    (t, height, force, target)."""
    servo = PlateServo(max(target(0.0), target(0.25 * duration)))
    contact_time, wall, history, calm = None, time.monotonic(), [], 0
    stage.steer_plate(-APPROACH_SPEED)
    while True:
        stage.run_steps(SYNC_INTERVAL)
        force, height, t = stage.plate_force(), stage.plate_z, stage.time
        if contact_time is None and (force >= target(0.0) or t > APPROACH_LIMIT):
            contact_time = t  # the pattern starts once the plate carries its first target (or took too long)
        if contact_time is None:
            # Down at APPROACH_SPEED through stones still falling or loose on top; the servo once the plate bears.
            servo_velocity = servo.velocity(height, force, target(0.0), stage.dt)
            velocity = servo_velocity if force > 0.05 * target(0.0) else -APPROACH_SPEED
            stage.steer_plate(velocity)
            continue
        tau = t - contact_time
        velocity = servo.velocity(height, force, target(tau), stage.dt)
        stage.steer_plate(velocity)
        history.append((t, height, force, target(tau)))
        if len(history) % 20 == 0:
            say(f"{name}: t = {t:.3f} s, plate at z = {height:.4f} m, force {force / 1e3:.3f} kN "
                f"(target {target(tau) / 1e3:.3f} kN), bed stiffness {servo.stiffness:.3g} N/m")
        if settle_tolerance is None and tau >= duration:
            break
        if settle_tolerance is not None:
            calm = calm + 1 if abs(force - target(tau)) < settle_tolerance * target(tau) and abs(velocity) < 1e-3 else 0
            if calm >= 10 or tau >= duration:
                break
    stage.steer_plate(0.0)
    log.append({"stage": name, "simulated_s": stage.time, "wall_s": time.monotonic() - wall,
                "bodies": len(stage.bed), "plate_height_m": height, "plate_force_n": force,
                "bed_stiffness_n_m": servo.stiffness})
    return height, np.array(history)


def lift_plate(stage, log, name):
    """Raises the plate off the bed at PLATE_SPEED until it carries nothing for 10 batches."""
    free = 0
    stage.steer_plate(PLATE_SPEED)
    while free < 10:
        stage.run_steps(SYNC_INTERVAL)
        free = free + 1 if abs(stage.plate_force()) == 0.0 else 0
    stage.steer_plate(0.0)


def compact(Stage, scene, bed, p, time_step, log, name):
    """A plate over the whole bed comes down onto it and presses it with a force cycling sinusoidally between
    (1 -+ amplitude) x the compaction pressure x area for the given cycles, then lifts off."""
    length, width, _ = scene["bed"]
    gap = bed.exact_top(scene, (0, length, 0, width)) + 2e-3
    stage = Stage(scene, bed, p, time_step, plate_box=(0, length, 0, width, gap), wall_top=gap + 0.05)
    mean = p["compaction_pressure_kPa"] * 1e3 * length * width
    f, a = p["compaction_frequency_hz"], p["compaction_amplitude"]
    target = lambda tau: mean * (1.0 - a * math.cos(2 * math.pi * f * tau)) if tau > 0 else mean * (1 - a)
    say(f"{name}: plate from z = {gap:.3f} m, force {mean * (1 - a) / 1e3:.1f}-{mean * (1 + a) / 1e3:.1f} kN at {f:g} Hz "
        f"for {p['compaction_cycles']} cycles")
    height, history = drive_plate(stage, target, p["compaction_cycles"] / f, log, name)
    lift_plate(stage, log, name)
    stage.finish()
    return history


def trim(scene, bed, height, with_sensors, log, name):
    """Removes stones centred above `height` (and, with_sensors, those reaching into a sensor's box)."""
    before = len(bed)
    keep = ~((bed.kind == STONE) & (bed.position[:, 2] > height))
    if with_sensors:
        # A stone reaches into a sensor's box when the box and the stone's axis-aligned bounds (rotated core + r_d)
        # overlap: tighter than its bounding sphere, so that the sensor's bed is not dug out below it.
        half = np.array(sc.SENSOR_SIZE) / 2.0
        for i in range(len(bed)):
            if not keep[i] or bed.kind[i] != STONE:
                continue
            world = bed.core(scene, i) @ sc.rotation_matrix(bed.orientation[i]).T + bed.position[i]
            low, high = world.min(axis=0) - bed.dilation[i], world.max(axis=0) + bed.dilation[i]
            for centre in scene["sensors"]["centres"]:
                if np.all(high > np.asarray(centre) - half) and np.all(low < np.asarray(centre) + half):
                    keep[i] = False
                    break
    bed.keep(keep)
    bed.velocity[:] = 0.0
    bed.angular_velocity[:] = 0.0
    say(f"{name}: {before - len(bed)} stones removed, {len(bed)} bodies left")
    if with_sensors:
        core, dilation = sc.sensor_core(scene)
        n = len(scene["sensors"]["centres"])
        bed.add(SENSOR, [-1] * n, [sc.SENSOR_SIZE[0]] * n, [dilation] * n, np.array(scene["sensors"]["centres"]),
                np.tile([1.0, 0, 0, 0], (n, 1)))
        say(f"{name}: 5 sensor blocks placed, tops at z = {scene['sensors']['top']:.3f} m")
    log.append({"stage": name, "removed": before - len(bed) + (5 if with_sensors else 0), "bodies": len(bed)})


def seat(Stage, scene, bed, p, time_step, log, name, load):
    """A rigid plate of the sleeper's footprint comes down onto the bed and holds the sleeper's weight plus the
    seating load until at rest; its height is where the sleeper's bottom face starts."""
    x0, y0 = scene["sleeper"]["origin"]
    box = (x0, x0 + sc.SLEEPER_SIZE[0], y0, y0 + sc.SLEEPER_SIZE[1])
    gap = bed.exact_top(scene, (box[0] - 0.1, box[1] + 0.1, box[2] - 0.1, box[3] + 0.1)) + 1e-3
    stage = Stage(scene, bed, p, time_step, plate_box=box + (gap,), wall_top=gap + 0.05)
    say(f"{name}: sleeper footprint plate from z = {gap:.4f} m to {load:.1f} N")
    height, history = drive_plate(stage, lambda tau: load, 0.3, log, name, settle_tolerance=0.02)
    stage.finish()
    return height, history


class StageCheckpoints:
    """The preparation's state after each finished stage, in one file beside the bed file (PATH.stages.h5): the bed's
    bodies, the stage log, the random generator's state, the time step and the plate histories. A preparation that is
    stopped (a run's time limit, a GPU machine's 10-minute calls) goes on from the last finished stage when started
    again with the same parameters, and gives the same bed as one run through: every stage starts from the bodies
    alone, on a fresh system. Removed once the bed file is written."""

    def __init__(self, path):
        self.path = path + ".stages.h5"

    def load(self, bed, rng):
        """(finished stage names, log, dt, plates) of the file, the bed and the generator set to its state."""
        if not os.path.isfile(self.path):
            return [], [], None, {}
        import h5py
        with h5py.File(self.path, "r") as f:
            for field in Bed.FIELDS:
                setattr(bed, field, f[field][()])
            plates = {name: f[f"plate/{name}"][()] for name in f.get("plate", {})}
            rng.bit_generator.state = json.loads(f.attrs["rng"])
            done, log = json.loads(f.attrs["done"]), json.loads(f.attrs["log"])
            dt = float(f.attrs["dt"])
        say(f"resuming after stage {done[-1]} from {self.path} ({len(bed)} bodies)")
        return done, log, dt, plates

    def save(self, done, bed, rng, log, dt, plates):
        import h5py
        temporary = f"{self.path}.{os.getpid()}.tmp"
        with h5py.File(temporary, "w") as f:
            for field in Bed.FIELDS:
                f.create_dataset(field, data=getattr(bed, field))
            for name, history in plates.items():
                f.create_dataset(f"plate/{name}", data=history)
            f.attrs["rng"] = json.dumps(rng.bit_generator.state)
            f.attrs["done"] = json.dumps(done)
            f.attrs["log"] = json.dumps(log)
            f.attrs["dt"] = dt
        os.replace(temporary, self.path)

    def remove(self):
        if os.path.isfile(self.path):
            os.remove(self.path)


def prepare(p, path, Stage):
    """Runs the stages (resuming after the last finished one, StageCheckpoints) and writes the bed file."""
    scene = sc.build(p)
    rng = np.random.default_rng(p["seed"])
    say(sc.describe(p))
    bed = Bed()
    checkpoints = StageCheckpoints(path)
    done, log, dt, plates = checkpoints.load(bed, rng)
    stages = {s["name"]: s for s in scene["stages"]}
    seat_height = None

    def layer1():
        nonlocal dt
        dt = generate(Stage, scene, bed, rng, stages["layer1"]["z_high"], p, None, log, "layer1").dt
        design = sc.design_contact_loads(p, scene, "preparation")
        say(f"time step {dt:.3e} s: {p['critical_step_fraction']:g} x the critical step of the smallest stone for "
            f"contacts of {design['contact_force_n']:.0f} N and impacts at {design['impact_speed_m_s']:.2f} m/s")

    def trim2():
        trim(scene, bed, scene["final_trim"], False, log, "trim2")
        stage = Stage(scene, bed, p, dt)
        settle(stage, p["trim_settle_s"], 0.0, log, "trim2")
        stage.finish()

    def seat_plate():
        nonlocal seat_height
        seat_height, plates["seat"] = seat(Stage, scene, bed, p, dt, log, "seat", stages["seat"]["load_n"])

    sequence = [("layer1", layer1),
                ("compact1", lambda: plates.update(compact1=compact(Stage, scene, bed, p, dt, log, "compact1"))),
                ("trim1", lambda: trim(scene, bed, scene["first_trim"], True, log, "trim1")),
                ("layer2", lambda: generate(Stage, scene, bed, rng, stages["layer2"]["z_high"], p, dt, log, "layer2")),
                ("compact2", lambda: plates.update(compact2=compact(Stage, scene, bed, p, dt, log, "compact2"))),
                ("trim2", trim2), ("seat", seat_plate)]
    for name, run in sequence:
        if name in done:
            continue
        run()
        done.append(name)
        if name != "seat":
            checkpoints.save(done, bed, rng, log, dt, plates)
    save(path, p, scene, bed, log, seat_height, dt, plates, Stage.DRIVER)
    checkpoints.remove()
    return log


def save(path, p, scene, bed, log, seat_height, time_step, plates, driver, stone_volumes=None):
    """Writes the bed file whole (a temporary name, then a rename): bodies, seat height, the stage log.
    stone_volumes: the stones' volumes where they are not the dilated polyhedra's (clusters)."""
    import h5py
    stones = bed.kind == STONE
    if stone_volumes is None:
        volume = sum(sc.stone_volume(scene, s, d) for s, d in zip(bed.shape[stones], bed.size[stones]))
    else:
        volume = float(np.sum(np.asarray(stone_volumes)[stones]))
    sensor_volume = np.sum(bed.kind == SENSOR) * math.prod(sc.SENSOR_SIZE)
    length, width, _ = scene["bed"]
    porosity = 1.0 - (volume + sensor_volume) / math.prod(scene["bed"])
    os.makedirs(os.path.dirname(path), exist_ok=True)
    temporary = f"{path}.{os.getpid()}.tmp"
    with h5py.File(temporary, "w") as f:
        for field in Bed.FIELDS:
            f.create_dataset(field, data=getattr(bed, field))
        for name, history in plates.items():
            f.create_dataset(f"plate/{name}", data=history)  # t, height, force, target
        f.attrs["key"] = sc.bed_key(p)
        f.attrs["parameters"] = json.dumps(sc.bed_parameters(p))
        f.attrs["stage_log"] = json.dumps(log)
        f.attrs["seat_height_m"] = seat_height
        f.attrs["time_step_s"] = time_step
        f.attrs["stones"] = int(np.sum(stones))
        f.attrs["porosity"] = porosity
        f.attrs["size_scale"] = scene["size_scale"]
        f.attrs["driver"] = driver
        f.attrs["preparation_version"] = sc.PREPARATION_VERSION
        f.attrs["units"] = "SI (m, s, N); orientation w,x,y,z of the body frame; kind 0 stone, 1 sensor"
    os.replace(temporary, path)
    say(f"bed saved: {path} ({int(np.sum(stones))} stones, porosity {porosity:.3f}, sleeper bottom at {seat_height:.4f} m)")


def polyhedron_parameters(p):
    """The parameters of the polyhedra bed a cluster bed is made from: p's, as polyhedra (cluster_level at case.toml's
    default, which a polyhedra bed's key holds: the polyhedra runs' own bed is reused)."""
    return {**p, "particle_shape": "polyhedron", "cluster_level": "coarse"}


def prepare_clusters(p, path, Stage, polyhedron_stage):
    """The cluster bed (particle_shape = "cluster"): the polyhedra bed of the same parameters (prepared first with
    `polyhedron_stage` unless its file is kept), each stone replaced by its library cluster at the same pose and size
    (the Stage puts it inside the dilated polyhedron, so no two clusters overlap), let settle under gravity as a
    generated layer does (settle_max_s, settle_speed_m_s; the clusters are thinner than the polyhedra and the bed
    sinks onto them), then seated as the polyhedra bed was (stage seat). The step is the clusters' contact law's for
    the design loads (the Stage's first stage)."""
    source = polyhedron_parameters(p)
    source_path = sc.bed_path(source)
    with bedcache.exclusive(source_path) as reused:
        if reused:
            say(f"polyhedra bed found: {source_path}")
        else:
            say(f"preparing the polyhedra bed first: {source_path}")
            prepare(source, source_path, polyhedron_stage)
    bed, attrs = load(source_path)
    scene = sc.build(p)
    log = json.loads(attrs["stage_log"])
    log.append({"stage": "clusters", "source_bed": source_path, "bodies": len(bed),
                "source_seat_height_m": float(attrs["seat_height_m"]), "source_porosity": float(attrs["porosity"])})
    bed.velocity[:] = 0.0
    bed.angular_velocity[:] = 0.0
    stage = Stage(scene, bed, p, None)
    dt = stage.dt
    design = sc.design_contact_loads(p, scene, "preparation")
    say(f"{len(bed)} bodies as {p['cluster_level']} clusters; time step {dt:.3e} s: {p['critical_step_fraction']:g} x the "
        f"clusters' critical step for contacts of {design['contact_force_n']:.0f} N and impacts at "
        f"{design['impact_speed_m_s']:.2f} m/s")
    volumes = stage.stone_volumes()
    settle(stage, p["settle_max_s"], p["settle_speed_m_s"], log, "clusters")
    stage.finish()
    seat_load = {s["name"]: s for s in scene["stages"]}["seat"]["load_n"]
    seat_height, history = seat(Stage, scene, bed, p, dt, log, "seat", seat_load)
    save(path, p, scene, bed, log, seat_height, dt, {"seat": history}, Stage.DRIVER, stone_volumes=volumes)
    return log


def load(path):
    """(Bed, attrs) of a bed file."""
    import h5py
    bed = Bed()
    with h5py.File(path, "r") as f:
        for field in Bed.FIELDS:
            setattr(bed, field, f[field][()])
        attrs = dict(f.attrs)
    return bed, attrs


def stone_figures(scene, bed):
    """The bed's stones in figures: mean triangles of their cores (triangles_per_stone), mean and largest
    characteristic length [m]."""
    stones = bed.kind == STONE
    triangles = np.array([len(t["triangles"]) for t in sc.templates(scene)])
    return {"mean_triangles_per_stone": float(np.mean(triangles[bed.shape[stones]])),
            "mean_stone_size_m": float(np.mean(bed.size[stones])), "max_stone_size_m": float(np.max(bed.size[stones]))}


def main(argv, Stage, polyhedron_stage=None):
    """bed.py's command line: prepares the bed of the parameters with `Stage`'s driver unless its file exists (clusters:
    from the polyhedra bed, prepared with `polyhedron_stage` unless kept; prepare_clusters)."""
    p, out = parameters_from_command_line(argv)
    path = sc.bed_path(p)
    with bedcache.exclusive(path) as reused:
        if reused:
            say(f"bed found: {path} (key {sc.bed_key(p)}), no preparation")
        elif p["particle_shape"] == "cluster":
            prepare_clusters(p, path, Stage, polyhedron_stage)
        else:
            prepare(p, path, Stage)
    bed, attrs = load(path)
    record = {"path": path, "key": sc.bed_key(p), "reused": reused, "stones": int(attrs["stones"]),
              "porosity": float(attrs["porosity"]), "seat_height_m": float(attrs["seat_height_m"]),
              "size_scale": float(attrs["size_scale"]), **stone_figures(sc.build(p), bed),
              "stage_log": json.loads(attrs["stage_log"]),
              "driver": attrs.get("driver", "yade"), "preparation_version": int(attrs.get("preparation_version", 1)),
              "wall_time_s": time.monotonic() - WALL_START}
    if out:
        with open(os.path.join(out, "bed.json"), "w") as f:
            json.dump(record, f, indent=2)
    print(json.dumps({k: v for k, v in record.items() if k != "stage_log"}), flush=True)


WALL_START = time.monotonic()
