"""Run by test_yade_engines.py as `yade -n -x yade_engines.py MODE OUT.json [ARGS]`: scenes
bonded by YADE's own functors (CohFrictMat, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys with
setCohesionNow), then what anisobond_yade does with them.

Modes:
  fresh MODEL SCENE   build the scene, O.save it to SCENE, assign(MODEL), run the steps
  loaded MODEL SCENE  O.load(SCENE) in this new process, assign(MODEL), run the same steps
  handles MODEL       assign(MODEL) (stress-free bonds), element_tests_in_place, then
                      settings changed through the script's own handles (functor,
                      labelled engine, body, material)
  unbalanced MODEL    element_tests_in_place on YADE's bonds as they start (loaded, out of
                      equilibrium): refused; then after assign(MODEL): accepted
  prestress           bond_table of YADE's cohesive bonds as they start (in tension)
"""

import json
import math
import os
import sys
import warnings

here = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, os.path.join(here, "..", "..", "yade-scripts"))

import anisobond_yade as ay  # noqa: E402
from yade import O, pack  # noqa: E402
from yade.minieigenHP import Vector3  # noqa: E402
from yade.wrapper import (Bo1_Sphere_Aabb, CohFrictMat, ForceResetter,  # noqa: E402
                          Ig2_Sphere_Sphere_ScGeom6D, InsertionSortCollider, InteractionLoop,
                          Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator)

mode, out = sys.argv[1], sys.argv[2]
STEPS = 600  # the loaded scene's run went NaN after 502 steps before assign refreshed unp
handles = {}


def yade_scene(seed=11, size=1.2e-2):
    """YADE's periodic packing bonded by YADE's functors (detection factor 1.06: the bonds
    span gaps and start in tension, unp = 0); one step with dt = 0 makes them."""
    sp = pack.randomPeriPack(radius=1e-3, initSize=Vector3(size, size, size), rRelFuzz=0.1,
                             seed=seed, noPrint=True)
    O.reset()
    mat = O.materials.append(CohFrictMat(young=1e9, poisson=0.3, density=2600.0,
                                         frictionAngle=0.5, isCohesive=True,
                                         momentRotationLaw=True, normalCohesion=1e30,
                                         shearCohesion=1e30, label="bondmat"))
    sp.toSimulation(material=mat)
    bo1 = Bo1_Sphere_Aabb(aabbEnlargeFactor=1.06)
    ig2 = Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=1.06)
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([bo1]),
        InteractionLoop([ig2], [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True)],
                        [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=False)]),
        NewtonIntegrator(damping=0.4, label="newton"),
    ]
    O.dt = 0.0
    O.step()
    bo1.aabbEnlargeFactor = ig2.interactionDetectionFactor = 1.0
    handles.update(ig2=ig2, bo1=bo1, mat=O.materials[0])


def time_step(table):
    packing = ay.Packing([tuple(b.state.pos) for b in O.bodies],
                         [b.shape.radius for b in O.bodies],
                         tuple(O.cell.hSize[k, k] for k in range(3)))
    return 0.8 * ay.critical_time_step(packing, table, 2600.0)


def finite(x):
    return all(math.isfinite(v) for v in x)


result = {}
if mode in ("fresh", "loaded"):
    model, scene = sys.argv[3], sys.argv[4]
    if mode == "fresh":
        yade_scene()
        bonds = ay.cohesive_interactions()
        # The depth from positions is the one YADE's Ig2 computed (same rounding).
        result["depth_vs_yade"] = max(abs(ay.penetration_depth(I) - I.geom.penetrationDepth)
                                      for I in bonds)
        O.save(scene)
    else:
        O.load(scene)
        bonds = ay.cohesive_interactions()
    # Before assign: O.load leaves every stored penetrationDepth NaN.
    result["nan_depths_before"] = sum(1 for I in bonds if math.isnan(I.geom.penetrationDepth))
    table = ay.assign(model)
    result["unp"] = [I.phys.unp for I in bonds]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ay.bond_table()
    result["warnings_after_assign"] = [str(w.message) for w in caught]
    O.dt = time_step(table)
    # The user's run: a shear strain in one step, then STEPS steps with their engines.
    hist = ay.run_path(5, 1e-5, STEPS, 0.4)
    result["stress"] = [s for _, _, _, s in hist]
    result["positions"] = [list(b.state.pos) for b in O.bodies]
    result["n_bonds"], result["n_particles"] = len(bonds), len(O.bodies)
    result["finite"] = (all(finite(s) for s in result["stress"])
                        and all(finite(p) for p in result["positions"]))
