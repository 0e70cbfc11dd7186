//! The Python package `anisobond` (feature `python`): a thin pyo3 binding of the library's
//! one pipeline ([`crate::Assembly`], [`crate::Model`], [`crate::calibrate::calibrate`]).
//! numpy arrays in and out; long calls release the GIL; library errors become exceptions of
//! the package (`InputError`, `ModelError`, … subclasses of `ValueError`) with the library's
//! message. The pure-Python part (`src/python/anisobond/`) re-exports it with docs and stubs.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

use crate::assembly::{Assembly, EqualSpheres, Method, MethodKind, MethodOptions};
use crate::bonds::stiffness::{check_bond_columns, springs_along};
use crate::calibrate::cubic::{CubicOptions, Family};
use crate::calibrate::target::Target;
use crate::calibrate::{calibrate, CalibrateOn, Calibration};
use crate::dem::element::ElementTestOptions;
use crate::dem::LawKind;
use crate::homogenize::network::LeverArm;
use crate::homogenize::relaxed::{CgPreconditioner, RelaxedOptions, RelaxedSolver};
use crate::homogenize::report::TensorReport;
use crate::io::OutputSet;
use crate::model::Model;
use crate::packing::{Packing, PeriodicCell};
use crate::schemes::StiffnessScheme;
use crate::tensor::elastic::EngineeringConstants;
use crate::tensor::Stiffness6;
use crate::{Error, Vec3};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

create_exception!(
    anisobond,
    AnisobondError,
    PyValueError,
    "Base class of every error anisobond raises: the input is wrong or the result would be."
);
create_exception!(
    anisobond,
    InputError,
    AnisobondError,
    "An input file, array or option is wrong; the message names which and what was expected."
);
create_exception!(
    anisobond,
    ModelError,
    AnisobondError,
    "A model (scheme parameters, geometry, bonding rule) is not admissible."
);
create_exception!(
    anisobond,
    DegenerateError,
    AnisobondError,
    "The inputs are admissible, but what they give is not a result: no bonds, a tensor that is zero or a mechanism, a run that blows up."
);
create_exception!(
    anisobond,
    NotConvergedError,
    AnisobondError,
    "An iterative computation (relaxed solver, element tests, calibration) reached its limit before its tolerance."
);
create_exception!(
    anisobond,
    FileError,
    AnisobondError,
    "A file could not be read or written (the message names it)."
);

create_exception!(
    anisobond,
    EngineError,
    AnisobondError,
    "An external program (YADE, LIGGGHTS, LAMMPS) could not be started, failed or wrote no usable result."
);
create_exception!(
    anisobond,
    ValidationError,
    AnisobondError,
    "A validation against another code ran, and some comparison lies outside its tolerance."
);

/// The package's exception for a library error, with the library's message.
fn to_py(e: Error) -> PyErr {
    let e = e.with_user_paths();
    let message = e.to_string();
    match e {
        Error::Model(_) => ModelError::new_err(message),
        Error::Io { .. } => FileError::new_err(message),
        Error::Parse { .. } | Error::Invalid(_) => InputError::new_err(message),
        Error::Degenerate(_) => DegenerateError::new_err(message),
        Error::NotConverged(_) => NotConvergedError::new_err(message),
        Error::EngineFailed { .. } => EngineError::new_err(message),
        Error::OutOfTolerance { .. } => ValidationError::new_err(message),
    }
}

type PyResultOf<T> = PyResult<T>;

/// `obj` as a C-contiguous float64 ndarray of `ndim` dimensions (no copy when it is one
/// already); booleans, complex numbers, strings and objects are refused by name.
fn float_array<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    name: &str,
    ndim: usize,
) -> PyResultOf<Bound<'py, PyAny>> {
    let np = py.import("numpy")?;
    let arr = np.call_method1("asarray", (obj,)).map_err(|e| {
        PyTypeError::new_err(format!("{name}: expected an array of real numbers ({e})"))
    })?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "i" | "u" | "f") {
        let dtype = arr.getattr("dtype")?.str()?.to_string();
        return Err(PyTypeError::new_err(format!(
            "{name}: expected real numbers (integer or float dtype), got dtype {dtype}"
        )));
    }
    let got: usize = arr.getattr("ndim")?.extract()?;
    if got != ndim {
        let shape = arr.getattr("shape")?.str()?.to_string();
        return Err(InputError::new_err(format!(
            "{name}: expected a {ndim}-D array, got shape {shape}"
        )));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float64")?)?;
    np.call_method("ascontiguousarray", (arr,), Some(&kwargs))
}

/// A column of `n` finite floats (m, Pa, …).
fn column(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: Option<usize>,
) -> PyResult<Vec<f64>> {
    let arr = float_array(py, obj, name, 1)?;
    let arr: PyReadonlyArray1<f64> = arr.extract()?;
    let v = arr.as_slice()?.to_vec();
    if let Some(n) = n {
        if v.len() != n {
            return Err(InputError::new_err(format!(
                "{name}: expected {n} values (one per row of the first argument), got {}",
                v.len()
            )));
        }
    }
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(InputError::new_err(format!(
            "{name}[{k}] = {} is not finite",
            v[k]
        )));
    }
    Ok(v)
}

