# The thesis's own measure of the bed's support, k_sub (Irazábal 2017 §7.2.1: a vertical force ramped on one sleeper,
# the slope of force against its settlement), on this case's bed, DEM only: the sleepers are rigid YADE boxes on the
# packed bed of railcosim.track (the coupled run's bed, from the same cache), the force acts on the loaded sleeper
# alone, without rail or pads. It separates what the bed and the base give from what the FreeFEM track adds.
# Options that take parts away (README, "The bed's own support"): --rigid-base (the base wall's E x 1000),
# --locked (ballast-ballast mu and eta_r 10: no sliding or rolling between grains), --cycles N (N unloadings to 10 %
# and reloadings before the hold). --restitution E gives every contact the restitution E (the thesis's 0, Table 7.1),
# --rolling-friction ETA the grains' eta_r (0.6: cases/angle_of_repose's calibration), on the cached bed, which was
# packed and rested with the case's values.
# Run: ./railcosim yade cases/track_stiffness/sleeper_test.py OUT [--smoke] [--set KEY=VALUE ...] [--seat-load N]
#      [--rigid-base] [--locked] [--cycles N] [--restitution E] [--rolling-friction ETA]
# Writes OUT/sleeper_test.json and OUT/sleeper_test.csv (time, force, settlements, base force).
import argparse
import json
import math
import os
import sys
import time

import numpy as np

from railcosim import parameters, track
from railcosim.case import load_case
from railcosim.dem import run_steps

if "RAILCOSIM_ROOT" not in os.environ:
    sys.exit("sleeper_test.py: run it through the repository's launcher: ./railcosim yade "
             "cases/track_stiffness/sleeper_test.py OUT ...")
CASE = os.path.join(os.environ["RAILCOSIM_ROOT"], "cases", "track_stiffness")
REFERENCE_S = 0.01          # settlements from the sleepers' mean height over this span before the ramp (as case.py)
STEPS_PER_RECORD = 20
UNLOAD_TO = 0.1             # a cycle unloads to this share of the seat load
STATICS_TOLERANCE = 0.03    # the base's force against the weights and the load at the hold (the case's statics check)

parser = argparse.ArgumentParser(prog="sleeper_test.py")
parser.add_argument("out")
parser.add_argument("--smoke", action="store_true", help="the case's smoke bed (grains x 3, 2 sleepers)")
parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a case parameter")
parser.add_argument("--seat-load", type=float, default=75000.0,
                    help="N per rail seat, i.e. on half the loaded sleeper (default: the thesis's 150 kN halved)")
parser.add_argument("--rigid-base", action="store_true", help="the base wall's E x 1000")
parser.add_argument("--locked", action="store_true", help="no sliding or rolling between grains (mu, eta_r 10)")
parser.add_argument("--cycles", type=int, default=0, help="unload-reload cycles before the hold")
parser.add_argument("--restitution", type=float, default=None,
                    help="every contact's restitution in the test, 0 to 1 (default: the case's restitution)")
parser.add_argument("--rolling-friction", type=float, default=None,
                    help="eta_r between grains in the test, >= 0 (default: the case's rolling_friction)")
args = parser.parse_args(sys.argv[1:])
if not (math.isfinite(args.seat_load) and args.seat_load > 0) or args.cycles < 0:
    sys.exit("sleeper_test.py: --seat-load must be a positive number and --cycles not negative")
if args.restitution is not None and not 0.0 <= args.restitution <= 1.0:  # NaN fails too
    sys.exit(f"sleeper_test.py: --restitution must lie in [0, 1], not {args.restitution}")
if args.rolling_friction is not None and not (math.isfinite(args.rolling_friction) and args.rolling_friction >= 0):
    sys.exit(f"sleeper_test.py: --rolling-friction must be a number >= 0, not {args.rolling_friction}")
if args.locked and args.rolling_friction is not None:
    sys.exit("sleeper_test.py: --locked sets eta_r to 10; leave out --rolling-friction")

config, case = load_case(CASE)
try:
    p = parameters.resolve_parameters(config, args.smoke, args.set)
    problems = parameters.check_parameters(p, config, case)  # the case's own: a hold after the ramp, 0.01 s before
except parameters.ParameterError as error:
    problems = [str(error)]
if not problems and p["subgrade"] != "wall":
    problems = ["the test stands on the base wall (subgrade = wall): the FreeFEM layers need the coupled run"]
if problems:
    sys.exit("sleeper_test.py: " + "; ".join(problems))
os.makedirs(args.out, exist_ok=True)
wall_start = time.monotonic()

