//! Command failures and their exit codes: 1 for a failed operation, 2 for bad usage.

use thiserror::Error;

/// Why a command failed.
#[derive(Debug, Error)]
pub enum CliError {
    /// The user asked for something malformed or contradictory (exit code 2).
    #[error("{0}")]
    Usage(String),
    /// Input data or a model is invalid.
    #[error(transparent)]
    Surface(#[from] caoen::surface::SurfaceError),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// Any other failure of the operation.
    #[error("{0}")]
    Failed(String),
}

impl CliError {
    /// The process exit code for this failure.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Usage(_) => 2,
            _ => 1,
        }
    }

    /// Whether this is standard output losing its reader (`caoen ... | head`): the
    /// reader chose to stop, so it is no failure.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, CliError::Io { path, source }
            if path == crate::output::STDOUT && source.kind() == std::io::ErrorKind::BrokenPipe)
    }

    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<std::path::Path>, source: std::io::Error) -> Self {
        CliError::Io {
            path: path.as_ref().display().to_string(),
            source,
        }
    }
}

/// Result alias for commands.
pub type CliResult<T = ()> = Result<T, CliError>;
