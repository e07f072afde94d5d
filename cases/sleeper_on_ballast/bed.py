# Bed preparation of the sleeper-on-ballast case (Ullrich 2022 Fig. 6.4): generate, settle, compact, trim, sensors,
# second layer, compact, trim, seat; the result is kept in a bed file that load runs and repetitions reuse.
# The stages are preparation.py's; the DEM driver is the parameter dem_driver's:
#   "yade":       railcosim yade bed.py PARAMETERS.json OUTDIR     (YADE's PolyhedraGpuEngine, yade_engine.py)
#   "standalone": python3 bed.py PARAMETERS.json OUTDIR            (the polyhedra library by ctypes, driver_engine.py;
#                                                                  the GPU machine's path: no YADE there)
# particle_shape = "cluster" (YADE only): the polyhedra bed of the same parameters, its stones replaced by their
# library clusters (cluster_engine.ClusterStage), settled and seated (preparation.prepare_clusters).
# Alone, with case.toml's defaults: [railcosim yade | python3] bed.py [--smoke] [--set name=value ...] (prints the file)
# The bed of a parameter set is prepared once: its file name is a hash of the parameters that define it
# (scene.BED_PARAMETERS, not the driver: both give the same bed); a later run with the same ones skips the preparation.
import os
import sys

# YADE runs a script without __file__: the repository is RAILCOSIM_ROOT there (set by the launchers).
ROOT = os.environ.get("RAILCOSIM_ROOT") or os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [os.path.join(ROOT, "cases", "sleeper_on_ballast"), os.path.join(ROOT, "python")]
import preparation  # noqa: E402

p, _ = preparation.parameters_from_command_line(sys.argv)
if p["particle_shape"] == "cluster":  # YADE's clumps, from the polyhedra bed of the same parameters (YadeStage)
    from cluster_engine import ClusterStage
    from yade_engine import YadeStage
    preparation.main(sys.argv, ClusterStage, polyhedron_stage=YadeStage)
elif p["dem_driver"] == "yade":
    from yade_engine import YadeStage
    preparation.main(sys.argv, YadeStage)
else:
    from driver_engine import DriverStage
    preparation.main(sys.argv, DriverStage)