/// Rows of 3 finite floats, shape (N, 3).
fn rows3(py: Python<'_>, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec3>> {
    let arr = float_array(py, obj, name, 2)?;
    let arr: PyReadonlyArray2<f64> = arr.extract()?;
    let shape = arr.shape().to_vec();
    if shape[1] != 3 {
        return Err(InputError::new_err(format!(
            "{name}: expected shape (N, 3), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    let flat = arr.as_slice()?;
    if let Some(k) = flat.iter().position(|x| !x.is_finite()) {
        return Err(InputError::new_err(format!(
            "{name}[{}, {}] = {} is not finite",
            k / 3,
            k % 3,
            flat[k]
        )));
    }
    Ok(flat
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect())
}

/// An (N, 3) float64 array of vectors.
fn vec3_array<'py>(py: Python<'py>, v: &[Vec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = v.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    PyArray1::from_vec(py, flat).reshape([v.len(), 3])
}

/// A (6, 6) float64 array of a Voigt tensor (Pa).
fn tensor_array<'py>(py: Python<'py>, c: &[[f64; 6]; 6]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = c.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([6, 6])
}

/// A (6, 6) float64 tensor from Python (Pa), finite.
fn tensor_from(py: Python<'_>, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Stiffness6> {
    let arr = float_array(py, obj, name, 2)?;
    let arr: PyReadonlyArray2<f64> = arr.extract()?;
    if arr.shape() != [6, 6] {
        return Err(InputError::new_err(format!(
            "{name}: expected a (6, 6) Voigt tensor in Pa, got shape {:?}",
            arr.shape()
        )));
    }
    let flat = arr.as_slice()?;
    if flat.iter().any(|x| !x.is_finite()) {
        return Err(InputError::new_err(format!("{name}: not finite")));
    }
    Ok(Stiffness6::from_fn(|i, j| flat[6 * i + j]))
}

/// A JSON text as Python objects (dicts, lists, floats).
fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// Write a file or a directory atomically through an output set: `plan` stages `path`
/// ([`OutputSet::file`]: a file in a folder that exists; [`OutputSet::dir`]: a directory),
/// `write` fills the staging path, and only a successful write replaces `path` (nothing is
/// left behind otherwise).
fn write_staged(
    path: PathBuf,
    plan: fn(&mut OutputSet, &std::path::Path) -> crate::Result<PathBuf>,
    write: impl FnOnce(&std::path::Path) -> crate::Result<()>,
) -> PyResult<()> {
    let mut out = OutputSet::new(&[]);
    let staged = plan(&mut out, &path).map_err(to_py)?;
    write(&staged).map_err(to_py)?;
    out.commit().map_err(to_py)
}

/// A bond stiffness model: the model file's bonding rule, stiffness scheme and geometry.
///
/// Make one with Model.load(path) (TOML, or JSON by extension), Model.from_toml(text),
/// Model.from_dict({...}) or Model.truszkowska_mrv(); docs/formats.md has the keys.
#[pyclass(name = "Model", module = "anisobond", frozen)]
#[derive(Clone)]
pub struct PyModel {
    inner: Model,
    /// The scheme, built (and checked, which scans the sphere) once; None when it needs a
    /// lattice scaling μ (cross-anisotropic).
    scheme: Option<Arc<dyn StiffnessScheme>>,
}

impl PyModel {
    fn wrap(inner: Model) -> PyResult<Self> {
        let scheme = if inner.needs_packing() {
            None
        } else {
            Some(Arc::from(inner.build_scheme(None).map_err(to_py)?))
        };
        Ok(PyModel { inner, scheme })
    }
}

#[pymethods]
impl PyModel {
    /// Read a model file (TOML, or JSON by extension `.json`).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        PyModel::wrap(Model::from_path(&path).map_err(to_py)?)
    }

    /// Parse a TOML model text; `name` appears in error messages.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<toml>"))]
    fn from_toml(text: &str, name: &str) -> PyResult<Self> {
        PyModel::wrap(Model::from_toml_str(text, name).map_err(to_py)?)
    }

    /// A model from a dict with the model file's tables (`bonding`, `scheme`, `geometry`).
    #[staticmethod]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyAny>) -> PyResult<Self> {
        let text: String = py
            .import("json")?
            .call_method1("dumps", (d,))
            .map_err(|e| InputError::new_err(format!("model dict: not JSON-serialisable ({e})")))?
            .extract()?;
        PyModel::wrap(Model::from_json_str(&text, "<dict>").map_err(to_py)?)
    }

    /// Truszkowska 2018's MRV model (Sec. 5.1), the default of `anisobond demo`.
    #[staticmethod]
    fn truszkowska_mrv() -> PyResult<Self> {
        PyModel::wrap(Model::truszkowska_mrv())
    }

    /// The model file text (TOML), as `anisobond calibrate` writes it.
    fn to_toml(&self) -> String {
        self.inner.to_toml_string()
    }

    /// The model as a dict of its tables.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("tomllib")
            .and_then(|t| t.call_method1("loads", (self.inner.to_toml_string(),)))
            .or_else(|_| {
                let text = serde_json::to_string(
                    &toml::from_str::<toml::Value>(&self.inner.to_toml_string())
                        .map_err(|e| InputError::new_err(e.to_string()))?,
                )
                .map_err(|e| InputError::new_err(e.to_string()))?;
                json_to_py(py, &text)
            })
    }

    /// Write the model file atomically: JSON when `path` ends in `.json`, TOML otherwise.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let text = self.inner.to_string_for(&path);
        write_staged(path, OutputSet::file, |p| {
            crate::io::write_string_atomic(p, &text)
        })
    }

    /// The scheme kind: `cubic`, `isotropic` or `cross-anisotropic`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.inner.scheme.kind_name()
    }

    /// Springs of arbitrary bonds, exactly as an Assembly assigns them.
    ///
    /// normals: (N, 3) unit bond normals, lab frame (|n| = 1 within 1e-9).
    /// r_i, r_j: (N,) sphere radii at the two ends, m.
    /// lengths: (N,) centre distances, m.
    /// lattice_scaling: Šmilauer's μ (cross-anisotropic models only; `Assembly.lattice_scaling`).
    /// Returns a dict of (N,) arrays: kn, ks (N/m), kr, ktw (N·m/rad), radius (bond radius, m).
    #[pyo3(signature = (normals, r_i, r_j, lengths, lattice_scaling = None))]
    fn springs<'py>(
        &self,
        py: Python<'py>,
        normals: &Bound<'py, PyAny>,
        r_i: &Bound<'py, PyAny>,
        r_j: &Bound<'py, PyAny>,
        lengths: &Bound<'py, PyAny>,
        lattice_scaling: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = rows3(py, normals, "normals")?;
        let ri = column(py, r_i, "r_i", Some(n.len()))?;
        let rj = column(py, r_j, "r_j", Some(n.len()))?;
        let l = column(py, lengths, "lengths", Some(n.len()))?;
        let (model, cached) = (&self.inner, &self.scheme);
        let k = py
            .detach(|| match (cached, lattice_scaling) {
                (Some(scheme), _) => {
                    check_bond_columns(&n, &ri, &rj, &l)?;
                    springs_along(scheme.as_ref(), &model.geometry, &n, &ri, &rj, &l, &|b| {
                        format!("bond {b}")
                    })
                }
                _ => model.springs_for(&n, &ri, &rj, &l, lattice_scaling),
            })
            .map_err(to_py)?;
        let d = PyDict::new(py);
        d.set_item("kn", PyArray1::from_vec(py, k.kn))?;
        d.set_item("ks", PyArray1::from_vec(py, k.ks))?;
        d.set_item("kr", PyArray1::from_vec(py, k.kr))?;
        d.set_item("ktw", PyArray1::from_vec(py, k.ktw))?;
        d.set_item("radius", PyArray1::from_vec(py, k.radius))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "anisobond.Model.from_toml('''\n{}''')",
            self.inner.to_toml_string()
        )
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner.to_toml_string() == other.inner.to_toml_string()
    }
}

