"""The Python package against the `anisobond` command on the same inputs (to the last digit),
against closed forms, and on bad arguments. Run: pytest tests/python (after `pip install .`)."""

import csv
import json
import threading
import warnings

import numpy as np
import pytest

import anisobond as ab
from conftest import cli


def cli_report(files, method, model="cubic.toml", *extra):
    out = files / ("cli-%s-%s.json" % (model, method))
    cli("tensor", files / "packing.txt", "--model", files / model, "--method", method,
        "-o", out, *extra)
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def cubic(files):
    model = ab.Model.load(files / "cubic.toml")
    return ab.Assembly(ab.Packing.load(files / "packing.txt"), model)


@pytest.mark.parametrize("method", ["mean-field", "voigt", "relaxed", "laf"])
def test_tensor_equals_cli_to_the_last_digit(files, cubic, method):
    expected = cli_report(files, method)
    report = cubic.tensor_report(method)
    assert report == expected
    c = cubic.tensor(method)
    assert c.shape == (6, 6) and c.dtype == np.float64
    assert np.array_equal(c, np.array(expected["C"]))


def test_prestressed_equals_cli_and_raises_c12(files, cubic):
    # The preloaded tangent (docs/prestress.md): same digits as the command, and a compressive
    # preload raises C12 and lowers C44 against the stress-free relaxed tensor.
    free = cubic.tensor_report("relaxed")["cubic"]
    p = 0.05 * free["C11"]
    report = cubic.tensor_report("prestressed", prestress=p)
    assert report == cli_report(files, "prestressed", "cubic.toml", "--prestress", repr(p))
    assert report["cubic"]["C12"] > free["C12"] and report["cubic"]["C44"] < free["C44"]
    with pytest.raises(ab.InputError, match="prestress"):
        cubic.tensor("prestressed", prestress="high")


def test_cross_anisotropic_relaxed_equals_cli(files):
    asm = ab.Assembly(ab.Packing.load(files / "packing.txt"), ab.Model.load(files / "cross.toml"))
    assert asm.tensor_report("relaxed") == cli_report(files, "relaxed", "cross.toml")
    # Šmilauer's per-bond moduli need the packing's lattice scaling μ: without it, refused.
    b = asm.bonds
    r = asm.packing.radii
    with pytest.raises(ab.ModelError, match="lattice"):
        asm.model.springs(b["normal"], r[b["i"]], r[b["j"]], b["length"])
    k = asm.model.springs(b["normal"], r[b["i"]], r[b["j"]], b["length"],
                          lattice_scaling=asm.lattice_scaling)
    for name in ("kn", "ks", "kr", "ktw", "radius"):
        assert np.array_equal(k[name], b[name]), name


def test_dynamic_equals_cli_with_progress(files, cubic):
    seen = []
    report = cubic.tensor_report("dynamic", progress=seen.append)
    assert report == cli_report(files, "dynamic")
    assert seen and seen[-1] == pytest.approx(1.0) and seen == sorted(seen)


def test_springs_equal_bond_table(files, cubic):
    b = cubic.bonds
    n = cubic.n_bonds
    assert n == len(b["i"]) > 0 and b["normal"].shape == (n, 3) and b["image"].shape == (n, 3)
    r = cubic.packing.radii
    k = cubic.model.springs(b["normal"], r[b["i"]], r[b["j"]], b["length"])
    for name in ("kn", "ks", "kr", "ktw", "radius"):
        assert np.array_equal(k[name], b[name]), name
    # ... and the table the command writes (shortest round-trip decimals).
    cli("bonds", files / "packing.txt", "--model", files / "cubic.toml", "-o", files / "b.csv")
    table = np.genfromtxt(files / "b.csv", delimiter=",", names=True)
    for name in ("i", "j", "length", "radius", "kn", "ks", "kr", "ktw"):
        assert np.array_equal(table[name], b[name]), name
    assert np.array_equal(np.column_stack([table["nx"], table["ny"], table["nz"]]), b["normal"])
    assert np.array_equal(np.column_stack([table["ix"], table["iy"], table["iz"]]), b["image"])
    # write_bonds writes the same bytes as the command.
    cubic.write_bonds(files / "py.csv")
    assert (files / "py.csv").read_bytes() == (files / "b.csv").read_bytes()


