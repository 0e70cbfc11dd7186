"""anisobond.polycrystal, Assembly.grains and the "cg-amg" solver (docs/polycrystal.md): the
study's dict is the command's polycrystal.json, the grains are the bond table's and survive
being written as grain and Euler-angle files, a single crystal has none, bad keywords are
refused by name, and the multigrid-preconditioned solve gives the direct solver's tensor."""

import json

import numpy as np
import pytest

import anisobond as ab
from conftest import CUBIC_MODEL, cli

GRAINS = "\n[grains]\ncount = 5\nseed = 3\n"


@pytest.fixture(scope="module")
def poly(tmp_path_factory):
    """A 600-sphere periodic packing from `anisobond pack`, the cubic model in 5 grains."""
    d = tmp_path_factory.mktemp("poly")
    cli("pack", "--particles", 600, "--seed", 11, "-o", d / "packing.txt")
    (d / "poly.toml").write_text(CUBIC_MODEL + GRAINS)
    (d / "single.toml").write_text(CUBIC_MODEL)
    return d


def command_report(d, name, *flags):
    out = d / name
    cli("polycrystal", d / "packing.txt", "--model", d / "poly.toml", "-o", out, *flags)
    return json.loads((out / "polycrystal.json").read_text())


def test_polycrystal_equals_the_command(poly):
    pk, model = ab.Packing.load(poly / "packing.txt"), ab.Model.load(poly / "poly.toml")
    # The defaults are the command's: the same dict, key for key, to the last digit.
    r = ab.polycrystal(pk, model)
    assert r == command_report(poly, "default")
    assert len(r["grains"]) == 5 and r["particles"] == 600 and r["series"] == []
    # Every keyword against its flag.
    r = ab.polycrystal(pk, model, strain=-2e-4, load_axis="z", grain_counts=[1, 3])
    assert r == command_report(poly, "flags", "--strain", "-2e-4", "--load-axis", "z",
                               "--grain-counts", "1,3")
    assert r["load_axis"] == 2 and r["strain"] == -2e-4
    assert [s["grains"] for s in r["series"]] == [1, 3]


def bunge(phi1, big_phi, phi2):
    """g = Z(phi2) X(Phi) Z(phi1), passive elementary rotations (degrees): sample -> crystal."""
    def z(a):
        c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
        return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])

    c, s = np.cos(np.radians(big_phi)), np.sin(np.radians(big_phi))
    x = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
    return z(phi2) @ x @ z(phi1)


def test_grains_are_the_bond_tables_and_survive_their_files(poly):
    pk = ab.Packing.load(poly / "packing.txt")
    asm = ab.Assembly(pk, ab.Model.load(poly / "poly.toml"))
    g = asm.grains
    grain, orientation = g["grain"], g["orientation"]
    assert grain.dtype == np.uint32 and grain.shape == (600,)
    assert orientation.shape == (5, 3, 3) and orientation.dtype == np.float64
    assert g["centres"].shape == (5, 3)
    assert set(grain.tolist()) == set(range(5))
    for q in orientation:
        assert np.allclose(q @ q.T, np.eye(3), atol=1e-12) and np.linalg.det(q) > 0
    # The command's bond table carries each bond's grains: those of its two particles here.
    cli("bonds", poly / "packing.txt", "--model", poly / "poly.toml", "-o", poly / "b.csv")
    t = np.genfromtxt(poly / "b.csv", delimiter=",", names=True)
    i, j = t["i"].astype(np.int64), t["j"].astype(np.int64)
    assert np.array_equal(t["grain_i"], grain[i]) and np.array_equal(t["grain_j"], grain[j])
    # The study's Bunge angles rebuild the orientations (the passive ZXZ convention).
    r = ab.polycrystal(pk, ab.Model.load(poly / "poly.toml"))
    for row in r["grains"]:
        assert np.allclose(bunge(*row["bunge_deg"]), orientation[row["grain"]], atol=1e-12)
    # Written as a grain file and an Euler-angle file, read back: the same ids, no centres,
    # the same orientations and the polycrystal's relaxed tensor.
    (poly / "grains.txt").write_text("".join("%d\n" % k for k in grain))
    angles = {row["grain"]: row["bunge_deg"] for row in r["grains"]}
    (poly / "euler.txt").write_text("".join("%r %r %r\n" % tuple(angles[k]) for k in range(5)))
    (poly / "files.toml").write_text(
        CUBIC_MODEL + '\n[grains]\nfile = "grains.txt"\norientation = "euler-file"\n'
        'euler_file = "euler.txt"\n')
    back = ab.Assembly(pk, ab.Model.load(poly / "files.toml"))
    assert np.array_equal(back.grains["grain"], grain)
    assert back.grains["centres"] is None
    assert np.allclose(back.grains["orientation"], orientation, atol=1e-12)
    c = back.tensor("relaxed")
    assert np.abs(c - np.array(r["tensor_pa"])).max() <= 1e-8 * np.abs(c).max()


def test_single_crystal_has_no_grains_and_bad_keywords_are_named(poly):
    pk = ab.Packing.load(poly / "packing.txt")
    single = ab.Model.load(poly / "single.toml")
    assert ab.Assembly(pk, single).grains is None
    with pytest.raises(ab.ModelError, match=r"\[grains\]"):
        ab.polycrystal(pk, single)
    model = ab.Model.load(poly / "poly.toml")
    with pytest.raises(ab.InputError, match="load_axis `w`"):
        ab.polycrystal(pk, model, load_axis="w")
    with pytest.raises(ab.InputError, match="^strain = 0"):
        ab.polycrystal(pk, model, strain=0.0)
    with pytest.raises(ab.InputError, match="^grain_counts"):
        ab.polycrystal(pk, model, grain_counts=[4, 0])


def test_cg_amg_gives_the_direct_solvers_tensor(poly):
    # The multigrid-preconditioned CG against the sparse Cholesky factorisation (an
    # independent direct solve) and the default two-level CG, on the polycrystal.
    asm = ab.Assembly(ab.Packing.load(poly / "packing.txt"), ab.Model.load(poly / "poly.toml"))
    amg = asm.tensor("relaxed", solver="cg-amg")
    scale = np.abs(amg).max()
    for other in ("cholesky", "cg"):
        c = asm.tensor("relaxed", solver=other)
        assert np.abs(amg - c).max() <= 1e-8 * scale, other
    # ... and equals the command's --solver cg-amg to the last digit.
    out = poly / "amg.json"
    cli("tensor", poly / "packing.txt", "--model", poly / "poly.toml", "--method", "relaxed",
        "--solver", "cg-amg", "-o", out)
    assert asm.tensor_report("relaxed", solver="cg-amg") == json.loads(out.read_text())
    with pytest.raises(ab.InputError, match="cg-amg"):
        asm.tensor("relaxed", solver="amg")
