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
}

/// `"N: "` for a line number, `" "` for line 0 (the whole file), after `path:`.
fn line_prefix(line: usize) -> String {
    if line == 0 {
        " ".to_string()
    } else {
        format!("{line}: ")
    }
}

/// Result with the library's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

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

    /// The same error naming the user's output paths where it names a hidden staging path of
    /// [`crate::io`] (a write into `.anisobondXXXX.csv` failed: the user wrote `-o bonds.csv`).
    pub fn with_user_paths(self) -> Self {
        let path_of =
            |p: String| crate::io::user_path(Path::new(&p)).map_or(p, |u| u.display().to_string());
        let text = |m: String| crate::io::user_paths_in(&m);
        match self {
            Error::Io { path, source } => Error::Io {
                path: path_of(path),
                source,
            },
            Error::Parse {
                path,
                line,
                message,
            } => Error::Parse {
                path: path_of(path),
                line,
                message: text(message),
            },
            Error::Model(m) => Error::Model(text(m)),
            Error::Invalid(m) => Error::Invalid(text(m)),
            Error::Degenerate(m) => Error::Degenerate(text(m)),
            Error::NotConverged(m) => Error::NotConverged(text(m)),
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
            other => other,
        }
    }
}
