"""anisobond_yade -- run an anisobond bonded packing in YADE (tested with YADE 2023.02a).

Loads a SPEC packing (``# periodic Lx Ly Lz`` header, lines ``x y z r`` in m) and a SPEC
bond table (CSV ``i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz``), builds a periodic
YADE scene with exactly those bonds and exactly those springs
(CohFrictMat / CohFrictPhys / ``Law2_ScGeom6D_CohFrictPhys_CohesionMoment``), and runs
element tests in the periodic cell (velocity gradient) that give the 6x6 stiffness.

Usage, in your own script run with ``yade -n -x myscript.py`` (``python3`` on PATH does not
import yade; YADE does not set ``__file__`` for ``-x`` scripts, use ``sys.argv[0]``)::

    import os, sys
    sys.path.insert(0, "/dir/holding/this/module")
    import anisobond_yade as ab

    packing = ab.read_packing("packing.txt")
    bonds = ab.read_bond_table("bonds.csv")
    scene = ab.build_scene(packing, bonds, density=2600.0)   # resets O, verifies every bond
    result = ab.element_tests(packing, bonds, strain=1e-5, steps=200, damping=0.4)
    ab.write_history_csv("yade-history.csv", result)
    ab.write_tensor_json("yade-tensor.json", result, packing, bonds)

In place on the user's own scene (periodic or not; walls, boxes and facets skipped, clumps
refused), with the anisobond package importable for ``assign``::

    table = ab.assign("model.toml")     # the model's springs on YADE's sphere-sphere bonds
    ab.bond_table("bonds.csv")          # the bonds, full precision, i/j = sphere index
    ab.write_packing("packing.txt")     # the spheres, full precision, body ids, cell or free

A platen test of a finite specimen, in place on the current scene (``build_scene`` of a
``# free`` packing, or the user's own bonded scene), to compare with ``anisobond specimen``::

    r = ab.platen_test(axis=2, platens="frictionless", strain=1e-6)   # or "bonded"
    print(r.stiffness(), r.steps, r.remaining)   # N/m; see docs/specimens.md

or the command line (what the exported ``run.py`` calls)::

    yade -n -x anisobond_yade.py --packing packing.txt --bonds bonds.csv --out DIR \
         [--strain 1e-5] [--steps 200] [--damping 0.4] [--density 2600] [--dt S] \
         [--safety 0.8] [--paths 11,22,33,23,13,12] [--grains grains.txt]

Undamped step-by-step mode (for comparison with another integrator): ``--damping 0
--steps 1000`` -- the history records the stress after every step either way.

Conventions: SI units; Voigt order 11, 22, 33, 23, 13, 12 with engineering shear strain;
stress is YADE's ``utils.getStress()`` = Love stress (1/V) sum f (x) l, tension positive, no
kinetic term, symmetrised for the Voigt vector. The bond normal points from i to the
periodic image (ix, iy, iz) of j.

YADE traps handled here (all measured on the Debian package of YADE 2023.02a):

* ``Ig2_Sphere_Sphere_ScGeom6D(avoidGranularRatcheting=True)`` (the default) scales the
  shear increment by (R1+R2)/d, i.e. the shear spring becomes ks*(R1+R2)/d: we set
  ``avoidGranularRatcheting=False``. The contact point is then mid-gap (ScGeom),
  r_i = R_i + gap/2 (anisobond's ``LeverArm::MidGap``).
* A bond made across a gap starts in tension (Fn = kn*(penetrationDepth - unp), unp = 0):
  we set ``phys.unp = geom.penetrationDepth`` and ``phys.unpMax = -1`` (stress-free bond).
* ``utils.createInteraction(i, j)`` picks the wrong periodic image whenever
  x_j - x_i < -L/2 in a component (it truncates instead of rounding): we set
  ``I.cellDist`` from the table's image, step once with ``O.dt = 0`` so the geometry is
  recomputed, and check that every bond's branch vector equals the table's length*n
  (``BondMismatch`` is raised otherwise).
* Interactions created without ``setCohesionNow`` have ``cohesionBroken = True`` and a
  gap bond is erased at the next step: we set ``cohesionBroken = False``, never-breaking
  adhesion (``normalAdhesion = shearAdhesion = 1e300``, ``fragile = False``), no
  rolling/twisting plasticity (``maxRollPl = maxTwistPl = -1``), friction 0, and
  ``initCohesion = False`` so the Ip2 functor never overwrites them.
* With adhesion columns in the bond table (a model with a [strength] table), each bond
  instead gets its own ``normalAdhesion``, ``shearAdhesion``, ``tangensOfFrictionAngle`` and
  ``fragile = True``: YADE breaks it by its own criterion (docs/strength.md, "YADE").
* ``momentRotationLaw = True`` on every bond (kr, ktw act; total-rotation form,
  ``useIncrementalForm = False``).
* No collider: the scene holds only bonds, so ``InteractionLoop`` runs without
  ``InsertionSortCollider`` (faster; real interactions are never erased by it).
* ``GlobalStiffnessTimeStepper`` skips interactions with zero normal force, so on fresh
  stress-free bonds it returns a time step ~12x too large and the run blows up: the time
  step is computed here from the bond stiffnesses (``critical_time_step``).
* ``O.cell.velGrad = L`` only sets ``nextVelGrad``: NewtonIntegrator copies it in the same
  step and gives the particles the affine velocity (they move in that step), but the cell
  (``trsf``, ``hSize``) is integrated at the start of the *next* step. The element-test
  driver sets ``velGrad = strain/dt`` before step 0 and ``velGrad = 0`` after it: the
  whole strain is then in both the particles and the cell from step 1 on, the forces of
  step 0 see no strain and those of step 1 the full affine strain.
* ``NewtonIntegrator(damping=lambda)`` is Cundall's non-viscous damping applied per
  component to the fluctuating velocity of a periodic cell:
  a_k <- a_k*(1 - lambda*sgn(a_k*(v_k + a_k*dt/2))).
* ``utils.getStress()`` is tension-positive Love stress without kinetic terms.
"""

from __future__ import print_function

import json
import math
import os
import sys
import tempfile
import time
import warnings

VOIGT_LABELS = ("11", "22", "33", "23", "13", "12")
VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
BOND_COLUMNS = ("i", "j", "nx", "ny", "nz", "length", "radius", "kn", "ks", "kr", "ktw",
                "ix", "iy", "iz")
# Trailing columns of a table written from a YADE scene: the spheres' body ids.
ID_COLUMNS = ("id_i", "id_j")
INT_COLUMNS = ("i", "j", "ix", "iy", "iz", "id_i", "id_j")
HUGE_ADHESION = 1e300
# Optional trailing columns of a bond table (``anisobond export yade`` of a model with a
# [strength] table): each bond's CohFrictPhys normalAdhesion, shearAdhesion (N) and
# tangensOfFrictionAngle. With them the bonds are fragile and YADE breaks them by its own
# criterion (docs/strength.md, "YADE"); without them they never break.
ADHESION_COLUMNS = ("normal_adhesion", "shear_adhesion", "tan_friction")


class InputError(ValueError):
    """A packing or bond-table file is not what the SPEC describes (file, line, what)."""


class BondMismatch(RuntimeError):
    """A bond's branch vector in YADE differs from the table's length*n."""


class RotationWarning(UserWarning):
    """Bonds whose spheres have rotated since YADE made their geometry: the total-form moment
    law measures rotations from those orientations, so the moments come back at the next step
    whatever ``assign`` set."""


class PrestressWarning(UserWarning):
    """The bonds of a scene carry forces: its relaxed tensor (stress-free bonds) is not what
    YADE's element tests from that state measure (docs/prestress.md)."""


# --------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------

class Packing(object):
    """Spheres: positions (m, list of 3-tuples), radii (m), cell lengths (m) or None, and
    the spheres' own ids (YADE body ids) or None when they are known by index only."""

    def __init__(self, positions, radii, cell, ids=None):
        self.positions = positions
        self.radii = radii
        self.cell = cell
        self.ids = ids

    def __len__(self):
        return len(self.radii)

    def volume(self):
        return self.cell[0] * self.cell[1] * self.cell[2]


def _number(word, what, path, line):
    try:
        v = float(word)
    except ValueError:
        raise InputError("%s:%d: expected a number for %s, found `%s`" % (path, line, what, word))
    if math.isnan(v) or math.isinf(v):
        raise InputError("%s:%d: %s must be finite, found `%s`" % (path, line, what, word))
    return v


def read_packing(path):
    """Read a SPEC packing (also YADE ``export.text`` / ``SpherePack.save`` text).

    Lines ``x y z r`` (``SpherePack.save``'s ``x y z r clumpId`` with clumpId -1 too;
    ``#format id_x_y_z_r_matId`` as ``write_packing`` writes, body ids kept in ``ids``);
    ``# periodic Lx Ly Lz`` (or ``##PERIODIC:: Lx Ly Lz``) declares the
    periodic cell [0,L); ``# free`` a free cluster (``cell`` None: for ``build_scene`` and
    ``platen_test``; the element tests need the periodic cell); ``#format
    x_y_z_r[_matId]`` is accepted. A file stating neither is refused.
    """
    positions, radii, cell, columns, ids, free = [], [], None, 4, [], False
    with open(path) as f:
        for n, raw in enumerate(f, 1):
            t = raw.strip()
            header = None
            if t.startswith("##PERIODIC::"):
                header = t[len("##PERIODIC::"):].split()
            elif t.startswith("#"):
                words = t[1:].split()
                if words and words[0].lower() == "periodic":
                    header = words[1:]
                elif words and words[0].lower() == "free" and len(words) == 1:
                    free = True
                    continue
                elif t.startswith("#format"):
                    fmt = words[1] if len(words) > 1 else ""
                    if fmt not in ("x_y_z_r", "x_y_z_r_matId", "id_x_y_z_r_matId"):
                        raise InputError("%s:%d: unsupported `#format %s`: expected x_y_z_r, "
                                         "x_y_z_r_matId or id_x_y_z_r_matId" % (path, n, fmt))
                    columns = {"x_y_z_r": 4, "x_y_z_r_matId": 5, "id_x_y_z_r_matId": 6}[fmt]
                    continue
                else:
                    continue
            if header is not None:
                if cell is not None:
                    raise InputError("%s:%d: second periodic cell header" % (path, n))
                if len(header) != 3:
                    raise InputError("%s:%d: expected `# periodic Lx Ly Lz`" % (path, n))
                cell = tuple(_number(w, "cell length", path, n) for w in header)
                if min(cell) <= 0:
                    raise InputError("%s:%d: cell lengths must be > 0" % (path, n))
                continue
            words = t.split("#")[0].split()
            if not words:
                continue
            if columns == 4 and len(words) == 5:
                # SpherePack.save: `x y z r clumpId`, -1 for a sphere of no clump.
                if words[4] != "-1":
                    raise InputError("%s:%d: clump member (clumpId %s): a clump is one rigid "
                                     "body, not bonded spheres" % (path, n, words[4]))
                words = words[:4]
            if len(words) != columns:
                raise InputError("%s:%d: expected %d numbers `%s`, found %d"
                                 % (path, n, columns, {4: "x y z r", 5: "x y z r matId",
                                                       6: "id x y z r matId"}[columns],
                                    len(words)))
            if columns == 6:
                try:
                    ids.append(int(words[0]))
                except ValueError:
                    raise InputError("%s:%d: expected an integer body id, found `%s`"
                                     % (path, n, words[0]))
                words = words[1:]
            x, y, z, r = (_number(w, c, path, n) for w, c in zip(words, "xyzr"))
            if r <= 0:
                raise InputError("%s:%d: radius must be > 0, found %r" % (path, n, r))
            positions.append((x, y, z))
            radii.append(r)
    if cell is not None and free:
        raise InputError("%s: both `# periodic` and `# free`: expected one" % path)
    if cell is None and not free:
        raise InputError("%s: no `# periodic Lx Ly Lz` header (nor `# free` for a free "
                         "cluster): the YADE element tests need a periodic packing" % path)
    if not radii:
        raise InputError("%s: no spheres" % path)
    if cell is None:
        return Packing(positions, radii, None, ids=ids if columns == 6 else None)
    # Wrap into [0, L) like anisobond does.
    wrapped = []
    for p in positions:
        wrapped.append(tuple(p[k] - math.floor(p[k] / cell[k]) * cell[k] for k in range(3)))
    return Packing(wrapped, radii, cell, ids=ids if columns == 6 else None)


