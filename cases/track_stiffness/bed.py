# Preparation run of the track cases (track_stiffness; train_passage runs it too): the ballast bed of railcosim.track
# packed once per geometry, grading and materials and kept in the bed cache (the coupled run's dem.py or dem_driver.py
# then finds it there; the FEM side would not wait for a packing) and its base's height written to OUT/bed.json.
# Run by `railcosim run` as: railcosim yade bed.py PARAMETERS.json OUTDIR (dem_driver = "yade"), or
# python3 bed.py PARAMETERS.json OUTDIR (dem_driver = "standalone": the polyhedra library, railcosim.track_driver).
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [os.path.join(ROOT, "python"), os.path.join(ROOT, "yade_engines", "clusters")]
from railcosim import track  # noqa: E402

with open(sys.argv[1]) as f:
    parameters = json.load(f)
if parameters.get("dem_driver", "yade") == "standalone":
    from railcosim import track_driver
    bed, base_z, cache = track_driver.packed_bed(parameters, sys.argv[2], log=lambda line: print(line, flush=True))
    spheres = len(bed)
else:
    bed = track.TrackBed(parameters, sys.argv[2])
    base_z, spheres, cache = bed.base_z, len(bed.spheres), bed.cache
with open(os.path.join(sys.argv[2], track.BED_INFO), "w") as f:
    json.dump({"base_z": base_z, "spheres": spheres, "cache": cache}, f, indent=2)
print(f"bed: {spheres} spheres, base at z = {base_z:.4f} m, {cache}", flush=True)
