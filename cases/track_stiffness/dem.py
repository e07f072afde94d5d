# DEM participant of the track cases (track_stiffness; train_passage runs it too): the ballast bed of a quarter or a
# half of a straight track (railcosim.track) under the sleepers' bases, which arrive from FreeFEM
# (freefem_scripts/examples/track.edp) as the coupled surface.
# Run by `railcosim run` as: railcosim yade dem.py PARAMETERS.json ENDPOINT OUTDIR
import numpy as np

from railcosim import track
from railcosim.dem import CoupledDem

dem = CoupledDem()  # the run's parameters, endpoint and results folder, from `railcosim run`
p = dem.parameters

# 1-2. Materials (Irazábal 2017 Table 7.1), the base wall (subballast + formation), the mirror walls and the packed bed
#      (from the cache, packed once per geometry and grading).
bed = track.TrackBed(p, dem.out)

# 3. Engines: the ballast contact law with bounded rolling friction; the coupling engine between the contact loop and
#    the integrator (the sleepers' bases are facets of the sleepers' material).
coupling = dem.coupling_engine(material=bed.sleeper_material)
O.engines = bed.engines() + [coupling, NewtonIntegrator(damping=0.0, gravity=(0, 0, -track.GRAVITY))]
O.dt = dem.time_step()
dem.connect()  # receives the sleepers' bases, inserts their facets, sets O.dt = fem_dt / subcycles
bed_mass = bed.mass
print(f"{len(bed.spheres)} spheres, {bed_mass:.1f} kg, base at z = {bed.base_z:.4f} m ({p['subgrade']}); "
      f"bed {bed.cache}", flush=True)


# 4. Run the windows, one record per window: the force on the sleepers (total and nodal), on the base, kinetic energy.
def record():
    return dict(interface_force=coupling.totalForce, base_force=bed.base_force(), kinetic_energy=utils.kineticEnergy(),
                nodal_forces=coupling.nodalForces)


dem.run(record, progress=lambda last: f"interface Fz={last['interface_force'][2]:.0f} N  base wall "
                                      f"{last['base_force']:.0f} N  kinetic energy {last['kinetic_energy']:.3e} J")
# 5. What the post-processing reads (dem_info.json): the bed and the interface nodes' reference positions.
dem.save(particles=len(bed.spheres), total_particle_mass_kg=bed_mass, base_z=bed.base_z, packed_bed=bed.cache,
         arrays={"node_positions": np.asarray([tuple(v) for v in coupling.nodePositions]),
                 "triangles": np.asarray([tuple(t) for t in coupling.triangles], dtype=int)})
