//! Command failures and their exit codes: 1 for a failed operation, 2 for bad usage.
//!
//! A library's error is kept whole, with its causes, rather than flattened into text:
//! `main` prints the error and every cause its message does not already say, on one
//! line.

use std::error::Error as StdError;
use std::path::{Path, PathBuf};

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
    /// A `.cae` file could not be coded or decoded.
    #[error("{}: {source}", path.display())]
    Codec {
        /// The file involved.
        path: PathBuf,
        /// The codec's error.
        source: caoen::codec::CodecError,
    },
    /// An image file could not be read or written (its errors name the file).
    #[error(transparent)]
    Image(#[from] caoen::image_io::ImageIoError),
    /// A mesh could not be read, converted or measured.
    #[error(transparent)]
    Convert(#[from] caoen::conversion::ConvertError),
    /// A job would need more memory than its limit.
    #[error(transparent)]
    Memory(#[from] caoen::budget::OverBudget),
    /// A library call on a file failed.
    #[error("{}: {source}", path.display())]
    File {
        /// The file involved.
        path: PathBuf,
        /// The library's error.
        source: Box<dyn StdError + Send + Sync>,
    },
    /// A library call failed.
    #[error(transparent)]
    Library(Box<dyn StdError + Send + Sync>),
    /// The command's own check failed: what was found, where a library has no error
    /// for it.
    #[error("{0}")]
    Failed(String),
}

impl From<caoen::image_io::TranscodeError> for CliError {
    fn from(e: caoen::image_io::TranscodeError) -> Self {
        match e {
            caoen::image_io::TranscodeError::Codec { path, source } => codec(&path, source),
            caoen::image_io::TranscodeError::Image(e) => CliError::Image(e),
        }
    }
}

/// A codec error on `path`: a refused parameter is the user's to fix (exit code 2).
pub fn codec(path: &Path, e: caoen::codec::CodecError) -> CliError {
    match e {
        caoen::codec::CodecError::Parameter { .. } | caoen::codec::CodecError::Region { .. } => {
            CliError::Usage(e.to_string())
        }
        source => CliError::Codec {
            path: path.to_path_buf(),
            source,
        },
    }
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
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        CliError::Io {
            path: path.as_ref().display().to_string(),
            source,
        }
    }

    /// A library's error on the file `path`.
    pub fn file(path: impl AsRef<Path>, source: impl StdError + Send + Sync + 'static) -> Self {
        CliError::File {
            path: path.as_ref().to_path_buf(),
            source: Box::new(source),
        }
    }

    /// A library's error that names its own file, if any.
    pub fn library(source: impl StdError + Send + Sync + 'static) -> Self {
        CliError::Library(Box::new(source))
    }

    /// The error and each cause whose text its message does not already hold, joined
    /// on one line.
    pub fn chain(&self) -> String {
        let mut message = self.to_string();
        let mut cause = self.source();
        while let Some(c) = cause {
            let text = c.to_string();
            if !message.contains(&text) {
                message.push_str(": ");
                message.push_str(&text);
            }
            cause = c.source();
        }
        message
    }
}

/// Result alias for commands.
pub type CliResult<T = ()> = Result<T, CliError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Error)]
    #[error("outer")]
    struct Outer(#[source] Inner);

    #[derive(Debug, Error)]
    #[error("inner")]
    struct Inner;

    #[test]
    fn the_chain_says_each_cause_once() {
        let e = CliError::file("m.json", Outer(Inner));
        assert_eq!(e.chain(), "m.json: outer: inner");
        let io = CliError::io("x.png", std::io::Error::other("disk full"));
        assert_eq!(io.chain(), "x.png: disk full");
        assert_eq!(CliError::Usage("bad".into()).exit_code(), 2);
    }
}
