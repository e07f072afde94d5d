# YADE helper for the peer-loss test: couples a resting sphere to a FEM participant and runs until stopped.
# Run: ./railcosim yade yade_engines/checks/coupled_until_stopped.py ENDPOINT
import sys

endpoint = sys.argv[1]
mat = O.materials.append(FrictMat(young=5e7, poisson=0.3, density=7800, frictionAngle=0.5))
O.bodies.append(utils.sphere((0.05, 0.05, 0.0201), 0.02, material=mat))
coupling = FemCouplingEngine(endpoint=endpoint, material=O.materials[mat], timeout=30, label="coupling")
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
             InteractionLoop([Ig2_Facet_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             coupling, NewtonIntegrator(damping=0.5, gravity=(0, 0, -9.81))]
O.dt = 1e-5
coupling.connect()
print("coupled: running until the peer stops", flush=True)
O.run(10 ** 9, True)