# 1. The case's bed (packed once and cached, as for the coupled run), base and mirror walls; the options' changes to the
#    materials before any contact exists.
bed = track.TrackBed(p, args.out)
if args.rigid_base:
    # The bed rests on the soft base with overlaps of up to ~0.2 mm: against a base 1000 times stiffer they would
    # push with ~75 times the bed's weight. The stiff base is lowered by the largest overlap; the bed comes down onto
    # it and rests during load_start_s.
    O.materials[bed.base].young *= 1000.0
    overlap = max(0.0, max(bed.base_z - (O.bodies[i].state.pos[2] - O.bodies[i].shape.radius) for i in bed.spheres))
    O.bodies[bed.base_wall].state.pos = O.bodies[bed.base_wall].state.pos - Vector3(0, 0, overlap)
if args.locked:
    O.materials[bed.ballast].frictionAngle = math.atan(10.0)
    O.materials[bed.ballast].rollingFriction = 10.0
if args.rolling_friction is not None:
    O.materials[bed.ballast].rollingFriction = args.rolling_friction
if args.restitution is not None:  # e = 0: Thornton's damping ratio 14.2, strongly overdamped contacts
    for material in O.materials:
        material.restitution = args.restitution

# 2. The sleepers: boxes of the NS90 block at the spacing, their bases at z = 0 where the bed's highest grain under them
#    is. The quarter holds a quarter of the loaded sleeper (x = 0 and y = 0 are planes of symmetry) and halves of the
#    others; each moves vertically only, as the thesis's sleepers.
L, B, H, spacing = p["sleeper_length"], p["sleeper_width"], p["sleeper_height"], p["sleeper_spacing"]
boxes = []
for k in range(p["sleepers"]):
    box = utils.box(center=(k * spacing, 0, 0.5 * H), extents=(0.5 * B, 0.5 * L, 0.5 * H),
                    material=bed.sleeper_material)
    box.state.mass = L * B * H * p["sleeper_density"] * (0.25 if k == 0 else 0.5)
    box.state.inertia = Vector3(1, 1, 1) * 1e9   # no rotation (blocked below); finite for the integrator
    box.state.blockedDOFs = "xyXYZ"
    boxes.append(O.bodies.append(box))
weights = sum(O.bodies[b].state.mass for b in boxes) * track.GRAVITY + bed.mass * track.GRAVITY
O.engines = bed.engines(boxes=True) + [NewtonIntegrator(damping=0.0, gravity=(0, 0, -track.GRAVITY))]
O.dt = p["dem_dt_safety"] * utils.PWaveTimeStep()

# 3. The load: the sleepers settle under their weight for load_start_s, the seat load is ramped over ramp_s, then
#    (--cycles) unloaded to UNLOAD_TO and reloaded, each branch ramp_s long, then held for the case's hold.
settle, ramp = p["load_start_s"], p["ramp_s"]
hold = p["duration_s"] - settle - ramp
end_time = settle + ramp * (1 + 2 * args.cycles) + hold


def seat_load(t):
    u = (t - settle) / ramp
    if u <= 1.0 or args.cycles == 0:
        return args.seat_load * min(1.0, max(0.0, u))
    cycle, phase = divmod(u - 1.0, 2.0)
    if cycle >= args.cycles:
        return args.seat_load
    return args.seat_load * (1.0 - (1.0 - UNLOAD_TO) * (phase if phase < 1.0 else 2.0 - phase))


rows = []
next_progress = 0.0
at_rest = 0.0  # the loaded sleeper's z when the load starts
origin = O.time  # a freshly packed bed leaves the packing's time on the clock


def test_time():
    return O.time - origin


while test_time() < end_time:
    F = seat_load(test_time())
    O.forces.setPermF(boxes[0], Vector3(0, 0, -0.5 * F))  # the quarter's box is half a rail seat's sleeper
    run_steps(STEPS_PER_RECORD)
    rows.append([test_time(), F] + [O.bodies[b].state.pos[2] - 0.5 * H for b in boxes] + [bed.base_force()])
    if rows[-1][0] < settle:
        at_rest = rows[-1][2]
    if rows[-1][0] >= next_progress:  # the loaded sleeper's settlement from its place at rest under its weight
        print(f"t={rows[-1][0]:.3f} s  seat load {F / 1e3:.1f} kN  settlement {(at_rest - rows[-1][2]) * 1e3:.3f} mm  "
              f"{time.monotonic() - wall_start:.0f} s", flush=True)
        next_progress += 0.05
rows = np.array(rows)
header = "time_s,seat_load_N," + ",".join(f"sleeper{k}_z_m" for k in range(len(boxes))) + ",base_force_N"
np.savetxt(os.path.join(args.out, "sleeper_test.csv"), rows, delimiter=",", header=header, comments="")

