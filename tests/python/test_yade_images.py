"""Issue 29, B1: YADE keeps periodic positions outside the cell; the images
Assembly.from_bonds takes (I.cellDist) are of those positions. On a fresh randomPeriPack
scene YADE builds itself (yade_images.py), every bond gets YADE's own branch vector, the
relaxed tensor equals that of the minimum-image bonds, and a wrong cellDist is refused."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np

from conftest import CUBIC_MODEL
from test_yade import yade_pythonpath

HERE = Path(__file__).resolve().parent


def test_from_bonds_takes_yade_images_of_positions_outside_the_cell(tmp_path):
    path = yade_pythonpath()
    (tmp_path / "model.toml").write_text(CUBIC_MODEL)
    out = tmp_path / "images.json"
    env = dict(os.environ, PYTHONPATH=path)
    r = subprocess.run(["yade", "-n", "-x", str(HERE / "yade_images.py"),
                        str(tmp_path / "model.toml"), str(out)],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=900)
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    print("YADE scene: %(n_particles)d particles, %(outside)d outside the cell, %(n_bonds)d "
          "bonds (%(bonds_with_outside)d touch one), longest %(max_length).3e m, branch "
          "difference %(branch_difference).1e" % d)
    # The case of the report: YADE keeps some positions outside the cell.
    assert d["outside"] > 0 and d["bonds_with_outside"] > 0
    # Taken relative to the wrapped positions, those images would give other branch vectors.
    print("bonds whose cellDist is wrong for the wrapped positions: %(naive_wrong)d" % d)
    assert d["naive_wrong"] > 0
    # Every bond is YADE's own: branch vector and image.
    assert d["branch_difference"] < 1e-12 and d["image_equal"]
    assert d["max_length"] < 0.5 * min(d["cell"])
    c, c_nearest = np.array(d["relaxed"]), np.array(d["nearest"])
    assert np.max(np.abs(c - c_nearest)) <= 1e-9 * np.max(np.abs(c_nearest))
    assert d["refusal"] and "nearest images" in d["refusal"], d["refusal"]
