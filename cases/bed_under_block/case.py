"""Case bed_under_block: the loaded block and the load transfer check (see README.md)."""
import os

import numpy as np

from railcosim import results
from railcosim.case import Case


class BedUnderBlock(Case):
    def fem_arguments(self, p):
        """A free block coupled on its bottom face, pressed down by load_pressure on its top face, monitored at
        the centre of its top face."""
        L, W, H = p["block_length"], p["block_width"], p["block_height"]
        return {"Lx": L, "Ly": W, "Lz": H, "nx": p["block_elements"], "ny": max(1, p["block_elements"] // 2), "nz": 1,
                "order": 2, "E": p["block_young"], "nu": p["block_poisson"], "rho": p["block_density"],
                "clamped": "", "coupled": 5, "extraPressure": p["load_pressure"], "extraFace": 6,
                "rayleighMass": p["rayleigh_mass"], "monitor": f"{L / 2},{W / 2},{H}"}

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        final = results.final_span(series["time"], p["average_s"])
        load = dem["load_n"]
        block_force = float(np.mean(series["interface_force"][final, 2]))  # upward on the block
        force_error = abs(block_force - load) / load
        fluctuation = results.force_fluctuation(series["time"], series["interface_force"][:, 2], p["average_s"], load)
        energy_error = results.interface_energy_error(dem)
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {"dem": series, "fem": monitor})
        results.plot_history(os.path.join(out, "load_transfer.png"), title="Loaded block on a sphere bed", panels=[
            {"x": series["time"], "y": series["interface_force"][:, 2], "label": "force of the bed on the block",
             "ylabel": "force [N]", "lines": [(load, "applied load")]},
            {"x": monitor["time"], "y": [-u * 1e3 for u in monitor["uz"]], "label": "block top settlement",
             "ylabel": "settlement [mm]", "lines": []},
            results.interface_work_panel(series),
        ])
        checks = [
            # At rest the bed carries the applied load (frictionless side walls); 5 % is the stability criterion
            # of the stability maps: unstable couplings depart from it by far more.
            {"name": "force of the bed on the block vs applied load", "value": force_error, "limit": 0.05},
            # ... and carries it steadily: rms oscillation of the window-sampled force over the final span.
            {"name": "force oscillation (rms / load) over the final span", "value": fluctuation["final"], "limit": 0.10},
        ]
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"load_n": load, "block_force_n": block_force,
                        "settlement_m": -float(fem["averageMonitorDisplacement"][2]),
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "final_kinetic_energy_j": dem["final_kinetic_energy_j"],
                        "force_fluctuation": fluctuation["final"], "force_fluctuation_before": fluctuation["previous"],
                        "force_fluctuation_growth": fluctuation["growth"]},
            "reference": {"load_n": load},
            "relative_error": {"interface_force_vs_weight": force_error, "interface_force_fluctuation": fluctuation["final"],
                               "interface_energy": energy_error},
            "checks": checks,
        }
