# Writes the files YADE itself writes, and what they hold as JSON (anisobond test).
from yade import pack, export
import json

info = {}

def spheres():
    return [b for b in O.bodies if isinstance(b.shape, Sphere)]

# 1. randomPeriPack + SpherePack.save: ##PERIODIC:: and `x y z r clumpId`.
sp = pack.randomPeriPack(radius=1e-3, initSize=Vector3(1.2e-2, 1.2e-2, 1.2e-2),
                         rRelFuzz=0.1, seed=5, noPrint=True)
sp.save('peri.txt')
info['peri'] = {'n': len(sp), 'radii': [r for (c, r) in sp],
                'cell': [sp.cellSize[k] for k in range(3)]}

# 2. The same pack as a periodic scene, written by export.text / textExt.
O.reset()
O.periodic = True
O.cell.setBox(sp.cellSize)
sp.toSimulation()
export.text('text.txt')
export.textExt('matid.txt', format='x_y_z_r_matId')
export.textExt('attrs.txt', format='x_y_z_r_attrs', attrs=['b.state.mass', 'b.state.vel'],
               comment='mass vx vy vz')
export.textExt('idmat.txt', format='id_x_y_z_r_matId')
info['scene'] = {'n': len(spheres()), 'radii': [b.shape.radius for b in spheres()],
                 'ids': [b.id for b in spheres()]}

# 3. A non-periodic randomDensePack, saved: no ##PERIODIC:: line.
O.reset()
dense = pack.randomDensePack(pack.inAlignedBox((0, 0, 0), (1e-2, 1e-2, 1e-2)), radius=1e-3,
                             rRelFuzz=0.1, returnSpherePack=True, spheresInCell=300, seed=1)
dense.save('dense.txt')
info['dense'] = {'n': len(dense), 'radii': [r for (c, r) in dense]}

# 4. A clump saved by SpherePack.fromSimulation + save: clumpId >= 0.
O.reset()
O.bodies.append(sphere((5e-3, 0, 0), 1e-3))
O.bodies.appendClumped([sphere((0, 0, 0), 1e-3), sphere((1.5e-3, 0, 0), 1e-3)])
cl = pack.SpherePack()
cl.fromSimulation()
cl.save('clump.txt')

with open('yade-files.json', 'w') as f:
    json.dump(info, f)