def test_from_bonds_reproduces_the_rule(cubic):
    b = cubic.bonds
    # Given in another order and with i, j swapped: the same canonical bonds and springs.
    order = np.arange(cubic.n_bonds)[::-1]
    again = ab.Assembly.from_bonds(cubic.packing, cubic.model, b["j"][order], b["i"][order],
                                   -b["image"][order])
    g = again.bonds
    for name in ("kn", "ks", "length"):
        assert np.array_equal(g[name][order], b[name]), name
    # The sum runs in the given order: equal to round-off reversed, to the last digit as given.
    np.testing.assert_allclose(again.tensor("voigt"), cubic.tensor("voigt"), rtol=1e-12)
    same = ab.Assembly.from_bonds(cubic.packing, cubic.model, b["i"], b["j"], b["image"])
    assert np.array_equal(same.tensor("relaxed"), cubic.tensor("relaxed"))


def test_packing_from_arrays_and_save(files, cubic, tmp_path):
    pk = cubic.packing
    copy = ab.Packing(pk.positions, pk.radii, cell=pk.cell)
    assert len(copy) == len(pk) and copy.cell == pk.cell
    copy.save(tmp_path / "p.txt")
    cli("bonds", tmp_path / "p.txt", "--model", files / "cubic.toml", "-o", tmp_path / "b.csv")
    assert ab.Packing.load(tmp_path / "p.txt").positions.tolist() == pk.positions.tolist()
    # Accepted: integer dtype, float32, Fortran order, non-contiguous views, lists.
    pos = np.asfortranarray(pk.positions)
    wide = np.zeros((len(pk), 6))
    wide[:, ::2] = pk.positions
    for p in (pos, wide[:, ::2], pk.positions.tolist()):
        assert np.array_equal(ab.Packing(p, pk.radii, cell=pk.cell).positions, pk.positions)
    ints = ab.Packing(np.array([[0, 0, 0], [3, 0, 0]]), np.array([1, 1]))
    assert ints.positions.dtype == np.float64 and ints.cell is None


def test_packing_cell_choice_and_ids(cubic, tmp_path):
    pk, model = cubic.packing, cubic.model
    # A file that states no cell (plain `x y z r` lines, like YADE's export.text).
    plain = tmp_path / "plain.txt"
    plain.write_text("".join(
        f"{x!r} {y!r} {z!r} {r!r}\n" for (x, y, z), r in zip(pk.positions.tolist(), pk.radii.tolist())
    ))
    with pytest.warns(UserWarning, match=r"states no periodic cell.*give cell=\(Lx, Ly, Lz\)"):
        free = ab.Packing.load(plain)
    assert free.cell is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        periodic = ab.Packing.load(plain, cell=pk.cell)
        also_free = ab.Packing.load(plain, free=True)
    assert periodic.cell == pk.cell and also_free.cell is None
    # The stated cell gives the original network; the free cluster loses the bonds across faces.
    assert ab.Assembly(periodic, model).n_bonds == cubic.n_bonds
    assert ab.Assembly(free, model).n_bonds < cubic.n_bonds
    with pytest.raises(ab.InputError, match="at most one of"):
        ab.Packing.load(plain, cell=pk.cell, free=True)
    # Ids are carried to the bond table's id_i, id_j columns.
    assert pk.ids is None
    ids = 1000 + 3 * np.arange(len(pk))
    tagged = ab.Packing(pk.positions, pk.radii, cell=pk.cell, ids=ids)
    assert tagged.ids.tolist() == ids.tolist()
    ab.Assembly(tagged, model).write_bonds(tmp_path / "b.csv")
    with open(tmp_path / "b.csv") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    assert len(rows) == cubic.n_bonds
    assert all(int(r["id_i"]) == ids[int(r["i"])] and int(r["id_j"]) == ids[int(r["j"])] for r in rows)
    with pytest.raises(ab.InputError, match="particle id 7 appears twice"):
        ab.Packing(pk.positions[:2], pk.radii[:2], ids=[7, 7])


