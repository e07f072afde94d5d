"""Stand-in case for the restart tests: the bridge's stand-in participants, each writing its figures exactly."""
import hashlib
import os

from railcosim.case import Case


def _program(name):
    return os.path.join(os.environ["RAILCOSIM_BUILD"], "bridge", "dummies", name)


class DummyRestartCase(Case):
    def fem_command(self, p, endpoint, out):
        return [_program("railcosim_dummy_fem"), "--endpoint", endpoint, "--scheme", p["scheme"], "--dt",
                repr(p["fem_dt"]), "--nodes", str(p["nodes"]), "--compute-ms", repr(p["compute_ms"]),
                "--result", os.path.join(out, "fem_result.txt")]

    def dem_command(self, p, endpoint, out):
        command = [_program("railcosim_dummy_dem"), "--endpoint", endpoint, "--scheme", p["scheme"], "--windows",
                   str(p["windows"]), "--load", repr(p["load"]), "--compute-ms", repr(p["compute_ms"]),
                   "--result", os.path.join(out, "dem_result.txt")]
        if p["contact_stiffness"] > 0:
            command += ["--contact-stiffness", repr(p["contact_stiffness"])]
        return command

    def postprocess(self, p, out):
        """Digests of the stand-ins' figures (hexadecimal floats, exact): equal runs have equal metrics."""
        metrics = {}
        for side in ("fem", "dem"):
            with open(os.path.join(out, f"{side}_result.txt"), "rb") as f:
                metrics[f"{side}_result_sha256"] = hashlib.sha256(f.read()).hexdigest()
        return {"metrics": metrics, "checks": []}
