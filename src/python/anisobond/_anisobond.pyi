# Type stubs of the compiled part of anisobond (src/python/mod.rs). Units: m, N, Pa;
# springs kn, ks in N/m, kr, ktw in N·m/rad; tensors (6, 6) in Pa, Voigt order 11 22 33 23 13 12.
from os import PathLike
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from typing_extensions import TypedDict, Unpack

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike]
_Floats = npt.ArrayLike
_Progress = Optional[Callable[[float], Any]]

class TensorOptions(TypedDict, total=False):
    """Keyword options of Assembly.tensor / tensor_report (defaults in brackets)."""

    shell: int  # LAF shell order 1-6 [2]
    energy: bool  # LAF energy (upper-bound) form [False]
    lever_arm: str  # "mid-gap" | "proportional" | "half-length" ["mid-gap"]
    tolerance: float  # relaxed: relative CG residual [1e-6]
    solver: str  # relaxed: "cg" | "cg-jacobi" | "cg-amg" | "cholesky" ["cg"]
    law: str  # dynamic: "yade" | "parallel-bond" | "kumar" | "lammps-bpm" ["yade"]
    strain: float  # dynamic: strain per path [1e-5]
    damping: float  # dynamic: Cundall damping [0.4]
    max_steps: int  # dynamic: step limit per path [20000]
    prestress: float  # prestressed: compressive preload, Pa [0]
    progress: _Progress  # dynamic: callable(fraction) [None]

class LabOptions(TypedDict, total=False):
    """The virtual laboratory's keywords of strength_test, strength_sweep and
    calibrate_strength_model: the ``strength-test`` flags (None or left out: the default)."""

    width_particles: Optional[float]  # prism width / cylinder or disc diameter, in mean radii [16]
    aspect: Optional[float]  # length / width (disc: thickness / diameter) [the test's own]
    end_layer: Optional[float]  # glued end layers' depth, in mean radii [1]
    loading_rate: Optional[float]  # axial strain per wave transit time, at most [1e-6]
    max_strain: Optional[float]  # the run ends at this axial strain [0.005]
    stop_fraction: Optional[float]  # ... or once the stress fell below this fraction of its peak [0.5]
    peak_drop: Optional[float]  # the first peak ends where the stress falls by this fraction [0.05]
    local_damping: Optional[float]  # Cundall local damping [0.1]
    cell_particles: Optional[int]  # spheres of the generated packing (packing None) [1000]
    seed: Optional[int]  # seed of the generated packing [1]
    points: Optional[int]  # recorded points of the curve [1000]

__version__: str

class AnisobondError(ValueError): ...
class InputError(AnisobondError): ...
class ModelError(AnisobondError): ...
class FileError(AnisobondError): ...
class DegenerateError(AnisobondError): ...
class NotConvergedError(AnisobondError): ...
class EngineError(AnisobondError): ...
class ValidationError(AnisobondError): ...

