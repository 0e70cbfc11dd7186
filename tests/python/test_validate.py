"""`anisobond.validate`: the engine interface from Python. A real YADE run against the
`anisobond validate yade` command on the same input (the report the package returns is the
command's report.json), a tolerance no two codes can meet raising ValidationError (and the
report kept), a program that fails raising EngineError, and bad arguments raising
InputError. YADE tests skip with the reason outside CI and fail under CI=true."""

import json
import os
import shutil
import stat

import pytest

import anisobond as ab
from conftest import cli


def need_yade():
    """Skip (fail under CI) when `yade` is not on PATH."""
    if shutil.which("yade") is None:
        why = "yade is not on PATH (apt install yade)"
        if os.environ.get("CI"):
            pytest.fail(why)
        pytest.skip(why)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A 150-particle periodic packing made by `anisobond pack`, the cubic model, and the
    assembly of both."""
    from conftest import CUBIC_MODEL

    d = tmp_path_factory.mktemp("validate")
    cli("pack", "--particles", 150, "--seed", 11, "-o", d / "packing.txt")
    (d / "cubic.toml").write_text(CUBIC_MODEL)
    asm = ab.Assembly(ab.Packing.load(d / "packing.txt"), ab.Model.load(d / "cubic.toml"))
    return d, asm


def test_validate_yade_is_the_commands_report(small, tmp_path):
    need_yade()
    d, asm = small
    r = ab.validate("yade", asm, tmp_path / "py")
    assert r["validation"] == "yade" and r["passed"] is True
    cli("validate", "yade", d / "packing.txt", "--model", d / "cubic.toml", "-o",
        tmp_path / "cli")
    files = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == files
    j = json.loads((tmp_path / "cli" / "validation.json").read_text())
    kept = json.loads((tmp_path / "py" / "validation.json").read_text())
    for report in (j, kept):
        report.pop("timings")
    r.pop("timings")
    # The same inputs through the library's one engine interface: the command's numbers
    # (YADE runs deterministically on one thread), and the dict is the file written.
    assert r == kept
    assert [c["id"] for c in r["checks"]] == [c["id"] for c in j["checks"]]
    for a, b in zip(r["checks"], j["checks"]):
        assert a["passed"] == b["passed"]
        assert a["value"] == pytest.approx(b["value"], rel=1e-6, abs=1e-12), a["id"]


def test_validate_out_of_tolerance_raises_and_keeps_the_report(small, tmp_path):
    need_yade()
    _, asm = small
    # An undamped tolerance no two codes summing in different orders can meet (measured
    # differences ~1e-10), the others loose: exactly the history checks fail.
    tight = {"history": 1e-15, "tensor": 1.0, "relaxed": 1.0}
    with pytest.raises(ab.ValidationError, match="validate yade FAILED") as e:
        ab.validate("yade", asm, tmp_path / "out", tolerances=tight)
    assert "undamped stress history" in str(e.value)
    assert not isinstance(e.value, ab.InputError) and isinstance(e.value, ab.AnisobondError)
    # The files are written even when the validation fails.
    assert json.loads((tmp_path / "out" / "validation.json").read_text())["passed"] is False
    r = ab.validate("yade", asm, tolerances=tight, check=False)
    assert r["passed"] is False
    failed = [c["id"] for c in r["checks"] if not c["passed"]]
    assert failed and all("history" in c or "undamped" in c for c in failed), failed


def test_a_failing_engine_program_raises_engine_error(small, tmp_path):
    # No LAMMPS needed: an `lmp` that exits 1 at once is an engine failure, not bad input.
    _, asm = small
    lmp = tmp_path / "lmp"
    lmp.write_text("#!/bin/sh\necho 'ERROR: broken on purpose' >&2\nexit 1\n")
    lmp.chmod(lmp.stat().st_mode | stat.S_IXUSR)
    with pytest.raises(ab.EngineError):
        ab.validate("lammps", asm, program=lmp, processes=1)
    assert not (tmp_path / "never").exists()
    with pytest.raises(ab.EngineError):
        ab.validate("lammps", asm, tmp_path / "never", program=lmp, processes=1)
    assert not (tmp_path / "never").exists()


def test_validate_bad_arguments(small):
    _, asm = small
    with pytest.raises(ab.InputError, match="unknown engine `abaqus`"):
        ab.validate("abaqus", asm)
    with pytest.raises(ab.InputError, match="`driver` does not apply"):
        ab.validate("yade", asm, driver="x")
    with pytest.raises(ab.InputError, match="unknown tolerance `stress`"):
        ab.validate("yade", asm, tolerances={"stress": 1e-3})
    with pytest.raises(ab.InputError, match="processes must be 1 or 2"):
        ab.validate("lammps", asm, program=shutil.which("sh"), processes=3)
