# Direct tension of a bonded bar exported by `anisobond export yade` (run by
# tests/yade/strength_tension.rs):
#   yade -n -x strength_tension.py EXPORT_DIR OUT.json REACH CAP
# REACH (N): the force per column the speed is set for (reached in about 40,000 steps);
# CAP: the most steps run.
# The bar is built by the exported module from the export's packing.txt and bonds.csv
# (build_scene: adhesions from the table's columns when present), its bottom layer held,
# its top layer moved along +z at a constant speed, with Cundall damping 0.4. Every step the
# axial force on the top layer is recorded; the run stops once the bar has parted (or at
# the step cap). Writes the peak force, the bonds YADE lost or broke (table rows), the bond
# states and the time step.
import json
import os
import sys

export_dir, out_path = sys.argv[1], sys.argv[2]
sys.path.insert(0, export_dir)
import anisobond_yade as ay  # noqa: E402
from yade import O  # noqa: E402

packing = ay.read_packing(os.path.join(export_dir, "packing.txt"))
bonds = ay.read_bond_table(os.path.join(export_dir, "bonds.csv"), len(packing))
scene = ay.build_scene(packing, bonds, density=2600.0, damping=0.4)
z = [p[2] for p in packing.positions]
r = max(packing.radii)
bottom = [k for k in range(len(z)) if z[k] < min(z) + 0.5 * r]
top = [k for k in range(len(z)) if z[k] > max(z) - 0.5 * r]
# The axial bonds' spring and the number of bonds in series along a column: the speed is
# set so that a chain reaches `reach` (N) in about 40,000 steps.
axial = [b for b in range(len(bonds)) if abs(bonds.nz[b]) > 0.5]
kn = bonds.kn[axial[0]]
layers = len(set(round(v / (2 * r)) for v in z))
reach = float(sys.argv[3])
speed = reach * (layers - 1) / kn / (40000 * scene.dt)
for k in bottom + top:
    s = O.bodies[k].state
    s.blockedDOFs = "xyzXYZ"
    s.vel = (0, 0, speed if k in top else 0)
    s.angVel = (0, 0, 0)

interactions = scene.interactions
initial_fragile = [bool(I.phys.fragile) for I in interactions]
initial_adhesion = [float(I.phys.normalAdhesion) for I in interactions]


def top_force():
    return -sum(O.forces.f(k)[2] for k in top)


def intact(b):
    I = O.interactions[bonds.i[b], bonds.j[b]]
    return I is not None and I.isReal and not I.phys.cohesionBroken


peak, peak_step, forces = 0.0, 0, []
steps, cap = 0, int(sys.argv[4])
parted_at = None
while steps < cap:
    O.step()
    steps += 1
    f = top_force()
    forces.append(f)
    if f > peak:
        peak, peak_step = f, steps
    if parted_at is None and f < 0.01 * peak and peak > 0:
        parted_at = steps
    if parted_at is not None and steps > parted_at + 200:
        break
broken = [b for b in range(len(bonds)) if not intact(b)]
out = {
    "dt": scene.dt,
    "speed": speed,
    "steps": steps,
    "peak": peak,
    "peak_step": peak_step,
    "parted_at": parted_at,
    "final_force": forces[-1],
    "broken": [[bonds.i[b], bonds.j[b]] for b in broken],
    "n_bonds": len(bonds),
    "fragile": initial_fragile,
    "normal_adhesion": initial_adhesion,
    "top": top,
    "bottom": bottom,
}
with open(out_path, "w") as f:
    json.dump(out, f)
print("strength_tension: peak %.9g N at step %d of %d, %d bonds broken"
      % (peak, peak_step, steps, len(broken)))
