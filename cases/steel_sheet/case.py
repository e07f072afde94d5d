"""Case steel_sheet: the sheet, its reference run, the closed-form bounds and the post-processing (see README.md)."""
import math
import os

import numpy as np

from railcosim import results, solvers
from railcosim.case import Case

GRAVITY = 9.81


def cantilever_influence(x, a):
    """Deflection at x of a clamped-free beam of unit flexural rigidity under a unit load at a (both from the clamp):
    a^2 (3x - a) / 6 for x >= a, x^2 (3a - x) / 6 otherwise (Timoshenko & Gere 1961, Mechanics of Materials)."""
    return np.where(x >= a, a ** 2 * (3.0 * x - a) / 6.0, x ** 2 * (3.0 * a - x) / 6.0)


def closed_form_bounds(p, positions, forces):
    """(strip, beam) deflections [m, downward] at the measurement position under nodal forces (N x 3) at positions
    (N x 3): the cantilever beam of stiffness E b t^3 / 12 (anticlastic curvature free: the softer bound) and the plate
    strip, E / (1 - nu^2) (anticlastic curvature suppressed: the stiffer bound). The clamped plate lies between them
    (docs/thin-structures.md: 42 % of the way from beam to strip under a uniform load)."""
    b, t, young, nu = p["sheet_width"], p["sheet_thickness"], p["sheet_young"], p["sheet_poisson"]
    rigidity = young * b * t ** 3 / 12.0
    a = np.clip(positions[:, 0] - p["clamp_length"], 0.0, None)
    beam = float(np.sum(-forces[:, 2] * cantilever_influence(p["measurement_x"] - p["clamp_length"], a))) / rigidity
    return beam * (1.0 - nu ** 2), beam


def beverloo_slot(p, mean_diameter):
    """Mass flow rate [kg/s] of a slot b x L in a flat bottom: C rho_b sqrt(g) (b - k d)^1.5 (L - k d) (Nedderman 1992,
    Statics and Kinematics of Granular Materials, ch. 10, after Beverloo et al. 1961)."""
    k, d = p["beverloo_k"], mean_diameter
    return (p["beverloo_c"] * p["bulk_density"] * math.sqrt(GRAVITY) * (p["outlet_length"] - k * d) ** 1.5
            * (p["hopper_width"] - k * d))


def flow_rate(times, passed, span):
    """Mass flow rate history: the passed mass differenced over `span` (centred)."""
    rate = np.full_like(passed, np.nan)
    for k, t in enumerate(times):
        lo, hi = t - 0.5 * span, t + 0.5 * span
        if lo >= times[0] and hi <= times[-1]:
            rate[k] = (np.interp(hi, times, passed) - np.interp(lo, times, passed)) / span
    return rate