/// Spheres in a periodic cell or as a free cluster.
///
/// Packing(positions, radii, cell=None, ids=None): positions (N, 3) in m, radii (N,) in m
/// (> 0), cell (Lx, Ly, Lz) in m or None for a free cluster, ids N distinct integers (e.g.
/// LIGGGHTS atom ids; bond tables then carry id_i, id_j). Positions are wrapped into the cell;
/// periodic images (from_bonds, bond tables) are of the positions as given (YADE's cellDist
/// with its body positions, also outside the cell).
/// Packing.load(path, cell=None, periodic=False, free=False) reads every format the command
/// line reads (docs/formats.md).
#[pyclass(name = "Packing", module = "anisobond", frozen)]
#[derive(Clone)]
pub struct PyPacking {
    inner: Packing,
}

#[pymethods]
impl PyPacking {
    #[new]
    #[pyo3(signature = (positions, radii, cell = None, ids = None))]
    fn new(
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        radii: &Bound<'_, PyAny>,
        cell: Option<&Bound<'_, PyAny>>,
        ids: Option<Vec<u64>>,
    ) -> PyResult<Self> {
        let p = rows3(py, positions, "positions")?;
        let r = column(py, radii, "radii", Some(p.len()))?;
        let cell = match cell {
            None => None,
            Some(c) if c.is_none() => None,
            Some(c) => {
                let l = column(py, c, "cell", Some(3))?;
                Some(PeriodicCell::new(Vec3::new(l[0], l[1], l[2])).map_err(to_py)?)
            }
        };
        let mut inner = Packing::new(p, r, cell).map_err(to_py)?;
        if let Some(ids) = ids {
            inner = inner.with_ids(ids).map_err(to_py)?;
        }
        Ok(PyPacking { inner })
    }

    /// Read a packing file: every format the command line reads (docs/formats.md).
    ///
    /// For a file that does not state its cell (YADE export.text, plain text, LIGGGHTS data):
    /// cell=(Lx, Ly, Lz) makes it periodic with that cell (m), periodic=True takes a
    /// LIGGGHTS box as the periodic cell, free=True makes it a free cluster. Without them
    /// the reader's default is used and a UserWarning says what was assumed.
    #[staticmethod]
    #[pyo3(signature = (path, *, cell = None, periodic = false, free = false))]
    fn load(
        py: Python<'_>,
        path: PathBuf,
        cell: Option<(f64, f64, f64)>,
        periodic: bool,
        free: bool,
    ) -> PyResult<Self> {
        use crate::packing::io::{read_packing_as, CellChoice, CellOptionNames, CellOrigin};
        let choice =
            match (cell, periodic, free) {
                (None, false, false) => CellChoice::AsStated,
                (Some((x, y, z)), false, false) => CellChoice::Cell(Vec3::new(x, y, z)),
                (None, true, false) => CellChoice::Periodic,
                (None, false, true) => CellChoice::Free,
                _ => return Err(InputError::new_err(
                    "Packing.load: give at most one of cell=(Lx, Ly, Lz), periodic=True, free=True",
                )),
            };
        if let CellChoice::Cell(l) = choice {
            PeriodicCell::new(l).map_err(to_py)?;
        }
        let read = py
            .detach(|| read_packing_as(&path, choice))
            .map_err(to_py)?;
        if read.origin == CellOrigin::Assumed {
            let names = CellOptionNames {
                cell: "cell=(Lx, Ly, Lz)",
                periodic: "periodic=True",
                free: "free=True",
            };
            if let Some(note) = read.cell_note(&path.display().to_string(), names) {
                let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
                PyErr::warn(py, &category, &std::ffi::CString::new(note)?, 1)?;
            }
        }
        Ok(PyPacking {
            inner: read.packing,
        })
    }

    /// Particle ids from the file (LIGGGHTS atom ids, YADE body ids) or the constructor,
    /// shape (N,), or None when the particles are known by their index only.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<u64>>> {
        self.inner
            .ids
            .as_ref()
            .map(|ids| PyArray1::from_slice(py, ids))
    }

    /// Write the packing as anisobond's text format (`# periodic Lx Ly Lz`, `x y z r`).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        write_staged(path, OutputSet::file, |p| {
            crate::packing::io::write_packing(p, &self.inner)
        })
    }

    /// Centres, shape (N, 3), m (wrapped into the cell when periodic).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        vec3_array(py, &self.inner.positions)
    }

    /// Radii, shape (N,), m.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.radii)
    }

    /// Cell lengths (Lx, Ly, Lz) in m, or None for a free cluster.
    #[getter]
    fn cell(&self) -> Option<(f64, f64, f64)> {
        self.inner
            .cell
            .map(|c| (c.lengths.x, c.lengths.y, c.lengths.z))
    }

    /// Volume (m³): the cell's, or the bounding box's of a free cluster.
    #[getter]
    fn volume(&self) -> f64 {
        self.inner.volume()
    }

    /// Solid fraction φ (sphere volume over [`Self::volume`]).
    #[getter]
    fn solid_fraction(&self) -> f64 {
        self.inner.solid_fraction()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        match self.inner.cell {
            Some(c) => format!(
                "<anisobond.Packing: {} spheres, periodic cell {} × {} × {} m>",
                self.inner.len(),
                c.lengths.x,
                c.lengths.y,
                c.lengths.z
            ),
            None => format!(
                "<anisobond.Packing: {} spheres, free cluster>",
                self.inner.len()
            ),
        }
    }
}

/// A bonded packing: the bonds the model's rule draws and every bond's springs.
///
/// Assembly(packing, model) bonds by the model's rule; Assembly.from_bonds(packing, model,
/// i, j, image=None) takes given pairs (a YADE or LIGGGHTS scene's own interactions).
/// .bonds is the bond table, .tensor(method) the 6×6 stiffness in Pa.
#[pyclass(name = "Assembly", module = "anisobond", frozen)]
pub struct PyAssembly {
    inner: Assembly,
}

