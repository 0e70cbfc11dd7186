"""anisobond.calibrate_strength: the same calibration as `anisobond calibrate-strength` (the
same report, the same written model), the simple-cubic bar's closed form σ_t = 4 × target,
and refusals by keyword."""

import json

import numpy as np
import pytest

import anisobond as ab
from conftest import cli

BAR = (
    '[bonding]\nrule = "gap"\nvalue = 0.01\n[scheme]\nkind = "isotropic"\n'
    'normal = 2e6\nshear = 7e5\n[geometry]\nconvention = "spring"\n'
    "[strength.bond]\ntensile = 1.5e6\ncohesion = 3.0e8\n"
)
LAB = dict(width_particles=6.0, aspect=8 / 3, end_layer=0.5, loading_rate=1e-6,
           max_strain=2e-3, points=4000, tolerance=2e-4)


def bar():
    rad = 1e-3
    pos = [[2 * rad * i, 2 * rad * j, 2 * rad * k] for k in range(8) for j in range(3) for i in range(3)]
    return ab.Packing(np.array(pos), np.full(len(pos), rad))


def test_calibrate_strength_equals_the_command_and_the_closed_form(tmp_path):
    packing, model = bar(), ab.Model.from_toml(BAR)
    new, r = ab.calibrate_strength(model, "tension=1MPa", packing=packing, **LAB)
    # 3 x 3 chains of YADE adhesions σ_t R² over (6R)²: peak = σ_t / 4.
    fitted = r["fitted_strength"]["bond"]["tensile"]
    assert abs(fitted / 4e6 - 1) < 1e-3
    assert abs(r["measured_peak_pa"][0] / 1e6 - 1) <= 2e-4
    packing.save(tmp_path / "bar.txt")
    (tmp_path / "bar.toml").write_text(BAR)
    flags = []
    for k, v in LAB.items():
        flags += ["--" + k.replace("_", "-"), v]
    cli("calibrate-strength", "--model", tmp_path / "bar.toml", "--packing", tmp_path / "bar.txt",
        "--target", "tension=1MPa", *flags, "-o", tmp_path / "cal.toml",
        "--report", tmp_path / "cal.json")
    js = json.loads((tmp_path / "cal.json").read_text())
    assert set(r) == set(js)
    for k, v in js.items():
        assert r[k] == v, k
    assert ab.Model.load(tmp_path / "cal.toml").to_toml() == new.to_toml()


def test_calibrate_strength_refuses_by_keyword():
    packing, model = bar(), ab.Model.from_toml(BAR)
    with pytest.raises(ab.InputError, match="max_strain"):
        ab.calibrate_strength(model, "tension=5MPa", packing=packing, **LAB)
    with pytest.raises(ab.NotConvergedError, match="max_iterations"):
        ab.calibrate_strength(model, "tension=1MPa", packing=packing, max_iterations=1, **LAB)
    with pytest.raises(ab.InputError, match="tolerance"):
        ab.calibrate_strength(model, "tension=1MPa", packing=packing, **{**LAB, "tolerance": 0.5})
