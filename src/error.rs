//! One error type for the library: every variant says which input is wrong and what was
//! expected, so the CLI can print it as it is and exit non-zero.

use std::path::Path;

/// Everything that can go wrong in anisobond.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A line of an input file could not be understood. Shown as `path:line: message`, or
    /// `path: message` when the file as a whole is wrong (line 0).
    #[error("{path}:{}{message}", line_prefix(*line))]
    Parse {
        /// The file (or `<stdin>`, `<embedded>`).
        path: String,
        /// 1-based line number (0 when the file as a whole is wrong).
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A model (scheme parameters, geometry, bonding) is not admissible.
    #[error("invalid model: {0}")]
    Model(String),
    /// Any other invalid input (packing, target tensor, option values).
    #[error("{0}")]
    Invalid(String),
    /// The inputs are admissible one by one, but what they give is not a result: a packing
    /// the bonding rule leaves without bonds, a tensor that is zero, overflows or is not
    /// positive definite (a mechanism), a run that blows up at this time step.
    #[error("{0}")]
    Degenerate(String),
    /// An iterative computation reached its step or iteration limit before its tolerance:
    /// relaxed solver, element-test relaxation, stress servo, packing generation and
    /// preparation, calibration.
    #[error("{0}")]
    NotConverged(String),
    /// An external program anisobond runs (YADE, LIGGGHTS, LAMMPS, mpirun, make) could not be
    /// started, exited with an error or wrote no usable result: the inputs may be fine, the
    /// engine's installation or run is not.
    #[error("{engine}: {message}")]
    EngineFailed {
        /// The program, as the user knows it (`YADE`, `LIGGGHTS`, `LAMMPS`).
        engine: String,
        /// What it did and said (exit status, its error lines).
        message: String,
    },
    /// A validation ran to the end and some comparison lies outside its tolerance.
    #[error("{message}")]
    OutOfTolerance {
        /// Checks outside their tolerance.
        failed: usize,
        /// Checks made.
        checks: usize,
        /// The failed checks, one a line.
        message: String,
    },
}

/// The documented exit status of the `anisobond` command for each kind of error (README
/// "Errors and limits"); 2 is clap's malformed command line, 128 + n a signal.
impl Error {
    /// Exit status: 1 bad input (file, model, option), 3 file system, 4 degenerate result,
    /// 5 not converged, 6 engine failed, 7 validation out of tolerance.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Parse { .. } | Error::Model(_) | Error::Invalid(_) => 1,
            Error::Io { .. } => 3,
            Error::Degenerate(_) => 4,
            Error::NotConverged(_) => 5,
            Error::EngineFailed { .. } => 6,
            Error::OutOfTolerance { .. } => 7,
        }
    }

    /// An [`Error::EngineFailed`] of `engine`.
    pub fn engine(engine: impl Into<String>, message: impl Into<String>) -> Self {
        Error::EngineFailed {
            engine: engine.into(),
            message: message.into(),
        }
    }
}

/// `"N: "` for a line number, `" "` for line 0 (the whole file), after `path:`.
fn line_prefix(line: usize) -> String {
    if line == 0 {
        " ".to_string()
    } else {
        format!("{line}: ")
    }
}

/// Result with the library's [`Error`]; the error type can be given (`Result<T, E>`), so that
/// `use anisobond::prelude::*` does not break a program's own two-parameter `Result`s.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A parse error at `line` (1-based) of `path`.
    pub fn parse(path: impl AsRef<Path>, line: usize, message: impl Into<String>) -> Self {
        Error::Parse {
            path: path.as_ref().display().to_string(),
            line,
            message: message.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().display().to_string(),
            source,
        }
    }

    /// The same error with `context: ` before the message of an [`Error::Invalid`],
    /// [`Error::Degenerate`] or [`Error::NotConverged`] (the variant kept); any other
    /// error unchanged.
    pub fn in_context(self, context: impl std::fmt::Display) -> Self {
        match self {
            Error::Invalid(m) => Error::Invalid(format!("{context}: {m}")),
            Error::Degenerate(m) => Error::Degenerate(format!("{context}: {m}")),
            Error::NotConverged(m) => Error::NotConverged(format!("{context}: {m}")),
            Error::EngineFailed { engine, message } => Error::EngineFailed {
                engine,
                message: format!("{context}: {message}"),
            },
            other => other,
        }
    }
}
