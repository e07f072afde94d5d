# Preparation run of the track cases (track_stiffness; train_passage runs it too): the ballast bed of railcosim.track
# packed once per geometry, grading and materials and kept in the bed cache (the coupled run's dem.py then finds it there; the FEM side would not wait for a
# packing) and its base's height written to OUT/bed.json.
# Run by `railcosim run` as: railcosim yade bed.py PARAMETERS.json OUTDIR
import json
import os
import sys

from railcosim import track

with open(sys.argv[1]) as f:
    parameters = json.load(f)
bed = track.TrackBed(parameters, sys.argv[2])
with open(os.path.join(sys.argv[2], track.BED_INFO), "w") as f:
    json.dump({"base_z": bed.base_z, "spheres": len(bed.spheres), "cache": bed.cache}, f, indent=2)
print(f"bed: {len(bed.spheres)} spheres, base at z = {bed.base_z:.4f} m, {bed.cache}", flush=True)