/// The value `name` stands for among `choices` (the strings keyword argument `key` takes),
/// or an error listing them all: "key `name`: expected 'a', 'b' or 'c'".
fn one_of<T: Clone>(key: &str, name: &str, choices: &[(&str, T)]) -> PyResult<T> {
    if let Some((_, value)) = choices.iter().find(|(n, _)| *n == name) {
        return Ok(value.clone());
    }
    let quoted: Vec<String> = choices.iter().map(|(n, _)| format!("'{n}'")).collect();
    let expected = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => "nothing".into(),
    };
    Err(InputError::new_err(format!(
        "{key} `{name}`: expected {expected}"
    )))
}

/// The lever arms of the relaxed and LAF methods (`lever_arm=`).
const LEVER_ARMS: [(&str, LeverArm); 3] = [
    ("mid-gap", LeverArm::MidGap),
    ("proportional", LeverArm::Proportional),
    ("half-length", LeverArm::HalfLength),
];

/// The solvers of the relaxed method (`solver=`; "cg" is the default, two-level CG).
fn relaxed_solvers() -> [(&'static str, RelaxedSolver); 3] {
    [
        ("cg", RelaxedSolver::default()),
        (
            "cg-jacobi",
            RelaxedSolver::Cg {
                preconditioner: CgPreconditioner::BlockJacobi,
            },
        ),
        ("cholesky", RelaxedSolver::Cholesky),
    ]
}

/// The bond laws of the dynamic method (`law=`).
const LAWS: [(&str, LawKind); 4] = [
    ("yade", LawKind::Yade),
    ("parallel-bond", LawKind::ParallelBond),
    ("kumar", LawKind::Kumar),
    ("lammps-bpm", LawKind::LammpsBpm),
];

/// The options of `Assembly.tensor` / `tensor_report` (keyword arguments; defaults as the
/// CLI's `tensor`): one parser for both methods.
struct MethodArgs {
    method: String,
    shell: usize,
    energy: bool,
    lever_arm: String,
    tolerance: f64,
    solver: String,
    law: String,
    strain: f64,
    damping: f64,
    max_steps: usize,
    prestress: f64,
    progress: Option<Py<PyAny>>,
}

/// The keyword arguments `MethodArgs::parse` accepts, in the order of the stubs.
const METHOD_OPTIONS: &str = "shell, energy, lever_arm, tolerance, solver, law, strain, \
                              damping, max_steps, prestress, progress";

impl MethodArgs {
    /// `method` with the keyword `options`; an unknown keyword or a value of the wrong type
    /// is an `InputError` naming it.
    fn parse(method: &str, options: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let d = MethodOptions::default();
        let mut a = MethodArgs {
            method: method.to_owned(),
            shell: d.shell,
            energy: d.energy,
            lever_arm: "mid-gap".into(),
            tolerance: d.relaxed.tolerance,
            solver: "cg".into(),
            law: "yade".into(),
            strain: d.element.strain,
            damping: d.element.local_damping,
            max_steps: d.element.max_steps,
            prestress: d.prestress,
            progress: None,
        };
        let Some(options) = options else {
            return Ok(a);
        };
        for (key, value) in options.iter() {
            let key: String = key.extract()?;
            fn get<'py, T: pyo3::conversion::FromPyObjectOwned<'py>>(
                key: &str,
                value: &Bound<'py, PyAny>,
                what: &str,
            ) -> PyResult<T> {
                value.extract::<T>().map_err(|_| {
                    InputError::new_err(format!("option `{key}`: expected {what}, got {value}"))
                })
            }
            match key.as_str() {
                "shell" => a.shell = get(&key, &value, "an integer ≥ 1")?,
                "energy" => a.energy = get(&key, &value, "True or False")?,
                "lever_arm" => a.lever_arm = get(&key, &value, "a string")?,
                "tolerance" => a.tolerance = get(&key, &value, "a number")?,
                "solver" => a.solver = get(&key, &value, "a string")?,
                "law" => a.law = get(&key, &value, "a string")?,
                "strain" => a.strain = get(&key, &value, "a number")?,
                "damping" => a.damping = get(&key, &value, "a number")?,
                "max_steps" => a.max_steps = get(&key, &value, "an integer ≥ 0")?,
                "prestress" => a.prestress = get(&key, &value, "a number (Pa)")?,
                "progress" => a.progress = (!value.is_none()).then(|| value.clone().unbind()),
                other => {
                    return Err(InputError::new_err(format!(
                        "unknown option `{other}`: expected one of {METHOD_OPTIONS}"
                    )))
                }
            }
        }
        Ok(a)
    }
}

impl MethodArgs {
    fn method(&self) -> PyResult<Method> {
        let kind: MethodKind = self.method.parse().map_err(to_py)?;
        Ok(match kind {
            MethodKind::MeanField => Method::MeanField,
            MethodKind::Voigt => Method::Voigt,
            MethodKind::Relaxed | MethodKind::Prestressed => {
                let opts = RelaxedOptions {
                    lever_arm: one_of("lever_arm", &self.lever_arm, &LEVER_ARMS)?,
                    tolerance: self.tolerance,
                    solver: one_of("solver", &self.solver, &relaxed_solvers())?,
                    ..Default::default()
                };
                opts.validate().map_err(to_py)?;
                if kind == MethodKind::Prestressed {
                    Method::Prestressed {
                        options: opts,
                        pressure: self.prestress,
                    }
                } else {
                    Method::Relaxed(opts)
                }
            }
            MethodKind::Laf => Method::Laf {
                shell: self.shell,
                energy: self.energy,
                lever_arm: one_of("lever_arm", &self.lever_arm, &LEVER_ARMS)?,
            },
            MethodKind::Dynamic => {
                let mut options = ElementTestOptions {
                    strain: self.strain,
                    local_damping: self.damping,
                    max_steps: self.max_steps,
                    ..Default::default()
                };
                options.dem.local_damping = self.damping;
                Method::Dynamic {
                    law: one_of("law", &self.law, &LAWS)?,
                    options,
                }
            }
        })
    }
}

impl PyAssembly {
    /// The checked report of `args`' method, computed without the GIL; `progress(fraction)`
    /// is called (with the GIL) as the dynamic method advances, at most every 1 %.
    fn report(&self, py: Python<'_>, args: MethodArgs) -> PyResult<TensorReport> {
        let method = args.method()?;
        let progress = args.progress;
        let last = Mutex::new(-1.0_f64);
        let report = |f: f64| {
            let Some(cb) = &progress else { return };
            let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
            if f - *l < 0.01 && f < 1.0 {
                return;
            }
            *l = f;
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (f,)) {
                    e.write_unraisable(py, None);
                }
            });
        };
        let asm = &self.inner;
        let result = py
            .detach(|| asm.tensor_with_progress(&method, &report))
            .map_err(to_py)?;
        Ok(result.report)
    }
}

