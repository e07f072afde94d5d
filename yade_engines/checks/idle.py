# YADE helper for the launch test: checks that YADE started as usual, reports its PID, then idles SECONDS.
# Run: ./railcosim yade yade_engines/checks/idle.py [SECONDS]   (tests/yade/no_listening_sockets.py audits it)
import os
import sys
import time

# What yade_launch.py must leave as YADE's main script makes it: the scene, YADE's and railcosim's classes in
# the script's namespace, the script's own arguments in sys.argv, a few steps that run.
missing = [name for name in ("O", "utils", "Vector3", "FemCouplingEngine", "NewtonIntegrator", "PyRunner")
           if name not in globals()]
if missing:
    print(f"FAIL: not in the script's namespace: {', '.join(missing)}", flush=True)
    sys.exit(1)
if os.path.basename(sys.argv[0]) != "idle.py":
    print(f"FAIL: sys.argv[0] is {sys.argv[0]!r}, expected this script", flush=True)
    sys.exit(1)
ticks = []
O.engines = [ForceResetter(), NewtonIntegrator(), PyRunner(command="ticks.append(O.iter)", iterPeriod=1)]
O.dt = 1e-3
O.run(5, True)
if ticks != [1, 2, 3, 4]:  # a PeriodicEngine first fires once iterPeriod steps have passed: steps 1-4 of 0-4
    print(f"FAIL: a PyRunner in the script's namespace ran at {ticks}, expected iterations 1-4", flush=True)
    sys.exit(1)

print(f"ready pid={os.getpid()}", flush=True)
time.sleep(float(sys.argv[1]) if len(sys.argv) > 1 else 30.0)
print("idle: done", flush=True)