@pytest.mark.parametrize("positions, radii, exc, message", [
    (np.zeros((3, 2)), np.ones(3), ab.InputError, r"expected shape \(N, 3\), got \(3, 2\)"),
    (np.zeros(3), np.ones(1), ab.InputError, "expected a 2-D array"),
    ([[0, 0, 0], [np.nan, 0, 0]], [1, 1], ab.InputError, r"positions\[1, 0\] = NaN is not finite"),
    ([[0, 0, 0], [3, 0, 0]], [1, -1], ab.InputError, "sphere 1: radius must be finite and > 0"),
    ([[0, 0, 0], [3, 0, 0]], [1], ab.InputError, "expected 2 values"),
    ([[0, 0, 0], [3, 0, 0]], [1, np.inf], ab.InputError, r"radii\[1\] = inf is not finite"),
    (np.zeros((2, 3), dtype=complex), [1, 1], TypeError, "got dtype complex128"),
    ([["a", "b", "c"]], [1], TypeError, "expected real numbers"),
    (np.zeros((2, 3), dtype=bool), [1, 1], TypeError, "got dtype bool"),
])
def test_bad_packing_arguments(positions, radii, exc, message):
    with pytest.raises(exc, match=message):
        ab.Packing(positions, radii)


def test_bad_arguments_elsewhere(files, cubic, tmp_path):
    assert issubclass(ab.InputError, ValueError) and issubclass(ab.ModelError, ab.AnisobondError)
    with pytest.raises(ab.InputError, match=r"cell\[2\] = NaN"):
        ab.Packing([[0, 0, 0]], [1], cell=(1, 1, float("nan")))
    with pytest.raises(ab.InputError, match="method `relax`: expected .*, prestressed, laf or dynamic"):
        cubic.tensor("relax")
    with pytest.raises(ab.InputError, match=r"\[1e-12, 1e-2\]"):
        cubic.tensor("relaxed", tolerance=0.5)
    with pytest.raises(ab.InputError, match="unknown option `tolerence`: expected one of shell"):
        cubic.tensor("relaxed", tolerence=1e-8)
    with pytest.raises(ab.InputError, match="option `shell`: expected an integer"):
        cubic.tensor_report("laf", shell="two")
    m = cubic.model
    with pytest.raises(ab.InputError, match="normal 1 has length 2"):
        m.springs([[1, 0, 0], [0, 2, 0]], [1, 1], [1, 1], [2, 2])
    with pytest.raises(ab.InputError, match=r"length\[0\] = -2, expected a finite value > 0 m"):
        m.springs([[1, 0, 0]], [1], [1], [-2])
    with pytest.raises(ab.InputError, match="expected 1 values"):
        m.springs([[1, 0, 0]], [1, 1], [1], [2])
    with pytest.raises(ab.FileError, match="no-such.toml"):
        ab.Model.load(tmp_path / "no-such.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\n"
                   "normal = 1e13\nshear = 1e12\na_n = 3\n")
    with pytest.raises(ab.InputError, match="bad.toml:.*a_n"):
        ab.Model.load(bad)
    with pytest.raises(ab.ModelError):
        ab.Model.from_dict({"scheme": {"kind": "isotropic", "normal": -1.0, "shear": 1.0}})
    p = tmp_path / "p.txt"
    p.write_text("# periodic 1 1 1\n0 0 0 0.1\n0.5 0.5 zero 0.1\n")
    with pytest.raises(ab.InputError, match="p.txt:3"):
        ab.Packing.load(p)
    with pytest.raises(ab.InputError, match="particles 0 and 0"):
        ab.Assembly.from_bonds(cubic.packing, m, [0], [0])
    # Nothing is written on a refusal.
    with pytest.raises(ab.InputError, match="missing-dir` does not exist"):
        cubic.write_bonds(tmp_path / "missing-dir" / "b.csv")
    assert not (tmp_path / "missing-dir").exists()