class SteelSheet(Case):
    def dem_command(self, p, endpoint, out):
        """dem.py on YADE, or dem_driver.py (dem_driver = "standalone": the polyhedra library, the GPU machine's
        path) on this Python with dem_threads OpenMP threads."""
        if p["dem_driver"] == "yade":
            return super().dem_command(p, endpoint, out)
        return solvers.library_dem_command(p, os.path.join(p["case_dir"], "dem_driver.py"),
                                           os.path.join(out, "parameters.json"), endpoint, out)

    def fem_arguments(self, p):
        """The free span x = clamp_length..sheet_length as a P2 solid shell, one layer, graded towards the clamp (face 4,
        x = clamp_length), coupled on its top face (6), monitored on the mid-surface at the measurement position."""
        clamp, span = p["clamp_length"], p["sheet_length"] - p["clamp_length"]
        t, width = p["sheet_thickness"], p["sheet_width"]
        grading = [clamp + t * 2 ** k for k in range(8) if t * 2 ** k < 0.75 * span / p["elements_x"]]
        return {"timeout": 3600.0, "order": 2, "origin": f"{clamp!r},0,0", "Lx": span, "Ly": width, "Lz": t,
                "nx": p["elements_x"], "ny": p["elements_y"], "nz": 1, "gridLinesX": ",".join(repr(x) for x in grading),
                "E": p["sheet_young"], "nu": p["sheet_poisson"], "rho": p["sheet_density"], "clamped": 4, "coupled": 6,
                "alphaB": p["alpha_bossak"], "rayleighMass": p["rayleigh_mass"],
                "monitor": f"{p['measurement_x']!r},{width / 2!r},{t / 2!r}"}

    def reference_runs(self, p, out):
        """A static solve of the same sheet under the coupled run's nodal forces averaged over the final span (the
        grains at rest: smoke scene), the FEM side of the static oracle."""
        if not p["static_check"]:
            return []
        forces = results.read_dem_series(out)["mean_nodal_forces"].ravel()
        path = os.path.join(out, "mean_nodal_forces.txt")
        with open(path, "w") as f:
            f.write(f"{forces.size}\n" + "\n".join(f"{v:.12e}" for v in forces) + "\n")
        return [self.fem_reference(p, out, "same_load_fem", "static", nodalForces=path)]

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        time, deflection = monitor["time"], -monitor["uz"]      # downward positive, from the unloaded sheet
        peak_index = int(np.argmax(deflection))
        plateau = deflection[time >= p["plateau_from_s"]]
        t_dem, passed = series["time"], series["passed_mass"]
        rate = flow_rate(t_dem, passed, p["flow_smoothing_s"])
        flow = float((np.interp(p["flow_to_s"], t_dem, passed) - np.interp(p["flow_from_s"], t_dem, passed))
                     / (p["flow_to_s"] - p["flow_from_s"]))
        mean_diameter = 0.5 * (dem["diameter_min_m"] + dem["diameter_max_m"])
        beverloo = beverloo_slot(p, mean_diameter)
        metrics = {"peak_deflection_m": float(deflection[peak_index]), "plateau_deflection_m": float(np.mean(plateau)),
                   "peak_time_s": float(time[peak_index]), "mass_flow_kg_per_s": flow,
                   "beverloo_mass_flow_kg_per_s": beverloo, "grains": dem["particles"],
                   "total_grain_mass_kg": dem["total_grain_mass_kg"],
                   "final_hopper_mass_kg": float(series["hopper_mass"][-1]),
                   "final_sheet_mass_kg": float(series["sheet_mass"][-1]),
                   "max_grain_speed_m_per_s": float(np.max(series["max_speed"])),
                   "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"]}
        reference = {"beverloo_mass_flow_kg_per_s": beverloo,
                     "seed002": {"flow_peak_time_s": 0.25, "flow_drop_s": 0.3, "flow_constant_s": [0.3, 1.5],
                                 "free_fall_time_s": math.sqrt(2.0 * p["fall_height"] / GRAVITY),
                                 "note": "Ullrich 2022 sec. 5.3-5.5: Figs. 5.3/5.4 give curves only"}}
        relative_error, checks = {"interface_energy": results.interface_energy_error(dem)}, []
        checks.append({"name": "grains through the sheet", "value": float(np.max(series["through_sheet"])), "limit": 0.0})
        # The final span (average_s): the grains at rest (smoke) or the steady stream's plateau (desk). Its mean
        # deflection against the closed-form cantilever bounds under its mean nodal forces: linear statics of the span's
        # mean, up to the mean inertia of the sheet's ringing over it.
        final = results.final_span(t_dem, p["average_s"])
        coupled = -float(fem["averageMonitorDisplacement"][2])
        strip, beam = closed_form_bounds(p, series["node_positions"], series["mean_nodal_forces"])
        # An unloaded final span (a run that ends before the stream lands) has both bounds 0: any deflection is outside.
        if strip > 0:
            outside = max(strip - coupled, coupled - beam, 0.0) / strip
        else:
            outside = math.inf if abs(coupled) > 1e-9 else 0.0
        carried = -float(np.mean(series["interface_force"][final, 2]))
        metrics.update(final_span_deflection_m=coupled, strip_bound_deflection_m=strip, beam_bound_deflection_m=beam,
                       carried_force_n=carried)
        reference["closed_form_bounds_m"] = [strip, beam]
        relative_error["coupled_outside_closed_form_bounds"] = outside
        # The plate lies between the beam and strip bounds under a uniform load; grains resting in a patch add a local
        # plate response the bounds do not have: 5 %.
        checks.append({"name": "final-span deflection outside the closed-form [strip, beam] bounds under its mean forces",
                       "value": outside, "limit": p["bounds_tolerance"]})
        if p["static_check"]:
            same_load = -float(results.read_json(os.path.join(out, "same_load_fem", "fem_summary.json"))
                               ["finalMonitorDisplacement"][2])
            resting = float(series["sheet_mass"][-1]) * GRAVITY
            accounted = float(series["sheet_mass"][-1] + series["clamp_mass"][-1] + series["parked_mass"][-1])
            balance = abs(float(series["passed_mass"][-1]) - accounted) / dem["total_grain_mass_kg"]
            metrics.update(same_load_fem_deflection_m=same_load, resting_weight_n=resting)
            reference.update(same_load_fem_deflection_m=same_load, resting_weight_n=resting)
            # interface_force_vs_weight and interface_force_fluctuation: the names tools/stability_map.py judges by.
            fluctuation = results.force_fluctuation(t_dem, series["interface_force"][:, 2], p["average_s"], resting)
            relative_error.update(coupled_vs_same_load_fem=abs(coupled - same_load) / same_load,
                                  interface_force_vs_weight=abs(carried - resting) / resting,
                                  interface_force_fluctuation=fluctuation["final"], mass_balance=balance)
            checks += [
                # Same forces, static: what remains is the sheet's residual motion over the final span.
                {"name": "coupled vs static FEM under the final span's mean nodal forces",
                 "value": relative_error["coupled_vs_same_load_fem"], "limit": p["static_fem_tolerance"]},
                # At rest the sheet carries the weight of the grains on it (nothing else touches it).
                {"name": "load on the sheet vs weight of the grains resting on it",
                 "value": relative_error["interface_force_vs_weight"], "limit": p["weight_tolerance"]},
                # Every grain that left the hopper ends on the sheet, on the clamp or beyond the sheet: none lost or
                # stuck in the rig. One and a half grains of the largest size is the resolution of the count.
                {"name": "mass passed vs mass on the sheet, the clamp and beyond (fraction of the total)",
                 "value": balance, "limit": 1.5 * p["grain_density"] * math.pi / 6 * p["diameter_max"] ** 3
                 / dem["total_grain_mass_kg"]},
                {"name": "hopper emptied (kg left)", "value": float(series["hopper_mass"][-1]), "limit": 0.0},
            ]
        else:
            # The stream's momentum balance over the plateau, compared (not checked: the rebound of the grains is
            # neither zero nor known): a perfectly inelastic stream presses with its momentum flux, the mass flow rate
            # times the free-fall speed over fall_height, plus the weight of the grains lying on the sheet.
            impact = flow * math.sqrt(2.0 * GRAVITY * p["fall_height"])
            lying = float(np.mean(series["sheet_mass"][final])) * GRAVITY
            metrics.update(stream_momentum_flux_n=impact, lying_weight_n=lying)
            relative_error["carried_force_vs_momentum_flux_and_weight"] = abs(carried - impact - lying) / (impact + lying)
            relative_error["mass_flow_vs_beverloo"] = abs(flow - beverloo) / beverloo
            checks.append({"name": "steady mass flow rate vs Beverloo's slot law", "value": relative_error[
                "mass_flow_vs_beverloo"], "limit": p["beverloo_tolerance"]})
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {
            "dem": {k: v for k, v in series.items() if k not in ("triangles",)}, "fem": monitor,
            "derived": {"time": t_dem, "mass_flow_rate": rate}})
        results.plot_history(os.path.join(out, "deflection.png"),
                             title=f"Steel sheet under {dem['total_grain_mass_kg']:.2f} kg of wheat "
                                   f"({dem['particles']} spheres, {p['scheme']}, Δt_F = {p['fem_dt']:g} s)", panels=[
            {"x": time, "y": deflection * 1e3, "label": f"deflection at x = {p['measurement_x'] * 1e3:.0f} mm (mid-width)",
             "ylabel": "deflection [mm]", "lines": [(metrics["plateau_deflection_m"] * 1e3, "plateau mean")]},
            {"x": t_dem, "y": rate, "label": f"mass flow rate {p['flow_plane_depth'] * 1e3:.0f} mm under the flaps",
             "ylabel": "mass flow [kg/s]", "lines": [(beverloo, "Beverloo slot law"), (flow, "steady mean")]},
            {"x": t_dem, "y": -series["interface_force"][:, 2], "label": "load on the sheet (DEM)", "ylabel": "force [N]",
             "more": [(series["sheet_mass"] * GRAVITY, "weight of the grains on the sheet")]},
        ])
        return {**results.participant_summary(dem, fem), "metrics": metrics, "reference": reference,
                "relative_error": relative_error, "checks": checks}