#[pymethods]
impl PyAssembly {
    #[new]
    fn new(py: Python<'_>, packing: &PyPacking, model: &PyModel) -> PyResult<Self> {
        let (p, m) = (packing.inner.clone(), model.inner.clone());
        let inner = py.detach(|| Assembly::new(p, m)).map_err(to_py)?;
        Ok(PyAssembly { inner })
    }

    /// An assembly of given bonds (e.g. a YADE scene's interactions) instead of the
    /// model's bonding rule.
    #[staticmethod]
    #[pyo3(signature = (packing, model, i, j, image = None))]
    fn from_bonds(
        py: Python<'_>,
        packing: &PyPacking,
        model: &PyModel,
        i: &Bound<'_, PyAny>,
        j: &Bound<'_, PyAny>,
        image: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let index = |obj: &Bound<'_, PyAny>, name: &str| -> PyResult<Vec<u32>> {
            let v = column(py, obj, name, None)?;
            v.iter()
                .enumerate()
                .map(|(k, &x)| {
                    if x >= 0.0 && x.fract() == 0.0 && x <= u32::MAX as f64 {
                        Ok(x as u32)
                    } else {
                        Err(InputError::new_err(format!(
                            "{name}[{k}] = {x}: expected a particle index (integer >= 0)"
                        )))
                    }
                })
                .collect()
        };
        let (i, j) = (index(i, "i")?, index(j, "j")?);
        let image = match image {
            Some(m) if !m.is_none() => {
                let rows = rows3(py, m, "image")?;
                let mut out = Vec::with_capacity(rows.len());
                for (k, r) in rows.iter().enumerate() {
                    if r.iter().any(|x| x.fract() != 0.0 || x.abs() > 1e6) {
                        return Err(InputError::new_err(format!(
                            "image[{k}] = {:?}: expected integer cell shifts",
                            [r.x, r.y, r.z]
                        )));
                    }
                    out.push([r.x as i32, r.y as i32, r.z as i32]);
                }
                Some(out)
            }
            _ => None,
        };
        let (p, m) = (packing.inner.clone(), model.inner.clone());
        let inner = py
            .detach(|| {
                let bonds = crate::bonds::BondSet::from_pairs(&p, &i, &j, image.as_deref())?;
                Assembly::with_bonds(p, m, bonds)
            })
            .map_err(to_py)?;
        Ok(PyAssembly { inner })
    }

    /// The bond table as a dict of numpy columns: i, j (particle indices, i < j), normal
    /// (Nb, 3, unit, from i to the image of j), length (m), radius (bond radius, m), kn, ks
    /// (N/m), kr, ktw (N·m/rad), image (Nb, 3, cell shifts of j among the positions as
    /// given to Packing, as from_bonds takes them).
    #[getter]
    fn bonds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (b, k) = (&self.inner.bonds, &self.inner.springs);
        let d = PyDict::new(py);
        d.set_item("i", PyArray1::from_slice(py, &b.i))?;
        d.set_item("j", PyArray1::from_slice(py, &b.j))?;
        d.set_item("normal", vec3_array(py, &b.normal)?)?;
        d.set_item("length", PyArray1::from_slice(py, &b.length))?;
        d.set_item("radius", PyArray1::from_slice(py, &k.radius))?;
        d.set_item("kn", PyArray1::from_slice(py, &k.kn))?;
        d.set_item("ks", PyArray1::from_slice(py, &k.ks))?;
        d.set_item("kr", PyArray1::from_slice(py, &k.kr))?;
        d.set_item("ktw", PyArray1::from_slice(py, &k.ktw))?;
        let as_given = self.inner.bonds_as_given();
        let image: Vec<i32> = as_given.image.iter().flatten().copied().collect();
        d.set_item(
            "image",
            PyArray1::from_vec(py, image).reshape([b.len(), 3])?,
        )?;
        Ok(d)
    }

    /// The packing.
    #[getter]
    fn packing(&self) -> PyPacking {
        PyPacking {
            inner: self.inner.packing.clone(),
        }
    }

    /// The model.
    #[getter]
    fn model(&self) -> PyResult<PyModel> {
        PyModel::wrap(self.inner.model.clone())
    }

    /// Number of bonds.
    #[getter]
    fn n_bonds(&self) -> usize {
        self.inner.bonds.len()
    }

    /// Number of particles.
    #[getter]
    fn n_particles(&self) -> usize {
        self.inner.packing.len()
    }

    /// Mean bonds per particle Z = 2 N_b / N.
    #[getter]
    fn coordination(&self) -> f64 {
        self.inner.coordination()
    }

    /// Šmilauer's lattice scaling μ of these bonds (the cross-anisotropic scheme's input).
    #[getter]
    fn lattice_scaling(&self) -> PyResult<f64> {
        let a = &self.inner;
        crate::bonds::lattice_scaling(&a.packing, &a.bonds, a.model.geometry.pi_hat).map_err(to_py)
    }

    /// The (6, 6) stiffness tensor in Pa (Voigt order 11 22 33 23 13 12, engineering strain).
    ///
    /// method: "mean-field" (orientation integral at the bond density), "voigt" (affine sum
    /// over the bonds), "relaxed" (exact static equilibrium, sparse solve), "prestressed"
    /// (relaxed tangent under the isotropic preload `prestress` Pa), "laf" (Kruyt's
    /// local adjustment field, shell order `shell` 1-6, `energy` for the upper bound) or
    /// "dynamic" (the reference integrator's damped element tests).
    /// Keyword options (defaults): shell=2, energy=False, lever_arm="mid-gap",
    /// tolerance=1e-6, solver="cg", law="yade", strain=1e-5, damping=0.4, max_steps=20000,
    /// progress=None; an unknown keyword is an InputError.
    /// lever_arm: "mid-gap" (YADE's contact point), "proportional" or "half-length"
    /// (LAMMPS bpm/rotational). tolerance, solver: relaxed only; relative CG residual in [1e-12, 1e-2], "cg",
    /// "cg-jacobi" or "cholesky".
    /// law, strain, damping, max_steps: dynamic only; "yade", "parallel-bond", "kumar" or "lammps-bpm",
    /// strain per path, Cundall damping, step limit per path.
    /// progress: a callable taking the completed fraction (0-1), called as the dynamic
    /// method advances. The GIL is released during the computation.
    #[pyo3(signature = (method = "relaxed", **options))]
    fn tensor<'py>(
        &self,
        py: Python<'py>,
        method: &str,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let r = self.report(py, MethodArgs::parse(method, options)?)?;
        tensor_array(py, &r.c)
    }

    /// The tensor report of `method` as a dict: the JSON `anisobond tensor --json` prints
    /// (C in Pa, cubic and transverse projections, coordination, relative_residual, …).
    /// Arguments as for `tensor`.
    #[pyo3(signature = (method = "relaxed", **options))]
    fn tensor_report<'py>(
        &self,
        py: Python<'py>,
        method: &str,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let r = self.report(py, MethodArgs::parse(method, options)?)?;
        json_to_py(py, &r.to_json())
    }

    /// The assembly as a finite specimen between two platens (`anisobond specimen`,
    /// docs/specimens.md): the dict of specimen.json (platen_stiffness N/m, young Pa, poisson,
    /// …) plus "displacement" (N, 3) m and "layer" (N,) 0/1/2 (none, held, moved).
    #[pyo3(signature = (axis = "z", *, end_layer = None, platens = "frictionless", strain = 1e-4))]
    fn specimen<'py>(
        &self,
        py: Python<'py>,
        axis: &str,
        end_layer: Option<f64>,
        platens: &str,
        strain: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        use crate::specimen::{solve, Platens, SpecimenOptions};
        let axis = match axis {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            other => {
                return Err(InputError::new_err(format!(
                    "axis {other:?}: expected \"x\", \"y\" or \"z\""
                )))
            }
        };
        let platens = match platens {
            "frictionless" => Platens::Frictionless,
            "bonded" => Platens::Bonded,
            other => {
                return Err(InputError::new_err(format!(
                    "platens {other:?}: expected \"frictionless\" or \"bonded\""
                )))
            }
        };
        let src = &self.inner;
        let mean_radius = src.packing.radii.iter().sum::<f64>() / src.packing.len() as f64;
        let mut opts = SpecimenOptions::new(axis, end_layer.unwrap_or(mean_radius));
        opts.platens = platens;
        opts.strain = strain;
        let r = py.detach(|| solve(src, &opts)).map_err(to_py)?;
        let text = serde_json::to_string(&r)
            .map_err(|e| InputError::new_err(format!("specimen report: {e}")))?;
        let d = json_to_py(py, &text)?;
        d.set_item("displacement", vec3_array(py, &r.displacement_field)?)?;
        d.set_item(
            "layer",
            numpy::PyArray1::from_vec(py, r.layer.iter().map(|&l| l as i64).collect()),
        )?;
        Ok(d)
    }

    /// Šmilauer's pressurised cavity (docs/cavity.md), as `anisobond cavity` without the
    /// wave run: a slab with a hole of radius `hole_radius` (m; default 10 R̄) cut from this
    /// periodic assembly, clamped beyond `outer_radius` (default 24 R̄), the wall under
    /// `pressure` (Pa). Returns a dict: the DEM wall displacement (m) beside Lamé (the
    /// relaxed tensor's isotropic projection) and the anisotropic continuum of the full
    /// relaxed tensor (`continuum_*`), the ±20° wall bins along ±x, ±y (u_r, u_z, m), and
    /// numpy arrays `positions`, `displacement` (m) of the slab's spheres. GIL released.
    #[pyo3(signature = (hole_radius = None, *, outer_radius = None, pressure = 1e6,
        clamp_width = None, ray_spacing = None))]
    fn cavity<'py>(
        &self,
        py: Python<'py>,
        hole_radius: Option<f64>,
        outer_radius: Option<f64>,
        pressure: f64,
        clamp_width: Option<f64>,
        ray_spacing: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        use crate::cavity::{Cavity, CavityGeometry};
        for (name, v) in [
            ("hole_radius", hole_radius),
            ("outer_radius", outer_radius),
            ("clamp_width", clamp_width),
            ("ray_spacing", ray_spacing),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(InputError::new_err(format!(
                        "{name} must be finite and > 0 m, got {v}"
                    )));
                }
            }
        }
        let src = &self.inner;
        let (cavity, cmp) = py
            .detach(|| {
                let geometry = CavityGeometry::with_defaults(
                    src,
                    hole_radius,
                    outer_radius,
                    clamp_width,
                    ray_spacing,
                );
                let relaxed = src.tensor(&Method::relaxed())?.report.tensor();
                let cavity = Cavity::new(src, geometry)?;
                let cmp = cavity.compare_static(&relaxed, pressure)?;
                Ok::<_, Error>((cavity, cmp))
            })
            .map_err(to_py)?;
        let s = &cmp.solution;
        let d = PyDict::new(py);
        d.set_item("pressure_pa", pressure)?;
        d.set_item("hole_radius_m", cavity.geometry.inner_radius)?;
        d.set_item("clamped_radius_m", cavity.geometry.outer_radius)?;
        d.set_item("spheres", cavity.cut.packing.len())?;
        d.set_item("free_spheres", s.free_spheres)?;
        d.set_item("wall_spheres", cavity.wall.len())?;
        d.set_item("relative_residual", s.relative_residual)?;
        d.set_item("wall_displacement_m", s.wall_displacement)?;
        d.set_item("wall_axial_displacement_m", s.wall_axial_displacement)?;
        d.set_item("lame_wall_displacement_m", cmp.lame_wall_displacement)?;
        d.set_item(
            "dem_over_lame",
            s.wall_displacement / cmp.lame_wall_displacement,
        )?;
        d.set_item("lame_lambda_pa", cmp.lame_constants.0)?;
        d.set_item("lame_mu_pa", cmp.lame_constants.1)?;
        d.set_item(
            "continuum_wall_displacement_m",
            cmp.continuum.wall_displacement,
        )?;
        d.set_item(
            "dem_over_continuum",
            s.wall_displacement / cmp.continuum.wall_displacement,
        )?;
        let bins =
            serde_json::to_string(&cmp.bins).map_err(|e| InputError::new_err(e.to_string()))?;
        d.set_item("wall_bins_20deg", json_to_py(py, &bins)?)?;
        d.set_item("positions", vec3_array(py, &cavity.cut.packing.positions)?)?;
        d.set_item("displacement", vec3_array(py, &s.displacement)?)?;
        Ok(d)
    }

    /// Write the bond table (CSV, docs/formats.md) to `path` atomically.
    fn write_bonds(&self, path: PathBuf) -> PyResult<()> {
        write_staged(path, OutputSet::file, |p| self.inner.write_bonds(p))
    }

    /// Write a directory YADE 2023.02a runs as it is (`yade -n -x DIR/run.py`), as
    /// `anisobond export yade` does: strain per path, steps after it, damping λ, density
    /// (kg/m³), time_step (s; None: safety × the critical step), paths ("11,22,…").
    #[pyo3(signature = (directory, *, strain = 1e-5, steps = 200, damping = 0.4,
        density = 2600.0, time_step = None, safety = 0.8, paths = "11,22,33,23,13,12"))]
    #[allow(clippy::too_many_arguments)]
    fn export_yade(
        &self,
        directory: PathBuf,
        strain: f64,
        steps: usize,
        damping: f64,
        density: f64,
        time_step: Option<f64>,
        safety: f64,
        paths: &str,
    ) -> PyResult<()> {
        use crate::export::yade::{parse_paths, write_assembly_export, YadeRunOptions};
        let opts = YadeRunOptions {
            strain,
            steps,
            damping,
            density,
            time_step,
            safety,
            paths: parse_paths(paths).map_err(to_py)?,
        };
        opts.validate().map_err(to_py)?;
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            write_assembly_export(d, a, &opts).map(|_| ())
        })
    }

    /// Write LIGGGHTS 3.8 decks into `directory` as `anisobond export liggghts` does
    /// (driver deck `anisobond.in`, stock `harmonic.in`); shear=False: the three normal cases.
    #[pyo3(signature = (directory, *, shear = true))]
    fn export_liggghts(&self, directory: PathBuf, shear: bool) -> PyResult<()> {
        use crate::export::liggghts::{export_liggghts, DeckOptions};
        let opts = DeckOptions {
            shear,
            ..Default::default()
        };
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            export_liggghts(d, &a.packing, &a.bonds, &a.springs, &opts).map(|_| ())
        })
    }

    /// ParaView files `particles.vtu` and `bonds.vtu` in `directory`, as `anisobond export
    /// vtk` writes them: unloaded, or with `strain` (6 Voigt components, engineering, each
    /// |ε| ≤ 0.1; periodic packings) the quasi-static state (displacements, bond forces).
    #[pyo3(signature = (directory, *, strain = None))]
    fn export_vtk(
        &self,
        py: Python<'_>,
        directory: PathBuf,
        strain: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let strain = match strain {
            Some(s) if !s.is_none() => {
                let e = column(py, s, "strain", Some(6))?;
                Some(crate::tensor::Voigt6::from_column_slice(&e))
            }
            _ => None,
        };
        let a = &self.inner;
        write_staged(directory, OutputSet::dir, |d| {
            py.detach(|| a.write_vtk(d, strain.as_ref())).map(|_| ())
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "<anisobond.Assembly: {} particles, {} bonds, Z = {:.3}>",
            self.inner.packing.len(),
            self.inner.bonds.len(),
            self.inner.coordination()
        )
    }
}

