# Loads anisobond convert's outputs with YADE's own loaders (anisobond test): argv[1] by
# SpherePack.load, argv[2] by ymport.text; writes what YADE read as load-back.json.
import json
import sys
from yade import pack, ymport

sp = pack.SpherePack()
sp.load(sys.argv[1])
bodies = ymport.text(sys.argv[2])
with open('load-back.json', 'w') as f:
    json.dump({'spherepack': {'n': len(sp), 'cell': [sp.cellSize[k] for k in range(3)],
                              'radii': [r for (c, r) in sp]},
               'ymport': {'n': len(bodies), 'radii': [b.shape.radius for b in bodies]}}, f)
