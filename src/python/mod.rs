//! The Python package `anisobond` (feature `python`): a thin pyo3 binding of the library's
//! one pipeline ([`crate::Assembly`], [`crate::Model`], [`crate::calibrate::calibrate`]).
//! numpy arrays in and out; long calls release the GIL; library errors become exceptions of
//! the package (`InputError`, `ModelError`, … subclasses of `ValueError`) with the library's
//! message. The pure-Python part (`src/python/anisobond/`) re-exports it with docs and stubs.

// pyo3's macros expand to code that clippy and missing_docs judge as if it were ours.
#![allow(missing_docs)]
#![allow(clippy::useless_conversion)]

mod assembly;
mod calibrate;
mod convert;
mod errors;
mod manybody;
mod method;
mod model;
mod packing;
mod strength;
mod studies;
mod tensor;
mod validate;

use errors::{
    AnisobondError, DegenerateError, EngineError, FileError, InputError, ModelError,
    NotConvergedError, ValidationError,
};
use pyo3::prelude::*;

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
    m.add_class::<model::PyModel>()?;
    m.add_class::<packing::PyPacking>()?;
    m.add_class::<assembly::PyAssembly>()?;
    m.add_class::<manybody::PyManyBody>()?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate_model, m)?)?;
    m.add_function(wrap_pyfunction!(studies::buckle_bar, m)?)?;
    m.add_function(wrap_pyfunction!(studies::strength_test, m)?)?;
    m.add_function(wrap_pyfunction!(studies::strength_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(studies::polycrystal, m)?)?;
    m.add_function(wrap_pyfunction!(strength::calibrate_strength_model, m)?)?;
    m.add_function(wrap_pyfunction!(tensor::engineering_constants, m)?)?;
    m.add_function(wrap_pyfunction!(validate::validate, m)?)?;
    Ok(())
}
