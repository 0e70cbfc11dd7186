"""Run by test_yade_images.py as `yade -n -x yade_images.py MODEL OUT.json`, with the
anisobond package importable (issue 29, B1): YADE builds a fresh periodic scene
(pack.randomPeriPack and its interactions), whose body positions YADE keeps partly outside
the cell; Assembly.from_bonds(packing of those positions, i, j, image=I.cellDist) must give
every bond YADE's own branch vector (b2.pos + hSize·cellDist − b1.pos, computed here by
YADE) and the tensor of the minimum-image bonds; a cellDist made wrong must be refused."""

import json
import os
import sys

import numpy as np

import anisobond as ab
from yade import O, pack
from yade.minieigenHP import Vector3
from yade.wrapper import (Bo1_Sphere_Aabb, CohFrictMat, ForceResetter,
                          Ig2_Sphere_Sphere_ScGeom6D, InsertionSortCollider, InteractionLoop,
                          Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator)

model_path, out = sys.argv[1], sys.argv[2]
DETECTION = 1.06

sp = pack.randomPeriPack(radius=1e-3, initSize=Vector3(1.2e-2, 1.2e-2, 1.2e-2),
                         rRelFuzz=0.1, seed=3, noPrint=True)
O.reset()
mat = O.materials.append(CohFrictMat(young=1e9, poisson=1.0, density=2600.0, frictionAngle=0.0))
sp.toSimulation(material=mat)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=DETECTION)]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=DETECTION)],
                    [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys()],
                    [Law2_ScGeom6D_CohFrictPhys_CohesionMoment()]),
    NewtonIntegrator(damping=0.4),
]
O.dt = 0.0
O.step()

cell = tuple(O.cell.hSize[k, k] for k in range(3))
positions = [tuple(b.state.pos) for b in O.bodies]
radii = [b.shape.radius for b in O.bodies]
outside = sum(1 for x in positions if any(not 0 <= x[k] < cell[k] for k in range(3)))
inters = [I for I in O.interactions if I.isReal]
i = [I.id1 for I in inters]
j = [I.id2 for I in inters]
image = [tuple(int(I.cellDist[k]) for k in range(3)) for I in inters]
# YADE's own branch vectors, from its body positions and cellDist.
branch = [tuple(O.bodies[I.id2].state.pos + O.cell.hSize * I.cellDist - O.bodies[I.id1].state.pos)
          for I in inters]
with_outside = sum(1 for I in inters
                   if any(not 0 <= positions[n][k] < cell[k]
                          for n in (I.id1, I.id2) for k in range(3)))

model = ab.Model.load(model_path)
pk = ab.Packing(positions, radii, cell=cell)
asm = ab.Assembly.from_bonds(pk, model, i, j, image=image)
b = asm.bonds
# from_bonds stores each pair with i < j: the branch vector and image then change sign.
sign = np.where(np.asarray(i) < np.asarray(j), 1.0, -1.0)
ours = b["normal"] * b["length"][:, None]
yade_branch = np.asarray(branch) * sign[:, None]
branch_difference = float(np.max(np.linalg.norm(ours - yade_branch, axis=1)) / np.min(b["length"]))
image_equal = bool(np.array_equal(b["image"], np.asarray(image) * sign[:, None].astype(int)))
# What taking cellDist relative to the wrapped positions would give (the reported fault).
wrapped = pk.positions
naive = (wrapped[np.asarray(j)] + np.asarray(image) * np.asarray(cell)
         - wrapped[np.asarray(i)])
naive_wrong = int(np.sum(np.linalg.norm(naive - np.asarray(branch), axis=1)
                         > 1e-9 * np.min(b["length"])))
relaxed = asm.tensor("relaxed", tolerance=1e-10)
nearest = ab.Assembly.from_bonds(pk, model, i, j).tensor("relaxed", tolerance=1e-10)

# A cellDist made wrong (one more cell along x on the first bond): refused, not computed.
wrong = list(image)
wrong[0] = (image[0][0] + 1, image[0][1], image[0][2])
try:
    ab.Assembly.from_bonds(pk, model, i, j, image=wrong)
    refusal = None
except ab.InputError as e:
    refusal = str(e)

with open(out, "w") as f:
    json.dump({"n_particles": len(positions), "outside": outside, "n_bonds": len(inters),
               "bonds_with_outside": with_outside, "cell": cell, "naive_wrong": naive_wrong,
               "max_length": float(np.max(b["length"])),
               "branch_difference": branch_difference, "image_equal": image_equal,
               "relaxed": relaxed.tolist(), "nearest": nearest.tolist(),
               "refusal": refusal}, f, indent=1)
print("yade_images: %d particles (%d outside the cell), %d bonds" % (len(positions), outside,
                                                                    len(inters)))
sys.exit(0)
