"""Angle of repose of ballast (or wheat): the pile's surface fitted on every flank, against a reference angle (the
thesis' 40° for ballast; see README.md)."""
import math
import os

import numpy as np

from railcosim import results, solvers
from railcosim.case import Case

GRAVITY = 9.81


def surface_profile(spheres, sectors, bin_width):
    """The pile's surface around the z axis (the hopper's axis): for each of `sectors` equal azimuthal sectors, the
    radial bins of width bin_width and in each the highest sphere top z + r, then the sector's silhouette: the height
    at a bin is the highest top at that distance from the axis or farther, as the flank is seen from outside (near
    the axis a narrow sector's bin may hold no surface sphere). Returns [(bin centres, heights)] per sector, empty
    bins left out."""
    x, y, z, r = spheres.T
    radius = np.hypot(x, y)
    sector = np.minimum((np.arctan2(y, x) + math.pi) / (2.0 * math.pi) * sectors, sectors - 1).astype(int)
    bins = (radius / bin_width).astype(int)
    profiles = []
    for s in range(sectors):
        mine = sector == s
        tops = {}
        for b, top in zip(bins[mine], (z + r)[mine]):
            tops[b] = max(tops.get(b, 0.0), top)
        keys = sorted(tops)
        heights = np.maximum.accumulate(np.array([tops[k] for k in keys])[::-1])[::-1]
        profiles.append((np.array([(k + 0.5) * bin_width for k in keys]), heights))
    return profiles


def repose_angle(spheres, sectors, bin_width, lower, upper):
    """The angle of repose [deg]: on each sector's surface profile, the least-squares line through the points whose
    height lies between lower and upper times the pile height (the highest surface point), its slope's angle; the
    mean over the sectors. Returns the mean, the sectors' angles, the pile height and the profiles with the fits."""
    profiles = surface_profile(spheres, sectors, bin_width)
    height = max(h.max() for _, h in profiles if len(h))
    angles, fits = [], []
    for radius, h in profiles:
        band = (h >= lower * height) & (h <= upper * height)
        if band.sum() < 2:
            raise ValueError(f"a sector has {band.sum()} surface points between {lower} and {upper} of the pile height "
                             f"{height:.3f} m: the pile is too small for {sectors} sectors or bins of {bin_width:.3f} m")
        slope, intercept = np.polyfit(radius[band], h[band], 1)
        angles.append(math.degrees(math.atan(-slope)))
        fits.append((slope, intercept, radius[band], h[band]))
    return {"angle_deg": float(np.mean(angles)), "sector_angles_deg": angles, "height_m": float(height),
            "profiles": profiles, "fits": fits}