class BondTable(object):
    """Bond table columns as lists (see ``BOND_COLUMNS``); ``len(table)`` bonds."""

    def __init__(self, columns):
        self.__dict__.update(columns)

    def __len__(self):
        return len(self.i)

    def branch(self, b):
        """Branch vector length*n of bond b (m)."""
        return (self.length[b] * self.nx[b], self.length[b] * self.ny[b],
                self.length[b] * self.nz[b])


def read_bond_table(path, n_particles=None):
    """Read a SPEC bond table CSV (columns found by header name)."""
    with open(path) as f:
        lines = f.read().splitlines()
    rows = [(n, l) for n, l in enumerate(lines, 1) if l.strip()]
    if not rows:
        raise InputError("%s:1: empty file: expected the header `%s`"
                         % (path, ",".join(BOND_COLUMNS)))
    header = [c.strip() for c in rows[0][1].split(",")]
    index = {}
    for c in BOND_COLUMNS:
        if c not in header:
            raise InputError("%s:1: header lacks column `%s`: expected `%s`"
                             % (path, c, ",".join(BOND_COLUMNS)))
        index[c] = header.index(c)
    cols = dict((c, []) for c in BOND_COLUMNS)
    present = [c for c in ADHESION_COLUMNS if c in header]
    if present and len(present) != len(ADHESION_COLUMNS):
        raise InputError("%s:1: header has %s but not %s: the adhesion columns come together"
                         % (path, ", ".join(present),
                            ", ".join(c for c in ADHESION_COLUMNS if c not in present)))
    adhesion = bool(present)
    adhesions = dict((c, []) for c in ADHESION_COLUMNS)
    for n, line in rows[1:]:
        fields = [w.strip() for w in line.split(",")]
        if len(fields) != len(header):
            raise InputError("%s:%d: expected %d fields, found %d"
                             % (path, n, len(header), len(fields)))
        for c in BOND_COLUMNS:
            w = fields[index[c]]
            if c in ("i", "j", "ix", "iy", "iz"):
                try:
                    cols[c].append(int(w))
                except ValueError:
                    raise InputError("%s:%d: column `%s`: expected an integer, found `%s`"
                                     % (path, n, c, w))
            else:
                cols[c].append(_number(w, "column `%s`" % c, path, n))
        i, j = cols["i"][-1], cols["j"][-1]
        if not 0 <= i < j or (n_particles is not None and j >= n_particles):
            raise InputError("%s:%d: expected particle indices 0 <= i < j < N, found i=%d j=%d"
                             % (path, n, i, j))
        if cols["length"][-1] <= 0:
            raise InputError("%s:%d: bond length must be > 0" % (path, n))
        for c in ("kn", "ks", "kr", "ktw"):
            if cols[c][-1] < 0:
                raise InputError("%s:%d: %s must be >= 0" % (path, n, c))
        if adhesion:
            for c in ADHESION_COLUMNS:
                v = _number(fields[header.index(c)], "column `%s`" % c, path, n)
                if not (math.isfinite(v) and v >= 0):
                    raise InputError("%s:%d: column `%s`: expected a finite value >= 0, found "
                                     "`%s`" % (path, n, c, fields[header.index(c)]))
                adhesions[c].append(v)
    table = BondTable(cols)
    for c in ADHESION_COLUMNS:
        setattr(table, c, adhesions[c] if adhesion else None)
    return table


GRAIN_LABEL = "anisobond-grain-"


def read_grains(path, n_particles):
    """Read a grain-id file (docs/formats.md "Grain files"; ``anisobond export yade`` of a
    polycrystal writes ``grains.txt``): one grain id per data line, an integer 0 <= id <
    2^32 - 1, in the packing's order, ``#`` comments and blank lines skipped, exactly
    ``n_particles`` ids. Errors name the file and line."""
    ids = []
    with open(path) as f:
        for n, raw in enumerate(f, 1):
            t = raw.split("#", 1)[0].strip()
            if not t:
                continue
            try:
                g = int(t)
            except ValueError:
                g = -1
            if not 0 <= g < 2 ** 32 - 1:
                raise InputError("%s:%d: `%s`: expected one grain id per line, an integer from "
                                 "0 to %d" % (path, n, t, 2 ** 32 - 2))
            ids.append(g)
    if len(ids) != n_particles:
        raise InputError("%s: %d grain ids, but the packing has %d particles (one id per "
                         "particle, in the packing's order)" % (path, len(ids), n_particles))
    return ids


def grain_colour(g):
    """A colour of grain ``g`` for YADE's view (``shape.color``): hues spread by the golden
    ratio, so neighbouring ids differ."""
    import colorsys
    return colorsys.hsv_to_rgb((0.618033988749895 * g) % 1.0, 0.75, 0.95)


def attach_grains(grains, bodies=None):
    """Give each sphere of the current scene (``bodies``: default ``scene_spheres()``, in
    body-id order) its grain ``grains[k]``: a copy of its material labelled
    ``anisobond-grain-G`` (one copy per grain and original material, every other attribute
    equal, appended to ``O.materials``, so it is saved with the scene) and the grain's colour
    (``grain_colour``). Not ``groupMask``: masks decide which bodies interact. The copies
    have the original's density (masses unchanged) and stiffness, friction and cohesion
    values, so the Ip2 functor makes the same physics for a new contact, and existing
    interactions are not touched. ``scene_grains()`` reads the ids back."""
    from yade import O
    if bodies is None:
        bodies, _ = scene_spheres()
    if len(grains) != len(bodies):
        raise InputError("%d grain ids for %d spheres: expected one per sphere"
                         % (len(grains), len(bodies)))
    copies = {}
    for body, g in zip(bodies, grains):
        g = int(g)
        key = (g, body.material.id)
        if key not in copies:
            m = body.material
            attrs = m.dict()
            attrs["label"] = GRAIN_LABEL + str(g)
            attrs.pop("id", None)
            copy = type(m)(**attrs)
            O.materials.append(copy)
            copies[key] = copy
        body.material = copies[key]
        body.shape.color = grain_colour(g)


def scene_grains(bodies=None):
    """The grain id of each sphere of the current scene (``bodies``: default
    ``scene_spheres()``) as ``attach_grains`` set it, None for a sphere without one."""
    if bodies is None:
        bodies, _ = scene_spheres()
    out = []
    for body in bodies:
        label = body.material.label
        out.append(int(label[len(GRAIN_LABEL):]) if label.startswith(GRAIN_LABEL) else None)
    return out


def _write_atomic(path, text):
    """Write text to path through a temporary file in the same directory + rename."""
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-", suffix=os.path.basename(path))
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


# --------------------------------------------------------------------------------------
# Springs from the anisobond Python package (when it is importable)
# --------------------------------------------------------------------------------------

INSTALL_HINT = ("the anisobond Python package is not importable in this Python (%s): from a "
                "clone of anisobond, `/usr/bin/python3 -m pip install --break-system-packages "
                "--no-deps .` (YADE's Python), or `pip install --target DIR --no-deps "
                "anisobond-*.whl` and PYTHONPATH=DIR")


def package():
    """The ``anisobond`` Python package, or ImportError saying how to install it."""
    try:
        import anisobond
    except ImportError as e:
        raise ImportError(INSTALL_HINT % e)
    return anisobond


def _model(model):
    ab = package()
    return model if isinstance(model, ab.Model) else ab.Model.load(model)


def lattice_scaling(model, packing, bonds):
    """Šmilauer's lattice scaling mu of these bonds (what the cross-anisotropic scheme's
    springs depend on), computed by the package; None for the other schemes."""
    ab = package()
    if _model(model).kind != "cross-anisotropic":
        return None
    pk = ab.Packing(packing.positions, packing.radii, cell=packing.cell)
    return ab.Assembly.from_bonds(pk, _model(model), bonds.i, bonds.j).lattice_scaling


def assign_springs(model, packing, bonds):
    """Replace the table's springs kn, ks, kr, ktw (and bond radius) with those the anisobond
    package computes for ``model`` (an ``anisobond.Model`` or a model file) from each bond's
    normal, radii and length -- the table then holds the model's springs whatever wrote it.
    Returns the table."""
    import numpy as np
    m = _model(model)
    normals = np.column_stack([bonds.nx, bonds.ny, bonds.nz])
    radii = np.asarray(packing.radii, dtype=float)
    i, j = np.asarray(bonds.i), np.asarray(bonds.j)
    k = m.springs(normals, radii[i], radii[j], np.asarray(bonds.length, dtype=float),
                  lattice_scaling=lattice_scaling(m, packing, bonds))
    for name in ("kn", "ks", "kr", "ktw", "radius"):
        setattr(bonds, name, k[name].tolist())
    return bonds


def has_adhesions(bonds):
    """True when the table carries YADE adhesions (``ADHESION_COLUMNS``)."""
    return getattr(bonds, "normal_adhesion", None) is not None


def assign_adhesions(model, packing, bonds):
    """Set the table's ``normal_adhesion``, ``shear_adhesion``, ``tan_friction`` (and
    ``joint``: the plane family a bond crosses, -1 for none) to YADE's CohFrict limits of
    ``model``'s [strength] table, computed by the anisobond package
    (``Model.yade_adhesions``: a_n = sigma_t*r^2, a_s = c*r^2, r = min(R_i, R_j), from each
    bond's start ``packing.positions[i]`` and branch vector length*n); all None when the
    model has no [strength] table (the bonds then never break). Returns the table."""
    import numpy as np
    m = _model(model)
    if not m.has_strength:
        for c in ADHESION_COLUMNS + ("joint",):
            setattr(bonds, c, None)
        return bonds
    radii = np.asarray(packing.radii, dtype=float)
    pos = np.asarray(packing.positions, dtype=float)
    i, j = np.asarray(bonds.i), np.asarray(bonds.j)
    branches = np.column_stack([bonds.nx, bonds.ny, bonds.nz]) * np.asarray(
        bonds.length, dtype=float)[:, None]
    a = m.yade_adhesions(pos[i], branches, radii[i], radii[j])
    for c in ADHESION_COLUMNS + ("joint",):
        setattr(bonds, c, a[c].tolist())
    return bonds


def set_bond_limits(ph, bonds, b, keep_friction=False):
    """Bond b's cohesion in YADE's CohFrictPhys ``ph``: with adhesions in the table, fragile
    with its normalAdhesion, shearAdhesion and tangensOfFrictionAngle (YADE breaks it by its
    own criterion: tension when -F_n > a_n, shear when |F_s| > a_s + F_n tan(phi)); without,
    never-breaking (adhesions 1e300, not fragile; friction 0, or as it was with
    ``keep_friction``, as ``assign`` always left it). Either way no rolling or
    twisting plasticity: YADE 2023.02a's moments are elastic (docs/strength.md, "YADE")."""
    ph.cohesionBroken = False
    ph.initCohesion = False
    if has_adhesions(bonds):
        ph.fragile = True
        ph.normalAdhesion = bonds.normal_adhesion[b]
        ph.shearAdhesion = bonds.shear_adhesion[b]
        ph.tangensOfFrictionAngle = bonds.tan_friction[b]
    else:
        ph.fragile = False
        ph.normalAdhesion = HUGE_ADHESION
        ph.shearAdhesion = HUGE_ADHESION
        if not keep_friction:
            ph.tangensOfFrictionAngle = 0.0
    ph.maxRollPl = -1.0
    ph.maxTwistPl = -1.0


