//! numpy and Python values to and from the library's: checked float arrays, vectors,
//! tensors, JSON texts, and files written through an output set.

use super::errors::{to_py, InputError};
use crate::io::OutputSet;
use crate::tensor::Stiffness6;
use crate::Vec3;
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

pub(super) type PyResultOf<T> = PyResult<T>;

/// `obj` as a C-contiguous float64 ndarray of `ndim` dimensions (no copy when it is one
/// already); booleans, complex numbers, strings and objects are refused by name.
pub(super) fn float_array<'py>(
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
pub(super) fn column(
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
pub(super) fn rows3(py: Python<'_>, obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec3>> {
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
pub(super) fn vec3_array<'py>(py: Python<'py>, v: &[Vec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = v.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    PyArray1::from_vec(py, flat).reshape([v.len(), 3])
}

/// A (6, 6) float64 array of a Voigt tensor (Pa).
pub(super) fn tensor_array<'py>(
    py: Python<'py>,
    c: &[[f64; 6]; 6],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = c.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([6, 6])
}

/// A (6, 6) float64 tensor from Python (Pa), finite.
pub(super) fn tensor_from(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<Stiffness6> {
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

/// A report as a Python dict, through the check every written report gets
/// ([`crate::io::refuse_non_finite`]): a non-finite number anywhere in it is refused, naming
/// its key under `at`, rather than handed on as `None`; the report's own `None`s stay `None`.
pub(super) fn report_to_py<'py>(
    py: Python<'py>,
    report: &impl serde::Serialize,
    at: &str,
) -> PyResult<Bound<'py, PyDict>> {
    crate::io::refuse_non_finite(report, at).map_err(to_py)?;
    let value = serde_json::to_value(report)
        .map_err(|e| InputError::new_err(format!("{at}: cannot serialise: {e}")))?;
    Ok(json_to_py(py, &value.to_string())?.cast_into::<PyDict>()?)
}

/// The value of keyword option `key` as a `T`; a value of another type is an InputError
/// naming the option and `what` it expects.
pub(super) fn get<'py, T: pyo3::conversion::FromPyObjectOwned<'py>>(
    key: &str,
    value: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<T> {
    value
        .extract::<T>()
        .map_err(|_| InputError::new_err(format!("option `{key}`: expected {what}, got {value}")))
}

/// A JSON text as Python objects (dicts, lists, floats).
pub(super) fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// Write a file or a directory atomically through an output set: `plan` stages `path`
/// ([`OutputSet::file`]: a file in a folder that exists; [`OutputSet::dir`]: a directory),
/// `write` fills the staging path, and only a successful write replaces `path` (nothing is
/// left behind otherwise).
pub(super) fn write_staged(
    path: PathBuf,
    plan: fn(&mut OutputSet, &std::path::Path) -> crate::Result<PathBuf>,
    write: impl FnOnce(&std::path::Path) -> crate::Result<()>,
) -> PyResult<()> {
    let mut out = OutputSet::new(&[]);
    let staged = plan(&mut out, &path).map_err(to_py)?;
    write(&staged).map_err(to_py)?;
    out.commit().map_err(to_py)
}
