"""Run by test_yade.py as `yade -n -x yade_scene.py MODEL OUT.json`, with the anisobond
package importable: YADE builds a periodic packing and its interactions itself
(pack.randomPeriPack, the collider with an interaction detection factor); the package
computes the springs of exactly those interactions; YADE runs its damped element tests on
them (yade-scripts/anisobond_yade.py) and the package gives the relaxed tensor of the same
bonds. The test compares the two tensors."""

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
DETECTION = 1.06  # interactions between spheres closer than 1.06 (R1 + R2)

# YADE's own packing and interactions.
sp = pack.randomPeriPack(radius=1e-3, initSize=Vector3(1.6e-2, 1.6e-2, 1.6e-2),
                         rRelFuzz=0.1, seed=5, noPrint=True)
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
n_interactions = sum(1 for I in O.interactions if I.isReal)

# The package computes the springs of those interactions (anisobond.Model.springs).
model = ab.Model.load(model_path)
packing, table = ay.scene_bonds(model)

# The package's relaxed tensor of the same bonds (same pairs and images, minimum image).
pk = ab.Packing(packing.positions, packing.radii, cell=packing.cell)
asm = ab.Assembly.from_bonds(pk, model, table.i, table.j)
b = asm.bonds
swap = np.asarray(table.i) > np.asarray(table.j)
spring_difference = max(
    float(np.max(np.abs(b[k] - np.asarray(getattr(table, k))) / np.max(b[k])))
    for k in ("kn", "ks", "kr", "ktw"))
length_difference = float(np.max(np.abs(b["length"] - np.asarray(table.length)) / b["length"]))
relaxed = asm.tensor("relaxed", tolerance=1e-9)

# YADE's quasi-static tensor: damped element tests on exactly those bonds and springs.
res = ay.element_tests(packing, table, strain=1e-5, steps=1500, damping=0.4)

with open(out, "w") as f:
    json.dump({
        "n_particles": len(packing), "n_interactions": n_interactions, "n_bonds": len(table),
        "swapped": int(swap.sum()), "coordination": asm.coordination,
        "spring_difference": spring_difference, "length_difference": length_difference,
        "yade": res.c, "relaxed": relaxed.tolist(), "numpy": np.__version__,
        "anisobond": ab.__version__,
    }, f, indent=1)
print("yade_scene: %d particles, %d bonds; wrote %s" % (len(packing), len(table), out))
sys.exit(0)
