"""Case track_stiffness: a quarter of a straight track (FreeFEM sleepers, pads and rail) on a bed of spheres under a
wheel load ramp: track stiffness K = Q/delta, the sleepers' support stiffness k_sub, the rail's deflection line."""
import os

import numpy as np

from railcosim import results, solvers, track
from railcosim.case import Case

# Irazábal 2017 §7.2.1 (Table 7.1 and text): k_sub of the adopted base (E 0.03 GPa) and of the first one (0.3 GPa);
# the high-speed-line range of López Pita et al. quoted there; §7.2.2: the track stiffness K adopted for the
# Zimmermann loads (optimum 70-80 kN/mm).
THESIS_K_SUB = 102.22           # kN/mm
THESIS_K_SUB_STIFF_BASE = 192.82  # kN/mm
RANGE_KN_PER_MM = (70.0, 110.0)
THESIS_TRACK_K = 75.0           # kN/mm
THESIS_POROSITY = 0.3941        # of the packed track bed (§7.2, Fig. 7.3)
KN_PER_MM = 1e6                 # N/m in a kN/mm


class TrackStiffness(Case):
    fem_script = track.FEM_SCRIPT

    def fem_arguments(self, p):
        """The track of railcosim.track with the wheel's ramp (track.edp's load options)."""
        return {**track.fem_arguments(p), "wheelLoad": p["wheel_load_N"], "loadStart": p["load_start_s"],
                "rampTime": p["ramp_s"], "loadLength": p["load_length"]}

    def preparation_runs(self, p, out):
        """The ballast bed (bed.py): packed once per parameter set and kept in the bed cache; later runs reuse it."""
        return [("bed", track.dem_script(p, "bed.py", os.path.join(out, "parameters.json"), out))]

    def dem_command(self, p, endpoint, out):
        """dem.py (YADE) or dem_driver.py (dem_driver = "standalone": the polyhedra library): track.dem_command."""
        return track.dem_command(p, endpoint, out)

    def fem_command(self, p, endpoint, out):
        """track.edp coupled; with subgrade = "layers" the layers' top at the packed bed's base (bed.py's BED_INFO)."""
        arguments = self.fem_arguments(p)
        if p["subgrade"] == "layers":
            arguments["baseZ"] = results.read_json(os.path.join(out, track.BED_INFO))["base_z"]
        return solvers.coupled_fem_command(p, endpoint, out, solvers.fem_script(self.fem_script), arguments)

    def check_parameters(self, p):
        problems = track.check(p)
        if p["load_start_s"] + p["ramp_s"] + p["average_s"] > p["duration_s"] + 1e-12:
            problems.append(f"duration_s {p['duration_s']} leaves no hold of average_s {p['average_s']} after the "
                            f"ramp (load_start_s + ramp_s = {p['load_start_s'] + p['ramp_s']} s)")
        if p["subgrade"] == "layers" and p["scheme"] != "implicit" and not p["force_explicit_layers"]:
            # Soft layers under stiff grain contacts: an explicit exchange multiplies the interface error by about the
            # contacts' stiffness over the layers' local stiffness every window, whatever its length (README, "The
            # subgrade as FreeFEM layers"); the implicit scheme's relaxation (Aitken) removes that gain.
            problems.append(f"subgrade = layers needs scheme = implicit (got {p['scheme']}): soft layers under the "
                            "ballast's contacts make an explicit exchange diverge within about 200 windows at any "
                            "window length; add --set scheme=implicit (or, to study it, "
                            "--set force_explicit_layers=true)")
        if p["load_start_s"] < 0.01:
            problems.append("load_start_s: the deflection is measured from the state under the weight alone, "
                            "averaged over the 0.01 s before the ramp")
        return problems

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        t = np.asarray(monitor["time"])
        hold = results.final_span(t, p["average_s"])
        before = (t > p["load_start_s"] - 0.01) & (t <= p["load_start_s"])  # under the weight alone
        x = np.asarray(fem["stations"])
        rail = np.array([monitor[f"railUz{k}"] for k in range(len(x))])  # (stations, steps), z up
        seat = np.array([monitor[f"seatUz{k}"] for k in range(len(x))])
        wheel = float(np.mean(np.asarray(monitor["wheelLoad"])[hold]))

        # 1. Deflections caused by the wheel: the hold's mean minus the mean under the weight alone (positive down).
        rail_line = rail[:, before].mean(axis=1) - rail[:, hold].mean(axis=1)
        seat_line = seat[:, before].mean(axis=1) - seat[:, hold].mean(axis=1)
        rail_deflection = float(rail_line[0])
        stiffness = wheel / rail_deflection / KN_PER_MM  # K = Q / delta
        # The tangent over the last half of the ramp (Irazábal: "the mean slope" of F-delta).
        ramp = (t >= p["load_start_s"] + 0.5 * p["ramp_s"]) & (t <= p["load_start_s"] + p["ramp_s"])
        slope = np.polyfit(-rail[0, ramp], np.asarray(monitor["wheelLoad"])[ramp], 1)[0] / KN_PER_MM
        # and over its first fifth (the bed's first response, before its grains rearrange under the sleeper).
        start = (t >= p["load_start_s"]) & (t <= p["load_start_s"] + 0.2 * p["ramp_s"])
        initial = np.polyfit(-rail[0, start], np.asarray(monitor["wheelLoad"])[start], 1)[0] / KN_PER_MM

        # 2. The ballast's reaction on each sleeper from the interface's nodal forces (DEM windows).
        td = np.asarray(series["time"])
        base_z = dem["base_z"]
        seats = track.seat_forces(series["nodal_forces"], series["node_positions"], p, base_z)  # (windows, sleepers)
        dem_hold = results.final_span(td, p["average_s"])
        dem_before = (td > p["load_start_s"] - 0.01) & (td <= p["load_start_s"])
        seat_force = seats[dem_hold].mean(axis=0) - seats[dem_before].mean(axis=0)
        seat_force[0] *= 2.0  # the quarter holds half of the loaded sleeper: the rail seat's whole reaction
        seat_x = x[::2][:p["sleepers"]]
        seat_deflection = np.interp(seat_x, x, seat_line)
        rail_at_seat = np.interp(seat_x, x, rail_line)
        k_sub = seat_force / seat_deflection / KN_PER_MM  # per rail seat = per half sleeper (README: the reading)
        # The sleepers' support stiffness per rail seat as one value for the quarter: its reaction Q/2 over the seats'
        # deflections, the loaded sleeper's counted half (one grain more or less under a half sleeper of coarse grains
        # moves a single seat's figure by a factor, README).
        share = np.where(np.arange(p["sleepers"]) == 0, 0.5, 1.0)
        k_support = 0.5 * wheel / float(np.sum(share * seat_deflection)) / KN_PER_MM
        k_rail_seat = seat_force / rail_at_seat / KN_PER_MM  # pad and ballast in series, at the rail

        # 3. Winkler (Zimmermann) closed form with the support modulus measured at the loaded seat, periodic by the
        #    planes of symmetry (a load every 2 end_x).
        #    The modulus is the support's mean over the quarter: its reaction Q/2 over the rail's deflection integrated
        #    from 0 to end_x (the sleepers' support stiffness over their spacing, averaged along the rail).
        bending = fem["railSecondMoment"] * p["rail_young"]
        modulus = 0.5 * wheel / results.trapezoid(rail_line, x)
        winkler = track.winkler_deflection(x, wheel, modulus, bending, period=2 * fem["endX"])
        winkler_error = float(np.max(np.abs(rail_line - winkler)) / winkler[0])
        beta = (modulus / (4 * bending)) ** 0.25

        # 4. Statics at the hold: the track on the ballast (Q/2 + its weight on the quarter), the ballast on the base.
        on_sleepers = track.sleeper_nodes(series["node_positions"], base_z)
        nodal_z = np.asarray(series["nodal_forces"])[dem_hold][..., 2]
        interface = float(np.mean(nodal_z[:, on_sleepers].sum(axis=1)))
        carried = 0.5 * wheel + fem["weight"]
        if p["subgrade"] == "layers":  # the layers' top carries the bed: the coupled forces on it, downwards
            base = -float(np.mean(nodal_z[:, ~on_sleepers].sum(axis=1)))
        else:
            base = float(np.mean(np.asarray(series["base_force"])[dem_hold]))
        bed_weight = dem["total_particle_mass_kg"] * track.GRAVITY
        # The bed's porosity between its base and the sleepers' base (Irazábal §7.2: 39.41 %).
        bed_volume = fem["endX"] * track.bed_width(p) * -base_z
        porosity = 1.0 - dem["total_particle_mass_kg"] / p["ballast_density"] / bed_volume
        track_error = abs(interface - carried) / carried
        base_error = abs(base - (interface + bed_weight)) / (interface + bed_weight)

        fine = np.linspace(0.0, x[-1], 200)
        winkler_fine = track.winkler_deflection(fine, wheel, modulus, bending, period=2 * fem["endX"])
        self._plot(out, p, monitor, t, td, seats, x, rail_line, seat_line, (fine, winkler_fine), stiffness, k_support)
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {
            "dem": {k: v for k, v in series.items() if k not in ("triangles", "node_positions")},
            "fem": monitor, "deflection_line": {"x": x, "rail": rail_line, "seat": seat_line, "winkler": winkler}})

        checks = [
            {"name": "ballast force on the track vs Q/2 + track weight (hold)", "value": track_error,
             "limit": p["statics_tolerance"]},
            {"name": "base force vs track force + bed weight (hold)", "value": base_error,
             "limit": p["statics_tolerance"]},
            {"name": "rail deflection line vs Winkler closed form (share of the deflection under the wheel)",
             "value": winkler_error, "limit": p["winkler_tolerance"]},
        ]
        stiffness_error = abs(stiffness - THESIS_K_SUB) / THESIS_K_SUB
        if not p["smoke"]:  # the thesis's figure needs the default bed; the smoke run's grains are twice as coarse
            checks.append({"name": "K vs the thesis's 102.22 kN/mm", "value": stiffness_error,
                           "limit": p["stiffness_tolerance"]})
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"track_stiffness_kN_per_mm": stiffness, "rail_deflection_m": rail_deflection,
                        "wheel_load_N": wheel, "ramp_tangent_stiffness_kN_per_mm": slope,
                        "initial_tangent_stiffness_kN_per_mm": initial,
                        "sleeper_support_stiffness_kN_per_mm": k_support,
                        "sleeper_support_stiffness_full_sleeper_kN_per_mm": 2 * k_support,
                        "sleeper_support_stiffness_each_kN_per_mm": k_sub.tolist(),
                        "rail_seat_stiffness_kN_per_mm": k_rail_seat.tolist(),
                        "seat_forces_N": seat_force.tolist(), "loaded_seat_share": float(seat_force[0] / wheel),
                        "sleeper_deflection_m": float(seat_deflection[0]),
                        "support_modulus_N_per_m2": modulus, "winkler_beta_per_m": beta,
                        "winkler_track_stiffness_kN_per_mm": wheel / winkler[0] / KN_PER_MM,
                        "deflection_line_x_m": x.tolist(), "rail_deflection_line_m": rail_line.tolist(),
                        "winkler_deflection_line_m": winkler.tolist(), "interface_force_N": interface,
                        "base_force_N": base, "track_weight_N": fem["weight"], "bed_weight_N": bed_weight,
                        "particles": dem["particles"], "bed_porosity": porosity, "bed_depth_m": -base_z,
                        "total_particle_mass_kg": dem["total_particle_mass_kg"],
                        "base_young_Pa": track.base_young(p), "elements": fem["elements"], "dofs": fem["dofs"]},
            "reference": {"thesis_k_sub_kN_per_mm": THESIS_K_SUB, "thesis_k_sub_stiff_base_kN_per_mm":
                          THESIS_K_SUB_STIFF_BASE, "range_kN_per_mm": list(RANGE_KN_PER_MM),
                          "thesis_track_stiffness_kN_per_mm": THESIS_TRACK_K, "thesis_bed_porosity": THESIS_POROSITY,
                          "winkler_rail_deflection_m": float(winkler[0])},
            "relative_error": {"track_stiffness_vs_thesis_k_sub": stiffness_error,
                               "sleeper_support_vs_thesis_k_sub": abs(k_support - THESIS_K_SUB) / THESIS_K_SUB,
                               "track_stiffness_vs_thesis_K": abs(stiffness - THESIS_TRACK_K) / THESIS_TRACK_K,
                               "deflection_line_vs_winkler": winkler_error, "track_statics": track_error,
                               "base_statics": base_error},
            "checks": checks,
        }

    @staticmethod
    def _plot(out, p, monitor, t, td, seats, x, rail_line, seat_line, winkler, stiffness, k_sub):
        """load_deflection.png: Q against the rail's deflection under the wheel with the thesis's stiffnesses, and the
        deflection line against Winkler's; history.png: load, deflections and the sleepers' reactions over time."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        before = (t > p["load_start_s"] - 0.01) & (t <= p["load_start_s"])
        rail0 = np.asarray(monitor["railUz0"])
        delta = (rail0[before].mean() - rail0) * 1e3  # mm
        q = np.asarray(monitor["wheelLoad"]) / 1e3   # kN
        fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
        a.plot(delta, q, lw=1.2, label=f"coupled run: K = {stiffness:.1f} kN/mm")
        top = q.max()
        for k, style, label in ((THESIS_K_SUB, "--", "thesis k_sub 102.22 kN/mm"),
                                (RANGE_KN_PER_MM[0], ":", "70 kN/mm"), (RANGE_KN_PER_MM[1], ":", "110 kN/mm"),
                                (THESIS_TRACK_K, "-.", "thesis K 75 kN/mm")):
            a.plot([0, top / k], [0, top], style, lw=1.0, label=label)
        a.set_xlabel("rail deflection under the wheel [mm]")
        a.set_ylabel("wheel load Q [kN]")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
        b.plot(x, rail_line * 1e3, "o-", label="rail (FEM, neutral axis)")
        seats_x = np.arange(p["sleepers"]) * p["sleeper_spacing"]
        b.plot(seats_x, np.interp(seats_x, x, seat_line) * 1e3, "s", label="sleeper base under the rail")
        b.plot(winkler[0], winkler[1] * 1e3, "--", label="Winkler closed form (measured modulus)")
        b.invert_yaxis()
        b.set_xlabel("x from the wheel [m]")
        b.set_ylabel("deflection [mm]")
        b.grid(alpha=0.3)
        b.legend(fontsize=8)
        b.set_title(f"sleepers' support k_sub (per rail seat) {k_sub:.1f} kN/mm")
        fig.tight_layout()
        fig.savefig(os.path.join(out, "load_deflection.png"), dpi=120)
        plt.close(fig)
        results.plot_history(os.path.join(out, "history.png"), title="track under a wheel load ramp", panels=[
            {"x": t, "y": q, "label": "wheel load Q", "ylabel": "[kN]"},
            {"x": t, "y": -rail0 * 1e3, "label": "rail under the wheel", "ylabel": "deflection [mm]",
             "more": [(-np.asarray(monitor["seatUz0"]) * 1e3, "loaded sleeper's base")]},
            {"x": td, "y": seats[:, 0] * 2 / 1e3, "label": "loaded sleeper (rail seat)",
             "ylabel": "ballast reaction [kN]",
             "more": [(seats[:, k] / 1e3, f"sleeper {k}") for k in range(1, seats.shape[1])]}])