class Model:
    """Bonding rule, stiffness scheme and geometry (a model file)."""
    @staticmethod
    def load(path: _Path) -> "Model": ...
    @staticmethod
    def from_toml(text: str, name: str = "<toml>") -> "Model": ...
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> "Model": ...
    @staticmethod
    def truszkowska_mrv() -> "Model": ...
    @property
    def kind(self) -> str:
        """'cubic', 'isotropic' or 'cross-anisotropic'."""
    def to_toml(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def save(self, path: _Path) -> None: ...
    def springs(
        self,
        normals: _Floats,
        r_i: _Floats,
        r_j: _Floats,
        lengths: _Floats,
        lattice_scaling: Optional[float] = None,
    ) -> Dict[str, np.ndarray]:
        """normals (N, 3) unit; r_i, r_j, lengths (N,) in m -> kn, ks (N/m), kr, ktw (N·m/rad), radius (m)."""
    @property
    def has_many_body(self) -> bool:
        """True when the model has a [manybody] table (docs/manybody.md)."""
    @property
    def has_strength(self) -> bool:
        """True when the model has a [strength] table (docs/strength.md)."""
    def yade_adhesions(
        self, starts: _Floats, branches: _Floats, r_i: _Floats, r_j: _Floats
    ) -> Optional[Dict[str, np.ndarray]]:
        """starts, branches (N, 3) in m; r_i, r_j (N,) in m -> normal_adhesion, shear_adhesion (N),
        tan_friction, joint (plane family or -1): YADE CohFrictPhys limits; None without [strength]."""

class Packing:
    """Spheres in a periodic cell (cell=(Lx, Ly, Lz) in m) or a free cluster (cell=None)."""
    def __init__(
        self,
        positions: _Floats,
        radii: _Floats,
        cell: Optional[Sequence[float]] = None,
        ids: Optional[Sequence[int]] = None,
    ) -> None: ...
    @staticmethod
    def load(
        path: _Path,
        *,
        cell: Optional[Tuple[float, float, float]] = None,
        periodic: bool = False,
        free: bool = False,
    ) -> "Packing":
        """Any format the CLI reads; cell/periodic/free for files that state no cell."""
    def save(self, path: _Path) -> None: ...
    @property
    def ids(self) -> Optional[np.ndarray]:
        """(N,) particle ids (LIGGGHTS atom ids, YADE body ids), or None."""
    @property
    def positions(self) -> np.ndarray:
        """(N, 3), m."""
    @property
    def radii(self) -> np.ndarray:
        """(N,), m."""
    @property
    def cell(self) -> Optional[Tuple[float, float, float]]: ...
    @property
    def volume(self) -> float:
        """m³."""
    @property
    def solid_fraction(self) -> float: ...
    def __len__(self) -> int: ...

class ManyBody:
    """The many-body term of an assembly (docs/manybody.md), its reference the assembly's packing."""
    def evaluate(
        self, positions: _Floats, cell_gradient: Optional[_Floats] = None
    ) -> Dict[str, Any]:
        """energy (J), forces ((N, 3) N, -dU/dx) and nominal stress ((3, 3) Pa) at positions (m)."""
    @property
    def tensor(self) -> np.ndarray:
        """D, (6, 6) Pa, lab frame."""
    @property
    def volume_fraction(self) -> float: ...
    @property
    def excluded(self) -> List[int]: ...
    def __len__(self) -> int: ...

class Assembly:
    """A packing bonded by a model: bonds and every bond's springs."""
    def __init__(self, packing: Packing, model: Model) -> None: ...
    @staticmethod
    def from_bonds(
        packing: Packing,
        model: Model,
        i: _Floats,
        j: _Floats,
        image: Optional[_Floats] = None,
    ) -> "Assembly": ...
    @property
    def bonds(self) -> Dict[str, np.ndarray]:
        """i, j, normal (Nb, 3), length, radius, kn, ks, kr, ktw, image (Nb, 3)."""
    @property
    def grains(self) -> Optional[Dict[str, Optional[np.ndarray]]]:
        """The grains of a model with [grains] (docs/polycrystal.md): grain (N,) uint32 per
        particle, orientation (G, 3, 3) Bunge matrices (sample -> crystal), centres (G, 3) m
        or None (a grain file's map); None for a single crystal."""
    @property
    def packing(self) -> Packing: ...
    @property
    def model(self) -> Model: ...
    @property
    def n_bonds(self) -> int: ...
    @property
    def n_particles(self) -> int: ...
    @property
    def coordination(self) -> float: ...
    @property
    def lattice_scaling(self) -> float: ...
    def many_body(self) -> "ManyBody":
        """The many-body term of the model's [manybody] table on these bonds (ModelError without one)."""
    def tensor(
        self,
        method: str = "relaxed",
        **options: Unpack[TensorOptions],
    ) -> np.ndarray:
        """(6, 6) stiffness in Pa: 'mean-field', 'voigt', 'relaxed', 'prestressed', 'laf' or 'dynamic'."""
    def tensor_report(
        self,
        method: str = "relaxed",
        **options: Unpack[TensorOptions],
    ) -> Dict[str, Any]: ...
    def write_bonds(self, path: _Path) -> None: ...
    def export_yade(
        self,
        directory: _Path,
        *,
        strain: float = 1e-5,
        steps: int = 200,
        damping: float = 0.4,
        density: float = 2600.0,
        time_step: Optional[float] = None,
        safety: float = 0.8,
        paths: str = "11,22,33,23,13,12",
    ) -> None: ...
    def export_liggghts(self, directory: _Path, *, shear: bool = True) -> None: ...
    def export_vtk(self, directory: _Path, *, strain: Optional[_Floats] = None) -> None:
        """particles.vtu, bonds.vtu; strain: 6 Voigt components (|e| <= 0.1), periodic only."""
    def specimen(
        self,
        axis: Optional[str] = None,
        *,
        end_layer: Optional[float] = None,
        platens: str = "frictionless",
        strain: Optional[float] = None,
        displacement: Optional[float] = None,
        force: Optional[float] = None,
        held: Optional[str] = None,
        moved: Optional[str] = None,
        confining_pressure: Optional[float] = None,
        shape: str = "prism",
        lateral: Optional[str] = None,
    ) -> Dict[str, Any]:
        """The assembly as a finite specimen between platens (docs/specimens.md; axis and
        lateral default as the command's: a slab as read along its free axis, laterally
        periodic; otherwise "z", "free"): the keys
        of specimen.json (platen_stiffness N/m, young Pa, poisson, …), "displacement" (N, 3)
        m and "layer" (N,) 0 none / 1 held / 2 moved."""
    def cavity(
        self,
        hole_radius: Optional[float] = None,
        *,
        outer_radius: Optional[float] = None,
        pressure: Optional[float] = None,
        clamp_width: Optional[float] = None,
        ray_spacing: Optional[float] = None,
        density: Optional[float] = None,
    ) -> Dict[str, Any]:
        """The pressurised cavity (docs/cavity.md): the keys of cavity.json (wall
        displacement (m) beside Lamé, `continuum` with its wall bins, Christoffel speeds at
        `density`), positions and displacement arrays (m). None: the library's defaults
        (pressure 1e6 Pa, density 2600 kg/m³)."""

def calibrate_model(
    model: Model, target: Union[str, Mapping[str, float]], on: Any = None, **options: Any
) -> Tuple[Model, Dict[str, Any]]: ...
def buckle_bar(
    packing: Packing,
    model: Model,
    radius: float,
    slenderness: float,
    *,
    clamp_depth: Optional[float] = None,
    deformed: bool = True,
    tolerance: Optional[float] = None,
) -> Dict[str, Any]:
    """Kumar 2016's clamped round bar (docs/buckling.md): a row of buckling.json
    (modulus_pa, sigma_network_pa, sigma_euler_pa, sigma_mazzilli_pa, sigma_deformed_pa,
    shear_stiffness_n, network with EI, …) and the first mode. tolerance None: 1e-6."""
def polycrystal(
    packing: Packing,
    model: Model,
    *,
    strain: float = 1e-4,
    load_axis: str = "x",
    grain_counts: Optional[Sequence[int]] = None,
) -> Dict[str, Any]:
    """The polycrystal study (docs/polycrystal.md), as `anisobond polycrystal`: model needs
    a [grains] table. polycrystal.json as a dict: tensor_pa, bulk_pa, shear_pa, anisotropy
    beside the single crystal's tensor and its Voigt/Reuss/Hill/Hashin-Shtrikman/
    self-consistent estimates (single_crystal), grains (per grain: bunge_deg,
    longitudinal_modulus_pa, mean_stress_pa, ...) under the uniaxial strain along load_axis
    ("x", "y", "z"), and series (one row per grain count of grain_counts)."""
def strength_test(
    test: str = "ucs",
    *,
    packing: Optional[Packing] = None,
    model: Optional[Model] = None,
    law: str = "yade",
    shape: str = "prism",
    bedding_deg: Optional[float] = None,
    **lab: Unpack[LabOptions],
) -> Dict[str, Any]:
    """The virtual laboratory (docs/strength-test.md), as ``anisobond strength-test``:
    "ucs", "tension" or "brazilian" on a specimen cut from ``packing`` (None: generated)
    bonded by ``model`` (None: the command's default), turned by ``bedding_deg`` about y.
    strength_test.json's dict (peak_stress_pa: the first peak, strain_at_peak,
    peak_dropped, max_stress_pa: the whole curve's largest, modulus_pa, poisson,
    cracks, broken_fraction, …) plus the curve as arrays: strain, stress_pa,
    lateral_strain (NaN where not measured), broken."""
def strength_sweep(
    angles_deg: Optional[Sequence[float]] = None,
    *,
    packing: Optional[Packing] = None,
    model: Optional[Model] = None,
    law: str = "yade",
    shape: str = "prism",
    **lab: Unpack[LabOptions],
) -> Dict[str, Any]:
    """The bedding sweep (docs/strength-test.md), as ``anisobond strength-test
    --bedding-sweep``: UCS and Brazilian disc at each angle (None: 0, 15, ..., 90).
    strength_sweep.json's dict: reference_deg, specimen sizes, rows (bedding_deg, ucs_pa,
    modulus_pa, poisson, brazilian_pa, ucs_cracks, brazilian_cracks, ucs_ratio,
    brazilian_ratio, ...)."""
def calibrate_strength_model(
    model: Model,
    target: str,
    *,
    packing: Optional[Packing] = None,
    law: str = "yade",
    shape: str = "prism",
    bedding_deg: Optional[float] = None,
    tolerance: Optional[float] = None,
    max_iterations: Optional[int] = None,
    **lab: Unpack[LabOptions],
) -> Tuple[Model, Dict[str, Any]]:
    """Strength calibration (docs/calibrate-strength.md), as ``anisobond
    calibrate-strength`` (re-exported as ``anisobond.calibrate_strength``): the
    [strength] table's scale(s) that make the virtual laboratory reach ``target``
    ("tension=2MPa", "ucs=50MPa", "tension-along=1MPa,tension-across=3MPa") on
    specimens cut from ``packing``. Returns the calibrated Model and the report
    (fitted_scale, fitted_strength; measured_peak_pa from the verification run of the
    calibrated model; iterations, runs, history)."""
def engineering_constants(stiffness: _Floats) -> Dict[str, float]:
    """E1, E2, E3, G23, G13, G12 (Pa) and nu_ij of a (6, 6) tensor in Pa."""
def validate(
    engine: str,
    assembly: Assembly,
    directory: Optional[_Path] = None,
    *,
    check: bool = True,
    density: Optional[float] = None,
    time_step: Optional[float] = None,
    strain: Optional[float] = None,
    processes: Optional[int] = None,
    program: Optional[_Path] = None,
    driver: Optional[_Path] = None,
    tolerances: Optional[Mapping[str, float]] = None,
) -> Dict[str, Any]:
    """The periodic element tests of ``assembly`` in ``engine`` ("yade", "liggghts" or
    "lammps") and in anisobond, compared (``anisobond validate ENGINE``): the report.json
    dict (passed, checks, …); the run's files kept in ``directory`` if given. Raises
    EngineError (the program failed), ValidationError (a check outside its tolerance) and
    NotConvergedError (a compared run not settled); ``check=False`` returns the report
    instead of raising the last two. ``tolerances``: {"history", "tensor", "relaxed",
    "processes": relative agreement} replacing the engine's defaults."""
