"""anisobond.strength_test: the same study as `anisobond strength-test` (one schema, the
same numbers), its refusals named as keywords, and E of a simple-cubic prism in closed form."""

import json

import numpy as np
import pytest

import anisobond as ab
from conftest import cli

SMALL = dict(width_particles=6.0, max_strain=2e-3, loading_rate=1e-4)


def flags(options):
    out = []
    for k, v in options.items():
        out += ["--" + k.replace("_", "-"), v]
    return out


@pytest.mark.parametrize("test", ["ucs", "tension", "brazilian"])
def test_strength_test_equals_the_command(files, tmp_path, test):
    packing = ab.Packing.load(files / "packing.txt")
    model = ab.Model.load(files / "cross.toml")
    r = ab.strength_test(test, packing=packing, model=model, bedding_deg=30.0, **SMALL)
    out = tmp_path / test
    cli(
        "strength-test", "--test", test, "--packing", files / "packing.txt",
        "--model", files / "cross.toml", "--bedding-deg", 30, *flags(SMALL), "-o", out,
    )
    js = json.loads((out / "strength_test.json").read_text())
    arrays = {"strain", "stress_pa", "lateral_strain", "broken"}
    assert set(r) - arrays == set(js)
    for k, v in js.items():
        assert r[k] == v, k
    # the curve: the CSV's columns, as written (shortest round-trip decimals)
    rows = [l.split(",") for l in (out / "strength_test.csv").read_text().splitlines()[1:]]
    assert np.array_equal(r["strain"], np.array([float(x[2]) for x in rows]))
    assert np.array_equal(r["stress_pa"], np.array([float(x[3]) for x in rows]))
    assert r["max_stress_pa"] == r["stress_pa"].max()
    assert r["peak_stress_pa"] <= r["max_stress_pa"]
    assert r["peak_stress_pa"] in r["stress_pa"]


def test_strength_test_simple_cubic_modulus_is_kn_over_2r():
    # 5 x 5 x 10 touching spheres, springs k_n: between glued platens E = k_n / (2R).
    rad, kn = 1e-3, 2e6
    pos = [[2 * rad * i, 2 * rad * j, 2 * rad * k] for k in range(10) for j in range(5) for i in range(5)]
    packing = ab.Packing(np.array(pos), np.full(len(pos), rad))
    model = ab.Model.from_toml(
        '[bonding]\nrule = "gap"\nvalue = 0.01\n[scheme]\nkind = "isotropic"\n'
        'normal = %r\nshear = %r\n[geometry]\nconvention = "spring"\n' % (kn, 0.35 * kn)
    )
    r = ab.strength_test(
        "ucs", packing=packing, model=model, width_particles=10.0, aspect=2.0,
        end_layer=0.5, loading_rate=1e-6, max_strain=1e-3,
    )
    assert r["modulus_pa"] == pytest.approx(kn / (2 * rad), rel=1e-2)
    assert r["static_modulus_pa"] == pytest.approx(kn / (2 * rad), rel=1e-9)


def test_strength_test_refusals_name_the_keyword():
    for kwargs, name in [
        (dict(stop_fraction=1.5), "stop_fraction"),
        (dict(loading_rate=0.0), "loading_rate"),
        (dict(points=3), "points"),
    ]:
        with pytest.raises(ab.InputError, match=name):
            ab.strength_test("ucs", **kwargs)
    with pytest.raises(ab.InputError, match="shape"):
        ab.strength_test("ucs", shape="sphere")
    with pytest.raises(ab.InputError, match="test"):
        ab.strength_test("triaxial")


def test_strength_sweep_equals_the_command(files, tmp_path):
    # The bedding sweep from Python and from `strength-test --bedding-sweep`: the same rows
    # (one schema), and each row's UCS equal to a single lab run at that angle.
    packing = ab.Packing.load(files / "packing.txt")
    model = ab.Model.load(files / "cross.toml")
    r = ab.strength_sweep([0.0, 90.0], packing=packing, model=model, **SMALL)
    out = tmp_path / "sweep"
    cli(
        "strength-test", "--bedding-sweep", "0,90", "--packing", files / "packing.txt",
        "--model", files / "cross.toml", *flags(SMALL), "-o", out,
    )
    js = json.loads((out / "strength_sweep.json").read_text())
    assert r == js
    one = ab.strength_test("ucs", packing=packing, model=model, bedding_deg=90.0, **SMALL)
    assert [row["bedding_deg"] for row in js["rows"]] == [0.0, 90.0]
    assert js["rows"][-1]["ucs_pa"] == one["peak_stress_pa"]
    assert js["rows"][-1]["ucs_ratio"] == one["peak_stress_pa"] / js["rows"][0]["ucs_pa"]
