# A non-periodic YADE scene as a user builds it (anisobond test, issue 31 item 3): a dense
# prism of spheres between four walls (utils.wall), a box floor (utils.box) and a facet lid
# (utils.facet), every contact bonded by YADE's own functors (Ip2 setCohesionNow with
# interactionDetectionFactor). Walls and box come before the spheres and the facets after
# them, so body ids are not sphere indices.
#
#   yade -n -x walled_scene.py tables OUT.json        bond_table + write_packing, what YADE holds
#   yade -n -x walled_scene.py assign MODEL OUT.json  anisobond_yade.assign (needs the package)
#   yade -n -x walled_scene.py rotated MODEL OUT.json some spheres turned after YADE bonded
#                                                     them, then assign (needs the package)
#   yade -n -x walled_scene.py rotated-periodic MODEL OUT.json   the same on the periodic scene
#   yade -n -x walled_scene.py clump OUT.json         a scene with clumps: every entry refuses it
#   yade -n -x walled_scene.py periodic OUT.json      tables of a periodic scene, some spheres
#                                                     placed outside the cell
import json
import os
import struct
import sys
import warnings

# The module: beside this script (the Rust test copies it there) or $ANISOBOND_YADE_SCRIPTS.
sys.path.insert(0, os.environ.get("ANISOBOND_YADE_SCRIPTS",
                                  os.path.dirname(os.path.abspath(sys.argv[0]))))
import anisobond_yade as ay  # noqa: E402
from yade import O, export, pack, utils  # noqa: E402
from yade.minieigenHP import Quaternion, Vector3  # noqa: E402
from yade.wrapper import (Bo1_Box_Aabb, Bo1_Facet_Aabb, Bo1_Sphere_Aabb,  # noqa: E402
                          Bo1_Wall_Aabb, CohFrictMat, CohFrictPhys, ForceResetter,
                          Ig2_Box_Sphere_ScGeom6D, Ig2_Facet_Sphere_ScGeom6D,
                          Ig2_Sphere_Sphere_ScGeom6D, Ig2_Wall_Sphere_ScGeom,
                          InsertionSortCollider, InteractionLoop,
                          FrictMat, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                          Ip2_FrictMat_FrictMat_FrictPhys,
                          Law2_ScGeom6D_CohFrictPhys_CohesionMoment,
                          Law2_ScGeom_FrictPhys_CundallStrack, NewtonIntegrator, Sphere)

mode, out = sys.argv[1], sys.argv[-1]
R = 5e-4
LX, LY, LZ = 6e-3, 6e-3, 1.2e-2


def bits(x):
    """The 64 bits of a double, to compare positions bit for bit (no decimal round trip)."""
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def engines(factor):
    bo1 = Bo1_Sphere_Aabb(aabbEnlargeFactor=factor)
    ig2 = Ig2_Sphere_Sphere_ScGeom6D(interactionDetectionFactor=factor)
    O.engines = [
        ForceResetter(),
        InsertionSortCollider([bo1, Bo1_Wall_Aabb(), Bo1_Box_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop(
            [ig2, Ig2_Wall_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom6D(),
             Ig2_Facet_Sphere_ScGeom6D()],
            [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=True),
             Ip2_FrictMat_FrictMat_FrictPhys()],
            [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=False),
             Law2_ScGeom_FrictPhys_CundallStrack()]),
        NewtonIntegrator(damping=0.4, gravity=(0, 0, -9.81)),
    ]
    return bo1, ig2


