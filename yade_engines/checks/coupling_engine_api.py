# YADE check: the railcosim plugin is loaded, FemCouplingEngine is usable from Python and rejects bad input.
# Run: ./railcosim yade yade_engines/checks/coupling_engine_api.py
import sys

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message)


engine = FemCouplingEngine()
check(engine.scheme == "justInTime", f"default scheme is justInTime, got {engine.scheme}")
check(engine.participantName == "dem", "default participant name is 'dem'")
check(engine.timeout > 0 and engine.heartbeat > 0, "timeouts are positive by default")

# Bad input must fail at connect() with a message naming the attribute, before any network wait.
for attrs, needle in (({}, "endpoint"), ({"endpoint": "ipc:///tmp/none.sock"}, "material"),
                      ({"endpoint": "ipc:///tmp/none.sock", "material": FrictMat(), "scheme": "sideways"}, "sideways")):
    e = FemCouplingEngine(**attrs)
    try:
        e.connect()
        check(False, f"connect() with {attrs} should raise")
    except Exception as error:  # YADE maps C++ exceptions to Python ones
        check(needle in str(error), f"error for {attrs} should mention '{needle}', got: {error}")

# A silent endpoint must be reported within the timeout, not hang.
import time
e = FemCouplingEngine(endpoint="ipc:///tmp/railcosim-nobody-listens.sock", material=FrictMat(), timeout=2.0)
start = time.monotonic()
try:
    e.connect()
    check(False, "connect() to a missing peer should raise")
except Exception as error:
    elapsed = time.monotonic() - start
    check(elapsed < 10.0, f"missing peer reported after {elapsed:.1f} s (limit 10 s)")
    check("fem" in str(error).lower() or "peer" in str(error).lower(), f"message names the peer: {error}")
    print("missing peer reported in %.1f s: %s" % (elapsed, error))

print("coupling_engine_api:", "FAILED" if failures else "passed", flush=True)
sys.exit(1 if failures else 0)