def test_model_constructors_agree(files):
    text = (files / "cubic.toml").read_text()
    a = ab.Model.load(files / "cubic.toml")
    b = ab.Model.from_toml(text)
    c = ab.Model.from_dict(a.to_dict())
    assert a == b == c and a.kind == "cubic"
    assert ab.Model.load(files / "cross.toml").kind == "cross-anisotropic"


def test_calibrate_equals_cli(files, cubic):
    target = {"C12/C11": 0.30, "C44/C11": 0.43}
    for on, extra in (("mean-field", ()), (cubic.packing, ("--on", "relaxed", files / "packing.txt"))):
        out = files / "cal.toml"
        cli("calibrate", "--model", files / "cubic.toml", "--target", "C12/C11=0.3,C44/C11=0.43",
            "-o", out, *extra)
        new, info = ab.calibrate(cubic.model, target, on=on, details=True)
        assert new.to_toml() == out.read_text()
        assert info["C12"] / info["C11"] == pytest.approx(0.30, rel=1e-3)
        assert info["C44"] / info["C11"] == pytest.approx(0.43, rel=1e-3)
    with pytest.raises(ab.InputError, match="C44/C11"):
        ab.calibrate(cubic.model, {"C12/C11": 0.3})


def test_exports_equal_cli(files, cubic, tmp_path):
    cli("export", "yade", files / "packing.txt", "--model", files / "cubic.toml",
        "-o", tmp_path / "cli-yade")
    cubic.export_yade(tmp_path / "py-yade")
    cli("export", "liggghts", files / "packing.txt", "--model", files / "cubic.toml",
        "-o", tmp_path / "cli-lig")
    cubic.export_liggghts(tmp_path / "py-lig")
    cli("export", "vtk", files / "packing.txt", "--model", files / "cubic.toml",
        "--strain", "1e-4,0,0,0,0,2e-4", "-o", tmp_path / "cli-vtk")
    cubic.export_vtk(tmp_path / "py-vtk", strain=[1e-4, 0, 0, 0, 0, 2e-4])
    with pytest.raises(ab.InputError, match="not a small strain"):
        cubic.export_vtk(tmp_path / "never", strain=[0.2, 0, 0, 0, 0, 0])
    assert not (tmp_path / "never").exists()
    for a, b in (("cli-yade", "py-yade"), ("cli-lig", "py-lig"), ("cli-vtk", "py-vtk")):
        names = sorted(p.name for p in (tmp_path / a).iterdir())
        assert names == sorted(p.name for p in (tmp_path / b).iterdir()) and names
        for n in names:
            assert (tmp_path / a / n).read_bytes() == (tmp_path / b / n).read_bytes(), n


def test_engineering_constants_closed_form():
    e, nu = 70e9, 0.25
    lam, mu = e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))
    c = np.zeros((6, 6))
    c[:3, :3] = lam
    c[np.arange(3), np.arange(3)] = lam + 2 * mu
    c[np.arange(3, 6), np.arange(3, 6)] = mu
    k = ab.engineering_constants(c)
    for name in ("E1", "E2", "E3"):
        assert k[name] == pytest.approx(e, rel=1e-12)
    for name in ("G23", "G13", "G12"):
        assert k[name] == pytest.approx(mu, rel=1e-12)
    assert k["nu12"] == pytest.approx(nu, rel=1e-12)
    with pytest.raises(ab.InputError):
        ab.engineering_constants(np.zeros((6, 5)))


def test_long_calls_release_the_gil(cubic):
    # While one thread solves, another runs Python: it must not wait for the solve to end.
    done = threading.Event()
    ticks = []
    def tick():
        while not done.is_set():
            ticks.append(1)
            done.wait(0.001)
    t = threading.Thread(target=tick)
    t.start()
    before = len(ticks)
    cubic.tensor("relaxed", solver="cg-jacobi", tolerance=1e-10)
    during = len(ticks) - before
    done.set()
    t.join()
    assert during > 0