class ClumpError(InputError):
    """The scene holds clumps: a clump is one rigid body, not bonded spheres."""


def scene_clumps():
    """The clumps of the current scene: {clump body id: [member body ids]}."""
    from yade import O
    clumps = {}
    for body in O.bodies:
        if body is None:
            continue
        if body.isClump:
            clumps.setdefault(body.id, [])
        elif body.isClumpMember:
            clumps.setdefault(body.clumpId, []).append(body.id)
    return clumps


def refuse_clumps():
    """Raise ``ClumpError`` naming every clump (and its members) of the current scene."""
    clumps = scene_clumps()
    if clumps:
        named = ["clump %d (members %s)" % (c, ", ".join(str(m) for m in sorted(clumps[c])))
                 for c in sorted(clumps)]
        raise ClumpError(
            "the scene holds %d clump(s): %s. A clump is one rigid body, not bonded spheres: "
            "anisobond bonds standalone spheres only (build the scene without clumps, or with "
            "each member as its own sphere)" % (len(clumps), "; ".join(named)))


def _is_sphere(body):
    from yade.wrapper import Sphere
    return body is not None and isinstance(body.shape, Sphere)


def scene_spheres():
    """The current scene's spheres in body-id order, and the ids of its other bodies
    (walls, boxes, facets, ...: they get no springs and are not in the packing). A scene
    with clumps is refused (``ClumpError``)."""
    from yade import O
    refuse_clumps()
    spheres, others = [], []
    for body in O.bodies:
        if body is None:
            continue
        if _is_sphere(body):
            spheres.append(body)
        else:
            others.append(body.id)
    return spheres, others


def scene_cell():
    """The lengths (m) of the current scene's periodic cell, or None when it is not periodic.
    A cell that is not an axis-aligned box (sheared ``hSize``) is refused: anisobond's cells
    are boxes [0, L)."""
    from yade import O
    if not O.periodic:
        return None
    h = O.cell.hSize
    off = [(a, b) for a in range(3) for b in range(3) if a != b and h[a, b] != 0]
    if off:
        raise InputError("the periodic cell is not an axis-aligned box (hSize[%d,%d] = %r): "
                         "anisobond's periodic cells are boxes [0, Lx)x[0, Ly)x[0, Lz)"
                         % (off[0][0], off[0][1], h[off[0][0], off[0][1]]))
    return tuple(float(h[k, k]) for k in range(3))


def _image(I):
    """The periodic image (cellDist) of interaction I as ints; (0, 0, 0) without a cell."""
    from yade import O
    if not O.periodic:
        return (0, 0, 0)
    return tuple(int(I.cellDist[k]) for k in range(3))


def scene_bonds(model, interactions=None):
    """The bond table of the current YADE scene: one bond per real sphere-sphere interaction
    (normal, branch vector, periodic image ``cellDist``; images 0 without a periodic cell),
    springs computed by the anisobond package for ``model``; with it, the packing of the
    scene's spheres (body-id order, ``ids`` their body ids; walls, boxes, facets left out).
    ``i``, ``j`` index that packing (``id_i``, ``id_j`` are the body ids). Interactions with
    a non-sphere body are skipped and counted (``table.skipped_interactions``,
    ``table.non_sphere_bodies``). Returns (Packing, BondTable)."""
    from yade import O
    spheres, others = scene_spheres()
    inters = [I for I in O.interactions if I.isReal] if interactions is None else list(interactions)
    inters, skipped = _sphere_pairs(inters)
    if not inters:
        raise InputError("the scene has no real sphere-sphere interactions to bond "
                         "(%d with a non-sphere body skipped)" % len(skipped))
    index = dict((body.id, k) for k, body in enumerate(spheres))
    positions = [tuple(body.state.pos) for body in spheres]
    radii = [body.shape.radius for body in spheres]
    packing = Packing(positions, radii, scene_cell(), ids=[body.id for body in spheres])
    cols = dict((c, []) for c in BOND_COLUMNS)
    for I in inters:
        l = branch_vector(I)
        length = l.norm()
        cols["i"].append(index[I.id1])
        cols["j"].append(index[I.id2])
        for k, c in enumerate(("nx", "ny", "nz")):
            cols[c].append(l[k] / length)
        cols["length"].append(length)
        for k, c in enumerate(("ix", "iy", "iz")):
            cols[c].append(_image(I)[k])
        for c in ("radius", "kn", "ks", "kr", "ktw"):
            cols[c].append(0.0)
    table = BondTable(cols)
    table.id_i = [I.id1 for I in inters]
    table.id_j = [I.id2 for I in inters]
    table.skipped_interactions = len(skipped)
    table.non_sphere_bodies = others
    return packing, assign_springs(model, packing, table)


def penetration_depth(I):
    """Penetration depth R_1 + R_2 - |x_2 + shift - x_1| (m, negative across a gap) of
    interaction I from the bodies' current positions, as ``Ig2_Sphere_Sphere_ScGeom``
    computes it at the next step (same operations, same rounding). ScGeom's own
    ``penetrationDepth`` is not saved by ``O.save``: NaN on a loaded scene until a step."""
    from yade import O
    return (O.bodies[I.id1].shape.radius + O.bodies[I.id2].shape.radius
            - branch_vector(I).norm())


def _sphere_pairs(interactions):
    """Split interactions into (sphere-sphere, with a non-sphere body: wall, box, facet...)."""
    from yade import O
    pairs, others = [], []
    for I in interactions:
        both = _is_sphere(O.bodies[I.id1]) and _is_sphere(O.bodies[I.id2])
        (pairs if both else others).append(I)
    return pairs, others


def _is_cohesive(I):
    return I.isReal and hasattr(I.phys, "cohesionBroken") and not I.phys.cohesionBroken


def cohesive_interactions():
    """The bonds of a YADE bonded-particle scene: its real sphere-sphere interactions whose
    physics is cohesive (CohFrictPhys with ``cohesionBroken`` False). Cohesive contacts with
    walls, boxes or facets are not bonds (``skipped_cohesive_interactions``). A scene with
    clumps is refused (``ClumpError``)."""
    from yade import O
    refuse_clumps()
    return _sphere_pairs([I for I in O.interactions if _is_cohesive(I)])[0]


def skipped_cohesive_interactions():
    """The real cohesive interactions of the current scene with a body that is not a sphere
    (wall, box, facet, ...): not bonds, left as they are."""
    from yade import O
    return _sphere_pairs([I for I in O.interactions if _is_cohesive(I)])[1]


def _bonds_of(interactions):
    """(sphere-sphere cohesive interactions, number skipped) of a given list, or of the scene."""
    from yade import O
    refuse_clumps()
    if interactions is None:
        inters = [I for I in O.interactions if _is_cohesive(I)]
    else:
        inters = list(interactions)
    pairs, others = _sphere_pairs(inters)
    return pairs, len(others)


def renew_interactions(interactions):
    """Make each interaction anew, so that YADE's ScGeom6D takes the bodies' current
    orientations as its reference (``initialOrientation1/2``, read-only from Python): erase
    it and ``utils.createInteraction`` the same pair, with the same periodic image
    (``cellDist``; createInteraction may pick another, see the module's traps). Its geometry
    is recomputed at the next step. Returns the new interactions in the same order; the old
    objects (and any handle to them) are dead."""
    from yade import O, utils
    renewed = []
    for I in interactions:
        id1, id2 = I.id1, I.id2
        image = I.cellDist if O.periodic else None
        O.interactions.erase(id1, id2)
        J = utils.createInteraction(id1, id2)
        if image is not None:
            J.cellDist = image if J.id1 == id1 else -image
        renewed.append(J)
    return renewed


def assign(model, interactions=None, renew=False):
    """Give every cohesive interaction of the current YADE scene the springs of an anisobond
    model, in place: kn, ks, kr, ktw from the interaction's own normal, radii, centre
    distance and periodic image (computed by the anisobond package; for a cross-anisotropic
    model with the lattice scaling mu of these interactions), and make the current state
    stress-free the way YADE needs: ``unp`` = the penetration depth of the current positions
    (``penetration_depth``: right on a scene read by ``O.load``, whose stored
    ``penetrationDepth`` is NaN until a step; a non-finite one raises ``BondMismatch``),
    forces and moments zero,
    ``cohesionBroken = False``, the moment law on, and
    ``avoidGranularRatcheting = False`` on the scene's Ig2_Sphere_Sphere_ScGeom6D functors
    (otherwise YADE scales the shear spring by (R1+R2)/d). Engines are otherwise left as the
    user set them. Only sphere-sphere interactions are bonds: cohesive contacts with walls,
    boxes or facets keep their physics (counted in ``table.skipped_interactions``); a scene
    with clumps is refused (``ClumpError``). Works with or without a periodic cell.

    Rotations: YADE's total-form moment law measures each bond's rotation from the
    orientations its geometry was made with (``ScGeom6D.initialOrientation1/2``, read-only
    from Python), which assign cannot reset: where spheres have rotated since and the bond
    has k_r or k_tw, the moments come back at the next step. assign then warns
    (``RotationWarning``, with the largest angles and moments; ``table.rotations`` holds
    (bending, twist) per bond, ``bond_rotations``) unless the scene's law uses
    ``useIncrementalForm=True``, whose moments start from the zero set here. With
    ``renew=True`` every bond is first made anew (``renew_interactions``: the current
    orientations become the reference, so the moments start from zero in the total form too;
    handles to the old interaction objects die).
    Strength: when the model has a [strength] table, every bond also gets YADE's CohFrict
    limits (``assign_adhesions``: normalAdhesion = sigma_t*r^2, shearAdhesion = c*r^2,
    r = min(R_i, R_j), tangensOfFrictionAngle = mu, ``fragile = True``; moments elastic, as
    YADE 2023.02a has no moment adhesions), so YADE breaks it by its own criterion; without
    one, never-breaking adhesion (1e300, not fragile) and the friction left as it was.

    Returns the bond table (see ``scene_bonds``) of what was assigned, with the limits
    (``normal_adhesion``, ``shear_adhesion``, ``tan_friction``, ``joint``; None without
    [strength])."""
    from yade import O
    from yade.minieigenHP import Vector3
    from yade.wrapper import Ig2_Sphere_Sphere_ScGeom6D, InteractionLoop
    inters, n_skipped = _bonds_of(interactions)
    if not inters:
        raise InputError("the scene has no sphere-sphere cohesive interactions (CohFrictPhys, "
                         "cohesionBroken False) to assign (%d with a wall, box or facet "
                         "skipped)" % n_skipped)
    if renew:
        inters = renew_interactions(inters)
    for e in O.engines:
        if isinstance(e, InteractionLoop):
            for f in e.geomDispatcher.functors:
                if isinstance(f, Ig2_Sphere_Sphere_ScGeom6D):
                    f.avoidGranularRatcheting = False
    # The penetration depth the next step's Ig2 computes from the current positions, not
    # ScGeom's stored one: that is NaN on a scene read by O.load until a step is taken (it is
    # not saved), and one step old on a scene that has moved since.
    depths = [penetration_depth(I) for I in inters]
    bad = [(I, d) for I, d in zip(inters, depths) if not math.isfinite(d)]
    if bad:
        raise BondMismatch("%d of %d bonds have a non-finite penetration depth (first: %d-%d, "
                           "%r): non-finite positions or radii" % (len(bad), len(inters),
                                                                   bad[0][0].id1, bad[0][0].id2,
                                                                   bad[0][1]))
    packing, table = scene_bonds(model, inters)
    assign_adhesions(model, packing, table)
    table.skipped_interactions = n_skipped
    table.rotations = bond_rotations(inters)
    for b, I in enumerate(inters):
        ph = I.phys
        ph.kn, ph.ks, ph.kr, ph.ktw = table.kn[b], table.ks[b], table.kr[b], table.ktw[b]
        ph.unp = depths[b]
        ph.unpMax = -1.0
        ph.normalForce = Vector3.Zero
        ph.shearForce = Vector3.Zero
        ph.moment_twist = Vector3.Zero
        ph.moment_bending = Vector3.Zero
        set_bond_limits(ph, table, b, keep_friction=True)
        ph.momentRotationLaw = True
    incremental = any(getattr(f, "useIncrementalForm", False)
                      for e in O.engines if isinstance(e, InteractionLoop)
                      for f in e.lawDispatcher.functors)
    message = None if incremental else rotation_message(table.rotations, table)
    if message is not None:
        warnings.warn(message, RotationWarning, stacklevel=2)
    return table


