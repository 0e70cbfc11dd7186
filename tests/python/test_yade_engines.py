"""anisobond_yade on scenes bonded by YADE itself (yade_engines.py, run by the real YADE
2023.02a): `assign` on a scene read back with O.load, `element_tests_in_place` leaving the
user's objects in the scene, and `bond_table` reporting the forces YADE's own cohesive bonds
start with."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import CUBIC_MODEL
from test_yade import yade_pythonpath

HERE = Path(__file__).resolve().parent


def yade_only():
    """Skip (fail under CI) when `yade` is not on PATH; these runs need no anisobond package."""
    if shutil.which("yade") is None:
        why = "yade is not on PATH (apt install yade)"
        if os.environ.get("CI"):
            pytest.fail(why)
        pytest.skip(why)


def run(tmp_path, *args, env=None):
    """`yade -n -x yade_engines.py MODE OUT ARGS…`; the JSON it wrote."""
    out = tmp_path / ("%s.json" % args[0])
    r = subprocess.run(["yade", "-n", "-x", str(HERE / "yade_engines.py"), args[0], str(out),
                        *map(str, args[1:])],
                       capture_output=True, text=True, cwd=tmp_path, timeout=900,
                       env=dict(os.environ, **(env or {})))
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    return json.loads(out.read_text())


def test_assign_on_a_scene_read_back_with_o_load(tmp_path):
    """A scene bonded by YADE, saved with O.save; in a new YADE process O.load leaves every
    penetrationDepth NaN until a step. assign there gives the same unp, and the same 600-step
    run (shear strain, then the user's engines), as on the fresh scene: finite and equal."""
    env = {"PYTHONPATH": yade_pythonpath()}
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    scene = tmp_path / "scene.yade.gz"
    fresh = run(tmp_path, "fresh", model, scene, env=env)
    loaded = run(tmp_path, "loaded", model, scene, env=env)
    assert fresh["nan_depths_before"] == 0
    # The case of the finding: every stored depth NaN on the loaded scene before assign.
    assert loaded["nan_depths_before"] == loaded["n_bonds"] == fresh["n_bonds"] > 0
    # The depth assign computes from positions is YADE's own (Ig2's value after a step).
    assert fresh["depth_vs_yade"] == 0.0
    assert fresh["finite"] and loaded["finite"]
    unp_f, unp_l = np.array(fresh["unp"]), np.array(loaded["unp"])
    assert np.all(np.isfinite(unp_l)) and np.array_equal(unp_f, unp_l)
    s_f, s_l = np.array(fresh["stress"]), np.array(loaded["stress"])
    assert s_f.shape == s_l.shape == (601, 6)
    assert np.max(np.abs(s_f[-1])) > 0  # the run is loaded, not trivially zero
    diff = np.max(np.abs(s_l - s_f)) / np.max(np.abs(s_f))
    pos = np.max(np.abs(np.array(loaded["positions"]) - np.array(fresh["positions"])))
    print("loaded vs fresh: stress history max diff / max = %.2e, positions %.2e m"
          % (diff, pos))
    assert diff <= 1e-12 and pos <= 1e-15
    # assign made the bonds stress-free: bond_table does not warn.
    assert fresh["warnings_after_assign"] == loaded["warnings_after_assign"] == []


def test_element_tests_in_place_keep_the_users_objects(tmp_path):
    """element_tests_in_place runs its paths on copies: afterwards the script's handles to
    its Ig2 functor, a labelled engine, a body and a material still reach the scene's
    objects (settings changed through them are seen by the scene), the scene was not moved
    (iteration, time, positions, bond forces as before), and running the tests again gives
    the same tensor."""
    env = {"PYTHONPATH": yade_pythonpath()}
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    d = run(tmp_path, "handles", model, env=env)
    assert d["seen"] == {k: True for k in ("ig2_ratcheting", "ig2_factor", "newton", "body",
                                           "material", "material_of_body", "label")}
    assert d["unchanged"]
    c1, c2 = np.array(d["c_first"]), np.array(d["c_second"])
    assert np.all(np.isfinite(c1)) and np.array_equal(c1, c2)


def test_bond_table_reports_the_forces_yades_cohesive_bonds_start_with(tmp_path):
    """YADE's cohesive bonds (setCohesionNow) start loaded: unp = 0, not the penetration depth,
    so a bond across a gap is in tension. bond_table warns (PrestressWarning) with the largest axial and shear
    forces, relative to k_n R_mean, names the `prestressed` method, and returns them; the
    numbers equal an independent recomputation from positions, radii, k_n and unp, and YADE's
    own normal forces."""
    yade_only()
    d = run(tmp_path, "prestress")
    assert d["unp_minus_depth"] > 0  # the bonds are not stress-free
    f = d["initial_forces"]
    indep = np.array(d["independent_axial"])
    print("%d particles, %d bonds: largest |N| %.4g N (%.3g k_n R_mean), mean preload stress "
          "%.4g Pa" % (d["n_particles"], d["n_bonds"], f["max_axial_force_N"],
                       f["max_axial_relative"], f["preload_mean_stress_Pa"]))
    assert not f["stress_free"] and f["n_bonds"] == d["n_bonds"]
    np.testing.assert_allclose(d["axial_force"], indep, rtol=1e-9,
                               atol=1e-9 * np.max(np.abs(indep)))
    # Bonds across gaps in tension (overlapping pairs of YADE's packing in compression).
    assert np.max(indep) > 0
    assert f["max_axial_force_N"] == pytest.approx(np.max(np.abs(indep)), rel=1e-9)
    assert f["max_axial_force_N"] == pytest.approx(d["yade_max_normal_force"], rel=1e-9)
    assert f["max_axial_relative"] == pytest.approx(d["independent_max_relative"], rel=1e-9)
    assert f["max_shear_force_N"] == 0.0  # no shear displacement yet
    assert f["max_shear_force_bond"] is None and len(f["max_axial_force_bond"]) == 2
    assert f["preload_mean_stress_Pa"] == pytest.approx(d["sigma_mean_independent"], rel=1e-9)
    assert "prestressed" in f["accounted_by"]
    assert len(d["warnings"]) == 1
    category, message = d["warnings"][0]
    assert category == "PrestressWarning"
    for said in ("not stress-free", "largest |axial force| %.4g N" % f["max_axial_force_N"],
                 "`prestressed` tensor method", "docs/prestress.md", "--prestress",
                 "anisobond_yade.assign"):
        assert said in message, (said, message)


def test_element_tests_in_place_refuse_a_scene_out_of_equilibrium(tmp_path):
    """YADE's own cohesive bonds start loaded (unp = 0 across gaps), so the scene is not in
    static equilibrium: element tests from it would measure the scene relaxing (a 203-sphere
    scene gave C11 = -136 GPa against a relaxed 0.50 GPa). element_tests_in_place refuses it,
    naming the imbalance; after assign (stress-free bonds) the imbalance is zero and the tests
    run, with a positive diagonal."""
    env = {"PYTHONPATH": yade_pythonpath()}
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    d = run(tmp_path, "unbalanced", model, env=env)
    print("imbalance / (k_n strain |l|): %.3g as YADE bonds them, %.3g after assign"
          % (d["before"], d["after"]))
    assert d["before"] > 1e-2, d["before"]
    assert d["refused"] is not None and "not in static equilibrium" in d["refused"], d["refused"]
    assert "anisobond_yade.assign" in d["refused"]
    assert d["after"] < 1e-9, d["after"]
    assert all(c > 0 for c in d["c_diagonal"]), d["c_diagonal"]


def test_assign_on_a_walled_non_periodic_scene_bonds_only_spheres(tmp_path):
    """A non-periodic YADE scene with walls, a box floor and a facet lid, bonded by YADE's own
    functors (tests/yade/walled_scene.py; before, assign raised AttributeError on
    O.cell.hSize, and 'Wall' object has no attribute 'radius'): assign gives every cohesive
    sphere-sphere interaction the model's springs (the package's Model.springs of each
    bond's own normal, radii and length, called in the script), makes it stress-free, and
    leaves YADE's cohesive contacts with the box and facets as they were, counting them."""
    env = dict(os.environ, PYTHONPATH=yade_pythonpath(),
               ANISOBOND_YADE_SCRIPTS=str(HERE.parent.parent / "yade-scripts"))
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    out = tmp_path / "assign.json"
    r = subprocess.run(["yade", "-n", "-x", str(HERE.parent / "yade" / "walled_scene.py"),
                        "assign", str(model), str(out)],
                       capture_output=True, text=True, cwd=tmp_path, timeout=900, env=env)
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    print("walled prism: %d bonds assigned, %d cohesive box/facet contacts left as they were; "
          "springs vs Model.springs %.2e" % (d["n_bonds"], d["n_other"], d["spring_difference"]))
    assert d["n_bonds"] > 100 and d["table_bonds"] == d["n_bonds"]
    assert d["n_other"] > 0 and d["table_skipped"] == d["n_other"]
    assert d["spring_difference"] <= 1e-12
    assert d["unp_minus_depth"] == 0.0
    assert d["others_unchanged"] and all(k > 0 for k in d["others_kn"])


@pytest.mark.parametrize("scene", ["rotated", "rotated-periodic"])
def test_assign_warns_when_spheres_rotated_since_yade_made_the_bonds(tmp_path, scene):
    """YADE's total-form moment law measures rotations from the orientations ScGeom6D kept
    when YADE made the contact (initialOrientation1/2, read-only from Python): assign cannot
    reset them, so on a scene that has moved the moments come back at the next step. On the
    walled prism after YADE's own 5 steps, with every tenth sphere turned by 1-4 mrad: the
    rotations assign predicts are YADE's own ScGeom6D bending and twist after one step (to
    1e-15 rad), YADE then applies k_r * bending, and assign warned (RotationWarning) with the
    largest angle; with useIncrementalForm=True (moments from the zero assign sets) it does
    not warn. assign(renew=True) makes the bonds anew: the same pairs and periodic images
    (the periodic scene has spheres outside the cell, where createInteraction picks wrong
    images), and after a step YADE's rotations, moments and normal forces are all zero."""
    env = dict(os.environ, PYTHONPATH=yade_pythonpath(),
               ANISOBOND_YADE_SCRIPTS=str(HERE.parent.parent / "yade-scripts"))
    model = tmp_path / "model.toml"
    model.write_text(CUBIC_MODEL)
    out = tmp_path / "rotated.json"
    r = subprocess.run(["yade", "-n", "-x", str(HERE.parent / "yade" / "walled_scene.py"),
                        scene, str(model), str(out)],
                       capture_output=True, text=True, cwd=tmp_path, timeout=900, env=env)
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    predicted, yade = np.array(d["predicted"]), np.array(d["yade"])
    kr = np.array(d["kr"])
    print("%d bonds: rotations since YADE made them, median %.3g rad, largest %.3g rad; "
          "assign's prediction vs YADE's ScGeom6D %.2e rad"
          % (len(kr), np.median(predicted[:, 0]), predicted[:, 0].max(),
             np.abs(predicted - yade).max()))
    assert np.all(kr > 0)
    assert np.abs(predicted - yade).max() <= 1e-15
    assert predicted[:, 0].max() > 1e-3  # the turned spheres
    # The moments came back: YADE applies k_r * bending although assign zeroed them.
    np.testing.assert_allclose(d["moment_bending"], kr * yade[:, 0], rtol=1e-12, atol=0)
    assert len(d["warnings"]) == 1 and d["warnings"][0][0] == "RotationWarning"
    message = d["warnings"][0][1]
    assert "Largest bending %.4g rad" % predicted[:, 0].max() in message, message
    assert "useIncrementalForm=True" in message
    assert d["incremental_warnings"] == []
    renewed = d["renewed"]
    assert renewed["warnings"] == [] and renewed["same_pairs"] and renewed["n"] == len(kr)
    for key in ("rotations", "yade_rotations", "moments", "normal_force_over_kn",
                "unp_minus_depth"):
        assert renewed[key] == 0.0, (key, renewed)
    if scene == "rotated-periodic":
        assert renewed["images_nonzero"] > 100, renewed
