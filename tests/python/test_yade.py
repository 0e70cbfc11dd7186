"""Real YADE imports the package: springs for the interactions of a scene YADE built itself,
and YADE's quasi-static tensor of those bonds equals the package's relaxed tensor (0.1 %,
the tolerance of `anisobond validate yade`: 1,500 damped steps leave a small residual)."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import CUBIC_MODEL, cli

HERE = Path(__file__).resolve().parent


def yade_pythonpath():
    """Where the package is installed for YADE's Python ($ANISOBOND_YADE_PYTHONPATH, set by
    .ci/test-all), or a skip/failure that says why."""
    path = os.environ.get("ANISOBOND_YADE_PYTHONPATH")
    why = None
    if shutil.which("yade") is None:
        why = "yade is not on PATH (apt install yade)"
    elif not path:
        why = "ANISOBOND_YADE_PYTHONPATH is not set (.ci/test-all installs the wheel for YADE)"
    if why:
        if os.environ.get("CI"):
            pytest.fail(why)
        pytest.skip(why)
    return path


def test_yade_scene_springs_and_tensor(tmp_path):
    path = yade_pythonpath()
    (tmp_path / "model.toml").write_text(CUBIC_MODEL)
    out = tmp_path / "yade.json"
    env = dict(os.environ, PYTHONPATH=path)
    r = subprocess.run(["yade", "-n", "-x", str(HERE / "yade_scene.py"),
                        str(tmp_path / "model.toml"), str(out)],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=900)
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    print("YADE scene: %(n_particles)d particles, %(n_bonds)d bonds, Z = %(coordination).3f, "
          "numpy %(numpy)s" % d)
    assert d["n_bonds"] == d["n_interactions"] > d["n_particles"]
    # The same bonds: the package's geometry and springs equal those YADE's interactions got.
    assert d["length_difference"] < 1e-12 and d["spring_difference"] < 1e-12
    c_yade, c_relaxed = np.array(d["yade"]), np.array(d["relaxed"])
    diff = np.max(np.abs(c_yade - c_relaxed)) / np.max(np.abs(c_relaxed))
    print("max |C_yade - C_relaxed| / max |C_relaxed| = %.2e" % diff)
    assert diff < 1e-3


def test_yade_in_place_recipe(tmp_path):
    """A scene bonded by YADE's own functors; anisobond_yade.assign(model); YADE's periodic
    element tests on that scene -> within 1e-4 of the relaxed tensor of its bond table."""
    path = yade_pythonpath()
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    out = tmp_path / "in-place.json"
    r = subprocess.run(["yade", "-n", "-x", str(HERE / "yade_in_place.py"), str(model), str(out)],
                       capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=path),
                       cwd=tmp_path, timeout=900)
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    assert d["n_bonds"] == d["cohesive"] > d["n_particles"]
    assert d["spring_difference"] < 1e-12
    assert d["spherepack_read"][0] == d["spherepack_read"][1] == d["n_particles"]
    c_yade, c_relaxed = np.array(d["yade"]), np.array(d["relaxed"])
    diff = np.max(np.abs(c_yade - c_relaxed)) / np.max(np.abs(c_relaxed))
    print("in place: %d bonds, max |C_yade - C_relaxed| / max |C_relaxed| = %.2e"
          % (d["n_bonds"], diff))
    assert diff < 1e-4
    # The command on the scene's own bond table (anisobond_yade.bond_table): the same tensor.
    report = tmp_path / "cli.json"
    cli("tensor", tmp_path / "packing.txt", "--model", model, "--bonds", tmp_path / "bonds.csv",
        "--method", "relaxed", "--cg-tolerance", "1e-10", "-o", report)
    c_cli = np.array(json.loads(report.read_text())["C"])
    np.testing.assert_allclose(c_cli, c_relaxed, rtol=0, atol=1e-9 * np.max(np.abs(c_relaxed)))