def test_example_tour_runs(files, tmp_path):
    # examples/python_tour.py on the command's packing: its own checks (springs equal the
    # bond table) run inside; the relaxed tensor it prints is the CLI's.
    import subprocess
    import sys
    from conftest import REPO
    r = subprocess.run([sys.executable, str(REPO / "examples" / "python_tour.py"), str(tmp_path),
                        str(files / "packing.txt")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "relaxed C (GPa)" in r.stdout and "Zener ratio" in r.stdout


def test_cli_tensor_of_a_bond_table(files, cubic, tmp_path):
    # `tensor --bonds TABLE`: the table's bonds and springs instead of the model's rule; on the
    # table the command itself wrote, the same report as without it.
    import subprocess
    from conftest import anisobond_bin
    table = tmp_path / "b.csv"
    cubic.write_bonds(table)
    out = tmp_path / "r.json"
    cli("tensor", files / "packing.txt", "--model", files / "cubic.toml", "--bonds", table,
        "--method", "relaxed", "-o", out)
    assert json.loads(out.read_text()) == cubic.tensor_report("relaxed")
    lines = table.read_text().splitlines()
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines[:2] + [lines[2].replace(lines[2].split(",")[1], "400", 1)]) + "\n")
    r = subprocess.run([anisobond_bin(), "tensor", str(files / "packing.txt"), "--model",
                        str(files / "cubic.toml"), "--bonds", str(bad), "--method", "voigt",
                        "-o", str(tmp_path / "never.json")], capture_output=True, text=True)
    assert r.returncode != 0 and "but the packing has 400 (0 to 399)" in r.stderr, r.stderr
    assert not (tmp_path / "never.json").exists()
    # A table of another packing (same count, other positions) is refused, not computed.
    other = tmp_path / "other.txt"
    cli("pack", "--particles", 400, "--seed", 8, "-o", other)
    r = subprocess.run([anisobond_bin(), "tensor", str(other), "--model",
                        str(files / "cubic.toml"), "--bonds", str(table), "--method", "voigt",
                        "-o", str(tmp_path / "never.json")], capture_output=True, text=True)
    assert r.returncode != 0 and "the bond table is not of this packing" in r.stderr, r.stderr
    assert not (tmp_path / "never.json").exists()


def test_degenerate_and_not_converged_are_their_own_exceptions(cubic):
    far = ab.Packing([[0, 0, 0], [5e-3, 0, 0]], [1e-3, 1e-3], cell=(1e-2, 1e-2, 1e-2))
    with pytest.raises(ab.DegenerateError, match="bonds no pair"):
        ab.Assembly(far, cubic.model)
    # Two bonded spheres carry no shear: the relaxed tensor is a mechanism, refused.
    pair = ab.Assembly.from_bonds(far, cubic.model, [0], [1])
    with pytest.raises(ab.DegenerateError):
        pair.tensor("relaxed")
    with pytest.raises(ab.NotConvergedError, match="relaxed solve"):
        ab.calibrate(cubic.model, {"C12/C11": 0.30, "C44/C11": 0.43}, on=cubic.packing,
                     max_iterations=1, tolerance=1e-9)
    assert issubclass(ab.DegenerateError, ValueError)


def test_cavity_equals_cli_and_follows_the_continuum(files, tmp_path):
    # Šmilauer's tilted cross-anisotropy: the package's cavity is the command's to the last
    # digit, and the slab's wall displacement is near the anisotropic continuum's.
    asm = ab.Assembly(ab.Packing.load(files / "packing.txt"), ab.Model.load(files / "cross.toml"))
    r = asm.cavity(6e-3, outer_radius=14e-3, pressure=1e4)
    out = tmp_path / "cav"
    cli("cavity", files / "packing.txt", "--model", files / "cross.toml", "--hole-radius", "6e-3",
        "--outer-radius", "14e-3", "--pressure", "1e4", "-o", out)
    j = json.loads((out / "cavity.json").read_text())
    # one schema: the dict is cavity.json, key for key, besides the numpy arrays
    assert {k: v for k, v in r.items() if k not in ("positions", "displacement")} == j
    assert r["wall_displacement_m"] == j["wall_displacement_m"]
    assert r["lame_wall_displacement_m"] == j["lame_wall_displacement_m"]
    assert r["continuum"]["wall_displacement_m"] == j["continuum"]["wall_displacement_m"]
    assert r["continuum"]["wall_bins_20deg"] == j["continuum"]["wall_bins_20deg"]
    dem_over_continuum = r["continuum"]["dem_over_continuum"]
    assert abs(dem_over_continuum - 1) < 0.1, dem_over_continuum
    assert r["positions"].shape == r["displacement"].shape == (r["spheres"], 3)
    assert np.isfinite(r["displacement"]).all()
    with pytest.raises(ab.InputError, match="hole_radius"):
        asm.cavity(-1.0)