/// Calibrate `model`'s scheme parameters to `target`; returns (Model, details dict).
/// Use anisobond.calibrate (documented there).
/// Kumar 2016 Sec. 5 (docs/buckling.md), as one row of `anisobond buckle`: the round bar of
/// radius `radius` (m) and slenderness l/r = `slenderness` cut along z from `packing`,
/// bonded by `model`, the spheres within `clamp_depth` (m; default the mean radius) of each
/// end clamped. Returns a dict: E (Pa), the network's linearised critical stress (Pa) beside
/// Euler (Eq. 14) and Mazzilli (Eq. 15), with `deformed` also on the bar deformed by its
/// pre-buckling shortening (`sigma_deformed_pa`), EI, κGA, solver figures and the first mode
/// (numpy, unit max norm). GIL released.
#[pyfunction]
#[pyo3(signature = (packing, model, radius, slenderness, *, clamp_depth = None,
    deformed = true, tolerance = 1e-6))]
#[allow(clippy::too_many_arguments)]
fn buckle_bar<'py>(
    py: Python<'py>,
    packing: &PyPacking,
    model: &PyModel,
    radius: f64,
    slenderness: f64,
    clamp_depth: Option<f64>,
    deformed: bool,
    tolerance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    use crate::homogenize::buckling::{
        euler_stress, mazzilli_stress, BucklingOptions, PreBuckling, RoundBar,
    };
    let (p, m) = (&packing.inner, model.inner.clone());
    let depth = clamp_depth.unwrap_or_else(|| p.mean_radius());
    let opts = BucklingOptions {
        tolerance,
        pre_buckling: if deformed {
            PreBuckling::UpdatedGeometry
        } else {
            PreBuckling::Linear
        },
        ..BucklingOptions::default()
    };
    let (bar, r) = py
        .detach(|| {
            let bar = RoundBar::cut(p, m, radius, slenderness, depth)?;
            let r = bar.buckling(&opts)?;
            Ok::<_, Error>((bar, r))
        })
        .map_err(to_py)?;
    let json = serde_json::to_string(&r).map_err(|e| InputError::new_err(e.to_string()))?;
    let d = json_to_py(py, &json)?.cast_into::<PyDict>()?;
    let (e, l) = (r.modulus, bar.length);
    // None, never NaN or infinity: Mazzilli has no root below l/r = 2π, a bar without
    // measurable shear flexibility has κGA = ∞.
    let finite = |x: f64| Some(x).filter(|x| x.is_finite());
    d.set_item("spheres", bar.assembly.packing.len())?;
    d.set_item("radius_m", radius)?;
    d.set_item("length_m", l)?;
    d.set_item("sigma_euler_pa", euler_stress(e, slenderness))?;
    d.set_item("sigma_mazzilli_pa", finite(mazzilli_stress(e, slenderness)))?;
    d.set_item("sigma_network_pa", r.critical_stress)?;
    d.set_item(
        "sigma_deformed_pa",
        r.updated_geometry.map(|u| u.critical_stress),
    )?;
    d.set_item("bending_ratio", r.bending_ratio(bar.area()))?;
    d.set_item("shear_stiffness_n", finite(r.shear_stiffness(l)))?;
    d.set_item(
        "network_over_engesser_own",
        finite(r.critical_force / r.engesser_force_own(l)),
    )?;
    d.set_item("mode", vec3_array(py, &r.mode)?)?;
    Ok(d)
}