def bond_rotations(interactions):
    """Per bond (bending, twist) angles (rad) of the relative rotation that YADE's total-form
    moment law (``Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=False)``)
    measures at the next step: ScGeom6D's delta = (q1 q01^-1)(q02 q2^-1) between the bodies'
    orientations and the geometry's ``initialOrientation1/2`` (set when YADE made the
    geometry, read-only from Python), its angle split along the current normal (as
    ``ScGeom6D.bending``/``twist``, without twist creep). Zero for bonds whose spheres have
    not rotated since."""
    from yade import O
    out = []
    for I in interactions:
        g = I.geom
        delta = ((O.bodies[I.id1].state.ori * g.initialOrientation1.conjugate())
                 * (g.initialOrientation2 * O.bodies[I.id2].state.ori.conjugate()))
        angle, axis = delta.toAngleAxis()
        if angle > math.pi:
            angle -= 2.0 * math.pi
        n = branch_vector(I).normalized()
        twist = angle * axis.dot(n)
        out.append(((axis * angle - n * twist).norm(), abs(twist)))
    return out


def rotation_message(rotations, table):
    """The ``RotationWarning`` of ``assign``, or None when no bond with a rotational spring
    has rotated by more than ``STRESS_FREE_TOLERANCE`` rad."""
    rows = [(b, bend, tw) for b, (bend, tw) in enumerate(rotations)
            if (table.kr[b] > 0 and bend > STRESS_FREE_TOLERANCE)
            or (table.ktw[b] > 0 and tw > STRESS_FREE_TOLERANCE)]
    if not rows:
        return None
    bb = max(rows, key=lambda r: r[1])[0]
    bt = max(rows, key=lambda r: r[2])[0]
    pair = lambda b: (table.id_i[b], table.id_j[b])
    return ("%d of %d bonds have spheres that rotated since YADE made their geometry "
            "(ScGeom6D.initialOrientation1/2, read-only from Python): YADE's total-form moment "
            "law will apply k_r theta and k_tw theta from the next step, whatever assign set. "
            "Largest bending %.4g rad (bond %s: %.4g N m), largest twist %.4g rad (bond %s: "
            "%.4g N m). To start the moments from zero, call assign(..., renew=True) (the bonds "
            "made anew, the current orientations their reference), or use "
            "Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=True) (moments then "
            "accumulate from the zero assign sets)"
            % (len(rows), len(rotations), rotations[bb][0], pair(bb),
               table.kr[bb] * rotations[bb][0], rotations[bt][1], pair(bt),
               table.ktw[bt] * rotations[bt][1]))


STRESS_FREE_TOLERANCE = 1e-9


def initial_forces(interactions, table):
    """The forces the bonds carry now, as YADE holds them (``phys.normalForce``,
    ``phys.shearForce``): per bond the axial force N = -F_n . n (N, tension positive; n the
    unit branch vector from id1 to id2, the direction of YADE's normal) and |F_s| (N); the largest of each with its bond, relative to
    k_n R_mean of that bond (a strain: the relative size of the stress-measure terms the
    relaxed tensor leaves out, docs/prestress.md); and the Love stress of the axial
    preloads, sigma0 = (1/V) sum N l n (x) n (Pa, docs/prestress.md), with its mean.
    ``stress_free`` when no bond exceeds ``STRESS_FREE_TOLERANCE`` relative."""
    from yade import O
    axial, shear, rel_n, rel_s = [], [], [], []
    sigma = [[0.0] * 3 for _ in range(3)]
    for b, I in enumerate(interactions):
        ph = I.phys
        n = (table.nx[b], table.ny[b], table.nz[b])
        # YADE's normal force is along ScGeom's normal, from id1 to id2: the axial force
        # (a scalar) from the branch vector of the same direction.
        l = branch_vector(I)
        fn = ph.normalForce
        N = -sum(fn[k] * l[k] for k in range(3)) / l.norm()
        fs = ph.shearForce.norm()
        axial.append(N)
        shear.append(fs)
        scale = ph.kn * 0.5 * (O.bodies[I.id1].shape.radius + O.bodies[I.id2].shape.radius)
        rel_n.append(abs(N) / scale if scale > 0 else (0.0 if N == 0 else float("inf")))
        rel_s.append(fs / scale if scale > 0 else (0.0 if fs == 0 else float("inf")))
        for a in range(3):
            for c in range(3):
                sigma[a][c] += N * table.length[b] * n[a] * n[c]
    volume = O.cell.volume if O.periodic else None
    if volume:
        sigma = [[x / volume for x in row] for row in sigma]
    else:
        sigma = None
    # The bond of the largest |value|, None when every value is zero.
    worst = lambda v: max(range(len(v)), key=lambda b: abs(v[b])) if any(v) else None
    bn, bs = worst(axial), worst(shear)
    bond = lambda b: None if b is None else (table.i[b], table.j[b])
    loaded = sum(1 for a, c in zip(rel_n, rel_s) if max(a, c) > STRESS_FREE_TOLERANCE)
    return {
        "stress_free": loaded == 0,
        "n_loaded": loaded,
        "n_bonds": len(axial),
        "max_axial_force_N": abs(axial[bn]) if bn is not None else 0.0,
        "max_axial_force_bond": bond(bn),
        "max_axial_relative": max(rel_n) if rel_n else 0.0,
        "max_shear_force_N": shear[bs] if bs is not None else 0.0,
        "max_shear_force_bond": bond(bs),
        "max_shear_relative": max(rel_s) if rel_s else 0.0,
        "preload_stress_Pa": sigma,
        "preload_mean_stress_Pa": None if sigma is None else (sigma[0][0] + sigma[1][1]
                                                              + sigma[2][2]) / 3.0,
        "accounted_by": "anisobond tensor --method prestressed (docs/prestress.md)",
        "axial_force": axial,
        "shear_force": shear,
    }


def prestress_message(f):
    """The warning ``bond_table`` gives for bonds that are not stress-free."""
    text = ("%d of %d bonds are not stress-free: largest |axial force| %.4g N (bond %s, "
            "%.3g k_n R_mean), largest |shear force| %.4g N (bond %s, %.3g k_n R_mean). The "
            "relaxed tensor of this bond table assumes stress-free bonds and leaves out the "
            "preloads' stress-measure terms (of relative size ~%.2g); the `prestressed` tensor "
            "method accounts for axial preloads (docs/prestress.md)"
            % (f["n_loaded"], f["n_bonds"], f["max_axial_force_N"], f["max_axial_force_bond"],
               f["max_axial_relative"], f["max_shear_force_N"], f["max_shear_force_bond"],
               f["max_shear_relative"], max(f["max_axial_relative"], f["max_shear_relative"])))
    if f["preload_mean_stress_Pa"] is not None:
        text += (": the axial preloads' mean Love stress is %.6g Pa (tension positive), i.e. "
                 "`anisobond tensor ... --method prestressed --prestress %.6g` for its isotropic "
                 "part" % (f["preload_mean_stress_Pa"], -f["preload_mean_stress_Pa"]))
    text += ("; shear preloads are not accounted for by any method. To measure the stress-free "
             "network instead, make the bonds stress-free first (anisobond_yade.assign).")
    return text


def bond_table(path=None, interactions=None):
    """The current scene's cohesive sphere-sphere interactions as an anisobond bond table
    with the springs YADE holds now (``BondTable``; written as CSV to ``path`` when given,
    atomically, every number at full precision), so that ``anisobond`` gives the exact
    relaxed tensor of the user's own bond network.

    ``i``, ``j`` index the scene's spheres in body-id order -- the packing ``write_packing``
    writes -- and ``id_i``, ``id_j`` are YADE's body ids. Works with or without a periodic
    cell (images 0 without one). Cohesive contacts with walls, boxes or facets are not bonds:
    they are skipped and counted (``table.skipped_interactions``; the non-sphere bodies in
    ``table.non_sphere_bodies``). A scene with clumps is refused (``ClumpError``).

    The relaxed tensor assumes stress-free bonds. The table also carries the forces the
    bonds hold now (``axial_force``, ``shear_force`` per bond, and ``initial_forces``, see
    ``initial_forces``); when they are not zero (YADE's own cohesive bonds start in tension
    across a gap: ``unp`` = 0, not the penetration depth) a ``PrestressWarning`` says how
    large they are and which method accounts for them."""
    from yade import O
    inters, n_skipped = _bonds_of(interactions)
    spheres, others = scene_spheres()
    index = dict((body.id, k) for k, body in enumerate(spheres))
    cols = dict((c, []) for c in BOND_COLUMNS + ID_COLUMNS)
    for I in inters:
        l = branch_vector(I)
        length = l.norm()
        i, j, sign = (I.id1, I.id2, 1) if I.id1 < I.id2 else (I.id2, I.id1, -1)
        cols["i"].append(index[i])
        cols["j"].append(index[j])
        cols["id_i"].append(i)
        cols["id_j"].append(j)
        for k, c in enumerate(("nx", "ny", "nz")):
            cols[c].append(sign * l[k] / length)
        cols["length"].append(length)
        r1, r2 = O.bodies[I.id1].shape.radius, O.bodies[I.id2].shape.radius
        cols["radius"].append(min(r1, r2))
        for c in ("kn", "ks", "kr", "ktw"):
            cols[c].append(getattr(I.phys, c))
        for k, c in enumerate(("ix", "iy", "iz")):
            cols[c].append(sign * _image(I)[k])
    table = BondTable(cols)
    table.skipped_interactions = n_skipped
    table.non_sphere_bodies = others
    forces = initial_forces(inters, table)
    table.axial_force = forces.pop("axial_force")
    table.shear_force = forces.pop("shear_force")
    table.initial_forces = forces
    if not forces["stress_free"]:
        warnings.warn(prestress_message(forces), PrestressWarning, stacklevel=2)
    if path is not None:
        lines = [",".join(BOND_COLUMNS + ID_COLUMNS)]
        for b in range(len(table)):
            lines.append(",".join(str(int(cols[c][b])) if c in INT_COLUMNS else _g(cols[c][b])
                                  for c in BOND_COLUMNS + ID_COLUMNS))
        _write_atomic(path, "\n".join(lines) + "\n")
    return table


