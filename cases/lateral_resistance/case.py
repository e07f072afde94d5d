"""Lateral resistance of a sleeper in ballast (DEM only): peak force against the laboratory line and the thesis's DEM
line, shares of base, sides and shoulder, vertical equilibrium and the mobilised base friction (see README.md)."""
import os
import sys

import numpy as np

from railcosim import results
from railcosim.case import Case

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bed_geometry  # noqa: E402  (the bed's profile, shared with dem.py)

GRAVITY = 9.81
# Peak lateral force against vertical load, F_p = slope F_v + intercept [N]: van 't Zand & Moraal (1997) in the lab,
# Irazábal (2017) eq. 6.10; the thesis's DEM fit, eq. 6.11.
LAB_LINE = (0.7247, 9011.9)
THESIS_DEM_LINE = (0.7442, 9213.39)
# Irazábal §6.4.5: the crest lowered by 6 cm cuts the unloaded sleeper's resistance by about 20 %.
CREST_DROP_M, CREST_DROP_FACTOR = 0.06, 0.80
# Beyond this push the thesis finds the base's share negligible and the shoulder's about 90 % (Fig. 6.29).
SHARE_FROM_M = 2.5e-3
# The laboratory's peak is the largest force over a 25 mm push (§6.4.1): compared only for a push that long.
FULL_PUSH_M = 0.025


def lab_peak(p):
    """The laboratory peak for this run's load and crest, or None where the lab and the thesis give none."""
    line = LAB_LINE[0] * p["vertical_load_N"] + LAB_LINE[1]
    if p["crest_drop_m"] == 0:
        return line
    if abs(p["crest_drop_m"] - CREST_DROP_M) < 1e-9 and p["vertical_load_N"] == 0:
        return CREST_DROP_FACTOR * line
    return None