#[pyfunction]
#[pyo3(signature = (model, target, on = None, *, family = "nearest", cubic_model = "auto",
    extended = false, tolerance = 5e-4, max_iterations = 30, coordination = 7.7,
    solid_fraction = 0.6, radius = 1e-3))]
#[allow(clippy::too_many_arguments)]
fn calibrate_model<'py>(
    py: Python<'py>,
    model: &PyModel,
    target: &Bound<'py, PyAny>,
    on: Option<&Bound<'py, PyAny>>,
    family: &str,
    cubic_model: &str,
    extended: bool,
    tolerance: f64,
    max_iterations: usize,
    coordination: f64,
    solid_fraction: f64,
    radius: f64,
) -> PyResult<(PyModel, Bound<'py, PyDict>)> {
    let text = if let Ok(s) = target.extract::<String>() {
        s
    } else if let Ok(d) = target.cast::<PyDict>() {
        let mut parts = Vec::new();
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let v: f64 = v.extract().map_err(|_| {
                InputError::new_err(format!("target {k}: expected a number (Pa or a ratio)"))
            })?;
            parts.push(format!("{k}={v:e}"));
        }
        parts.join(",")
    } else {
        return Err(PyTypeError::new_err(
            "target: expected a dict such as {'C12/C11': 0.30, 'C44/C11': 0.43} or the CLI's text",
        ));
    };
    let target = Target::parse(&text).map_err(to_py)?;
    let opts = CubicOptions {
        family: Family::from_name(family).map_err(to_py)?,
        extended,
        model: crate::calibrate::forced_cubic_model(cubic_model).map_err(to_py)?,
        tolerance,
        max_iterations,
        ..Default::default()
    };
    let base = &model.inner;
    let on_assembly: Option<(Assembly, bool)> = match on {
        None => None,
        Some(o) if o.is_none() => None,
        Some(o) => {
            if let Ok(s) = o.extract::<String>() {
                if s != "mean-field" {
                    return Err(InputError::new_err(format!(
                        "on = '{s}': expected 'mean-field', a Packing (relaxed tensor) or None"
                    )));
                }
                None
            } else if let Ok(p) = o.cast::<PyPacking>() {
                let p = p.get().inner.clone();
                let m = base.clone();
                Some((py.detach(|| Assembly::new(p, m)).map_err(to_py)?, true))
            } else if let Ok(a) = o.cast::<PyAssembly>() {
                let a = &a.get().inner;
                let rebonded = Assembly::new(a.packing.clone(), base.clone()).map_err(to_py)?;
                Some((rebonded, true))
            } else {
                return Err(PyTypeError::new_err(
                    "on: expected 'mean-field', a Packing or an Assembly",
                ));
            }
        }
    };
    let spheres = EqualSpheres {
        coordination,
        solid_fraction,
        radius,
    };
    let calibrated = py
        .detach(|| {
            let on = match &on_assembly {
                Some((a, true)) => CalibrateOn::Relaxed(a),
                Some((a, false)) => CalibrateOn::MeanFieldOf(a),
                None => CalibrateOn::MeanField(spheres),
            };
            calibrate(base, &target, on, &opts)
        })
        .map_err(to_py)?;
    let info = PyDict::new(py);
    match &calibrated.calibration {
        Calibration::Cubic(c) => {
            info.set_item("level", format!("{:?}", c.level).to_lowercase())?;
            info.set_item("a_n", c.parameters.a_n)?;
            info.set_item("a_s", c.parameters.a_s)?;
            info.set_item("shear_over_normal", c.parameters.shear_over_normal)?;
            info.set_item("C11", c.achieved_cubic.c11)?;
            info.set_item("C12", c.achieved_cubic.c12)?;
            info.set_item("C44", c.achieved_cubic.c44)?;
            info.set_item("iterations", c.history.len())?;
        }
        Calibration::CrossRelaxed(c) => {
            info.set_item("level", "relaxed")?;
            info.set_item("lattice_scaling", c.mu)?;
            info.set_item("written", PyList::new(py, c.written)?)?;
            let t = &c.achieved_transverse;
            info.set_item("C11", t.c11)?;
            info.set_item("C33", t.c33)?;
            info.set_item("C13", t.c13)?;
            info.set_item("C12", t.c12)?;
            info.set_item("C44", t.c44)?;
            info.set_item("iterations", c.history.len())?;
        }
        Calibration::CrossMeanField => {
            info.set_item("level", "meanfield")?;
        }
    }
    Ok((PyModel::wrap(calibrated.model)?, info))
}

