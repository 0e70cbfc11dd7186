//! The package's exception classes, one per library error variant, and [`to_py`].

use crate::Error;
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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
pub(super) fn to_py(e: Error) -> PyErr {
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