def walled_scene():
    # YADE's dense packing of the prism (made first: randomDensePack runs its own scene).
    sp = pack.randomDensePack(pack.inAlignedBox((0, 0, 0), (LX, LY, LZ)), radius=R,
                              rRelFuzz=0.15, returnSpherePack=True, spheresInCell=300, seed=3)
    O.reset()
    mat = O.materials.append(CohFrictMat(young=1e9, poisson=0.3, density=2600.0,
                                         frictionAngle=0.5, isCohesive=True,
                                         momentRotationLaw=True, normalCohesion=1e30,
                                         shearCohesion=1e30))
    # Walls are frictional (YADE's Ip2 for CohFrictMat casts the geometry to ScGeom6D, which
    # Ig2_Wall_Sphere does not make: CohFrictMat walls crash YADE); the box floor and the
    # facet lid are cohesive, so YADE bonds the spheres to them too.
    wall = O.materials.append(FrictMat(young=1e9, poisson=0.3, density=2600.0,
                                       frictionAngle=0.5))
    # Walls and the floor a fifth of a radius inside the prism: the outer spheres touch them.
    inset = 0.2 * R
    O.bodies.append([utils.wall(inset, axis=0, material=wall),
                     utils.wall(LX - inset, axis=0, material=wall),
                     utils.wall(inset, axis=1, material=wall),
                     utils.wall(LY - inset, axis=1, material=wall),
                     utils.box((LX / 2, LY / 2, inset - R), (LX, LY, R), fixed=True,
                               material=mat)])
    sp.toSimulation(material=mat)
    top = LZ - inset
    O.bodies.append([utils.facet([(-R, -R, top), (LX + R, -R, top), (LX + R, LY + R, top)],
                                 material=mat),
                     utils.facet([(-R, -R, top), (LX + R, LY + R, top), (-R, LY + R, top)],
                                 material=mat)])
    bo1, ig2 = engines(1.1)
    O.dt = 0.0
    O.step()  # YADE bonds every pair within 1.1 (R1 + R2), and every wall/box/facet contact
    bo1.aabbEnlargeFactor = ig2.interactionDetectionFactor = 1.0
    O.dt = 1e-7
    O.run(5, True)  # a few steps of the user's run: positions are YADE's, not the pack's


def periodic_scene():
    sp = pack.randomPeriPack(radius=R, initSize=(6e-3, 6e-3, 6e-3), rRelFuzz=0.1, seed=7,
                             noPrint=True)
    O.reset()
    O.periodic = True
    O.cell.setBox(sp.cellSize)
    mat = O.materials.append(CohFrictMat(young=1e9, poisson=0.3, density=2600.0,
                                         frictionAngle=0.5, isCohesive=True,
                                         momentRotationLaw=True, normalCohesion=1e30,
                                         shearCohesion=1e30))
    sp.toSimulation(material=mat)
    # YADE keeps periodic positions outside the cell: put every third sphere one cell away.
    L = sp.cellSize
    for b in O.bodies:
        if b.id % 3 == 0:
            b.state.pos = b.state.pos + Vector3(L[0], -L[1], 2 * L[2])
    bo1, ig2 = engines(1.1)
    O.engines[-1].gravity = (0, 0, 0)
    O.dt = 0.0
    O.step()
    bo1.aabbEnlargeFactor = ig2.interactionDetectionFactor = 1.0
    return [L[k] for k in range(3)]


def kind(body):
    return type(body.shape).__name__


