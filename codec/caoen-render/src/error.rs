//! Errors of the renderers and the scene file.

use thiserror::Error;

use caoen_surface::SurfaceError;

/// What went wrong when loading a scene or rendering it.
#[derive(Debug, Error)]
pub enum RenderError {
    /// A surface model or solid is invalid.
    #[error(transparent)]
    Surface(#[from] SurfaceError),
    /// A scene file (or a file it references) is malformed; the error names the field.
    #[error("scene file: {0}")]
    Field(#[from] caoen_surface::json::FieldError),
    /// A scene with nothing bounded to frame.
    #[error("scene file: the scene has no bounded geometry")]
    NoGeometry,
    /// A render parameter is out of range.
    #[error("{what}: {reason}")]
    Parameter {
        /// Which parameter.
        what: String,
        /// What the valid range is.
        reason: String,
    },
    /// An image file could not be loaded (the message names the file).
    #[error(transparent)]
    Image(#[from] caoen_io::ImageIoError),
    /// An image would not fit the memory budget.
    #[error(transparent)]
    Memory(#[from] caoen_base::budget::OverBudget),
    /// Reading a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file involved.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Encoding a rendered image into a file format failed.
    #[error("writing {format}: {source}")]
    Encode {
        /// The format (`PNG`, `OpenEXR`).
        format: &'static str,
        /// The encoder's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl RenderError {
    /// A parameter error.
    pub fn parameter(what: impl Into<String>, reason: impl Into<String>) -> Self {
        RenderError::Parameter {
            what: what.into(),
            reason: reason.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<std::path::Path>, source: std::io::Error) -> Self {
        RenderError::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
}

impl RenderError {
    /// The same error with any text from a file made printable.
    pub fn printable(self) -> Self {
        use caoen_surface::error::printable;
        match self {
            RenderError::Field(f) => RenderError::Field(f.printable()),
            RenderError::Parameter { what, reason } => RenderError::Parameter {
                what: printable(&what),
                reason: printable(&reason),
            },
            RenderError::Surface(e) => RenderError::Surface(e.printable()),
            other => other,
        }
    }
}

/// Result alias of the renderers.
pub type Result<T, E = RenderError> = std::result::Result<T, E>;
