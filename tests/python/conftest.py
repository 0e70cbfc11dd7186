"""Shared fixtures of the Python package tests: the `anisobond` command (the independent
reference the package must equal) and a small periodic packing it generated."""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

CUBIC_MODEL = """
[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "cubic"
model = "zener-above-1"
a_n = 4.31
a_s = 10.0
normal = 1.0e13
shear = 3.55e12
euler_zyz_deg = [10, 20, 30]
[geometry]
moments = "parallel-bond"
"""

CROSS_MODEL = """
[bonding]
rule = "factor"
value = 1.1
[scheme]
kind = "cross-anisotropic"
C11 = 130e6
C33 = 55e6
C13 = 28e6
C12 = 40e6
strike_deg = 270
dip_deg = 25
[geometry]
convention = "modulus"
"""


def anisobond_bin():
    """The command-line program: $ANISOBOND_BIN, else target/release/anisobond."""
    path = os.environ.get("ANISOBOND_BIN") or str(REPO / "target" / "release" / "anisobond")
    if not os.path.isfile(path):
        pytest.fail(
            "the anisobond command is not built (%s): run `cargo build --release` first" % path
        )
    return path


def cli(*args):
    """Run the command; return its standard output; fail the test on a non-zero exit."""
    r = subprocess.run([anisobond_bin(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, "anisobond %s failed:\n%s" % (" ".join(map(str, args)), r.stderr)
    return r.stdout


@pytest.fixture(scope="session")
def files(tmp_path_factory):
    """A 400-particle periodic packing made by `anisobond pack`, and two model files."""
    d = tmp_path_factory.mktemp("inputs")
    cli("pack", "--particles", 400, "--seed", 7, "-o", d / "packing.txt")
    (d / "cubic.toml").write_text(CUBIC_MODEL)
    (d / "cross.toml").write_text(CROSS_MODEL)
    return d