def write_packing(path):
    """Write the current scene's spheres as an anisobond packing file (atomically) at full
    precision -- every number the shortest ``repr`` that reads back bit for bit -- to go with
    ``bond_table``: ``#format id_x_y_z_r_matId`` lines ``body-id x y z r matId`` in body-id
    order (the order ``bond_table``'s ``i``, ``j`` index; the ids come back as the table's
    ``id_i``, ``id_j``), under ``# periodic Lx Ly Lz`` for a periodic scene (positions as
    YADE holds them, outside the cell too: ``cellDist`` is of those) or ``# free``. Walls,
    boxes and facets are left out (named in a comment); a scene with clumps is refused
    (``ClumpError``), a sheared cell too. YADE's own ``export.text`` and
    ``SpherePack.save`` keep 6 digits, which a full-precision bond table rightly refuses.
    Returns the ``Packing`` written (``ids`` the body ids)."""
    spheres, others = scene_spheres()
    if not spheres:
        raise InputError("the scene has no spheres to write")
    cell = scene_cell()
    positions = [tuple(float(x) for x in body.state.pos) for body in spheres]
    radii = [float(body.shape.radius) for body in spheres]
    lines = ["# anisobond_yade.write_packing: the %d spheres of a YADE scene, body ids, "
             "positions and radii in m at full precision" % len(spheres)]
    if others:
        lines.append("# %d non-sphere bodies left out (walls, boxes, facets): ids %s"
                     % (len(others), " ".join(str(i) for i in others)))
    lines.append("# periodic %s %s %s" % tuple(_g(x) for x in cell) if cell else "# free")
    lines.append("#format id_x_y_z_r_matId")
    for body, p, r in zip(spheres, positions, radii):
        mat = body.material.id if body.material is not None else -1
        lines.append("%d %s %s %s %s %d" % (body.id, _g(p[0]), _g(p[1]), _g(p[2]), _g(r), mat))
    _write_atomic(path, "\n".join(lines) + "\n")
    return Packing(positions, radii, cell, ids=[body.id for body in spheres])


def tensor_of_paths(histories, paths):
    """Per path (strain change, stress change, stress / strain_path) from its first and last
    history rows, and C = S E^-1 (6x6 list, Pa) when all six paths ran, else None."""
    import numpy as np
    columns = {}
    for p in paths:
        _, _, e_end, s_end = histories[p][-1]
        _, _, e_0, s_0 = histories[p][0]
        e = [e_end[k] - e_0[k] for k in range(6)]
        s = [s_end[k] - s_0[k] for k in range(6)]
        columns[p] = (e, s, [s[k] / e[p] for k in range(6)])
    c = None
    if sorted(paths) == [0, 1, 2, 3, 4, 5]:
        e_mat = np.array([columns[p][0] for p in range(6)]).T
        s_mat = np.array([columns[p][1] for p in range(6)]).T
        c = (s_mat.dot(np.linalg.inv(e_mat))).tolist()
    return columns, c


_COPY_SCENE = []  # the scene number element_tests_in_place runs its copies in, reused

# Largest resultant bond force on a body that element_tests_in_place accepts, relative to the
# force its strain step puts on a mean bond (k_n * strain * |l|): above it the tests would
# measure the scene relaxing towards equilibrium, not its stiffness.
UNBALANCE_TOLERANCE = 1e-2


def unbalanced_bond_force(strain, interactions=None):
    """The scene's imbalance as the element tests see it: the largest resultant of the bond
    forces on a free body (N) and its ratio to k_n * strain * |l| averaged over the bonds.
    Each bond's force is the one YADE's cohesive law applies at the next step with the
    current positions (``Law2_ScGeom6D_CohFrictPhys_CohesionMoment``, total form:
    F = k_n (depth - unp) n + F_s, minus on id1, plus on id2). Bodies with blocked degrees
    of freedom (supports) are left out. Returns (force, ratio, body id)."""
    from yade import O
    bonds = cohesive_interactions() if interactions is None else interactions
    resultant = {}
    scale = 0.0
    for I in bonds:
        l = branch_vector(I)
        length = l.norm()
        n = l / length
        f = n * (I.phys.kn * (penetration_depth(I) - I.phys.unp)) + I.phys.shearForce
        resultant[I.id1] = resultant.get(I.id1, 0 * n) - f
        resultant[I.id2] = resultant.get(I.id2, 0 * n) + f
        scale += I.phys.kn * abs(strain) * length
    if not bonds or scale == 0.0:
        return 0.0, 0.0, None
    scale /= len(bonds)
    free = [(v.norm(), b) for b, v in resultant.items()
            if O.bodies[b].dynamic and not O.bodies[b].state.blockedDOFs]
    if not free:
        return 0.0, 0.0, None
    force, body = max(free)
    return force, force / scale, body


def element_tests_in_place(strain=1e-5, steps=200, damping=0.4, paths=(0, 1, 2, 3, 4, 5)):
    """The six-path element tests on the current scene as the user built it (periodic cell,
    their engines, time step and bonds): every path starts from the current state, the
    strain in one step, then ``steps`` steps with Cundall damping ``damping``. Returns an
    ``ElementResult`` as ``element_tests`` does.

    The paths run on copies (``O.saveTmp``, then ``O.loadTmp`` into a second scene,
    ``O.addScene``/``O.switchToScene``); the user's scene is not stepped and its objects
    stay the scene's: engine, functor, body and material handles the script holds still
    reach it afterwards, and ``O.iter``, ``O.time``, positions and bond states are as
    before. Engine labels are mapped back to the user's objects (``O.engines =
    O.engines``). The copies run every engine of the scene (PyRunners included). Call it
    while the scene is not running (not from an engine). A scene out of static equilibrium
    (``unbalanced_bond_force`` above ``UNBALANCE_TOLERANCE``: e.g. YADE's own cohesive bonds,
    which start loaded) is refused with ``InputError``."""
    from yade import O
    if not O.periodic:
        raise InputError("element tests deform the periodic cell: the scene is not periodic")
    force, ratio, body = unbalanced_bond_force(strain)
    if ratio > UNBALANCE_TOLERANCE:
        raise InputError(
            "the scene is not in static equilibrium: the bond forces leave a resultant of "
            "%.4g N on body %d, %.3g times the force the strain step of %g puts on a mean "
            "bond (tolerance %g); the element tests would measure the scene relaxing, not its "
            "stiffness. Make the bonds stress-free first (anisobond_yade.assign), or relax the "
            "scene to equilibrium and call again (the relaxed, preloaded state is what "
            "`anisobond tensor --method prestressed` describes)"
            % (force, body, ratio, strain, UNBALANCE_TOLERANCE))
    home = O.thisScene
    O.saveTmp("anisobond-in-place")
    if not _COPY_SCENE or _COPY_SCENE[0] == home:
        _COPY_SCENE[:] = [O.addScene()]
    histories = {}
    try:
        O.switchToScene(_COPY_SCENE[0])
        for p in paths:
            O.loadTmp("anisobond-in-place")
            histories[p] = run_path(p, strain, steps, damping)
        dt = O.dt
    finally:
        if O.thisScene != home:
            O.resetThisScene()
            O.switchToScene(home)
        # Loading the copies bound the labels to their objects: bind them to the user's.
        O.engines = O.engines
    columns, c = tensor_of_paths(histories, paths)
    return ElementResult(c=c, histories=histories, columns=columns, timings={}, dt=dt,
                         strain=strain, steps=steps, damping=damping, density=None,
                         paths=list(paths), safety=None)


# --------------------------------------------------------------------------------------
# Time step
# --------------------------------------------------------------------------------------

def critical_time_step(packing, bonds, density, manybody=None):
    """Leapfrog stability limit dt_c = 2/omega_max (s) of the bonded packing.

    omega_max^2 is bounded by Gershgorin's theorem on M^-1/2 K M^-1/2, with K the
    linearised bond stiffness in the 6 DOFs per particle (translations and rotations,
    contact point mid-gap as ScGeom) and M the masses m = density*4/3*pi*r^3 and
    inertias 2/5*m*r^2 that YADE's ``utils.sphere`` gives. The bound is >= the true
    omega_max, so dt_c is safe; unlike GlobalStiffnessTimeStepper it counts fresh,
    force-free bonds. ``manybody`` (an ``anisobond.ManyBody``): its Hessian's Gershgorin
    rows are added to the translation rows, so the bound holds with the term.
    """
    import numpy as np
    n = len(packing)
    r = np.asarray(packing.radii, dtype=float)
    m = density * 4.0 / 3.0 * math.pi * r ** 3
    inertia = 0.4 * m * r ** 2
    scale = np.concatenate([np.repeat(m[:, None], 3, 1), np.repeat(inertia[:, None], 3, 1)],
                           axis=1) ** -0.5  # (n, 6)
    i = np.asarray(bonds.i)
    j = np.asarray(bonds.j)
    if len(i) == 0:
        raise InputError("no bonds: nothing to run")
    nv = np.stack([bonds.nx, bonds.ny, bonds.nz], axis=1)
    nv = nv / np.linalg.norm(nv, axis=1)[:, None]
    length = np.asarray(bonds.length)
    kn, ks = np.asarray(bonds.kn), np.asarray(bonds.ks)
    kr, ktw = np.asarray(bonds.kr), np.asarray(bonds.ktw)
    gap = length - r[i] - r[j]
    ai, aj = r[i] + 0.5 * gap, r[j] + 0.5 * gap
    nb = len(i)
    eye = np.broadcast_to(np.eye(3), (nb, 3, 3))
    nn = np.einsum("bi,bj->bij", nv, nv)
    s = ks[:, None, None] * eye + (kn - ks)[:, None, None] * nn

    def skew(a):
        z = np.zeros(len(a))
        return np.stack([np.stack([z, -a[:, 2], a[:, 1]], 1),
                         np.stack([a[:, 2], z, -a[:, 0]], 1),
                         np.stack([-a[:, 1], a[:, 0], z], 1)], 1)

    bi = np.concatenate([-eye, skew(nv * ai[:, None])], axis=2)  # (nb, 3, 6)
    bj = np.concatenate([eye, skew(nv * aj[:, None])], axis=2)
    rot = kr[:, None, None] * (eye - nn) + ktw[:, None, None] * nn
    kii = np.einsum("bki,bkl,blj->bij", bi, s, bi)
    kjj = np.einsum("bki,bkl,blj->bij", bj, s, bj)
    kij = np.einsum("bki,bkl,blj->bij", bi, s, bj)
    kii[:, 3:, 3:] += rot
    kjj[:, 3:, 3:] += rot
    kij[:, 3:, 3:] -= rot
    si, sj = scale[i], scale[j]
    row_i = (np.abs(kii * si[:, :, None] * si[:, None, :]).sum(2)
             + np.abs(kij * si[:, :, None] * sj[:, None, :]).sum(2))
    row_j = (np.abs(kjj * sj[:, :, None] * sj[:, None, :]).sum(2)
             + np.abs(kij.transpose(0, 2, 1) * sj[:, :, None] * si[:, None, :]).sum(2))
    rows = np.zeros((n, 6))
    np.add.at(rows, i, row_i)
    np.add.at(rows, j, row_j)
    if manybody is not None:
        rows[:, :3] += np.asarray(manybody.gershgorin_rows(m))[:, None]
    omega2 = rows.max()
    if not omega2 > 0:
        raise InputError("all bond springs are zero: no time step")
    return 2.0 / math.sqrt(omega2)


# --------------------------------------------------------------------------------------
# Scene
# --------------------------------------------------------------------------------------