/// Engineering constants of a (6, 6) stiffness tensor C in Pa, from S = C⁻¹: Young's
/// moduli E1, E2, E3 (Pa), shear moduli G23, G13, G12 (Pa), Poisson ratios nu_ij.
#[pyfunction]
fn engineering_constants<'py>(
    py: Python<'py>,
    stiffness: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let c = tensor_from(py, stiffness, "stiffness")?;
    let e = EngineeringConstants::from_stiffness(&c).map_err(to_py)?;
    let d = PyDict::new(py);
    for (k, name) in ["E1", "E2", "E3"].iter().enumerate() {
        d.set_item(*name, e.e[k])?;
    }
    for (k, name) in ["G23", "G13", "G12"].iter().enumerate() {
        d.set_item(*name, e.g[k])?;
    }
    for i in 0..3 {
        for j in 0..3 {
            if i != j {
                d.set_item(format!("nu{}{}", i + 1, j + 1), e.nu[(i, j)])?;
            }
        }
    }
    Ok(d)
}

/// The compiled part of the `anisobond` package.
#[pymodule]
fn _anisobond(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("AnisobondError", py.get_type::<AnisobondError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add("DegenerateError", py.get_type::<DegenerateError>())?;
    m.add("NotConvergedError", py.get_type::<NotConvergedError>())?;
    m.add("EngineError", py.get_type::<EngineError>())?;
    m.add("ValidationError", py.get_type::<ValidationError>())?;
    m.add_class::<PyModel>()?;
    m.add_class::<PyPacking>()?;
    m.add_class::<PyAssembly>()?;
    m.add_function(wrap_pyfunction!(calibrate_model, m)?)?;
    m.add_function(wrap_pyfunction!(buckle_bar, m)?)?;
    m.add_function(wrap_pyfunction!(engineering_constants, m)?)?;
    Ok(())
}
