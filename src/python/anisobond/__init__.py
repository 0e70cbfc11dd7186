"""anisobond: bonded-particle DEM models of anisotropic elastic solids.

Per-bond normal and shear stiffness from the bond's orientation (Truszkowska 2018's cubic
spheroids, Šmilauer's cross-anisotropic elliptic scheme, the isotropic baseline) and the
assembly's 6×6 stiffness tensor (mean field, Voigt, Kruyt's local adjustment field, the
exact relaxed tensor, the damped element tests). A thin binding of the Rust library: the
numbers are the ``anisobond`` command's, to the last digit.

Units are SI: m, N, Pa; springs kn, ks in N/m, kr, ktw in N·m/rad. Tensors are (6, 6)
numpy arrays in Pa, Voigt order 11, 22, 33, 23, 13, 12, acting on engineering strain.

>>> import anisobond as ab
>>> model = ab.Model.load("model.toml")                 # doctest: +SKIP
>>> pk = ab.Packing.load("packing.txt")                 # doctest: +SKIP
>>> asm = ab.Assembly(pk, model)                        # doctest: +SKIP
>>> C = asm.tensor("relaxed")                           # doctest: +SKIP

Errors are exceptions of this package, subclasses of ``ValueError``: ``InputError`` (a file,
array or option; the message names which and what was expected), ``ModelError`` (a model
that is not admissible), ``DegenerateError`` (no bonds, a tensor that is zero or a
mechanism), ``NotConvergedError`` (an iteration limit reached before the tolerance),
``FileError`` (a file that cannot be read or written), ``EngineError`` (YADE, LIGGGHTS or
LAMMPS could not be started or failed) and ``ValidationError`` (a comparison with another
code outside its tolerance).
"""

from ._anisobond import (
    AnisobondError,
    Assembly,
    DegenerateError,
    EngineError,
    FileError,
    InputError,
    ManyBody,
    Model,
    ModelError,
    NotConvergedError,
    Packing,
    ValidationError,
    __version__,
    buckle_bar,
    calibrate_model as _calibrate_model,
    calibrate_strength_model as calibrate_strength,
    engineering_constants,
    polycrystal,
    strength_sweep,
    strength_test,
    validate,
)

__all__ = [
    "AnisobondError",
    "Assembly",
    "DegenerateError",
    "EngineError",
    "FileError",
    "InputError",
    "ManyBody",
    "Model",
    "ModelError",
    "NotConvergedError",
    "Packing",
    "ValidationError",
    "__version__",
    "buckle_bar",
    "calibrate",
    "calibrate_strength",
    "engineering_constants",
    "polycrystal",
    "strength_sweep",
    "strength_test",
    "validate",
]


def calibrate(model, target, on="mean-field", *, details=False, **options):
    """Scheme parameters of ``model`` that reproduce a target stiffness tensor.

    Parameters
    ----------
    model : Model
        The base model: its scheme kind, geometry and bonding rule are kept, its scheme
        parameters replaced.
    target : dict or str
        ``{"C12/C11": 0.30, "C44/C11": 0.43}`` (cubic ratios), ``{"C11": 1.5e11, "C12": …,
        "C44": …}`` (cubic, Pa), ``{"C11": …, "C33": …, "C13": …, "C12": …}``
        (cross-anisotropic, Pa), or the command line's text ``"C11=150 GPa,C12=…"``.
    on : "mean-field", Packing or Assembly
        ``"mean-field"``: the orientation integral at the bond density of equal spheres
        (options ``coordination`` Z, ``solid_fraction`` φ, ``radius`` R in m); a Packing
        (bonded by ``model``'s rule) or an Assembly: the exact relaxed tensor of its bonds.
    details : bool
        Also return a dict of what was achieved (C11, C12, C44 in Pa, a_n, a_s, iterations).
    **options
        ``family`` ("nearest", "equi", "prolate", "oblate"; Truszkowska 2018 Sec. 6.3),
        ``cubic_model`` ("auto", "zener-above-1", "zener-below-1"), ``extended`` (the <110>
        models, Sec. 6.1), ``tolerance`` (relative, relaxed level, default 5e-4),
        ``max_iterations`` (relaxed solves, default 30), ``coordination`` (default 7.7),
        ``solid_fraction`` (0.6), ``radius`` (1e-3 m).

    Returns
    -------
    Model, or (Model, dict) with ``details=True``.
    """
    new, info = _calibrate_model(model, target, on, **options)
    if new.kind != model.kind:
        import warnings

        warnings.warn(
            f"the base model's scheme is {model.kind}; the target needs the {new.kind} "
            f"scheme, so the calibrated model is {new.kind}",
            stacklevel=2,
        )
    return (new, info) if details else new
