"""Case monoblock_sleeper: a user's FreeFEM structure (gmsh mesh, lib/coupling_loop.idp) on a bed of spheres."""
import os

import numpy as np

from railcosim import results, solvers
from railcosim.case import Case

GRAVITY = 9.81
BASE_AREA = 2.6 * 0.3  # m^2, the sleeper's base (monoblock_sleeper.geo)


class MonoblockSleeper(Case):
    fem_script = "examples/monoblock_sleeper.edp"

    def fem_arguments(self, p):
        """The sleeper of monoblock_sleeper.geo at mesh_size, its material and damping, monitored in its middle on its
        axis (x = 1.3 m, half the centre section's 0.175 m below the base, which lies at z = 0 turned over), away from
        the local indentation under the nodal forces of the base (as the beam case monitors its axis)."""
        return {"geo": os.path.join(solvers.root(), "freefem_scripts", "examples", "monoblock_sleeper.geo"),
                "meshSize": p["mesh_size"], "E": p["sleeper_young"], "nu": p["sleeper_poisson"],
                "rho": p["sleeper_density"], "rayleighMass": p["rayleigh_mass"], "monitor": "1.3,0,-0.0875"}

    def reference_runs(self, p, out):
        """Static solves of the same FreeFEM sleeper on the coupled run's mesh: (1) under the particles' weight as a
        uniform pressure on the base, lumped to the interface nodes; (2) under the coupled run's own nodal forces
        averaged over the final span."""
        series = results.read_dem_series(out)
        mean_forces = series["nodal_forces"][results.final_span(series["time"], p["average_s"])].mean(axis=0).ravel()
        forces_file = os.path.join(out, "mean_nodal_forces.txt")
        with open(forces_file, "w") as f:
            f.write(f"{mean_forces.size}\n" + "\n".join(f"{v:.12e}" for v in mean_forces) + "\n")
        mesh = os.path.join(out, "fem", "sleeper.msh")
        pressure = p["particle_mass_kg"] * GRAVITY / BASE_AREA
        return [self.fem_reference(p, out, "direct_fem", "static", pressure=pressure, mesh=mesh),
                self.fem_reference(p, out, "same_load_fem", "static", nodalForces=forces_file, mesh=mesh)]

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        direct = results.read_json(os.path.join(out, "direct_fem", "fem_summary.json"))
        same_load = results.read_json(os.path.join(out, "same_load_fem", "fem_summary.json"))
        coupled = -fem["averageMonitorDisplacement"][2]  # deflection of the middle of the axis, positive downwards
        direct_deflection = -direct["finalMonitorDisplacement"][2]
        same_load_deflection = -same_load["finalMonitorDisplacement"][2]
        weight = dem["total_particle_mass_kg"] * GRAVITY
        window = results.final_span(series["time"], p["average_s"])
        interface_force = -float(np.mean(series["interface_force"][window, 2]))

        results.write_timeseries(os.path.join(out, "timeseries.h5"), {
            "dem": {k: v for k, v in series.items() if k != "triangles"}, "fem": monitor,
            "interface": {"triangles": series["triangles"]}})
        results.plot_history(os.path.join(out, "deflection.png"),
                             title=f"B70-type sleeper held at its rail seats under {dem['total_particle_mass_kg']:.0f} kg "
                                   f"of spheres", panels=[
            {"x": monitor["time"], "y": [-u * 1e9 for u in monitor["uz"]], "label": "coupled FEM (middle of the sleeper, on its axis)",
             "ylabel": "deflection [nm]",
             "lines": [(direct_deflection * 1e9, "static FEM, uniform equivalent pressure"),
                       (same_load_deflection * 1e9, "static FEM, coupled run's mean nodal forces")]},
            {"x": series["time"], "y": -series["interface_force"][:, 2], "label": "interface force from DEM",
             "ylabel": "force on the sleeper [N]", "lines": [(weight, "particle weight")]},
            results.interface_work_panel(series)])

        # The structure loaded directly: the sleeper under the bed's weight as a uniform pressure. The goal is 1 %.
        errors, checks = results.bed_on_structure_checks(coupled, direct_deflection, same_load_deflection,
                                                         interface_force, weight, p["deflection_tolerance"])
        error_direct, error_same_load = errors["coupled_vs_direct_fem"], errors["coupled_vs_same_load_fem"]
        force_error = errors["interface_force_vs_weight"]
        fluctuation = results.force_fluctuation(series["time"], series["interface_force"][:, 2], p["average_s"], weight)
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"deflection_m": coupled, "direct_fem_deflection_m": direct_deflection,
                        "same_load_fem_deflection_m": same_load_deflection, "interface_force_n": interface_force,
                        "particle_weight_n": weight, "total_particle_mass_kg": dem["total_particle_mass_kg"],
                        "sleeper_mass_kg": fem["mass"], "elements": fem["elements"], "interface_nodes": fem["interfaceNodes"],
                        "final_kinetic_energy_j": dem["final_kinetic_energy_j"],
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "force_fluctuation": fluctuation["final"]},
            "reference": {"direct_fem_deflection_m": direct_deflection, "particle_weight_n": weight},
            "relative_error": {"coupled_vs_direct_fem": error_direct, "coupled_vs_same_load_fem": error_same_load,
                               "interface_force_vs_weight": force_error,
                               "interface_force_fluctuation": fluctuation["final"],
                               "interface_energy": results.interface_energy_error(dem)},
            "checks": checks,
        }
