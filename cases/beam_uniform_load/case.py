"""Case beam_uniform_load: the beam, its reference runs and post-processing (see README.md)."""
import os

import numpy as np

from railcosim import results
from railcosim.case import Case

GRAVITY = 9.81


def _top_pressure(p):
    return p["particle_mass_kg"] * GRAVITY / (p["beam_length"] * p["beam_width"])


def closed_form_deflection(p):
    """Clamped-clamped beam under a uniform line load: bending (wL^4/384EI) plus shear (wL^2/8kGA).

    Shear coefficient of a rectangle k = 10(1+nu)/(12+11nu) (Cowper 1966).
    """
    w = p["particle_mass_kg"] * GRAVITY / p["beam_length"]
    b, h, length = p["beam_width"], p["beam_height"], p["beam_length"]
    young, nu = p["beam_young"], p["beam_poisson"]
    inertia = b * h ** 3 / 12.0
    shear_modulus = young / (2.0 * (1.0 + nu))
    kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
    return w * length ** 4 / (384.0 * young * inertia) + w * length ** 2 / (8.0 * kappa * shear_modulus * b * h)


PARTICLE_NAMES = {"sphere": "spheres", "cluster": "sphere clusters", "polyhedron": "dilated polyhedra"}
# The surface contact models each particle shape can use ("auto" picks the first).
CONTACT_MODELS = {"sphere": ("facets", "meshContacts", "hierarchy"), "cluster": ("meshContacts", "hierarchy", "facets"),
                  "polyhedron": ("polyhedra",)}


