"""VTK files of a polycrystal opened by meshio (issue 34): particles.vtu's point field `grain`
and bonds.vtu's cell fields `grain_i`, `grain_j`, as meshio parses them, are the grain ids of
`Assembly.grains` and the particle ids of `Assembly.bonds` (the library's own arrays) — for
`Assembly.export_vtk` (unloaded and strained), for `anisobond export vtk` of the same files
and for `anisobond specimen` of the spheres as a free block; a single crystal's files have no
grain field. meshio is a third-party reader (PyPI, installed by .ci/test-all): missing, the
tests skip with the reason outside CI and fail under CI=true."""

import os

import numpy as np
import pytest

import anisobond as ab
from conftest import CUBIC_MODEL, cli

GRAINS = "\n[grains]\ncount = 6\nseed = 5\n"


@pytest.fixture(scope="module")
def meshio():
    try:
        import meshio
    except ImportError as e:
        why = "meshio is not installed (pip install meshio; .ci/test-all does): %s" % e
        if os.environ.get("CI"):
            pytest.fail("CI is set but " + why)
        pytest.skip(why)
    return meshio


@pytest.fixture(scope="module")
def poly(tmp_path_factory):
    """A 500-sphere periodic packing from `anisobond pack`, the cubic model in 6 grains."""
    d = tmp_path_factory.mktemp("vtk")
    cli("pack", "--particles", 500, "--seed", 13, "-o", d / "packing.txt")
    (d / "poly.toml").write_text(CUBIC_MODEL + GRAINS)
    (d / "single.toml").write_text(CUBIC_MODEL)
    return d


def check_grain_fields(meshio, out, pk, asm):
    """particles.vtu and bonds.vtu in `out`, read by meshio, against the library's arrays."""
    grain = asm.grains["grain"]
    i, j = asm.bonds["i"].astype(np.int64), asm.bonds["j"].astype(np.int64)
    image = asm.bonds["image"]
    p = meshio.read(out / "particles.vtu")
    assert np.array_equal(p.points, pk.positions)
    assert [c.type for c in p.cells] == ["vertex"]
    assert np.array_equal(p.cells[0].data.ravel(), np.arange(len(grain)))
    assert np.array_equal(p.point_data["grain"], grain)
    b = meshio.read(out / "bonds.vtu")
    assert [c.type for c in b.cells] == ["line"]
    ends = b.cells[0].data
    assert ends.shape == (len(i), 2)
    # Each line starts at particle i and ends at j, or at j's periodic image (an extra point
    # at x_i + the branch vector, beyond the particles).
    assert np.array_equal(ends[:, 0], i)
    inside = np.all(image == 0, axis=1)
    assert inside.any() and (~inside).any()
    assert np.array_equal(ends[inside, 1], j[inside])
    assert np.all(ends[~inside, 1] >= len(grain))
    assert np.array_equal(b.cell_data["grain_i"][0], grain[i])
    assert np.array_equal(b.cell_data["grain_j"][0], grain[j])
    # Bonds inside a grain and across a boundary both occur.
    same = grain[i] == grain[j]
    assert same.any() and (~same).any()


def test_meshio_reads_the_grain_ids_of_a_polycrystal(meshio, poly):
    pk = ab.Packing.load(poly / "packing.txt")
    asm = ab.Assembly(pk, ab.Model.load(poly / "poly.toml"))
    grain = asm.grains["grain"]
    assert set(grain.tolist()) == set(range(6))
    # The package's export, unloaded and under a strain.
    asm.export_vtk(poly / "api")
    check_grain_fields(meshio, poly / "api", pk, asm)
    asm.export_vtk(poly / "strained", strain=[1e-4, 0, 0, 0, 0, 2e-4])
    check_grain_fields(meshio, poly / "strained", pk, asm)
    f = meshio.read(poly / "strained" / "bonds.vtu").cell_data["force"][0]
    assert np.abs(f).max() > 0
    # The command on the same files.
    cli("export", "vtk", poly / "packing.txt", "--model", poly / "poly.toml", "-o", poly / "cli")
    check_grain_fields(meshio, poly / "cli", pk, asm)


def test_meshio_finds_no_grain_field_for_a_single_crystal(meshio, poly):
    pk = ab.Packing.load(poly / "packing.txt")
    asm = ab.Assembly(pk, ab.Model.load(poly / "single.toml"))
    assert asm.grains is None
    asm.export_vtk(poly / "single")
    p = meshio.read(poly / "single" / "particles.vtu")
    b = meshio.read(poly / "single" / "bonds.vtu")
    assert "grain" not in p.point_data and np.array_equal(p.point_data["radius"], pk.radii)
    assert "grain_i" not in b.cell_data and "grain_j" not in b.cell_data
    assert np.array_equal(b.cell_data["kn"][0], asm.bonds["kn"])


def test_meshio_reads_the_grain_ids_of_a_specimen(meshio, poly, tmp_path):
    """`anisobond specimen` on the polycrystal's spheres as a free block (the packing saved
    without its cell): particles.vtu's `grain` and bonds.vtu's `grain_i`, `grain_j` are those
    of `Assembly.grains` and `Assembly.bonds` of the same free packing and model (grains in
    the spheres' bounding box), beside the solve's displacements; a single crystal's specimen
    files have no grain field."""
    pk = ab.Packing.load(poly / "packing.txt")
    free = ab.Packing(pk.positions, pk.radii)
    free.save(tmp_path / "free.txt")
    asm = ab.Assembly(free, ab.Model.load(poly / "poly.toml"))
    grain = asm.grains["grain"]
    assert set(grain.tolist()) == set(range(6))
    out = tmp_path / "specimen"
    cli("specimen", tmp_path / "free.txt", "--model", poly / "poly.toml", "--free", "-o", out)
    p = meshio.read(out / "particles.vtu")
    assert np.array_equal(p.points, free.positions)
    assert np.array_equal(p.point_data["grain"], grain)
    assert np.abs(p.point_data["displacement"]).max() > 0
    b = meshio.read(out / "bonds.vtu")
    i, j = asm.bonds["i"].astype(np.int64), asm.bonds["j"].astype(np.int64)
    ends = b.cells[0].data
    # A free block: every line joins two particles, no periodic image.
    assert np.array_equal(ends[:, 0], i) and np.array_equal(ends[:, 1], j)
    assert np.array_equal(b.cell_data["grain_i"][0], grain[i])
    assert np.array_equal(b.cell_data["grain_j"][0], grain[j])
    same = grain[i] == grain[j]
    assert same.any() and (~same).any()
    single = tmp_path / "single"
    cli("specimen", tmp_path / "free.txt", "--model", poly / "single.toml", "--free", "-o", single)
    assert "grain" not in meshio.read(single / "particles.vtu").point_data
    assert "grain_i" not in meshio.read(single / "bonds.vtu").cell_data
