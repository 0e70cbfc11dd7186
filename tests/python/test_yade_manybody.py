"""The many-body term in YADE (issue 33, item 3): YADE's bond laws are pairwise, so
anisobond_yade.add_manybody runs the term as a PyRunner engine whose forces the anisobond
package computes. On an FCC lattice (every particle's fit exact, centro-symmetric: the
affine state is in equilibrium), the real YADE 2023.02a's element tests with the term minus
those without must be D, built here by hand from the cubic constants."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np

import anisobond as ab
from test_yade import yade_pythonpath

HERE = Path(__file__).resolve().parent
D11, D12, D44 = 3.0e6, 2.0e6, 0.5e6
MODEL = """
[bonding]
rule = "gap"
value = 1.0e-4
[scheme]
kind = "isotropic"
normal = 2.0e9
shear = 0.6e9
[manybody]
kind = "cubic"
c11 = %r
c12 = %r
c44 = %r
""" % (D11, D12, D44)


def fcc(cells, a):
    """FCC lattice of `cells`^3 conventional cells of side a, touching spheres."""
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    g = np.array([[i, j, k] for i in range(cells) for j in range(cells) for k in range(cells)])
    pos = ((g[:, None, :] + basis[None, :, :]).reshape(-1, 3) + 0.25) * a
    return pos, np.full(len(pos), a / (2.0 * np.sqrt(2.0)))


def test_yade_element_tests_with_the_term_add_d(tmp_path):
    path = yade_pythonpath()
    a = 2e-3
    pos, radii = fcc(3, a)
    pk = ab.Packing(pos, radii, cell=(3 * a, 3 * a, 3 * a))
    model = ab.Model.from_toml(MODEL)
    assert model.has_many_body
    asm = ab.Assembly(pk, model)
    assert asm.n_bonds == 6 * len(pos)  # 12 nearest neighbours each
    term = asm.many_body()
    assert abs(term.volume_fraction - 1.0) < 1e-12 and term.excluded == []
    pk.save(tmp_path / "packing.txt")
    asm.write_bonds(tmp_path / "bonds.csv")
    (tmp_path / "model.toml").write_text(MODEL)
    out = tmp_path / "out.json"
    r = subprocess.run(
        ["yade", "-n", "-x", str(HERE / "yade_manybody.py"), str(tmp_path / "packing.txt"),
         str(tmp_path / "bonds.csv"), str(tmp_path / "model.toml"), str(out)],
        capture_output=True, text=True, cwd=tmp_path, timeout=900,
        env=dict(os.environ, PYTHONPATH=path))
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    springs = np.array(d["springs"]["c"])
    total = np.array(d["manybody"]["c"])
    # D by hand: cubic in the lab frame (the isotropic scheme has no crystal rotation).
    want = np.zeros((6, 6))
    want[:3, :3] = D12
    np.fill_diagonal(want[:3, :3], D11)
    want[3, 3] = want[4, 4] = want[5, 5] = D44
    assert np.allclose(d["manybody"]["tensor"], want, rtol=0, atol=1e-6 * D11)
    err = np.abs((total - springs) - want).max() / D11
    # The strain is 1e-6: the Cauchy (YADE) against nominal (term) stress and the
    # Green-Lagrange nonlinearity are of that order.
    assert err < 1e-4, (err, total - springs)
    # The springs' tensor is not D (the test would pass trivially if both runs were one).
    assert np.abs(springs).max() > 0.1 * D11
    print("YADE with the term: %.3g s/step (term %.3g s/step), without %.3g s/step; "
          "max |dC - D|/D11 = %.2e" % (d["manybody"]["seconds_per_step"],
                                        d["manybody"]["term_seconds_per_step"],
                                        d["springs"]["seconds_per_step"], err))


def test_exported_run_py_adds_the_term(tmp_path):
    """`export yade` of a model with [manybody] writes a run.py that passes the model, so
    the real YADE run of the export gives the same tensor as the engine added by hand."""
    path = yade_pythonpath()
    a = 2e-3
    pos, radii = fcc(3, a)
    pk = ab.Packing(pos, radii, cell=(3 * a, 3 * a, 3 * a))
    asm = ab.Assembly(pk, ab.Model.from_toml(MODEL))
    out = tmp_path / "export"
    asm.export_yade(out, strain=1e-6, steps=20)
    run_py = (out / "run.py").read_text()
    line = '    "--model", os.path.join(HERE, "model.toml"),\n'
    assert line in run_py
    runs = {}
    # The export as written, then the same export without the term (the table's springs).
    for name, text in (("export", run_py), ("springs", run_py.replace(line, ""))):
        (out / "run.py").write_text(text)
        r = subprocess.run(["yade", "-n", "-x", str(out / "run.py")], capture_output=True,
                           text=True, cwd=out, timeout=900, env=dict(os.environ, PYTHONPATH=path))
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        assert ("[manybody] term runs as a PyRunner" in r.stdout) == (name == "export")
        runs[name] = np.array(json.loads((out / "yade-tensor.json").read_text())["C"])
    want = np.zeros((6, 6))
    want[:3, :3] = D12
    np.fill_diagonal(want[:3, :3], D11)
    want[3, 3] = want[4, 4] = want[5, 5] = D44
    err = np.abs((runs["export"] - runs["springs"]) - want).max() / D11
    assert err < 1e-4, (err, runs["export"] - runs["springs"])


def test_yade_relaxes_a_disordered_packing_with_the_terms_forces(files, tmp_path):
    """On a disordered packing the affine state is not in equilibrium: the term's forces
    move the particles. YADE's damped element tests with the term must reach the library's
    relaxed tensor with the term (an exact static solve), which lies far from both the
    affine (Voigt-level) tensor and the springs' relaxed tensor plus the term's closed form."""
    from conftest import CUBIC_MODEL
    path = yade_pythonpath()
    pk = ab.Packing.load(files / "packing.txt")
    springs = ab.Assembly(pk, ab.Model.from_toml(CUBIC_MODEL))
    c_springs = springs.tensor("relaxed")
    c11 = float(c_springs[0, 0])
    text = CUBIC_MODEL + "[manybody]\nkind = \"cubic\"\nc11 = %r\nc12 = %r\nc44 = %r\n" % (
        0.6 * c11, 0.5 * c11, 0.1 * c11)
    model = ab.Model.from_toml(text)
    asm = ab.Assembly(pk, model)
    c_rel = asm.tensor("relaxed")
    c_aff = asm.tensor("voigt")
    term = asm.many_body()
    scale = np.abs(c_rel).max()
    pk.save(tmp_path / "packing.txt")
    asm.write_bonds(tmp_path / "bonds.csv")
    (tmp_path / "model.toml").write_text(text)
    out = tmp_path / "out.json"
    r = subprocess.run(
        ["yade", "-n", "-x", str(HERE / "yade_manybody.py"), str(tmp_path / "packing.txt"),
         str(tmp_path / "bonds.csv"), str(tmp_path / "model.toml"), str(out), "1000"],
        capture_output=True, text=True, cwd=tmp_path, timeout=1800,
        env=dict(os.environ, PYTHONPATH=path))
    assert r.returncode == 0 and out.exists(), r.stdout[-3000:] + r.stderr[-3000:]
    d = json.loads(out.read_text())
    c_yade = np.array(d["manybody"]["c"])
    err = np.abs(c_yade - c_rel).max() / scale
    affine_gap = np.abs(c_aff - c_rel).max() / scale
    d_lab = np.asarray(term.tensor) * term.volume_fraction
    coupling_gap = np.abs(c_springs + d_lab - c_rel).max() / scale
    print("YADE with the term vs relaxed: %.2e; affine gap %.2e; springs+D gap %.2e; "
          "%.3g s/step" % (err, affine_gap, coupling_gap, d["manybody"]["seconds_per_step"]))
    assert err < 1e-4
    assert affine_gap > 5 * err and coupling_gap > 2 * err
