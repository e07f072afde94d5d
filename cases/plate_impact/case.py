"""Case plate_impact: the plate and the energy balance of an elastic impact (see README.md)."""
import math
import os

from railcosim import results
from railcosim.case import Case


class PlateImpact(Case):
    def fem_arguments(self, p):
        """A square plate clamped on its four sides, struck on its top face, monitored at its centre."""
        L, T, n = p["plate_length"], p["plate_thickness"], p["elements_xy"]
        return {"Lx": L, "Ly": L, "Lz": T, "nx": n, "ny": n, "nz": 1, "order": 2, "E": p["plate_young"],
                "nu": p["plate_poisson"], "rho": p["plate_density"], "clamped": "1,2,3,4", "coupled": 6,
                "monitor": f"{L / 2},{L / 2},{T / 2}"}

    def check_parameters(self, p):
        """Refuses a DEM step above the sphere's P-wave step (YADE's PWaveTimeStep: R / sqrt(E / rho)), the
        critical step estimate the other cases scale by dem_dt_safety, unless force_dem_dt is set."""
        critical = p["sphere_radius"] / math.sqrt(p["plate_young"] / p["sphere_density"])
        if p["dem_dt"] > critical and not p["force_dem_dt"]:
            return [f"dem_dt={p['dem_dt']:g} is above the critical step {critical:.4g} s (P-wave step of the sphere); "
                    f"choose dem_dt <= {critical:.4g} or --set force_dem_dt=true"]
        return []

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        initial = dem["initial_energy_j"]
        plate = monitor["kineticEnergy"] + monitor["strainEnergy"]
        sphere_final = dem["final_sphere_energy_j"]
        total_error = abs(sphere_final + plate[-1] - initial) / initial
        interface_error = abs(dem["interface_work_dem_j"] - dem["interface_work_fem_j"]) / initial
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {"dem": series, "fem": monitor})
        results.plot_history(os.path.join(out, "energy.png"), title="Sphere striking a clamped plate: energy",
                             panels=[
                                 {"x": series["time"], "y": series["sphere_velocity_z"], "label": "sphere velocity",
                                  "ylabel": "v_z [m/s]", "lines": []},
                                 {"x": monitor["time"], "y": plate / initial, "label": "plate energy (FEM)",
                                  "ylabel": "energy / initial", "lines": [(1.0, "initial sphere energy"),
                                                                         (sphere_final / initial, "sphere after rebound")]},
                                 results.interface_work_panel(series),
                             ])
        checks = [
            # Frictionless, undamped contact and energy-conserving Newmark: what is not conserved is made by the
            # coupling itself (force lag and sampling); the limit is the measured error at the default step.
            {"name": "sphere + plate energy after the impact vs initial", "value": total_error,
             "limit": p["energy_tolerance"]},
            # Elastic impact: the sphere must leave the plate upwards (negative value = rebounding).
            {"name": "sphere velocity after the impact, downward positive [m/s]",
             "value": -float(series["sphere_velocity_z"][-1]), "limit": 0.0},
        ]
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"initial_energy_j": initial, "sphere_energy_after_j": sphere_final,
                        "plate_energy_after_j": float(plate[-1]), "rebound_velocity_m_s": float(series["sphere_velocity_z"][-1]),
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "contact_windows": dem["contact_windows"]},
            "reference": {"initial_energy_j": initial},
            "relative_error": {"energy_balance": total_error, "interface_energy": interface_error},
            "checks": checks,
        }
