"""Case sleeper_on_ballast: the bed preparation, the sleeper, and the post-processing with its checks (see README.md)."""
import json
import math
import os
import sys

import numpy as np

from railcosim import results, solvers
from railcosim.case import Case

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene as sc  # noqa: E402

# The sensor readings reported at a load level: those taken while the applied load lies within this fraction of it
# (on the ramp named; at the 50x default pace a ramp passes +-5 % of 44 kN in 2 ms, 4 readings of the 0.5 ms period).
LOAD_BAND = 0.05
# Momentum balance of the sleeper over the hold: the interface force must match load + weight. What may part them is
# the sleeper's inertia: the ramp's end excites the sleeper on the bed, whose inertial force peaks at about P'/omega
# (P' the ramp rate in simulated time, omega its bounce on the bed, 2 pi 133 Hz on a bed of 1e8 N/m^3,
# freefem_scripts/README.md "Sleeper": 2.6 kN or 2 % of 132 kN at the 50x pace), and a hold of about one period
# averages it only partly; the limit is 1.5 times that peak (the bed's stiffness is known to a factor of about 2,
# omega to its square root).
BOUNCE_FREQUENCY_HZ = 133.0
HOLD_BALANCE_FACTOR = 1.5


def hold_balance_tolerance(p, applied):
    """Limit of |interface - (load + weight)| / (load + weight) over the hold (HOLD_BALANCE_FACTOR x P'/omega / it)."""
    ramp_rate = p["ramp_rate_kN_s"] * 1e3 * p["time_scale"]
    return HOLD_BALANCE_FACTOR * ramp_rate / (2.0 * math.pi * BOUNCE_FREQUENCY_HZ) / applied
LEVELS = {"44kN_before": ("ramp1", "cyclic_max_kN"), "132kN_before": ("hold", "peak_load_kN"),
          "44kN_after": ("ramp2", "cyclic_max_kN"), "132kN_after": ("final", "peak_load_kN")}

# Energy bound of the cluster bed (particle_shape = "cluster"): the ballast's contacts are dissipative (viscous
# damping, Coulomb sliding), so its mechanical energy (kinetic + gravitational, sensors included; the walls are fixed)
# can gain no more than the work the sleeper did on it plus the elastic energy its contacts held at the start:
# dE(t) <= -W_dem(t) + E_el(0). Reported: max over t of (dE - (-W_dem) - E_el(0)) / max(-W_dem), which a stable run
# keeps below 0 by what its contacts dissipated. The limit is the explicit step's own energy error: leapfrog at
# omega dt <= 0.6 (0.3 of the critical step) holds a contact's energy to within (omega dt)^2 / 4 = 9 % of what it
# exchanges (bounded, not growing; Hairer, Lubich & Wanner 2003 ch. IX), at most the work supplied; a step past the
# critical one gains energy without bound (angle_of_repose README, "Time step": 2.2 times the impact energy at 4 us).
ENERGY_BOUND_LIMIT = 0.09


def energy_bound(series, dem):
    """max_t (ballast energy gain - sleeper's work on the ballast - initial contact elastic energy) / max work."""
    work = -np.asarray(series["interface_work_dem"], float)
    gain = np.asarray(series["mechanical_energy_gain"], float)
    scale = max(float(np.max(work)), 1e-12)
    return float(np.max(gain - work - dem["contact_elastic_energy_start_j"]) / scale)


def talbot_pressure(bearing_pressure, depth):
    """Talbot's equation for the largest vertical pressure at depth h under a loaded sleeper, p_c = 16.8 p_a / h^1.25
    (h in inches, p_a the mean bearing pressure under the sleeper; Talbot 1919, as in AREMA Manual ch. 30 and Selig &
    Waters 1994 §11.3), an empirical fit to field tests for h of 4 to 30 in (0.1 to 0.76 m)."""
    return 16.8 * bearing_pressure / (depth / 0.0254) ** 1.25


def spread_pressure(load, depth):
    """2:1 load spread: the load on the sleeper's base B x L spreads at 1 horizontal to 2 vertical, so that at depth z
    it acts on (B + z)(L + z) (Selig & Waters 1994 §11.3; the Boussinesq-free estimate of track design)."""
    return load / ((sc.SLEEPER_SIZE[1] + depth) * (sc.SLEEPER_SIZE[0] + depth))


