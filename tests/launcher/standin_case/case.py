"""Stand-in case for the launcher tests: solver commands start tests/launcher/standin_solver.py (no YADE, no FreeFEM)."""
import json
import os
import sys
import time

from railcosim.case import Case

HERE = os.path.dirname(os.path.abspath(__file__))
SOLVER = os.path.join(os.path.dirname(HERE), "standin_solver.py")


def _command(p, name, behaviour, endpoint):
    if behaviour == "freefem":
        return ["FreeFem++", "-nw", "-v", "0", os.path.join(HERE, "ticks.edp")]
    return [sys.executable, SOLVER, name, p["marker_dir"], behaviour, endpoint, str(p["lines"]), str(p["interval_s"]),
            str(p["fail_after_s"])]


class StandinCase(Case):
    def fem_command(self, p, endpoint, out):
        return _command(p, "fem", p["fem_behaviour"], endpoint)

    def dem_command(self, p, endpoint, out):
        return _command(p, "dem", p["dem_behaviour"], endpoint)

    def reference_runs(self, p, out):
        if p["reference_behaviour"] == "none":
            return []
        return [("reference", _command(p, "reference", p["reference_behaviour"], "none"))]

    def postprocess(self, p, out):
        # Written whole, then renamed: the test reads the marker as soon as it exists.
        marker = os.path.join(p["marker_dir"], "postprocess.json")
        with open(marker + ".tmp", "w") as f:
            json.dump({"pid": os.getpid()}, f)
        os.rename(marker + ".tmp", marker)
        time.sleep(p["post_sleep_s"])
        return {"metrics": {"lines": p["lines"]}, "checks": [{"name": "stand-in check", "value": 0.0, "limit": 1.0}]}
