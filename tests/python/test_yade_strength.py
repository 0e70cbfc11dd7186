"""anisobond_yade.assign with a model's [strength] table (issue 32, item 5): on a block bonded
by YADE's own functors (yade_strength.py, run by the real YADE 2023.02a), every bond gets
YADE's CohFrict limits, checked here by hand from the spheres' radii and heights:
normalAdhesion = sigma_t * min(r)^2, shearAdhesion = c * min(r)^2, the friction, fragile;
joint strengths for the bonds crossing the plane of weakness. A model without [strength]
leaves the bonds unbreakable and their friction as YADE set it."""

import json
import math
import os
import subprocess
from pathlib import Path

from test_yade import yade_pythonpath

HERE = Path(__file__).resolve().parent
MODEL = """
[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "isotropic"
normal = 1.0e12
shear = 0.5e12
"""
STRENGTH = """
[strength]
[strength.bond]
tensile = 5.0e6
cohesion = 1.0e7
friction = 0.5
[[strength.planes]]
normal = [0.0, 0.0, 1.0]
spacing = 10.0
offset = 0.013
tensile = 2.0e6
cohesion = 4.0e6
friction = 0.6
"""


def run(tmp_path, text):
    model = tmp_path / "model.toml"
    model.write_text(text)
    out = tmp_path / "out.json"
    r = subprocess.run(["yade", "-n", "-x", str(HERE / "yade_strength.py"), str(model),
                        str(out)], capture_output=True, text=True, cwd=tmp_path, timeout=600,
                       env=dict(os.environ, PYTHONPATH=yade_pythonpath()))
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    return json.loads(out.read_text())


def test_assign_sets_yade_adhesions_of_the_strength_table(tmp_path):
    d = run(tmp_path, MODEL + STRENGTH)
    bonds = d["bonds"]
    # 3 x 3 x 4 block, nearest neighbours: 2*3*4*2 lateral + 3*3*3 axial.
    assert len(bonds) == 48 + 27
    joints = 0
    for b in bonds:
        r = min(b["r"])
        assert r == 0.9e-3  # checkerboard: every bond joins a 1.0 and a 0.9 mm sphere
        crosses = (b["z"][0] - 0.013) * (b["z"][1] - 0.013) < 0
        joints += crosses
        st, c, mu = (2.0e6, 4.0e6, 0.6) if crosses else (5.0e6, 1.0e7, 0.5)
        assert math.isclose(b["normal_adhesion"], st * r * r, rel_tol=1e-12)
        assert math.isclose(b["shear_adhesion"], c * r * r, rel_tol=1e-12)
        assert b["tan_friction"] == mu
        assert b["fragile"] and not b["cohesion_broken"]
    assert joints == 9
    assert sum(1 for j in d["table_joint"] if j == 0) == 9
    assert all(j in (0, -1) for j in d["table_joint"])


def test_assign_without_strength_leaves_bonds_unbreakable(tmp_path):
    d = run(tmp_path, MODEL)
    assert d["table_normal_adhesion"] is None
    for b, mu in zip(d["bonds"], d["friction_before"]):
        assert b["normal_adhesion"] == b["shear_adhesion"] == 1e300
        assert not b["fragile"] and not b["cohesion_broken"]
        assert b["tan_friction"] == mu == math.tan(0.3)
