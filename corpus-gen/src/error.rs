//! Error type of the corpus generator.

use std::path::PathBuf;

/// Everything that can go wrong while generating or writing a corpus.
#[derive(Debug, thiserror::Error)]
pub enum CorpusError {
    /// A command-line or API argument is out of range or malformed.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),

    /// The output directory has files but no manifest written by us.
    #[error(
        "output directory {0} is not empty and has no caoen-corpus manifest.json; refusing to write into it \
         (pass --force to write anyway)"
    )]
    ForeignDirectory(PathBuf),

    /// A file we would write exists and is not one of ours.
    #[error("{0} already exists and is not listed in the corpus manifest; refusing to overwrite it (pass --force)")]
    WouldOverwrite(PathBuf),

    /// A manifest entry names a file outside the manifest's folder.
    #[error(
        "{manifest}: entry {entry:?} is outside the corpus folder (entries are file names in it)"
    )]
    OutsideFolder {
        /// The manifest.
        manifest: PathBuf,
        /// The offending entry.
        entry: String,
    },

    /// A filesystem operation failed.
    #[error("I/O error on {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// PNG encoding failed.
    #[error("cannot write PNG {path}: {source}")]
    Png {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },

    /// OpenEXR encoding failed.
    #[error("cannot write OpenEXR {path}: {source}")]
    Exr {
        path: PathBuf,
        #[source]
        source: exr::error::Error,
    },

    /// The manifest could not be read or written.
    #[error("manifest {path}: {source}")]
    Manifest {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },

    /// A rayon thread pool could not be built.
    #[error("cannot start worker threads: {0}")]
    ThreadPool(#[source] rayon::ThreadPoolBuildError),
}

impl CorpusError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        CorpusError::Io {
            path: path.into(),
            source,
        }
    }
}