def plot_pile(path, title, measured, reference_deg, reference_label="thesis"):
    """The sectors' surface profiles, the points of each fit and its line, and the reference slope through the apex."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for k, ((radius, h), (slope, intercept, fr, fh)) in enumerate(zip(measured["profiles"], measured["fits"])):
        ax.plot(radius, h, ".", color="0.6", ms=3, label="silhouette (highest sphere top per bin and beyond)" if k == 0 else None)
        ax.plot(fr, fh, "o", mfc="none", color="C0", ms=4, label="points of the fits" if k == 0 else None)
        line = np.array([fr.min(), fr.max()])
        ax.plot(line, slope * line + intercept, "-", color="C1", lw=1, label="fits, one per sector" if k == 0 else None)
    apex = measured["height_m"]
    run = apex / math.tan(math.radians(reference_deg))
    ax.plot([0, run], [apex, 0], "k--", lw=1, label=f"{reference_deg:g}° ({reference_label})")
    ax.set_xlabel("distance from the hopper axis [m]")
    ax.set_ylabel("height [m]")
    ax.set_title(f"{title}: {measured['angle_deg']:.1f}°")
    ax.set_aspect("equal")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def measure_pile(spheres, dem, p):
    """repose_angle of a run's final spheres with its parameters p and dem_info.json dem, heights counted from the fixed
    base's top (base_top_m: its spheres' diameter, dem.py), without a base from the floor."""
    spheres = np.array(spheres, dtype=float)
    # runs before base_top_m was recorded had spheres only, whose base spheres have the mean diameter
    spheres[:, 2] -= dem.get("base_top_m", dem["mean_diameter_m"]) if p["base_radius"] > 0.0 else 0.0
    return repose_angle(spheres, p["profile_sectors"], p["profile_bin_diameters"] * dem["mean_diameter_m"],
                        p["profile_lower_fraction"], p["profile_upper_fraction"])


class AngleOfRepose(Case):
    def check_parameters(self, p):
        problems = []
        if p["material"] == "wheat" and p["particle_shape"] != "sphere":
            problems.append("material = \"wheat\" is spheres only (particle_shape = \"sphere\")")
        if self.on_library(p) and p["base_radius"] > 0.0:
            problems.append("the polyhedra library (particle_shape = \"polyhedron\", dem_driver = \"standalone\") has "
                            "no fixed bodies: base_radius must be 0")
        if p["hopper_gate_s"] > 0.0:
            # rig.Hopper.gate's travel is 1.5 apertures
            cleared = p["hopper_gate_s"] + 1.5 * p["hopper_aperture"] / p["hopper_gate_speed"]
            if cleared >= p["duration_s"]:
                problems.append(f"the gate opens at hopper_gate_s = {p['hopper_gate_s']:g} s and clears the aperture "
                                f"at {cleared:g} s, not before duration_s = {p['duration_s']:g} s: nothing could pile")
        if p["particle_shape"] == "cluster" and p["dem_driver"] == "standalone":
            problems.append("dem_driver = \"standalone\" (the polyhedra library) has no clusters: they run on YADE "
                            "(dem_driver = \"yade\")")
        if self.on_library(p) and p["material"] != "ballast":
            problems.append("dem_driver = \"standalone\" runs ballast spheres only (material = \"ballast\")")
        if p["particle_shape"] == "polyhedron" and p["friction_model"] != "constant":
            problems.append("particle_shape = \"polyhedron\" has constant friction only "
                            "(friction_model = \"constant\")")
        return problems

    @staticmethod
    def on_library(p):
        """Whether the run is polyhedra_dem.py's: polyhedra always, spheres with dem_driver = "standalone"."""
        return p["particle_shape"] == "polyhedron" or (p["particle_shape"] == "sphere" and
                                                        p["dem_driver"] == "standalone")

    def dem_command(self, p, endpoint, out):
        """dem.py on YADE, or polyhedra_dem.py (polyhedra, and spheres with dem_driver = "standalone": the polyhedra
        library without YADE, the GPU machine's path) on this Python with dem_threads OpenMP threads."""
        if not self.on_library(p):
            return super().dem_command(p, endpoint, out)
        return solvers.library_dem_command(p, os.path.join(p["case_dir"], "polyhedra_dem.py"),
                                           os.path.join(out, "parameters.json"), endpoint, out)

    def postprocess(self, p, out):
        dem = results.read_json(os.path.join(out, "dem_info.json"))
        series = results.read_dem_series(out)
        measured = measure_pile(series["spheres"], dem, p)
        angle, reference = measured["angle_deg"], p["reference_angle_deg"]
        # On a base disc what passed its edge has left the scene: the floor carries the rest.
        weight = (dem["ballast_mass_kg"] - dem.get("left_mass_kg", 0.0)) * GRAVITY
        # Oracles independent of the angle. (1) Once the hopper is empty the floor carries the whole weight (nothing
        # else holds the ballast): its mean reaction over the run's last rest_check_s, from the impulse summed every step,
        # differs from the weight only by the ballast's change of vertical momentum (a few stones still rolling).
        # (2) All of the ballast has left the hopper. (3) The contacts only dissipate (e = 0 dashpots, friction,
        # rolling friction) and the ballast starts at rest without contacts, so kinetic + potential energy never
        # exceeds its initial value: a step above the contacts' stable step shows as energy gained (README).
        time, impulse = series["time"], series["floor_impulse"]
        start = int(np.searchsorted(time, time[-1] - p["rest_check_s"] - 1e-9))
        floor_mean = float(impulse[-1] - impulse[start]) / float(time[-1] - time[start])
        floor_error = abs(floor_mean - weight) / weight
        hopper_fraction = float(series["hopper_mass"][-1]) / dem["ballast_mass_kg"]
        energy = series["kinetic_energy"] + series["potential_energy"] + series.get("left_energy", 0.0)
        released = dem["initial_energy_j"] - float(energy[-1])
        energy_gain = (max(0.0, float(energy.max()) - dem["initial_energy_j"]) / released
                       if np.all(np.isfinite(energy)) else math.inf)  # a run that blew up
        label = ("wheat, μ = %g" % p["friction"] if p["material"] == "wheat" else
                 "spheres, η_r = %g" % p["rolling_friction"] if p["particle_shape"] == "sphere" else
                 "polyhedra, r_d = %g size" % p["dilation_fraction"] if p["particle_shape"] == "polyhedron" else
                 f"{p['cluster_level']} clusters" + (f", SDF γ = {p['friction_exponent']:g}"
                                                if p["friction_model"] == "stress_dependent" else ""))
        plot_pile(os.path.join(out, "pile_profile.png"), f"Angle of repose, {label}", measured, reference,
                  "measured" if p["material"] == "wheat" else "thesis")
        results.plot_history(os.path.join(out, "discharge.png"), title=f"Hopper discharge, {label}", panels=[
            {"x": series["time"], "y": series["hopper_mass"], "label": "ballast above the aperture",
             "ylabel": "mass [kg]", "lines": []},
            {"x": series["time"], "y": series["floor_force"] / weight, "label": "floor reaction / weight",
             "ylabel": "[-]", "lines": [(1.0, "weight")]},
            {"x": series["time"], "y": series["kinetic_energy"], "label": "kinetic energy", "ylabel": "[J]", "lines": []},
        ])
        checks = [
            {"name": "angle of repose vs reference [deg]", "value": abs(angle - reference),
             "limit": p["angle_tolerance_deg"]},
            # The mean reaction is the weight to the ballast's vertical momentum change over the window (a stone of
            # 0.05 kg bumping at 0.1 m/s: 0.2 % of a 5 kg pile's weight times 0.05 s); 1 % would still flag ballast
            # held by the hopper or a pile still settling.
            {"name": "mean floor reaction vs ballast weight at the end", "value": floor_error,
             "limit": p["weight_tolerance"]},
            # A frictionless hopper keeps nothing: any ballast left above the aperture is a jam or a run cut short.
            {"name": "ballast left in the hopper (fraction)", "value": hopper_fraction, "limit": 0.0},
            # Exact bound 0; the records sample the kinetic energy at the half step of the leapfrog velocities, whose
            # offset is of order g dt per stone (1e-5 of the energy released), so any gain above energy_tolerance
            # of the released energy is the integration's.
            {"name": "kinetic + potential energy above its initial value / energy released", "value": energy_gain,
             "limit": p["energy_tolerance"]},
        ]
        if p["hopper_gate_s"] > 0.0:
            # A closed gate holds everything: no ballast may have left the hopper (centres below the aperture) before
            # it opens; a stone through it is a gate that leaks (its triangles' winding, a step too long for them).
            before = time < p["hopper_gate_s"] - 1e-9
            leaked = (float(np.max(dem["ballast_mass_kg"] - series["hopper_mass"][before])) / dem["ballast_mass_kg"]
                      if before.any() else 0.0)
            checks.append({"name": "ballast out of the hopper before the gate opened (fraction)", "value": leaked,
                           "limit": 0.0})
        if p["particle_shape"] in ("sphere", "polyhedron"):
            # Spheres stop on their rolling friction, polyhedra on their faces. Clusters have none (T2): a coarse
            # stone rolls on its round members across the bare floor for seconds (README), so a cluster run ends at
            # duration_s.
            checks.append({"name": "run ended at rest (0 = yes)", "value": 0.0 if dem["at_rest"] else 1.0,
                           "limit": 0.0})
        return {
            "metrics": {"angle_of_repose_deg": angle, "angle_spread_deg": float(np.std(measured["sector_angles_deg"])),
                        "sector_angles_deg": measured["sector_angles_deg"], "pile_height_m": measured["height_m"],
                        # the fixed-base (ISO 4324) angle: the pile's height over the base's radius (compared, not checked)
                        "base_cone_angle_deg": (math.degrees(math.atan(measured["height_m"] / p["base_radius"]))
                                                if p["base_radius"] > 0.0 else None),
                        "particles": dem["particles"], "spheres": dem["spheres"], "ballast_mass_kg": dem["ballast_mass_kg"],
                        "left_particles": dem.get("left_particles", 0), "left_mass_kg": dem.get("left_mass_kg", 0.0),
                        "simulated_s": dem["simulated_s"], "dem_steps": dem["steps"], "dem_wall_time_s": dem["wall_time_s"],
                        "floor_reaction_over_weight": floor_mean / weight, "energy_gain_fraction": energy_gain,
                        "at_rest": dem["at_rest"]},
            "reference": {"angle_of_repose_deg": reference, "ballast_weight_n": weight},
            "relative_error": {"angle_of_repose": abs(angle - reference) / reference},
            "checks": checks,
        }