def tables(periodic=False):
    cell = periodic_scene() if periodic else walled_scene()
    spheres = [b for b in O.bodies if isinstance(b.shape, Sphere)]
    # YADE's own count of its bonds: real sphere-sphere interactions with cohesion.
    ss, other = [], {}
    for I in O.interactions:
        if not I.isReal or not isinstance(I.phys, CohFrictPhys) or I.phys.cohesionBroken:
            continue
        b1, b2 = O.bodies[I.id1], O.bodies[I.id2]
        if isinstance(b1.shape, Sphere) and isinstance(b2.shape, Sphere):
            ss.append(I)
        else:
            k = kind(b2) if isinstance(b1.shape, Sphere) else kind(b1)
            other[k] = other.get(k, 0) + 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = ay.bond_table("bonds.csv")
    written = ay.write_packing("packing.txt")
    export.text("text6.txt")  # YADE's own writer of the same spheres: 6 significant digits
    return {
        "ids": [b.id for b in spheres],
        "x_bits": [[bits(b.state.pos[k]) for k in range(3)] for b in spheres],
        "r_bits": [bits(b.shape.radius) for b in spheres],
        "non_sphere": {str(b.id): kind(b) for b in O.bodies if not isinstance(b.shape, Sphere)},
        "yade_sphere_bonds": len(ss),
        "yade_bond_pairs": sorted([min(I.id1, I.id2), max(I.id1, I.id2)] for I in ss),
        "yade_kn": {"%d-%d" % (min(I.id1, I.id2), max(I.id1, I.id2)): I.phys.kn for I in ss},
        "yade_other_cohesive": other,
        "table_bonds": len(table),
        "table_skipped": table.skipped_interactions,
        "table_non_sphere_bodies": table.non_sphere_bodies,
        "written_ids": written.ids,
        "warnings": [w.category.__name__ for w in caught],
        "periodic": bool(O.periodic),
        "cell_bits": [bits(x) for x in cell] if periodic else None,
        # The module's own reader (what build_scene takes) reads write_packing's file back.
        "read_back": (lambda p: {"ids": p.ids, "r_bits": [bits(r) for r in p.radii],
                                 "cell_bits": [bits(x) for x in p.cell]})(
            ay.read_packing("packing.txt")) if periodic else None,
        "outside": sum(1 for b in spheres if any(not 0 <= b.state.pos[k] < cell[k]
                                                     for k in range(3))) if periodic else 0,
        "non_sphere_contacts": sum(1 for I in O.interactions if I.isReal and not (
            isinstance(O.bodies[I.id1].shape, Sphere)
            and isinstance(O.bodies[I.id2].shape, Sphere))),
    }


def assign(model):
    walled_scene()
    others = ay.skipped_cohesive_interactions()
    before = [(I.phys.kn, I.phys.ks, I.phys.unp) for I in others]
    table = ay.assign(model)
    import numpy as np
    import anisobond as ab
    m = ab.Model.load(model)
    bonds = ay.cohesive_interactions()
    # The model's springs of each bond, from its own normal, radii and length (the package's
    # spring functions called here, not through assign).
    n = np.array([list(ay.branch_vector(I).normalized()) for I in bonds])
    r1 = np.array([O.bodies[I.id1].shape.radius for I in bonds])
    r2 = np.array([O.bodies[I.id2].shape.radius for I in bonds])
    length = np.array([ay.branch_vector(I).norm() for I in bonds])
    k = m.springs(n, r1, r2, length)
    held = np.array([[I.phys.kn, I.phys.ks, I.phys.kr, I.phys.ktw] for I in bonds])
    want = np.column_stack([k["kn"], k["ks"], k["kr"], k["ktw"]])
    after = [(I.phys.kn, I.phys.ks, I.phys.unp) for I in ay.skipped_cohesive_interactions()]
    return {
        "n_bonds": len(bonds), "table_bonds": len(table),
        "table_skipped": table.skipped_interactions, "n_other": len(others),
        # Relative to each spring's largest value (a spring the model makes zero must be 0).
        "spring_difference": float(np.max(np.abs(held - want)
                                          / np.maximum(np.max(want, axis=0), 1e-300))),
        "unp_minus_depth": max(abs(I.phys.unp - ay.penetration_depth(I)) for I in bonds),
        "others_unchanged": before == after,
        "others_kn": [b[0] for b in before],
    }