class Scene(object):
    """What ``build_scene`` set up: time step (s), damping, density, counts, timings."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def build_scene(packing, bonds, density=2600.0, damping=0.0, dt=None, safety=0.8,
                branch_tolerance=1e-9, verify=True, grains=None):
    """Reset YADE's ``O`` and build the bonded scene: periodic with the packing's cell, or
    free (``O.periodic = False``, no cell; every bond's image must then be 0, 0, 0) when
    ``packing.cell`` is None.

    Spheres of CohFrictMat (``density`` kg/m^3), one interaction per table row with the
    table's periodic image and springs, stress-free and unbreakable, engines
    ForceResetter, InteractionLoop (ScGeom6D without ratcheting correction, CohFrictPhys,
    CohesionMoment law) and NewtonIntegrator(damping) -- no collider. ``dt`` defaults to
    ``safety * critical_time_step``. With ``verify`` every bond's branch vector, normal,
    penetration depth and springs are checked against the table (relative tolerance
    ``branch_tolerance`` of the bond length); a mismatch raises ``BondMismatch``.
    ``grains`` (a polycrystal's grain id per sphere, ``read_grains``) are attached to the
    spheres by ``attach_grains``. Returns a ``Scene``.
    """
    from yade import O, utils
    from yade.wrapper import (CohFrictMat, ForceResetter, InteractionLoop,
                              Ig2_Sphere_Sphere_ScGeom6D, Ip2_CohFrictMat_CohFrictMat_CohFrictPhys,
                              Law2_ScGeom6D_CohFrictPhys_CohesionMoment, NewtonIntegrator)
    from yade.minieigenHP import Matrix3, Vector3, Vector3i

    t0 = time.time()
    n = len(packing)
    periodic = packing.cell is not None
    for b in range(len(bonds)):
        if bonds.j[b] >= n:
            raise InputError("bond %d joins particle %d but the packing has %d"
                             % (b, bonds.j[b], n))
        if not periodic and (bonds.ix[b], bonds.iy[b], bonds.iz[b]) != (0, 0, 0):
            raise InputError("bond %d (%d-%d) has the periodic image %d,%d,%d but the packing "
                             "is free (no cell)" % (b, bonds.i[b], bonds.j[b], bonds.ix[b],
                                                    bonds.iy[b], bonds.iz[b]))
    if dt is None:
        dt = safety * critical_time_step(packing, bonds, density)
    O.reset()
    O.periodic = periodic
    if periodic:
        O.cell.setBox(*packing.cell)
        O.cell.velGrad = Matrix3.Zero
    mat = O.materials.append(CohFrictMat(
        young=1.0, poisson=1.0, density=density, frictionAngle=0.0, isCohesive=True,
        momentRotationLaw=True, normalCohesion=HUGE_ADHESION, shearCohesion=HUGE_ADHESION,
        etaRoll=-1.0, etaTwist=-1.0, fragile=False, label="anisobond"))
    O.bodies.append([utils.sphere(Vector3(*p), r, material=mat)
                     for p, r in zip(packing.positions, packing.radii)])
    if grains is not None:
        attach_grains(grains, [O.bodies[k] for k in range(n)])
    O.engines = [
        ForceResetter(),
        InteractionLoop(
            [Ig2_Sphere_Sphere_ScGeom6D(avoidGranularRatcheting=False)],
            [Ip2_CohFrictMat_CohFrictMat_CohFrictPhys(setCohesionNow=False,
                                                      setCohesionOnNewContacts=False)],
            [Law2_ScGeom6D_CohFrictPhys_CohesionMoment(useIncrementalForm=False,
                                                       always_use_moment_law=False)]),
        NewtonIntegrator(damping=damping, gravity=(0, 0, 0), label="newton"),
    ]
    interactions = []
    for b in range(len(bonds)):
        i, j = bonds.i[b], bonds.j[b]
        I = utils.createInteraction(i, j)
        if periodic:
            image = Vector3i(bonds.ix[b], bonds.iy[b], bonds.iz[b])
            # The table's image is that of j seen from i; YADE shifts body id2.
            I.cellDist = image if I.id1 == i else -image
        ph = I.phys
        set_bond_limits(ph, bonds, b)
        ph.unpMax = -1.0
        ph.momentRotationLaw = True
        interactions.append(I)
    # One step with dt = 0: the geometry is recomputed with the corrected images; nothing
    # moves.
    O.dt = 0.0
    O.step()
    for b, I in enumerate(interactions):
        if not I.isReal:
            raise BondMismatch("bond %d (%d-%d) was erased by YADE" % (b, bonds.i[b], bonds.j[b]))
        ph, g = I.phys, I.geom
        ph.kn, ph.ks, ph.kr, ph.ktw = bonds.kn[b], bonds.ks[b], bonds.kr[b], bonds.ktw[b]
        ph.unp = g.penetrationDepth
        ph.normalForce = Vector3.Zero
        ph.shearForce = Vector3.Zero
        ph.moment_twist = Vector3.Zero
        ph.moment_bending = Vector3.Zero
    O.dt = dt  # O.iter is now 1 and O.time 0 (the dt = 0 step); O.iter cannot be reset
    if verify:
        verify_bonds(packing, bonds, interactions, branch_tolerance)
    return Scene(dt=dt, damping=damping, density=density, n_particles=n,
                 n_bonds=len(bonds), interactions=interactions, build_time=time.time() - t0)


def branch_vector(I):
    """Branch vector x_2 + shift - x_1 of interaction I in YADE (m), from id1 to id2; the
    shift is hSize * cellDist in a periodic scene, none otherwise (the operations of YADE's
    Ig2_Sphere_Sphere_ScGeom, so the same rounding)."""
    from yade import O
    b1, b2 = O.bodies[I.id1], O.bodies[I.id2]
    if not O.periodic:
        return b2.state.pos - b1.state.pos
    return b2.state.pos + O.cell.hSize * I.cellDist - b1.state.pos


def verify_bonds(packing, bonds, interactions, tolerance=1e-9):
    """Check every bond in YADE against the table; raise ``BondMismatch`` listing the bad
    ones. Checked: the interaction is real and cohesive, its branch vector equals
    length*n, ScGeom's normal equals n, penetrationDepth = R_i + R_j - length, the four
    springs are the table's, the bond is stress-free (unp = penetrationDepth).
    Returns the largest relative branch-vector error."""
    bad, worst = [], 0.0
    for b, I in enumerate(interactions):
        sign = 1.0 if I.id1 == bonds.i[b] else -1.0
        l = branch_vector(I) * sign
        want = bonds.branch(b)
        L = bonds.length[b]
        err = math.sqrt(sum((l[k] - want[k]) ** 2 for k in range(3))) / L
        worst = max(worst, err)
        problems = []
        if not I.isReal:
            problems.append("not real")
        if err > tolerance:
            problems.append("branch vector %s != table %s" % (tuple(l), want))
        g, ph = I.geom, I.phys
        nerr = math.sqrt(sum((g.normal[k] * sign - want[k] / L) ** 2 for k in range(3)))
        if nerr > tolerance:
            problems.append("normal %s != table n" % (tuple(g.normal),))
        pd = packing.radii[bonds.i[b]] + packing.radii[bonds.j[b]] - L
        if abs(g.penetrationDepth - pd) > tolerance * L:
            problems.append("penetrationDepth %r != R_i+R_j-length %r" % (g.penetrationDepth, pd))
        for name in ("kn", "ks", "kr", "ktw"):
            if getattr(ph, name) != getattr(bonds, name)[b]:
                problems.append("%s %r != table %r" % (name, getattr(ph, name),
                                                       getattr(bonds, name)[b]))
        if ph.cohesionBroken or ph.unp != g.penetrationDepth:
            problems.append("not a stress-free cohesive bond")
        if problems:
            bad.append("bond %d (%d-%d image %d,%d,%d): %s" % (
                b, bonds.i[b], bonds.j[b], bonds.ix[b], bonds.iy[b], bonds.iz[b],
                "; ".join(problems)))
    if bad:
        raise BondMismatch("%d of %d bonds differ from the table in YADE:\n  %s"
                           % (len(bad), len(interactions), "\n  ".join(bad[:20])))
    return worst


# --------------------------------------------------------------------------------------
# The many-body term (docs/manybody.md): YADE's bond laws are pairwise, so the term runs
# as an engine of this module, its forces computed by the anisobond package every step.
# --------------------------------------------------------------------------------------

_MANYBODY = None


class ManyBodyEngine(object):
    """What ``add_manybody`` installed: the package's term (``anisobond.ManyBody``), the
    YADE body ids in the packing's order, the cell's transformation when it was added
    (the reference), the PyRunner, and the wall time its steps took (s)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def cell_gradient(self):
        """The cell's deformation gradient since the term's reference, H = trsf * trsf0^-1
        (identity in a free scene)."""
        from yade import O
        if not O.periodic:
            return None
        h = O.cell.trsf * self.trsf0_inverse
        return [[h[a, b] for b in range(3)] for a in range(3)]

    def positions(self):
        from yade import O
        return [tuple(O.bodies[i].state.pos) for i in self.ids]

    def evaluate(self):
        """The term's energy (J), forces (N) and nominal stress (Pa) now (a dict)."""
        return self.term.evaluate(self.positions(), self.cell_gradient())


def add_manybody(model, packing, bonds, ids=None, density=2600.0, safety=0.8, dt=None):
    """Add the many-body term of ``model``'s ``[manybody]`` table (an ``anisobond.Model`` or
    a model file) to the current scene: a ``PyRunner`` run every step just before
    ``NewtonIntegrator`` adds each body's term force (``O.forces.addF``), computed by the
    anisobond package from the bodies' positions and the cell's deformation gradient.
    The reference state is the scene as it is now, which must hold ``packing``'s
    positions and ``bonds`` (``build_scene`` makes such a scene); ``ids`` are the YADE body
    ids in the packing's order (default 0..N-1). ``stress_voigt`` then adds the term's
    stress. The term stiffens the packing: unless ``dt`` is given (then ``O.dt = dt``), the
    time step becomes at most ``safety`` times the stability bound of springs and term
    together (``critical_time_step(..., manybody=term)``, masses of ``density``). The term
    costs one package call per step (measured in docs/manybody.md). Returns the ``ManyBodyEngine``; raises ``anisobond.ModelError`` when the model has no
    ``[manybody]`` table."""
    global _MANYBODY
    import numpy as np
    from yade import O
    from yade.wrapper import NewtonIntegrator, PyRunner
    ab = package()
    m = _model(model)
    pk = ab.Packing(packing.positions, packing.radii, cell=packing.cell)
    image = np.column_stack([bonds.ix, bonds.iy, bonds.iz]).astype(float)
    term = ab.Assembly.from_bonds(pk, m, bonds.i, bonds.j, image=image).many_body()
    ids = list(range(len(packing))) if ids is None else list(ids)
    if len(ids) != len(packing):
        raise InputError("add_manybody: %d ids for %d particles" % (len(ids), len(packing)))
    newton = [k for k, e in enumerate(O.engines) if isinstance(e, NewtonIntegrator)]
    if not newton:
        raise InputError("add_manybody: the scene has no NewtonIntegrator to run before")
    runner = PyRunner(command="import anisobond_yade; anisobond_yade._manybody_step()",
                      iterPeriod=1, label="anisobond_manybody")
    engines = list(O.engines)
    engines.insert(newton[0], runner)
    O.engines = engines
    O.dt = dt if dt is not None else min(
        O.dt, safety * critical_time_step(packing, bonds, density, manybody=term))
    trsf0 = O.cell.trsf if O.periodic else None
    _MANYBODY = ManyBodyEngine(term=term, ids=ids, runner=runner, seconds=0.0, steps=0,
                               trsf0_inverse=trsf0.inverse() if trsf0 is not None else None)
    return _MANYBODY


def remove_manybody():
    """Take the term's engine out of the scene (and out of ``stress_voigt``)."""
    global _MANYBODY
    from yade import O
    O.engines = [e for e in O.engines if getattr(e, "label", "") != "anisobond_manybody"]
    _MANYBODY = None


def _manybody_step():
    """The PyRunner's command: add the term's forces of the current positions."""
    from yade import O
    from yade.minieigenHP import Vector3
    t0 = time.time()
    mb = _MANYBODY
    forces = mb.evaluate()["forces"]
    for i, f in zip(mb.ids, forces):
        O.forces.addF(i, Vector3(float(f[0]), float(f[1]), float(f[2])))
    mb.seconds += time.time() - t0
    mb.steps += 1


def manybody_stress_voigt():
    """The term's nominal stress (Pa, Voigt 6-vector, symmetric part) now; zeros without it."""
    if _MANYBODY is None:
        return [0.0] * 6
    s = _MANYBODY.evaluate()["stress"]
    return [0.5 * (s[a][b] + s[b][a]) for a, b in VOIGT_PAIRS]


# --------------------------------------------------------------------------------------
# Measurements
# --------------------------------------------------------------------------------------

def stress_voigt():
    """YADE's Love stress (Pa, tension positive, utils.getStress) as a Voigt 6-vector of
    its symmetric part, plus the many-body term's stress when ``add_manybody`` added one."""
    from yade import utils
    s = utils.getStress()
    extra = manybody_stress_voigt()
    return [0.5 * (s[a, b] + s[b, a]) + e for (a, b), e in zip(VOIGT_PAIRS, extra)]


def strain_voigt():
    """Cell strain (Voigt, engineering): e_ii = F_ii - 1, gamma_ij = F_ij + F_ji with F the
    cell's deformation gradient ``O.cell.trsf`` (small strain)."""
    from yade import O
    f = O.cell.trsf
    out = []
    for a, b in VOIGT_PAIRS:
        out.append(f[a, a] - 1.0 if a == b else f[a, b] + f[b, a])
    return out


def velocity_gradient(path, strain, dt):
    """Velocity gradient (1/s) that applies `strain` of path `path` (Voigt index 0-5) in one
    step: uniaxial e_aa, or pure shear gamma_ab = strain (symmetric gradient, no spin)."""
    from yade.minieigenHP import Matrix3
    a, b = VOIGT_PAIRS[path]
    m = Matrix3.Zero
    if a == b:
        m[a, a] = strain / dt
    else:
        m[a, b] = 0.5 * strain / dt
        m[b, a] = 0.5 * strain / dt
    return m


class ElementResult(object):
    """Result of ``element_tests``: C (6x6 list, Pa), per-path histories, settings."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def run_path(path, strain, steps, damping, stress_volume=None):
    """One element-test path on the current scene (fresh from ``build_scene``): the
    strain in one step (see the velGrad trap above), then relaxation. Returns the
    history: a list of (step, time, strain6, stress6) after every step, step 0 first
    being the unstrained state before any step. With ``stress_volume`` (m^3), stresses are
    per that volume instead of the cell's (a box of mixed periodicity, whose free axes
    the export extended: YADE's Love stress times V_cell/stress_volume, V_cell unstrained)."""
    from yade import O
    from yade.minieigenHP import Matrix3
    from yade.wrapper import NewtonIntegrator
    newton = [e for e in O.engines if isinstance(e, NewtonIntegrator)][0]
    newton.damping = damping
    scale = 1.0 if stress_volume is None else O.cell.volume / stress_volume
    stress = lambda: [scale * s for s in stress_voigt()]
    hist = [(0, O.time, strain_voigt(), stress())]
    O.cell.velGrad = velocity_gradient(path, strain, O.dt)
    for k in range(1, steps + 1):
        O.step()
        if k == 1:
            O.cell.velGrad = Matrix3.Zero
        hist.append((k, O.time, strain_voigt(), stress()))
    return hist


def element_tests(packing, bonds, strain=1e-5, steps=200, damping=0.4, density=2600.0,
                  dt=None, safety=0.8, paths=(0, 1, 2, 3, 4, 5), rebuild=False,
                  stress_volume=None, manybody=None, grains=None):
    """Six-path element test (three uniaxial strains, three pure shears, Voigt order).

    Every path starts from the same initial state: the scene is built (and verified) once
    and saved with ``O.saveTmp``, later paths restore it with ``O.loadTmp`` (``rebuild=True``
    builds it anew for every path; the results are the same). ``strain`` is applied
    in one step, and the assembly relaxes for ``steps`` steps with Cundall damping
    ``damping`` (0 = undamped, for step-by-step comparison). C = S E^-1 with S, E the 6x6
    matrices of final stress and strain columns (all six paths needed; with fewer paths
    ``C`` is None and ``columns`` holds stress/strain_a of each path run). ``stress_volume``
    (m^3): stresses per that volume, not the cell's (see ``run_path``). ``manybody``: a
    model (or model file) whose ``[manybody]`` term is added to the scene (``add_manybody``).
    ``grains``: each sphere's grain id, attached by ``build_scene`` (``attach_grains``).
    """
    from yade import O
    histories, timings, dt_used = {}, {}, None
    remove_manybody()
    for k, p in enumerate(paths):
        t0 = time.time()
        if rebuild or k == 0:
            sc = build_scene(packing, bonds, density=density, damping=damping, dt=dt,
                             safety=safety, grains=grains)
            dt_used = sc.dt
            if manybody is not None:
                add_manybody(manybody, packing, bonds, density=density, safety=safety, dt=dt)
                dt_used = O.dt
            if not rebuild:
                O.saveTmp("anisobond-initial")
        else:
            O.loadTmp("anisobond-initial")
        t1 = time.time()
        histories[p] = run_path(p, strain, steps, damping, stress_volume)
        t2 = time.time()
        timings[p] = {"build_s": t1 - t0, "run_s": t2 - t1}
    columns, c = tensor_of_paths(histories, paths)
    return ElementResult(c=c, histories=histories, columns=columns, timings=timings, dt=dt_used,
                         strain=strain, steps=steps, damping=damping, density=density,
                         paths=list(paths), safety=safety, stress_volume=stress_volume)


# --------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------

def _g(v):
    return repr(float(v))


def write_history_csv(path, result):
    """Stress history CSV (written atomically): one row per path and step."""
    lines = [
        "# anisobond YADE element test: strain %s in one step, then %d steps, damping %s, "
        "dt %s s, density %s kg/m^3" % (_g(result.strain), result.steps, _g(result.damping),
                                        _g(result.dt), _g(result.density)),
        "# units: time_s in s; e* engineering strain (-) from O.cell.trsf; s* in Pa, "
        "Love stress utils.getStress() (tension positive, symmetric part); Voigt 11,22,33,23,13,12",
        "path,step,time_s,e11,e22,e33,e23,e13,e12,s11_Pa,s22_Pa,s33_Pa,s23_Pa,s13_Pa,s12_Pa",
    ]
    for p in result.paths:
        for step, t, e, s in result.histories[p]:
            lines.append(",".join([VOIGT_LABELS[p], str(step), _g(t)] + [_g(x) for x in e]
                                  + [_g(x) for x in s]))
    _write_atomic(path, "\n".join(lines) + "\n")


def cubic_projection(c):
    """Truszkowska 2018 Eq. 30 cubic projection of the symmetric part of C (Pa)."""
    s = [[0.5 * (c[a][b] + c[b][a]) for b in range(6)] for a in range(6)]
    diag, off, shear = [(0, 0), (1, 1), (2, 2)], [(0, 1), (0, 2), (1, 2)], [(3, 3), (4, 4), (5, 5)]
    mean = lambda es: sum(s[a][b] for a, b in es) / 3.0
    c11, c12, c44 = mean(diag), mean(off), mean(shear)
    dev = lambda es, v: max(abs(s[a][b] - v) for a, b in es)
    zero_terms = [(a, b) for a in range(6) for b in range(a + 1, 6) if (a < 3) != (b < 3) or a >= 3]
    return {"C11": c11, "C12": c12, "C44": c44,
            "zener": 2.0 * c44 / (c11 - c12) if c11 != c12 else float("nan"),
            "uncertainty": {"C11": dev(diag, c11), "C12": dev(off, c12), "C44": dev(shear, c44),
                            "zero_terms": sum(abs(s[a][b]) for a, b in zero_terms) / 12.0}}


def transverse_projection(c):
    """Transversely isotropic (about z) least-squares projection of the symmetric part of
    C in the Frobenius norm of the Voigt matrix (as anisobond's TransverseProjection)."""
    s = [[0.5 * (c[a][b] + c[b][a]) for b in range(6)] for a in range(6)]
    a_, b_, d_ = 0.5 * (s[0][0] + s[1][1]), s[0][1], s[5][5]
    total, diff = a_ + b_, (4.0 * (a_ - b_) + 2.0 * d_) / 5.0
    return {"C11": 0.5 * (total + diff), "C33": s[2][2], "C13": 0.5 * (s[0][2] + s[1][2]),
            "C12": 0.5 * (total - diff), "C44": 0.5 * (s[3][3] + s[4][4])}


def yade_version():
    try:
        import yade.config
        return str(yade.config.version)
    except Exception:
        return "unknown"


def tensor_report(result, packing, bonds):
    """The SPEC tensor report (dict) of an element-test result, method "yade"."""
    n = len(packing)
    rep = {"method": "yade", "units": "Pa", "C": result.c, "n_particles": n,
           "n_bonds": len(bonds), "coordination": 2.0 * len(bonds) / n,
           "volume": packing.volume() if getattr(result, "stress_volume", None) is None
           else result.stress_volume}
    if result.c is not None:
        rep["cubic"] = cubic_projection(result.c)
        rep["transverse"] = transverse_projection(result.c)
    rep["yade"] = {
        "version": yade_version(), "dt_s": result.dt, "damping": result.damping,
        "strain": result.strain, "steps": result.steps, "density_kg_m3": result.density,
        "paths": [VOIGT_LABELS[p] for p in result.paths],
        "columns": dict((VOIGT_LABELS[p], result.columns[p][2]) for p in result.paths),
        "wall_time_s": dict((VOIGT_LABELS[p], result.timings[p]) for p in result.paths),
        "lever_arm": "mid-gap",
    }
    return rep


def write_tensor_json(path, result, packing, bonds):
    """Write the SPEC tensor report JSON atomically."""
    _write_atomic(path, json.dumps(tensor_report(result, packing, bonds), indent=2) + "\n")


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------

# --------------------------------------------------------------------------------------
# Platen tests of finite specimens (issue 31 item 5)
# --------------------------------------------------------------------------------------

AXES = "xyz"


class PlatenResult(object):
    """What ``platen_test`` measured: the layers (body ids), gauge length and shortening (m),
    the axial forces on the moved and held layers (N, compression positive), the steps run,
    and the estimated remaining relative change of the force (``remaining``)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def stiffness(self):
        """Platen stiffness F/delta (N/m) of the moved layer."""
        return self.force_top / self.displacement


def end_layers(axis, depth=None, bodies=None):
    """(bottom, top): body ids of the spheres whose centres lie within ``depth`` (m; default
    the mean radius) of the lowest and of the highest centre along ``axis`` (0, 1, 2) -- the
    same rule as ``anisobond specimen --end-layer``. ``bodies`` defaults to the scene's
    spheres."""
    _check_depth(depth)
    if bodies is None:
        bodies = scene_spheres()[0]
    if not bodies:
        raise InputError("no spheres: no end layers")
    if depth is None:
        depth = sum(b.shape.radius for b in bodies) / len(bodies)
    coords = [b.state.pos[axis] for b in bodies]
    lo, hi = min(coords), max(coords)
    bottom = [b.id for b, c in zip(bodies, coords) if c <= lo + depth]
    top = [b.id for b, c in zip(bodies, coords) if c >= hi - depth]
    if set(bottom) & set(top):
        raise InputError("end layers of depth %r m overlap along %s (extent %r m)"
                         % (depth, AXES[axis], hi - lo))
    return bottom, top


def _check_depth(depth):
    """Refuse an end-layer ``depth`` that is not None or a finite number >= 0 (a negative
    one selects no sphere: empty layers, and a gauge length divided by zero)."""
    if depth is not None and not (_is_number(depth) and math.isfinite(depth) and depth >= 0):
        raise InputError("depth must be None (the mean radius) or a finite end-layer depth "
                         ">= 0 m, got %r" % (depth,))


def _is_number(v):
    """True for an int or float that is not a bool."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_platen_settling(tolerance, max_steps):
    """Refuse a settling ``tolerance`` outside (0, 1) (0 or NaN never settles) and a
    ``max_steps`` that is not an integer >= 1 (0 measures nothing: the forces stay NaN)."""
    if not (_is_number(tolerance) and 0 < tolerance < 1):
        raise InputError("tolerance must be a relative change in (0, 1), got %r" % (tolerance,))
    if not (isinstance(max_steps, int) and not isinstance(max_steps, bool) and max_steps >= 1):
        raise InputError("max_steps must be an integer >= 1, got %r" % (max_steps,))


def _remaining(forces):
    """Estimated remaining relative change of the last force of ``forces`` (at least three
    readings a chunk apart): |d2| / (1 - |d2/d1|) / |f|, geometric extrapolation of the last
    two changes; inf (no estimate) when they are not decaying or the force is zero."""
    d1, d2 = forces[-2] - forces[-3], forces[-1] - forces[-2]
    ratio = abs(d2 / d1) if d1 != 0 else 0.0
    if ratio >= 1 or forces[-1] == 0:
        return float("inf")
    return abs(d2) / (1 - ratio) / abs(forces[-1])


def _axial_force(ids, axis):
    from yade import O
    return sum(O.forces.f(i)[axis] for i in ids)


def platen_test(axis=2, depth=None, platens="frictionless", strain=1e-6, ramp_steps=200,
                check_every=500, tolerance=1e-6, max_steps=400000, progress=None):
    """Quasi-static platen test of the current scene (its bonds as they are, its
    NewtonIntegrator's damping): the bottom end layer held, the top one moved towards it by
    ``strain`` x the gauge length (distance between the layers' mean centres) along
    ``axis``, at constant speed over ``ramp_steps`` steps (YADE's shear springs are
    incremental: a layer teleported would strain only the normal springs), then held while
    the specimen relaxes.

    ``frictionless`` blocks only the axial DOF of the layers' spheres (``blockedDOFs``
    ``'z'`` for axis z) and, to remove the rigid motions, the lateral translations of one
    bottom sphere and one lateral translation of the bottom sphere farthest from it;
    ``bonded`` blocks all six DOFs of the layers' spheres -- the boundary conditions of
    ``anisobond specimen --platens``. Runs ``check_every`` steps at a time until the force
    on the moved layer changes by less than ``tolerance`` (relative, geometric extrapolation
    of the last two changes) and both layers carry the same force to ``tolerance``, or
    ``max_steps``. Returns a ``PlatenResult``; ``remaining`` is the estimated remaining
    relative change (the run did not settle when it exceeds ``tolerance``). Compare
    ``stiffness()`` with ``anisobond specimen``'s ``platen_stiffness``. Refused
    (``InputError``, a ``ValueError`` naming the argument): a ``depth`` not None or finite
    >= 0, a ``tolerance`` outside (0, 1), a ``max_steps`` not an integer >= 1."""
    _check_depth(depth)
    _check_platen_settling(tolerance, max_steps)
    from yade import O
    from yade.minieigenHP import Vector3
    if platens not in ("frictionless", "bonded"):
        raise InputError("platens must be frictionless or bonded, got %r" % (platens,))
    if axis not in (0, 1, 2):
        raise InputError("axis must be 0, 1 or 2, got %r" % (axis,))
    if not 0 < strain < 1 or ramp_steps < 1 or check_every < 1:
        raise InputError("need 0 < strain < 1, ramp_steps >= 1, check_every >= 1")
    bottom, top = end_layers(axis, depth)
    pos = lambda i: O.bodies[i].state.pos[axis]
    length = sum(pos(i) for i in top) / len(top) - sum(pos(i) for i in bottom) / len(bottom)
    delta = strain * length
    letter = AXES[axis]
    for i in bottom + top:
        O.bodies[i].state.blockedDOFs = letter if platens == "frictionless" else "xyzXYZ"
        O.bodies[i].state.vel = Vector3.Zero
        O.bodies[i].state.angVel = Vector3.Zero
    if platens == "frictionless":
        # Rigid motions removed by translations only (a blocked spin would leave the
        # specimen's rigid rotation about the axis held by one sphere's bonds: a mode so
        # slow that Cundall damping does not settle it): one bottom sphere's lateral
        # translations, and the farthest bottom sphere from it its translation
        # perpendicular to the line joining them. They carry no force at equilibrium.
        a = O.bodies[bottom[0]].state.pos
        far = max(bottom, key=lambda i: (O.bodies[i].state.pos - a).norm())
        d = O.bodies[far].state.pos - a
        lateral = [k for k in range(3) if k != axis]
        block = lateral[0] if abs(d[lateral[1]]) >= abs(d[lateral[0]]) else lateral[1]
        O.bodies[bottom[0]].state.blockedDOFs = "xyz"
        O.bodies[far].state.blockedDOFs = letter + AXES[block]
    # Only the axial velocity component is set and reset: YADE's shear increment of a step
    # is the relative velocity (the one of the last position update) x dt, so zeroing a
    # free lateral velocity would drop that step's lateral motion from the shear springs.
    for i in top:
        O.bodies[i].state.vel[axis] = -delta / (ramp_steps * O.dt)
    start = O.iter
    O.run(ramp_steps, True)
    for i in top:
        O.bodies[i].state.vel[axis] = 0.0
    forces, remaining = [], float("inf")
    f_top = f_bottom = float("nan")
    while O.iter - start < max_steps:
        O.run(min(check_every, max_steps - (O.iter - start)), True)
        f_top = _axial_force(top, axis)
        f_bottom = -_axial_force(bottom, axis)
        forces.append(f_top)
        if len(forces) >= 3:
            remaining = _remaining(forces)
        if progress is not None:
            progress(O.iter - start, f_top, remaining)
        if remaining <= tolerance and abs(f_top - f_bottom) <= tolerance * abs(f_top):
            break
    return PlatenResult(axis=axis, platens=platens, bottom=bottom, top=top, length=length,
                        displacement=delta, force_top=f_top, force_bottom=f_bottom,
                        steps=O.iter - start, remaining=remaining)


def platen_main(argv=None):
    """Command line of the specimen validation: build the free scene of --packing (``#
    free``) and --bonds, run ``platen_test`` and write its result as JSON to --out."""
    import argparse
    ap = argparse.ArgumentParser(prog="anisobond_yade platen",
                                 description="YADE platen test of a free bonded specimen")
    ap.add_argument("--packing", required=True)
    ap.add_argument("--bonds", required=True)
    ap.add_argument("--out", required=True, help="result JSON file")
    ap.add_argument("--axis", type=int, default=2)
    ap.add_argument("--depth", type=float, default=None)
    ap.add_argument("--platens", default="frictionless")
    ap.add_argument("--strain", type=float, default=1e-6)
    ap.add_argument("--damping", type=float, default=0.8)
    ap.add_argument("--density", type=float, default=2600.0)
    ap.add_argument("--dt", type=float, default=None)
    ap.add_argument("--safety", type=float, default=0.8)
    ap.add_argument("--ramp-steps", type=int, default=200)
    ap.add_argument("--check-every", type=int, default=500)
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.add_argument("--max-steps", type=int, default=400000)
    a = ap.parse_args(argv)
    packing = read_packing(a.packing)
    if packing.cell is not None:
        ap.error("%s: the platen test runs a free specimen (`# free`), not a periodic cell"
                 % a.packing)
    bonds = read_bond_table(a.bonds, len(packing))
    t0 = time.time()
    scene = build_scene(packing, bonds, density=a.density, damping=a.damping, dt=a.dt,
                        safety=a.safety)
    t1 = time.time()
    r = platen_test(axis=a.axis, depth=a.depth, platens=a.platens, strain=a.strain,
                    ramp_steps=a.ramp_steps, check_every=a.check_every,
                    tolerance=a.tolerance, max_steps=a.max_steps)
    t2 = time.time()
    out = {"yade": {"version": yade_version()}, "dt": scene.dt, "damping": a.damping,
           "density": a.density, "axis": r.axis, "platens": r.platens,
           "strain": a.strain, "ramp_steps": a.ramp_steps, "check_every": a.check_every,
           "tolerance": a.tolerance, "bottom": r.bottom, "top": r.top, "length": r.length,
           "displacement": r.displacement, "force_top": r.force_top,
           "force_bottom": r.force_bottom, "stiffness": r.stiffness(), "steps": r.steps,
           "remaining": r.remaining if math.isfinite(r.remaining) else None,
           "build_seconds": t1 - t0, "run_seconds": t2 - t1}
    _write_atomic(a.out, json.dumps(out, indent=1) + "\n")
    print("anisobond_yade platen: %s platens, %d + %d layer spheres, stiffness %r N/m after "
          "%d steps (remaining %.3g) in %.1f s" % (r.platens, len(r.bottom), len(r.top),
                                                   r.stiffness(), r.steps, r.remaining,
                                                   t2 - t1))
    return r


def main(argv=None):
    """Command line: element tests on a packing + bond table, results into --out."""
    import argparse
    ap = argparse.ArgumentParser(prog="anisobond_yade",
                                 description="YADE element tests of an anisobond model")
    ap.add_argument("--packing", required=True)
    ap.add_argument("--bonds", required=True)
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--strain", type=float, default=1e-5)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--damping", type=float, default=0.4)
    ap.add_argument("--density", type=float, default=2600.0)
    ap.add_argument("--dt", type=float, default=None, help="time step (s); default safety*dt_c")
    ap.add_argument("--safety", type=float, default=0.8)
    ap.add_argument("--paths", default="11,22,33,23,13,12")
    ap.add_argument("--history", default="yade-history.csv")
    ap.add_argument("--tensor", default="yade-tensor.json")
    ap.add_argument("--stress-volume", type=float, default=None,
                    help="volume (m^3) the stresses are per, instead of the cell's (a box of "
                         "mixed periodicity: the box as read)")
    ap.add_argument("--grains", default=None,
                    help="grain-id file (a polycrystal): each sphere gets its grain's copy of "
                         "the material, labelled anisobond-grain-G, and colour")
    ap.add_argument("--model", default=None,
                    help="model file: compute the springs with the anisobond Python package "
                         "instead of taking the table's")
    a = ap.parse_args(argv)
    try:
        paths = [VOIGT_LABELS.index(p.strip()) for p in a.paths.split(",") if p.strip()]
    except ValueError:
        ap.error("--paths: expected labels among %s" % ",".join(VOIGT_LABELS))
    if not a.strain > 0 or a.steps < 1 or not 0 <= a.damping < 1 or not a.density > 0:
        ap.error("need strain > 0, steps >= 1, 0 <= damping < 1, density > 0")
    if a.stress_volume is not None and not 0 < a.stress_volume < float("inf"):
        ap.error("--stress-volume: expected a positive volume in m^3, got %r" % a.stress_volume)
    packing = read_packing(a.packing)
    bonds = read_bond_table(a.bonds, len(packing))
    grains = None if a.grains is None else read_grains(a.grains, len(packing))
    manybody = None
    if a.model is not None:
        assign_springs(a.model, packing, bonds)
        print("anisobond_yade: springs of %d bonds computed by the anisobond package %s for %s"
              % (len(bonds), package().__version__, a.model))
        if _model(a.model).has_many_body:
            manybody = a.model
            print("anisobond_yade: the model's [manybody] term runs as a PyRunner engine")
    t0 = time.time()
    res = element_tests(packing, bonds, strain=a.strain, steps=a.steps, damping=a.damping,
                        density=a.density, dt=a.dt, safety=a.safety, paths=paths,
                        stress_volume=a.stress_volume, manybody=manybody, grains=grains)
    wall = time.time() - t0
    write_history_csv(os.path.join(a.out, a.history), res)
    write_tensor_json(os.path.join(a.out, a.tensor), res, packing, bonds)
    print("anisobond_yade: %d particles, %d bonds, dt %.6g s, %d paths x %d steps in %.3f s"
          % (len(packing), len(bonds), res.dt, len(paths), a.steps, wall))
    if res.c is not None:
        print("C (GPa):")
        for row in res.c:
            print("  " + " ".join("%10.4f" % (x * 1e-9) for x in row))
    return res


if __name__ == "__main__" and os.path.basename(sys.argv[0]).startswith("anisobond_yade"):
    main(sys.argv[1:])