KUMAR_STIFF_SHEAR = """
[bonding]
rule = "factor"
value = 1.01
[scheme]
kind = "isotropic"
normal = 1e8
shear = 1e10
[geometry]
convention = "kumar"
moments = "kumar"
"""


def test_buckle_bar_lattice_column_is_euler_and_mazzilli(tmp_path):
    # A 2 x 2 x 10 simple-cubic column of touching spheres (shear-rigid bonds): Euler and
    # Mazzilli (Kumar 2016 Eqs. 14-15) from the bar's E, and on the deformed bar Mazzilli's
    # sigma (1 - sigma/E) = sigma_network (docs/buckling.md).
    rad = 1e-3
    pos = [[2 * rad * i, 2 * rad * j, 2 * rad * k] for k in range(10) for i in range(2) for j in range(2)]
    packing = ab.Packing(np.array(pos), np.full(len(pos), rad))
    model = ab.Model.from_toml(KUMAR_STIFF_SHEAR)
    # the bar runs between the end planes (l = 20 R, Kumar's), its end layers clamped
    r = ab.buckle_bar(packing, model, 1.5 * rad, 20 / 1.5, clamp_depth=1.5 * rad)
    e, s = r["modulus_pa"], r["length_m"] / r["radius_m"]
    assert r["particles"] == 40 and r["length_m"] == pytest.approx(20 * rad, rel=1e-12)
    assert r["sigma_euler_pa"] == pytest.approx(np.pi ** 2 * e / (4 * (0.5 * s) ** 2), rel=1e-12)
    # Mazzilli's relation holds with the strain of the deformed part, between the clamped
    # layers' centres (18 R): E over that length is e * 18/20
    lin, e_c = r["sigma_network_pa"], e * 18 / 20
    extensible = (1 - np.sqrt(1 - 4 * lin / e_c)) * e_c / 2
    assert r["sigma_deformed_pa"] == pytest.approx(extensible, rel=2e-3)
    assert r["sigma_deformed_pa"] > 1.2 * lin
    assert r["mode"].shape == (40, 3)
    linear = ab.buckle_bar(packing, model, 1.5 * rad, s, clamp_depth=1.5 * rad, deformed=False)
    assert linear["sigma_deformed_pa"] is None and linear["sigma_network_pa"] == lin
    # one schema: the dict is a row of the command's buckling.json (plus the mode), key for key
    out = tmp_path / "bk"
    cli("buckle", "--route", "unjammed", "--slenderness", "10", "--linear-only", "-o", out)
    row = json.loads((out / "buckling.json").read_text())["rows"][0]
    assert set(r) - {"mode"} == set(row)
    assert set(r["network"]) == set(row["network"])
    assert r["route"] is None and row["route"] == "unjammed"


SC_SPRINGS = """
[bonding]
rule = "gap"
value = 0.01
[scheme]
kind = "isotropic"
normal = 2e6
shear = 7e5
[geometry]
convention = "spring"
"""