def rotated(model, periodic=False):
    periodic_scene() if periodic else walled_scene()
    spheres = [b for b in O.bodies if isinstance(b.shape, Sphere)]
    # Turn every tenth sphere by a known small angle, as if the scene had moved since YADE
    # made the contacts (ScGeom6D keeps the orientations of that moment).
    for k, b in enumerate(spheres[::10]):
        axis = Vector3(1.0, 2.0, 3.0 - k % 3).normalized()
        b.state.ori = Quaternion(axis, 1e-3 * (1 + k % 4)) * b.state.ori
    bonds = ay.cohesive_interactions()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = ay.assign(model, interactions=bonds)
    predicted = table.rotations
    O.dt = 0.0
    O.step()  # nothing moves; YADE's Ig2 and law measure the rotations and set the moments
    law = [f for f in O.engines[2].lawDispatcher.functors
           if isinstance(f, Law2_ScGeom6D_CohFrictPhys_CohesionMoment)][0]
    result = {
        "predicted": [list(r) for r in predicted],
        "yade": [[I.geom.bending.norm(), abs(I.geom.twist)] for I in bonds],
        "moment_bending": [I.phys.moment_bending.norm() for I in bonds],
        "moment_twist": [I.phys.moment_twist.norm() for I in bonds],
        "kr": [I.phys.kr for I in bonds], "ktw": [I.phys.ktw for I in bonds],
        "warnings": [[w.category.__name__, str(w.message)] for w in caught],
    }
    # With the incremental moment law the moments start from the zero assign sets: no warning.
    law.useIncrementalForm = True
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ay.assign(model)
    result["incremental_warnings"] = [w.category.__name__ for w in caught]
    law.useIncrementalForm = False
    # assign(renew=True): the bonds made anew, the current orientations their reference; the
    # total-form moments then start from zero (YADE's own bending, twist and moments after a
    # step), and the pairs, images and penetration depths are those of before.
    pairs = [(I.id1, I.id2, tuple(I.cellDist)) for I in bonds]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renewed_table = ay.assign(model, renew=True)
    renewed = ay.cohesive_interactions()
    O.step()
    result["renewed"] = {
        "warnings": [w.category.__name__ for w in caught],
        "same_pairs": sorted(pairs) == sorted((I.id1, I.id2, tuple(I.cellDist))
                                              for I in renewed),
        "n": len(renewed_table),
        "rotations": max(max(r) for r in renewed_table.rotations),
        "yade_rotations": max(max(I.geom.bending.norm(), abs(I.geom.twist)) for I in renewed),
        "moments": max(max(I.phys.moment_bending.norm(), I.phys.moment_twist.norm())
                       for I in renewed),
        "normal_force_over_kn": max(I.phys.normalForce.norm() / I.phys.kn for I in renewed),
        "unp_minus_depth": max(abs(I.phys.unp - I.geom.penetrationDepth) for I in renewed),
        "images_nonzero": sum(1 for I in renewed if tuple(I.cellDist) != (0, 0, 0)),
    }
    return result


def clump():
    mat = O.materials.append(CohFrictMat(isCohesive=True))
    O.bodies.append(utils.wall(0, axis=2, material=O.materials.append(FrictMat())))
    O.bodies.append([utils.sphere((0, 0, R), R, material=mat),
                     utils.sphere((2 * R, 0, R), R, material=mat)])
    O.bodies.appendClumped([utils.sphere((0, 2 * R, R), R, material=mat),
                            utils.sphere((1.5 * R, 2 * R, R), R, material=mat)])
    engines(1.1)
    O.dt = 0.0
    O.step()
    said = {}
    for name, call in (("bond_table", lambda: ay.bond_table("clump-bonds.csv")),
                       ("write_packing", lambda: ay.write_packing("clump-packing.txt")),
                       ("assign", lambda: ay.assign("no-model.toml")),
                       ("scene_bonds", lambda: ay.scene_bonds("no-model.toml"))):
        try:
            call()
            said[name] = None
        except ay.ClumpError as e:
            said[name] = str(e)
    clumps = [b.id for b in O.bodies if b.isClump]
    members = [b.id for b in O.bodies if b.isClumpMember]
    return {"refused": said, "clumps": clumps, "members": members,
            "files": [f for f in ("clump-bonds.csv", "clump-packing.txt") if os.path.exists(f)]}


if mode == "tables":
    result = tables()
elif mode == "periodic":
    result = tables(periodic=True)
elif mode == "assign":
    result = assign(sys.argv[2])
elif mode == "rotated":
    result = rotated(sys.argv[2])
elif mode == "rotated-periodic":
    result = rotated(sys.argv[2], periodic=True)
elif mode == "clump":
    result = clump()
else:
    raise SystemExit("unknown mode %s" % mode)
with open(out, "w") as f:
    json.dump(result, f)
