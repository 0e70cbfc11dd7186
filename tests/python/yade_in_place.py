"""Run by test_yade.py as `yade -n -x yade_in_place.py MODEL OUT.json`: the in-place recipe
of the README on a scene bonded by YADE's own functors (cohesive CohFrictPhys interactions
from Ip2 setCohesionNow), then YADE's periodic element tests on that scene as it stands, and
the package's relaxed tensor of the scene's bond table."""

import json
import os
import sys

here = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, os.path.join(here, "..", "..", "yade-scripts"))

import numpy as np  # noqa: E402

import anisobond as ab  # noqa: E402
import anisobond_yade as ay  # noqa: E402
from yade import O, pack  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402
from yade.wrapper import (Bo1_Sphere_Aabb, CohFrictMat, ForceResetter,  # noqa: E402
                          Ig2_Sphere_Sphere_ScGeom6D, InsertionSortCollider, InteractionLoop,
                          Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator)

model_path, out = sys.argv[1], sys.argv[2]

# The user's scene: YADE's packing, bonded by YADE's own functors.
sp = pack.randomPeriPack(radius=1e-3, initSize=Vector3(1.6e-2, 1.6e-2, 1.6e-2),
                         rRelFuzz=0.1, seed=11, noPrint=True)
# anisobond_yade reads YADE's own SpherePack.save file (5 columns, clumpId -1).
saved = os.path.join(os.path.dirname(out), "spherepack.txt")
sp.save(saved)
read_back = ay.read_packing(saved)
O.reset()
mat = O.materials.append(CohFrictMat(young=1e9, poisson=0.3, density=2600.0, frictionAngle=0.5,
                                     isCohesive=True, momentRotationLaw=True,
                                     normalCohesion=1e30, shearCohesion=1e30))
sp.toSimulation(material=mat)
bo1 = Bo1_Sphere_Aabb(aabbEnlargeFactor=1.06)
ig2 = Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=1.06)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([bo1]),
    InteractionLoop([ig2], [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)],
                    [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=False)]),
    NewtonIntegrator(damping=0.4),
]
O.dt = 0.0
O.step()
bo1.aabbEnlargeFactor = ig2.interactionDetectionFactor = 1.0

# The recipe: springs from the anisobond model, stress-free, then the user's own run.
table = ay.assign(model_path)
packing = ay.Packing([tuple(b.state.pos) for b in O.bodies], [b.shape.radius for b in O.bodies],
                     tuple(O.cell.hSize[k, k] for k in range(3)))
O.dt = 0.8 * ay.critical_time_step(packing, table, 2600.0)
res = ay.element_tests_in_place(strain=1e-5, steps=3000, damping=0.4)

# anisobond's relaxed tensor of the scene's bond table (what YADE holds now).
written = ay.bond_table(os.path.join(os.path.dirname(out), "bonds.csv"))
pk = ab.Packing(packing.positions, packing.radii, cell=packing.cell)
pk.save(os.path.join(os.path.dirname(out), "packing.txt"))
asm = ab.Assembly.from_bonds(pk, ab.Model.load(model_path), written.i, written.j)
b = asm.bonds
spring_difference = max(
    float(np.max(np.abs(b[k] - np.asarray(getattr(written, k))) / max(np.max(b[k]), 1e-300)))
    for k in ("kn", "ks", "kr", "ktw"))
relaxed = asm.tensor("relaxed", tolerance=1e-10)
with open(out, "w") as f:
    json.dump({"n_particles": len(packing), "n_bonds": len(written),
               "cohesive": len(ay.cohesive_interactions()),
               "spherepack_read": [len(read_back), len(sp)],
               "spring_difference": spring_difference, "yade": res.c,
               "relaxed": relaxed.tolist()}, f, indent=1)
print("yade_in_place: %d particles, %d bonds" % (len(packing), len(written)))
sys.exit(0)