# 4. Settlements from the sleepers' mean height over REFERENCE_S before the ramp; at the hold, means over its last
#    average_s (after the cycles, with --cycles); the first loading's secant at the ramp's top and its tangent over
#    the ramp's last half; each cycle's reloading secant (10 % to 100 %).
z0 = rows[(rows[:, 0] > settle - REFERENCE_S) & (rows[:, 0] <= settle), 2:2 + len(boxes)].mean(axis=0)
last = rows[rows[:, 0] > end_time - p["average_s"]].mean(axis=0)
settlement = -(last[2:2 + len(boxes)] - z0)
top = rows[np.searchsorted(rows[:, 0], settle + ramp) - 1]  # the last record of the first ramp
first_secant = top[1] / (z0[0] - top[2])
late = (rows[:, 0] > settle + 0.5 * ramp) & (rows[:, 0] < settle + ramp)
tangent = np.polyfit(-rows[late, 2], rows[late, 1], 1)[0]
reloads = []
for k in range(args.cycles):
    branch = rows[(rows[:, 0] > settle + ramp * (2 + 2 * k)) & (rows[:, 0] < settle + ramp * (3 + 2 * k))]
    reloads.append((branch[-1, 1] - branch[0, 1]) / (branch[0, 2] - branch[-1, 2]))
try:
    porosity, coordination = track.bed_structure(bed.bed)
except ValueError as error:  # a bed of coarse grains, two to three deep, has no interior
    print(f"bed structure not measured: {error}", flush=True)
    porosity = coordination = float("nan")
# The statics: the mirror and shoulder walls are frictionless, so at rest the base carries the bed, the sleepers and
# the load on the quarter's box.
statics = abs(last[-1] - (weights + 0.5 * args.seat_load)) / (weights + 0.5 * args.seat_load)
summary = {
    "seat_load_N": args.seat_load, "rigid_base": args.rigid_base, "locked": args.locked, "cycles": args.cycles,
    "restitution": p["restitution"] if args.restitution is None else args.restitution,
    "rolling_friction": 10.0 if args.locked else (
        p["rolling_friction"] if args.rolling_friction is None else args.rolling_friction),
    "spheres": len(bed.spheres), "bed": bed.cache, "dem_dt_s": O.dt, "smoke": args.smoke, "set": args.set,
    "bed_interior_porosity": None if math.isnan(porosity) else porosity,
    "bed_interior_coordination_number": None if math.isnan(coordination) else coordination,
    "settlement_m": settlement.tolist(),
    "support_stiffness_per_rail_seat_kN_per_mm": args.seat_load / settlement[0] / 1e6,  # at the hold
    "first_loading_secant_kN_per_mm": first_secant / 1e6,
    "tangent_last_half_of_ramp_kN_per_mm": tangent / 1e6,
    "reload_secant_kN_per_mm": [r / 1e6 for r in reloads],
    "statics_error": statics, "statics_tolerance": STATICS_TOLERANCE,
    "wall_time_s": time.monotonic() - wall_start,
}
with open(os.path.join(args.out, "sleeper_test.json"), "w") as f:
    json.dump(summary, f, indent=2)
structure = "interior not measured" if math.isnan(porosity) else \
    f"interior porosity {porosity:.1%}, coordination number {coordination:.2f} (the bed at rest, before the sleepers)"
print(f"{len(bed.spheres)} spheres, {structure}; seat load {args.seat_load / 1e3:.1f} kN: settlement of the loaded "
      f"sleeper {settlement[0] * 1e3:.3f} mm (the others {', '.join(f'{s * 1e3:.3f}' for s in settlement[1:])} mm); "
      f"k_sub per rail seat {summary['support_stiffness_per_rail_seat_kN_per_mm']:.2f} kN/mm (secant at the hold"
      + (f", after {args.cycles} cycles; first loading {first_secant / 1e6:.2f}" if args.cycles else "")
      + f"), {tangent / 1e6:.2f} (tangent, last half of the ramp)"
      + "".join(f"; reload {k + 1}: {r / 1e6:.2f}" for k, r in enumerate(reloads))
      + f"; statics {statics:.2%} (limit {STATICS_TOLERANCE:.0%}); {summary['wall_time_s']:.0f} s", flush=True)
if statics > STATICS_TOLERANCE:
    sys.exit(f"sleeper_test.py: the base's force misses the weights and the load by {statics:.2%} "
             f"(limit {STATICS_TOLERANCE:.0%}): not at rest; a longer hold (duration_s)")
