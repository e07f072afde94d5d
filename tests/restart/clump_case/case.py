"""Restart test case: the stand-in FEM's spring surface under falling clumps (QuaternionIntegrator, see dem.py)."""
import os

from railcosim import results
from railcosim.case import Case


class ClumpRestartCase(Case):
    def fem_command(self, p, endpoint, out):
        """The stand-in FEM: 10 x 10 nodes, 0.02 m apart, each a vertical spring-mass (bridge/dummies)."""
        return [os.path.join(os.environ["RAILCOSIM_BUILD"], "bridge", "dummies", "railcosim_dummy_fem"),
                "--endpoint", endpoint, "--scheme", p["scheme"], "--dt", repr(p["fem_dt"]), "--nx", "10", "--ny", "10",
                "--spacing", "0.02", "--mass", "0.01", "--stiffness", "2e4", "--result", os.path.join(out, "fem_result.txt")]

    def postprocess(self, p, out):
        series = results.read_dem_series(out)
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {"dem": series})
        dem = results.read_json(os.path.join(out, "dem_info.json"))
        return {"metrics": {"final_kinetic_energy_j": dem["final_kinetic_energy_j"],
                            "implicit_passes": dem["implicit_passes"], "mean_height_m": float(series["mean_height"][-1])},
                "checks": []}
