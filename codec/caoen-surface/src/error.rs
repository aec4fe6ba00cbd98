//! Errors of the surface core, carrying the offending values.

use thiserror::Error;

/// What went wrong when building, loading or evaluating a surface model.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SurfaceError {
    /// A model with no key points has no surface.
    #[error("empty model: a network needs at least one key point")]
    Empty,
    /// A vector has the wrong length for its role.
    #[error("{what}: expected {expected} components, got {got}")]
    Dimension {
        /// Which vector.
        what: String,
        /// Length it must have.
        expected: usize,
        /// Length it has.
        got: usize,
    },
    /// A value that must be finite is NaN or infinite.
    #[error("{what} is not finite ({value})")]
    NonFinite {
        /// Which value.
        what: String,
        /// The offending value.
        value: f64,
    },
    /// A parameter is outside its valid range.
    #[error("{what} = {value}: {reason}")]
    Parameter {
        /// Which parameter.
        what: String,
        /// The offending value.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A number outside the range where the model's math stays finite.
    #[error("{what} = {value:e} is outside [{lo:.4e}, {hi:.4e}], the range where the model stays finite")]
    OutOfRange {
        /// Which value.
        what: String,
        /// The offending value.
        value: f64,
        /// Smallest allowed value.
        lo: f64,
        /// Largest allowed value.
        hi: f64,
    },
    /// A surface description file is malformed; the error names the field.
    #[error("surface file: {0}")]
    Field(#[from] crate::json::FieldError),
    /// A surface description file could not be read or written (the error is kept as
    /// its kind and text so that surface errors stay `Clone` and `PartialEq`).
    #[error("surface file: {}: {message}", path.display())]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The kind of failure.
        kind: std::io::ErrorKind,
        /// The operating system's description.
        message: String,
    },
    /// The memory budget does not hold what the operation would allocate.
    #[error("{0}")]
    OverBudget(#[from] caoen_base::budget::OverBudget),
}

impl SurfaceError {
    /// An I/O failure on `path`.
    pub fn io(path: &std::path::Path, e: std::io::Error) -> Self {
        SurfaceError::Io {
            path: path.to_path_buf(),
            kind: e.kind(),
            message: e.to_string(),
        }
    }
}

/// Result alias of the surface core.
pub type Result<T, E = SurfaceError> = std::result::Result<T, E>;

pub fn check_finite(what: impl FnOnce() -> String, values: &[f64]) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(SurfaceError::NonFinite {
            what: what(),
            value,
        }),
        None => Ok(()),
    }
}

pub fn check_len(what: impl FnOnce() -> String, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(SurfaceError::Dimension {
            what: what(),
            expected,
            got,
        })
    }
}

pub fn check_range(what: impl FnOnce() -> String, value: f64, lo: f64, hi: f64) -> Result<()> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(SurfaceError::OutOfRange {
            what: what(),
            value,
            lo,
            hi,
        })
    }
}

pub use crate::json::printable;

impl SurfaceError {
    /// The same error with any text from a file made printable.
    pub fn printable(self) -> Self {
        match self {
            SurfaceError::Field(f) => SurfaceError::Field(f.printable()),
            SurfaceError::Dimension {
                what,
                expected,
                got,
            } => SurfaceError::Dimension {
                what: printable(&what),
                expected,
                got,
            },
            other => other,
        }
    }
}