class BeamUniformLoad(Case):
    def check_parameters(self, p):
        """The contact model must suit the particle shape: polyhedra touch the beam only through their own engine."""
        usable = CONTACT_MODELS[p["particle_shape"]]
        if p["contact_model"] not in ("auto",) + usable:
            return [f"contact_model={p['contact_model']!r} does not work with particle_shape={p['particle_shape']!r}; "
                    f"use 'auto' or one of {', '.join(repr(m) for m in usable)}"]
        return []

    def fem_arguments(self, p):
        """A clamped-clamped beam (faces x = 0 and x = L), coupled on its top face, monitored on its axis at mid-span.
        Stones that settle before the coupled run (deposition_s) keep the FEM waiting for the handshake longer."""
        waiting = {"timeout": 3600.0} if p["particle_shape"] != "sphere" and p["deposition_s"] > 0 else {}
        return {**waiting, "Lx": p["beam_length"], "Ly": p["beam_width"], "Lz": p["beam_height"], "nx": p["elements_x"],
                "ny": p["elements_y"], "nz": p["elements_z"], "order": p["element_order"], "E": p["beam_young"],
                "nu": p["beam_poisson"], "rho": p["beam_density"], "rayleighMass": p["rayleigh_mass"],
                "clamped": "2,4", "coupled": 6,
                "monitor": f"{p['beam_length'] / 2},{p['beam_width'] / 2},{p['beam_height'] / 2}"}

    def reference_runs(self, p, out):
        """Static solves of the same FreeFEM beam: (1) under the equivalent uniform pressure lumped to the
        surface nodes (the case's reference); (2) under the coupled run's own nodal forces averaged over the
        final span, which isolates what the coupling adds from how unevenly the particles load the beam."""
        series = results.read_dem_series(out)
        mean_forces = series["nodal_forces"][results.final_span(series["time"], p["average_s"])].mean(axis=0).ravel()
        forces_file = os.path.join(out, "mean_nodal_forces.txt")
        with open(forces_file, "w") as f:
            f.write(f"{mean_forces.size}\n" + "\n".join(f"{v:.12e}" for v in mean_forces) + "\n")
        return [self.fem_reference(p, out, "direct_fem", "static", pressure=_top_pressure(p), load="lumped"),
                self.fem_reference(p, out, "same_load_fem", "static", nodalForces=forces_file)]

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        direct = results.read_json(os.path.join(out, "direct_fem", "fem_summary.json"))
        same_load = results.read_json(os.path.join(out, "same_load_fem", "fem_summary.json"))

        coupled = -fem["averageMonitorDisplacement"][2]       # downward deflection, positive
        direct_deflection = -direct["finalMonitorDisplacement"][2]
        same_load_deflection = -same_load["finalMonitorDisplacement"][2]
        closed = closed_form_deflection(p)
        weight = dem["total_particle_mass_kg"] * GRAVITY
        window = results.final_span(series["time"], p["average_s"])
        interface_force = -float(np.mean(series["interface_force"][window, 2]))

        results.write_timeseries(os.path.join(out, "timeseries.h5"), {
            "dem": {k: v for k, v in series.items() if k != "triangles"},
            "fem": monitor,
            "interface": {"triangles": series["triangles"]},
        })
        results.plot_history(
            os.path.join(out, "deflection.png"),
            title=f"Clamped beam under {dem['total_particle_mass_kg']:.1f} kg of "
                  f"{PARTICLE_NAMES[p['particle_shape']]}",
            panels=[
                {"x": monitor["time"], "y": [-u * 1e6 for u in monitor["uz"]], "label": "coupled FEM (beam axis, mid-span)",
                 "ylabel": "deflection [µm]",
                 "lines": [(direct_deflection * 1e6, "direct FEM, uniform equivalent load"),
                           (same_load_deflection * 1e6, "static FEM, coupled run's mean nodal forces"),
                           (closed * 1e6, "closed form (Timoshenko)")]},
                {"x": series["time"], "y": -series["interface_force"][:, 2], "label": "interface force from DEM",
                 "ylabel": "force on beam [N]", "lines": [(weight, "particle weight")]},
                results.interface_work_panel(series),
            ])

        # Ullrich 2022 reached 0.38 % (51 kg) and 0.85 % (72 kg); the case asks for 1 %. The smoke bed (2.5 spheres
        # across the width) loads the end stations visibly less than a uniform pressure: its limit is larger.
        errors, checks = results.bed_on_structure_checks(coupled, direct_deflection, same_load_deflection,
                                                         interface_force, weight, p["deflection_tolerance"])
        error_direct, error_same_load = errors["coupled_vs_direct_fem"], errors["coupled_vs_same_load_fem"]
        force_error = errors["interface_force_vs_weight"]
        error_closed = abs(direct_deflection - closed) / closed
        fluctuation = results.force_fluctuation(series["time"], series["interface_force"][:, 2], p["average_s"], weight)
        checks += [
            # P2 20x2x2 is 3 % below the closed form (mesh study in freefem_scripts/README.md); 5 % is the target.
            {"name": "direct FEM vs closed form", "value": error_closed, "limit": 0.05},
        ]
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"midspan_deflection_m": coupled, "direct_fem_deflection_m": direct_deflection,
                        "same_load_fem_deflection_m": same_load_deflection,
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "particles_below_surface": dem["particles_below_surface"],
                        "closed_form_deflection_m": closed, "total_particle_mass_kg": dem["total_particle_mass_kg"],
                        "interface_force_n": interface_force, "particle_weight_n": weight,
                        "final_kinetic_energy_j": dem["final_kinetic_energy_j"],
                        "force_fluctuation": fluctuation["final"], "force_fluctuation_growth": fluctuation["growth"]},
            "reference": {"direct_fem_deflection_m": direct_deflection, "closed_form_deflection_m": closed,
                          "seed002_table4_2": {"51kg": {"pure_fem_m": 7.06e-7, "coupled_m": 7.04e-7},
                                               "72kg": {"pure_fem_m": 9.97e-7, "coupled_m": 9.89e-7}}},
            "relative_error": {"coupled_vs_direct_fem": error_direct, "coupled_vs_same_load_fem": error_same_load,
                               "direct_fem_vs_closed_form": error_closed,
                               "interface_force_vs_weight": force_error, "interface_force_fluctuation": fluctuation["final"],
                               "interface_energy": results.interface_energy_error(dem)},
            "checks": checks,
        }