class SleeperOnBallast(Case):
    def check_parameters(self, p):
        problems = sc.check(p)
        if p["particle_shape"] == "cluster" and p["dem_driver"] != "yade":
            problems.append("particle_shape='cluster' runs on dem_driver='yade' only (YADE's clumps; the standalone "
                            "driver is the polyhedra library's)")
        return problems

    @staticmethod
    def dem_script(p, script, *arguments):
        """A DEM script of the case folder on the dem_driver's interpreter: YADE with dem_threads OpenMP threads (the
        polyhedra CPU backend's stones), or this Python with the standalone driver, as many threads."""
        path = os.path.join(p["case_dir"], script)
        if p["dem_driver"] == "yade":
            return [os.path.join(solvers.root(), "railcosim"), "yade", f"-j{p['dem_threads']}", path, *arguments]
        return solvers.library_dem_command(p, path, *arguments)

    def preparation_runs(self, p, out):
        """The ballast bed (bed.py): prepared once per parameter set and kept; later runs reuse the file."""
        return [("bed", self.dem_script(p, "bed.py", os.path.join(out, "parameters.json"), out))]

    def dem_command(self, p, endpoint, out):
        """dem.py (YADE), dem_cluster.py (YADE, particle_shape = "cluster") or dem_driver.py (standalone) on
        dem_threads threads."""
        script = "dem.py" if p["dem_driver"] == "yade" else "dem_driver.py"
        if p["particle_shape"] == "cluster":
            script = "dem_cluster.py"
        return self.dem_script(p, script, os.path.join(out, "parameters.json"), endpoint, out)

    @staticmethod
    def sleeper_options(p, seat_height):
        """The free timber sleeper over the bed's centre, its bottom face (coupled) at the seated height, loaded on
        the two rail seats of its top face by the load pattern, under its own weight."""
        scene = sc.build(p)
        x0, y0 = scene["sleeper"]["origin"]
        length, width, height = sc.SLEEPER_SIZE
        seats = scene["sleeper"]["rail_seats"]
        probes = [(seats[0], y0 + width / 2, seat_height), (scene["centre"][0], y0 + width / 2, seat_height),
                  (seats[1], y0 + width / 2, seat_height)]
        return {"origin": f"{x0},{y0},{seat_height}", "Lx": length, "Ly": width, "Lz": height,
                "nx": p["sleeper_cells_x"], "ny": p["sleeper_cells_y"], "nz": p["sleeper_cells_z"],
                "order": p["sleeper_order"], "E": p["sleeper_young"], "nu": p["sleeper_poisson"],
                "rho": p["sleeper_density"], "clamped": "", "coupled": 5, "gravity": sc.GRAVITY,
                "patchX": f"{seats[0]},{seats[1]}", "patchLength": sc.RAIL_SEAT_SIZE[0],
                "patchWidth": sc.RAIL_SEAT_SIZE[1], "patchFace": 6,
                "monitor": f"{scene['centre'][0]},{y0 + width / 2},{seat_height}",
                "probes": ",".join(f"{x},{y},{z}" for x, y, z in probes), **scene["load_pattern"]}

    def duration_s(self, p):
        """The load pattern's end and the rest after it."""
        return sc.load_run_duration(p)

    def fem_command(self, p, endpoint, out):
        """The sleeper at the height the bed preparation seated it (bed.json), for the pattern's duration."""
        with open(os.path.join(out, "bed.json")) as f:
            seat = json.load(f)["seat_height_m"]
        return solvers.coupled_fem_command({**p, "duration_s": self.duration_s(p)}, endpoint, out, solvers.box_solver(),
                                           self.sleeper_options(p, seat))

    def postprocess(self, p, out):
        dem, fem, monitor, series = results.read_coupled_run(out)
        with open(os.path.join(out, "bed.json")) as f:
            bed = json.load(f)
        phases = fem["loadPattern"]
        expected = sc.pattern_phase_ends(sc.load_pattern(p))
        pattern_error = max(abs(phases[k] - v) / expected["patternEnd"] for k, v in expected.items())
        t_fem, t_dem = monitor["time"], series["time"]
        load = -monitor["appliedLoadZ"]                       # total rail-seat load P(t) [N]
        weight = -fem["weightZ"]
        settlement = -monitor["faceMeanUz"]                   # mean downward displacement of the bottom face [m]
        strain = monitor["maxStrainXX"]
        interface = series["interface_force"][:, 2]           # force of the ballast on the sleeper, upward [N]
        load_dem = np.interp(t_dem, t_fem, load)

        # Momentum balance over the hold at the top of ramp 1: interface force vs load + weight.
        hold = (t_dem >= phases["holdStart"]) & (t_dem <= phases["holdEnd"])
        hold_fem = (t_fem >= phases["holdStart"]) & (t_fem <= phases["holdEnd"])
        interface_hold = float(np.mean(interface[hold]))
        applied_hold = float(np.mean(load[hold_fem])) + weight
        hold_error = abs(interface_hold - applied_hold) / applied_hold

        # Settlement at the end of the cycles and at the end of the run (means over the last millisecond).
        def mean_before(values, times, end, span=1e-3):
            chosen = (times <= end + 1e-12) & (times >= end - span)
            return float(np.mean(values[chosen]))

        settlement_final = mean_before(settlement, t_fem, t_fem[-1])
        settlement_cycles = mean_before(settlement, t_fem, phases["cyclesEnd"])

        # Sensor pressures at 44 and 132 kN on ramp 1 (before the cycles) and ramp 2 (after them).
        area = sc.SENSOR_SIZE[0] * sc.SENSOR_SIZE[1]
        readings = series["sensor_top_force"]
        taken = ~np.isnan(readings[:, 0])
        spans = {"ramp1": (phases["rampStart"], phases["holdStart"]), "hold": (phases["holdStart"], phases["holdEnd"]),
                 "ramp2": (phases["cyclesEnd"], phases["patternEnd"]), "final": (phases["cyclesEnd"], t_dem[-1] + 1.0)}
        pressures, counts = {}, {}
        for name, (span, level_name) in LEVELS.items():
            level = p[level_name] * 1e3
            low, high = spans[span]
            chosen = taken & (t_dem >= low) & (t_dem <= high) & (np.abs(load_dem - level) <= LOAD_BAND * level)
            counts[name] = int(np.sum(chosen))
            mean = readings[chosen].mean(axis=0) / area / 1e3 if counts[name] else np.full(readings.shape[1], np.nan)
            pressures[name] = [float(v) for v in mean]
        # Depth of the sensors' top faces at the start, below the bed's trim height and below the sleeper's bottom.
        sensor_top = float(np.mean(series["sensor_height"][0])) + 0.5 * sc.SENSOR_SIZE[2]
        depth = p["bed_height_m"] - sensor_top
        depth_below_sleeper = bed["seat_height_m"] - sensor_top
        estimates = {}
        for name, (_, level_name) in LEVELS.items():
            total = p[level_name] * 1e3 + weight
            bearing = total / (sc.SLEEPER_SIZE[0] * sc.SLEEPER_SIZE[1])
            estimates[name] = {"talbot_kPa": talbot_pressure(bearing, depth_below_sleeper) / 1e3,
                               "spread_2to1_kPa": spread_pressure(total, depth_below_sleeper) / 1e3}

        energy_error = results.interface_energy_error(dem)
        times = {"dem": series["time"], "fem": monitor["time"]}
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {
            "dem": {"time": times["dem"], "interface_force": series["interface_force"],
                    "sensor_top_force": readings, "sensor_pressure": readings / area, "sensor_height": series["sensor_height"],
                    "interface_work_dem": series["interface_work_dem"], "interface_work_fem": series["interface_work_fem"],
                    **({"mechanical_energy_gain": series["mechanical_energy_gain"]}
                       if "mechanical_energy_gain" in series else {})},
            "fem": {"time": times["fem"], "settlement": settlement, "applied_load": load, "max_strain_xx": strain,
                    **{k: v for k, v in monitor.items() if k != "time"}}})
        self.plots(out, p, t_fem, load, settlement, t_dem, interface, weight, phases, pressures, estimates, series)

        checks = [
            {"name": "interface force over the hold vs load + sleeper weight (momentum balance)", "value": hold_error,
             "limit": hold_balance_tolerance(p, applied_hold)},
            # The pattern is defined twice, in FreeFEM (the load) and here (the run's length, the reported levels).
            {"name": "load pattern phase times, FreeFEM vs scene.py (fraction of the pattern)", "value": pattern_error,
             "limit": 1e-9},
        ]
        checks.append({"name": "load levels without a sensor reading", "value": sum(1 for c in counts.values() if c == 0),
                       "limit": 0})
        extra = {}
        if p["particle_shape"] == "cluster":
            bound = energy_bound(series, dem)
            checks.append({"name": "ballast energy gain above the sleeper's work on it + its contacts' elastic energy at "
                                   "the start (fraction of that work; dissipative contacts can only lose energy)",
                           "value": bound, "limit": ENERGY_BOUND_LIMIT})
            extra = {"energy_bound": bound, "cluster_level": p["cluster_level"], "cluster_spheres": dem["cluster_spheres"],
                     "particle_mass_kg": dem["particle_mass_kg"]}
        return {
            **results.participant_summary(dem, fem),
            "metrics": {"settlement_m": settlement_final, "settlement_after_cycles_m": settlement_cycles,
                        "max_sleeper_strain": float(np.max(strain)), "sensor_pressure_kPa": pressures,
                        "interface_force_at_hold_N": interface_hold, "applied_load_at_hold_N": applied_hold,
                        "stones": dem["stones"], "sensor_depth_m": float(depth),
                        "sensor_depth_below_sleeper_m": float(depth_below_sleeper),
                        "sleeper_bottom_m": bed["seat_height_m"], "size_scale": bed["size_scale"],
                        "triangles_per_stone": p["triangles_per_stone"],
                        "mean_triangles_per_stone": bed["mean_triangles_per_stone"],
                        "mean_stone_size_m": bed["mean_stone_size_m"],
                        "bed_porosity": bed["porosity"], "bed_reused": bed["reused"],
                        "dem_dt_s": dem["dt"], "critical_time_step_s": dem["critical_time_step_s"],
                        "interface_work_dem_j": dem["interface_work_dem_j"], "interface_work_fem_j": dem["interface_work_fem_j"],
                        "sensor_readings": counts, **extra},
            "reference": {"applied_load_at_hold_N": applied_hold, "sensor_pressure_estimates_kPa": estimates,
                          "sleeper_weight_N": weight},
            "relative_error": {"interface_force_at_hold": hold_error, "interface_energy": energy_error},
            "checks": checks,
        }

    @staticmethod
    def plots(out, p, t_fem, load, settlement, t_dem, interface, weight, phases, pressures, estimates, series):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        # 1. Settlement vs time (with the load) and vs load.
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
        ax = axes[0]
        ax.plot(t_fem, settlement * 1e3, color="C0", label="settlement (mean of the bottom face)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("settlement [mm]", color="C0")
        twin = ax.twinx()
        twin.plot(t_fem, load / 1e3, color="C1", lw=0.8, label="applied load")
        twin.plot(t_dem, (interface - weight) / 1e3, color="C2", lw=0.8, ls="--", label="interface force - weight")
        twin.set_ylabel("load [kN]")
        for key in ("holdStart", "cyclesStart", "cyclesEnd"):
            ax.axvline(phases[key], color="0.6", lw=0.6)
        twin.legend(loc="upper left", fontsize=8)
        ax.set_title("Settlement and load over time")
        axes[1].plot(load / 1e3, settlement * 1e3, lw=0.8)
        axes[1].set_xlabel("applied load [kN]")
        axes[1].set_ylabel("settlement [mm]")
        axes[1].set_title("Settlement vs load")
        for ax in axes:
            ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "settlement.png"), dpi=120)
        plt.close(fig)
        # 2. Sensor pressures: bars before/after at 44 and 132 kN, with the two estimates at that depth.
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), sharey=True)
        x = np.arange(sc.SENSOR_COUNT)
        for ax, level in zip(axes, ("44kN", "132kN")):
            for k, when in enumerate(("before", "after")):
                ax.bar(x + (k - 0.5) * 0.38, pressures[f"{level}_{when}"], 0.36, label=f"{when} the cycles")
            ax.axhline(estimates[f"{level}_before"]["talbot_kPa"], color="C3", ls="--", label="Talbot (largest)")
            ax.axhline(estimates[f"{level}_before"]["spread_2to1_kPa"], color="C4", ls=":", label="2:1 spread (mean)")
            ax.set_xticks(x, [f"{i + 1}" for i in x])
            ax.set_xlabel("sensor (x order)")
            ax.set_title(f"{level[:-2]} kN on the sleeper")
            ax.grid(alpha=0.3, axis="y")
        axes[0].set_ylabel("pressure on the top face [kPa]")
        axes[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "sensor_pressures.png"), dpi=120)
        plt.close(fig)
        # 3. Interface energy audit.
        results.plot_history(os.path.join(out, "energy.png"), title="Interface energy audit",
                             panels=[results.interface_work_panel(series)])