class LateralResistance(Case):
    """DEM only (case.toml dem_only): the sleeper is rigid (README: its compliance is far below the ballast's)."""

    def postprocess(self, p, out):
        info = results.read_json(os.path.join(out, "dem_info.json"))
        series = results.read_dem_series(out)
        u, raw = series["displacement"], series["lateral_force"]
        # The peak of the force averaged over peak_window_m of push: the lab's actuator pushed over 150 s and
        # measured a quasi-static force; a sleeper riding over grains of the reduced (coarser) grading rattles,
        # and the records' short spikes are those impacts, not resistance.
        width = max(1, int(round(p["peak_window_m"] / p["record_every_m"])))
        force = np.convolve(raw, np.ones(width) / width, mode="same") if len(raw) > width else raw
        k = int(np.argmax(force))
        peak = float(force[k])
        faces = ("base", "sides", "shoulder", "top")
        smooth = lambda y: np.convolve(y, np.ones(width) / width, mode="same") if len(y) > width else y
        share = {f: smooth(series[f"{f}_lateral_force"]) / np.where(force > 0, force, np.nan) for f in faces}
        late = u >= SHARE_FROM_M
        shares_late = {f: float(np.nanmean(share[f][late])) for f in faces} if late.any() else {}
        # Vertical momentum of the free sleeper over the push (Newton's second law, whatever the contact law): the
        # ballast's mean vertical reaction minus the weight and load equals m (v_end - v_start) / T.
        mass = info["loaded_mass_kg"]
        weight = mass * GRAVITY
        duration = float(series["time"][-1])
        momentum = mass * (float(series["sleeper_velocity_z"][-1]) - info["sleeper_velocity_z_start"]) / duration
        equilibrium = abs(float(np.mean(series["vertical_reaction"])) - weight - momentum) / weight
        # Base friction mobilised over the last fifth of the push: the base's lateral over its normal force, at most
        # the ballast-sleeper mu (Coulomb), less where contacts stick or the layer under the sleeper moves with it.
        end = u >= 0.8 * u[-1]
        base_lateral = float(np.mean(series["base_lateral_force"][end]))
        base_vertical = float(np.mean(series["base_normal_force"][end]))
        # None when the base has left the grains (a sleeper riding up on its crib carries nothing on its base)
        mobilised = base_lateral / base_vertical if base_vertical > 0 else None
        # Coulomb on the base contacts: their tangential forces' lateral part over their normal forces' magnitudes,
        # summed over the push. |F_t| <= mu |F_n| per contact, so for the sum, whatever the contacts' normals (an edge
        # contact's normal force also pushes sideways, which is why the whole base's lateral force may exceed mu).
        if "base_shear_lateral_force" not in series:
            raise ValueError(f"{out}: the records have no base shear forces (a run of an earlier dem.py); run it again")
        base_normal = float(np.sum(series["base_normal_magnitude"]))
        if not base_normal > 0:
            raise ValueError(f"{out}: the sleeper's base touched no grain during the push; the bed under it is missing")
        coulomb = float(np.sum(series["base_shear_lateral_force"])) / base_normal
        total_end = float(np.mean(raw[end]))
        base_share_end = base_lateral / total_end if total_end > 0 else 0.0
        reference = lab_peak(p)
        # The bed as the push starts (after the rest under the sleeper): its porosity against the thesis's pre-packed
        # 39.44 % (T5) and 39.43 % (T7), whole and in its parts.
        if "bed_spheres_at_start" not in series:
            raise ValueError(f"{out}: the records have no bed at the push's start (a run of an earlier dem.py)")
        sleeper_z = p["ballast_depth"] + 0.5 * p["sleeper_height"] - info["sleeper_sink_m"]
        porosity = bed_geometry.porosities(p, series["bed_spheres_at_start"], sleeper_z)
        metrics = {"peak_lateral_force_N": peak, "vertical_load_N": p["vertical_load_N"],
                   "peak_displacement_m": float(u[k]), "force_at_end_N": float(force[-1]),
                   "peak_of_records_N": float(np.max(raw)),
                   "crest_drop_m": p["crest_drop_m"],
                   "mean_vertical_reaction_N": float(np.mean(series["vertical_reaction"])), "weight_and_load_N": weight, "base_friction_mobilised": mobilised,
                   "base_contact_friction_mobilised": coulomb,
                   "base_share_last_fifth": base_share_end,
                   **{f"{f}_share_at_peak": float(share[f][k]) for f in faces},
                   **{f"{f}_share_beyond_2_5mm": v for f, v in shares_late.items()},
                   "base_share_first_record": float(series["base_lateral_force"][0] / raw[0]) if raw[0] > 0 else 0.0,
                   **{f"porosity_{name}": value for name, value in porosity.items()},
                   "spheres": info["spheres"], "dem_dt_s": info["dt"], "push_steps": info["push_steps"],
                   "packing_wall_time_s": info["packing_wall_time_s"], "push_wall_time_s": info["push_wall_time_s"]}
        # Shares are undefined where the total force is not positive (a frictionless sleeper before its end meets
        # the shoulder): None in summary.json rather than NaN.
        metrics = {name: (None if isinstance(value, float) and not np.isfinite(value) else value)
                   for name, value in metrics.items()}
        checks = [
            # The records' means are of samples every few steps, not the exact time integral: 5 % of the weight.
            {"name": "vertical momentum balance of the sleeper", "value": equilibrium,
             "limit": p["equilibrium_tolerance"]},
        ]
        if p["sleeper_friction"] > 0:
            # Coulomb bound on the base contacts (above): exact, so the limit is 1 but for rounding.
            checks.append({"name": "base contacts' tangential / normal force over the ballast-sleeper mu",
                           "value": coulomb / p["sleeper_friction"], "limit": 1.0 + 1e-9})
        else:
            # Frictionless sleeper: the base's contacts push normal to it, vertically, so its lateral force vanishes
            # but for the contacts at its bottom edges, whose normals tilt: at most 5 % of what the base would carry
            # with the lab's mu (0.7247 x weight and load), a few of its contacts.
            checks.append({"name": "base lateral force of a frictionless sleeper / (0.7247 x weight and load)",
                           "value": abs(base_lateral) / (LAB_LINE[0] * weight),
                           "limit": p["frictionless_base_share"]})
        summary_reference = {"thesis_dem_peak_N": THESIS_DEM_LINE[0] * p["vertical_load_N"] + THESIS_DEM_LINE[1]}
        relative_error = {}
        if reference is not None and u[-1] >= FULL_PUSH_M * (1 - 1e-6):
            summary_reference["lab_peak_N"] = reference
            relative_error["peak_lateral_force_N"] = (peak - reference) / reference
            checks.append({"name": "peak lateral force vs laboratory", "value": abs(peak - reference) / reference,
                           "limit": p["peak_tolerance"]})
        results.write_timeseries(os.path.join(out, "timeseries.h5"), {"dem": series})
        self._plot(os.path.join(out, "force_displacement.png"), p, series, reference)
        return {"metrics": metrics, "reference": summary_reference, "relative_error": relative_error,
                "checks": checks, "wall_time_s_dem": info["wall_time_s"]}

    @staticmethod
    def _plot(path, p, series, reference):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        u = series["displacement"] * 1e3
        fig, ax = plt.subplots(figsize=(7, 4.5))
        ax.plot(u, series["lateral_force"] / 1e3, lw=0.6, color="0.6", label="total, each record")
        width = max(1, int(round(p["peak_window_m"] / p["record_every_m"])))
        if len(u) > width:
            mean = np.convolve(series["lateral_force"], np.ones(width) / width, mode="same")
            ax.plot(u, mean / 1e3, lw=1.8, color="k", label=f"total, mean over {p['peak_window_m'] * 1e3:g} mm")
        for face, style in (("base", "-."), ("sides", ":"), ("shoulder", "--")):
            ax.plot(u, series[f"{face}_lateral_force"] / 1e3, ls=style, lw=1.2, label=face)
        if reference is not None and u[-1] >= FULL_PUSH_M * (1 - 1e-6):
            ax.axhline(reference / 1e3, color="C3", lw=1.0, label="laboratory peak (van 't Zand & Moraal)")
        ax.set_xlabel("lateral displacement of the sleeper [mm]")
        ax.set_ylabel("lateral resistance [kN]")
        ax.set_title(f"Sleeper lateral resistance, F_v = {p['vertical_load_N'] / 1e3:g} kN, "
                     f"crest drop {p['crest_drop_m'] * 100:g} cm")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
