"""Run by test_yade_manybody.py as `yade -n -x yade_manybody.py PACKING BONDS MODEL OUT.json`:
the periodic element tests of the packing and bond table in the real YADE, once with the
springs only and once with MODEL's [manybody] term added by anisobond_yade.add_manybody
(a PyRunner engine); writes both tensors and the time per step of each run."""

import json
import os
import sys
import time

here = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, os.path.join(here, "..", "..", "yade-scripts"))

import anisobond_yade as ay  # noqa: E402

packing_path, bonds_path, model, out = sys.argv[1:5]
STEPS = int(sys.argv[5]) if len(sys.argv) > 5 else 50
packing = ay.read_packing(packing_path)
bonds = ay.read_bond_table(bonds_path, len(packing))
result = {}
for name, mb in (("springs", None), ("manybody", model)):
    t0 = time.time()
    r = ay.element_tests(packing, bonds, strain=1e-6, steps=STEPS, damping=0.4,
                         manybody=mb)
    result[name] = {"c": r.c, "seconds_per_step": (time.time() - t0) / (6 * STEPS)}
    if mb is not None:
        engine = ay._MANYBODY
        result[name]["term_seconds_per_step"] = engine.seconds / max(engine.steps, 1)
        result[name]["volume_fraction"] = engine.term.volume_fraction
        result[name]["tensor"] = engine.term.tensor.tolist()
with open(out, "w") as f:
    json.dump(result, f)