elif mode == "handles":
    yade_scene(seed=3, size=1.0e-2)
    ay.assign(sys.argv[3])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ay.PrestressWarning)
        table = ay.bond_table()
    O.dt = time_step(table)
    ig2, mat, body = handles["ig2"], handles["mat"], O.bodies[7]
    newton = O.engines[-1]
    before = {"iter": O.iter, "time": O.time,
              "pos": [list(b.state.pos) for b in O.bodies],
              "fn": [list(I.phys.normalForce) for I in ay.cohesive_interactions()]}
    first = ay.element_tests_in_place(strain=1e-5, steps=40, damping=0.4)
    after = {"iter": O.iter, "time": O.time,
             "pos": [list(b.state.pos) for b in O.bodies],
             "fn": [list(I.phys.normalForce) for I in ay.cohesive_interactions()]}
    result["unchanged"] = before == after
    # The same tests again: the scene was left as it was, so the same tensor.
    second = ay.element_tests_in_place(strain=1e-5, steps=40, damping=0.4)
    result["c_first"], result["c_second"] = first.c, second.c
    # Settings through the script's own handles reach the scene's objects.
    loop = O.engines[2]
    ig2.avoidGranularRatcheting = not ig2.avoidGranularRatcheting
    ig2.interactionDetectionFactor = 1.234
    newton.damping = 0.123
    body.state.vel = Vector3(1.0, 2.0, 3.0)
    mat.young = 4.5e9
    seen = {
        "ig2_ratcheting": loop.geomDispatcher.functors[0].avoidGranularRatcheting
        == ig2.avoidGranularRatcheting,
        "ig2_factor": loop.geomDispatcher.functors[0].interactionDetectionFactor == 1.234,
        "newton": O.engines[-1].damping == 0.123,
        "body": tuple(O.bodies[7].state.vel) == (1.0, 2.0, 3.0),
        "material": O.materials[0].young == 4.5e9,
        "material_of_body": O.bodies[7].material.young == 4.5e9,
    }
    # The label `newton` (a builtin YADE sets) names the scene's engine again.
    newton_label = __builtins__.newton if hasattr(__builtins__, "newton") else __builtins__["newton"]
    newton_label.damping = 0.25
    seen["label"] = O.engines[-1].damping == 0.25
    result["seen"] = seen
elif mode == "prestress":
    yade_scene(seed=11)
    bonds = ay.cohesive_interactions()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = ay.bond_table()
    result["warnings"] = [(w.category.__name__, str(w.message)) for w in caught]
    result["initial_forces"] = table.initial_forces
    result["axial_force"] = table.axial_force
    # Independently: the axial force of every bond from positions, radii and YADE's unp,
    # N = -k_n (R1 + R2 - |l| - unp) (tension positive), and the normal force YADE holds.
    indep, held, rel = [], [], []
    for I in bonds:
        b1, b2 = O.bodies[I.id1], O.bodies[I.id2]
        l = b2.state.pos + O.cell.hSize * I.cellDist - b1.state.pos
        depth = b1.shape.radius + b2.shape.radius - l.norm()
        indep.append(-I.phys.kn * (depth - I.phys.unp))
        held.append(I.phys.normalForce.norm())
        rel.append(abs(indep[-1]) / (I.phys.kn * 0.5 * (b1.shape.radius + b2.shape.radius)))
    result["independent_axial"] = indep
    result["independent_max_relative"] = max(rel)
    result["yade_max_normal_force"] = max(held)
    result["unp_minus_depth"] = max(abs(I.phys.unp - I.geom.penetrationDepth) for I in bonds)
    result["n_bonds"], result["n_particles"] = len(bonds), len(O.bodies)
    v = O.cell.volume
    result["sigma_mean_independent"] = sum(
        n * (O.bodies[I.id2].state.pos + O.cell.hSize * I.cellDist
             - O.bodies[I.id1].state.pos).norm() for n, I in zip(indep, bonds)) / (3.0 * v)
elif mode == "unbalanced":
    yade_scene(seed=3, size=1.0e-2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ay.PrestressWarning)
        table = ay.bond_table()
    O.dt = time_step(table)
    result["before"] = ay.unbalanced_bond_force(1e-5)[1]
    try:
        ay.element_tests_in_place(strain=1e-5, steps=40, damping=0.4)
        result["refused"] = None
    except ay.InputError as e:
        result["refused"] = str(e)
    table = ay.assign(sys.argv[3])
    O.dt = time_step(table)
    result["after"] = ay.unbalanced_bond_force(1e-5)[1]
    c = ay.element_tests_in_place(strain=1e-5, steps=40, damping=0.4).c
    result["c_diagonal"] = [c[k][k] for k in range(6)]
else:
    raise SystemExit("unknown mode %s" % mode)

with open(out, "w") as f:
    json.dump(result, f)
print("yade_engines %s: done" % mode)
sys.exit(0)