def test_specimen_equals_cli_and_the_simple_cubic_closed_form(tmp_path):
    # A free 3 x 3 x 7 simple-cubic column of 1 mm spheres: platen stiffness 9 k_n / 6 and
    # E = k_n / (2R) in closed form; the package's dict is the command's specimen.json.
    grid = np.array([(i, j, k) for i in range(3) for j in range(3) for k in range(7)], float)
    pk = ab.Packing(grid * 2e-3, np.full(len(grid), 1e-3))
    pk.save(tmp_path / "column.txt")
    (tmp_path / "springs.toml").write_text(SC_SPRINGS)
    asm = ab.Assembly(pk, ab.Model.load(tmp_path / "springs.toml"))
    r = asm.specimen("z", platens="bonded")
    assert abs(r["platen_stiffness"] / (9 * 2e6 / 6) - 1) < 1e-10
    assert abs(r["young"] / (2e6 / 2e-3) - 1) < 1e-10
    assert r["displacement"].shape == (len(grid), 3)
    assert set(r["layer"].tolist()) == {0, 1, 2}
    out = tmp_path / "spec"
    cli("specimen", tmp_path / "column.txt", "--model", tmp_path / "springs.toml", "--free",
        "--platens", "bonded", "-o", out)
    j = json.loads((out / "specimen.json").read_text())
    for key in ("platen_stiffness", "young", "poisson", "axial_force", "length", "area"):
        assert r[key] == j[key], key
    with pytest.raises(ab.InputError, match="axis"):
        asm.specimen("w")
    # The command's options: force control on the top layer chosen by a box gives
    # delta = F / k with k = 9 k_n / 6 (closed form), the held reaction balancing F; the same
    # run by the command gives the same numbers.
    k = 9 * 2e6 / 6
    f = asm.specimen("z", platens="bonded", force=3.0, moved="box:-1,-1,0.0115,1,1,1")
    assert abs(f["strain"] * f["length"] / (3.0 / k) - 1) < 1e-10
    assert abs(f["held_force"] / 3.0 - 1) < 1e-10
    cli("specimen", tmp_path / "column.txt", "--model", tmp_path / "springs.toml", "--free",
        "--platens", "bonded", "--force", "3", "--moved", "box:-1,-1,0.0115,1,1,1", "-o",
        tmp_path / "forced")
    j = json.loads((tmp_path / "forced" / "specimen.json").read_text())
    for key in ("platen_stiffness", "strain", "held_force", "axial_force"):
        assert f[key] == j[key], key
    with pytest.raises(ab.InputError, match="at most one"):
        asm.specimen("z", strain=1e-4, force=1.0)
    with pytest.raises(ab.InputError, match="moved"):
        asm.specimen("z", moved="sphere:1,2,3")


def test_relaxed_system_solved_by_numpy_is_the_cli_tensor(files, cubic):
    # The relaxed solve's K (CSR), G, H and V handed out: solved here by numpy's dense
    # least squares on the Jacobi-scaled K (independent of the library's solvers), C =
    # (H − Gᵀ K⁺ G)/V equals the command's sparse-Cholesky tensor.
    s = cubic.relaxed_system()
    n = len(s["indptr"]) - 1
    assert n == 6 * len(s["active"]) and s["g"].shape == (n, 6) and s["h"].shape == (6, 6)
    k = np.zeros((n, n))
    for r in range(n):
        lo, hi = s["indptr"][r], s["indptr"][r + 1]
        k[r, s["indices"][lo:hi]] = s["data"][lo:hi]
    assert np.abs(k - k.T).max() <= 1e-12 * np.abs(k).max()
    d = np.where(np.diag(k) > 0, 1 / np.sqrt(np.abs(np.diag(k))), 0.0)
    q = np.linalg.lstsq(k * d[:, None] * d[None, :], s["g"] * d[:, None], rcond=1e-11)[0]
    q *= d[:, None]
    c = (s["h"] - s["g"].T @ q) / s["volume"]
    c = 0.5 * (c + c.T)
    expected = np.array(cli_report(files, "relaxed", "cubic.toml", "--solver", "cholesky")["C"])
    assert np.abs(c - expected).max() <= 1e-9 * np.abs(expected).max()
    # Relaxing lowers the affine H/V (the comparison is not trivial).
    assert expected[3, 3] < 0.99 * s["h"][3, 3] / s["volume"]
    with pytest.raises(ab.InputError, match="lever_arm"):
        cubic.relaxed_system(lever_arm="nowhere")
