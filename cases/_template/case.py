"""Case template: the block, and the check that it carries the weight of the balls (see README.md)."""
import os

import numpy as np

from railcosim import results
from railcosim.case import Case

GRAVITY = 9.81


class Template(Case):
    def fem_arguments(self, p):
        """The block: clamped on its bottom face (z = 0), coupled on its top face, monitored at the top face's centre."""
        L, W, H, n = p["block_length"], p["block_width"], p["block_height"], p["block_elements"]
        return {"Lx": L, "Ly": W, "Lz": H, "nx": n, "ny": n, "nz": 1, "order": 2, "E": p["block_young"],
                "nu": p["block_poisson"], "rho": p["block_density"], "rayleighMass": p["rayleigh_mass"],
                "clamped": "5", "coupled": 6, "monitor": f"{L / 2},{W / 2},{H}"}

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        final = results.final_span(series["time"], p["average_s"])
        # Oracle: once the balls are at rest the block carries their whole weight (no walls, no gravity on
        # the block), whatever the contact law, the mesh or the coupling scheme.
        weight = dem["particle_mass_kg"] * GRAVITY
        carried = -float(np.mean(series["interface_force"][final, 2]))  # downward on the block, positive
        force_error = abs(carried - weight) / weight
        fluctuation = results.force_fluctuation(series["time"], series["interface_force"][:, 2], p["average_s"], weight)
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {"dem": series, "fem": monitor})
        results.plot_history(os.path.join(out, "load.png"), title="Balls dropped on an elastic block", panels=[
            {"x": series["time"], "y": -series["interface_force"][:, 2], "label": "force of the balls on the block",
             "ylabel": "force [N]", "lines": [(weight, "weight of the balls")]},
            {"x": monitor["time"], "y": [-u * 1e9 for u in monitor["uz"]], "label": "top face settlement (centre)",
             "ylabel": "settlement [nm]", "lines": []},
            results.interface_work_panel(series),
        ])
        checks = [
            # At rest the load is the weight exactly (measured 2e-6 with facets, 4e-7 with meshContacts); 1 % leaves
            # room for the balls' residual motion when a copy changes the balls, the block or the duration.
            {"name": "force on the block vs weight of the balls", "value": force_error, "limit": p["force_tolerance"]},
        ]
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"carried_force_n": carried, "particle_weight_n": weight,
                        "settlement_m": -float(fem["averageMonitorDisplacement"][2]),
                        "final_kinetic_energy_j": dem["final_kinetic_energy_j"],
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "force_fluctuation": fluctuation["final"], "force_fluctuation_growth": fluctuation["growth"]},
            "reference": {"particle_weight_n": weight},
            "relative_error": {"interface_force_vs_weight": force_error, "interface_force_fluctuation": fluctuation["final"],
                               "interface_energy": results.interface_energy_error(dem)},
            "checks": checks,
        }
