"""Run by test_yade_strength.py as `yade -n -x yade_strength.py MODEL OUT.json`: a
simple-cubic block of spheres of two radii (checkerboard, 1.0 and 0.9 mm, spacing 2 mm)
bonded by YADE's own functors (CohFrictMat, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys with
setCohesionNow, detection factor 1.1: nearest neighbours only), then
anisobond_yade.assign(MODEL) in place; writes every bond's CohFrictPhys limits as YADE
holds them, with its spheres' radii and heights, and what assign returned."""

import json
import math
import os
import sys

here = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, os.path.join(here, "..", "..", "yade-scripts"))

import anisobond_yade as ay  # noqa: E402
from yade import O, utils  # noqa: E402
from yade.wrapper import (Bo1_Sphere_Aabb, CohFrictMat, ForceResetter,  # noqa: E402
                          Ig2_Sphere_Sphere_ScGeom6D, InsertionSortCollider, InteractionLoop,
                          Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator)

model, out = sys.argv[1], sys.argv[2]
FACTOR = 1.1
mat = O.materials.append(CohFrictMat(young=1e9, poisson=0.3, density=2600, frictionAngle=0.3,
                                     isCohesive=True, normalCohesion=1e300,
                                     shearCohesion=1e300, momentRotationLaw=True))
for i in range(3):
    for j in range(3):
        for k in range(4):
            r = 1.0e-3 if (i + j + k) % 2 == 0 else 0.9e-3
            O.bodies.append(utils.sphere((0.01 + 2e-3 * i, 0.01 + 2e-3 * j, 0.01 + 2e-3 * k),
                                         r, material=mat))
ip2 = Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)
ig2 = Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=FACTOR)
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=FACTOR)]),
    InteractionLoop([ig2], [ip2], [Law2_ScGeom6D_CohFrictPhys_CohesionMoment()]),
    NewtonIntegrator(damping=0.4),
]
O.dt = 0.0
O.step()
ig2.interactionDetectionFactor = 1.0
friction_before = [I.phys.tangensOfFrictionAngle for I in O.interactions if I.isReal]
table = ay.assign(model)
bonds = []
for I in O.interactions:
    if not I.isReal:
        continue
    b1, b2 = O.bodies[I.id1], O.bodies[I.id2]
    ph = I.phys
    bonds.append({
        "r": [b1.shape.radius, b2.shape.radius],
        "z": [b1.state.pos[2], b2.state.pos[2]],
        "normal_adhesion": ph.normalAdhesion,
        "shear_adhesion": ph.shearAdhesion,
        "tan_friction": ph.tangensOfFrictionAngle,
        "fragile": bool(ph.fragile),
        "cohesion_broken": bool(ph.cohesionBroken),
    })
with open(out, "w") as f:
    json.dump({"bonds": bonds, "friction_before": friction_before,
               "table_normal_adhesion": table.normal_adhesion,
               "table_joint": table.joint}, f)
print("yade_strength: %d bonds assigned" % len(bonds))
