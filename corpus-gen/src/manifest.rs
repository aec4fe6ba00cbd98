//! `manifest.json`: what a corpus directory contains.
//!
//! ```json
//! {
//!   "generator": "caoen-corpus",
//!   "version": "0.1.0",
//!   "hash": "sha256 of the canonical pixel bytes: ...",
//!   "size": 512,
//!   "images": [
//!     { "file": "smooth-00-512x512.png", "class": "smooth", "variant": "linear gradient",
//!       "seed": 0, "width": 512, "height": 512, "channels": 3, "bit_depth": 8,
//!       "sample_format": "u8", "sha256": "…" }
//!   ],
//!   "contact_sheet": "sheet.png"
//! }
//! ```

use std::path::{Path, PathBuf};

use crate::error::CorpusError;
use crate::image::{CorpusImage, SampleFormat};
use crate::{Class, Spec};

/// File name of the manifest inside a corpus directory.
pub const MANIFEST_NAME: &str = "manifest.json";
/// Value of the `generator` field: identifies directories we wrote.
pub const GENERATOR: &str = "caoen-corpus";
/// Value of the `hash` field: what `sha256` is computed over.
pub const HASH_DESCRIPTION: &str =
    "sha256 of the canonical pixel bytes: row-major interleaved samples; \
    8-bit as is, 16-bit big-endian, float32 little-endian IEEE-754 (not of the file bytes)";

/// The manifest of a corpus directory.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    pub generator: String,
    pub version: String,
    pub hash: String,
    /// Nominal `--size` of the last run.
    pub size: u32,
    pub images: Vec<Entry>,
    /// Contact sheet file, if it was written inside the directory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_sheet: Option<String>,
}

/// One image of the corpus.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Entry {
    /// File name relative to the corpus directory.
    pub file: String,
    pub class: Class,
    pub variant: String,
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub channels: u8,
    /// 8, 16 (PNG) or 32 (float, OpenEXR).
    pub bit_depth: u8,
    pub sample_format: SampleFormat,
    /// See [`HASH_DESCRIPTION`]; equals [`CorpusImage::sha256`].
    pub sha256: String,
}

impl Entry {
    pub fn new(spec: &Spec, img: &CorpusImage) -> Entry {
        Entry {
            file: spec.file_name(),
            class: spec.class,
            variant: spec.class.variant_name(spec.seed).to_string(),
            seed: spec.seed,
            width: img.width(),
            height: img.height(),
            channels: img.channels(),
            bit_depth: img.bit_depth(),
            sample_format: img.sample_format(),
            sha256: img.sha256(),
        }
    }
}

impl Manifest {
    pub fn new(size: u32, images: Vec<Entry>) -> Manifest {
        Manifest {
            generator: GENERATOR.to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            hash: HASH_DESCRIPTION.to_string(),
            size,
            images,
            contact_sheet: None,
        }
    }

    /// Read `dir/manifest.json`. `Ok(None)` if there is none, or if it is not
    /// a manifest written by this generator.
    pub fn read_from_dir(dir: &Path) -> Result<Option<Manifest>, CorpusError> {
        let Some((_, text)) = read_manifest_text(dir)? else {
            return Ok(None);
        };
        match serde_json::from_str::<Manifest>(&text) {
            Ok(m) if m.generator == GENERATOR => Ok(Some(m)),
            _ => Ok(None),
        }
    }

    /// Read `dir/manifest.json` for a reader of the corpus: `Ok(None)` if there is none
    /// or it is another program's; an error if it does not parse, or if an entry names
    /// a file outside `dir` (an absolute path, or one with `..` or a root).
    pub fn read_for_reading(dir: &Path) -> Result<Option<Manifest>, CorpusError> {
        let Some((path, text)) = read_manifest_text(dir)? else {
            return Ok(None);
        };
        let value: serde_json::Value =
            serde_json::from_str(&text).map_err(|source| CorpusError::Manifest {
                path: path.clone(),
                source,
            })?;
        if value.get("generator").and_then(|g| g.as_str()) != Some(GENERATOR) {
            return Ok(None);
        }
        let m: Manifest =
            serde_json::from_value(value).map_err(|source| CorpusError::Manifest {
                path: path.clone(),
                source,
            })?;
        for e in &m.images {
            let inside = Path::new(&e.file)
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_)));
            if !inside || e.file.is_empty() {
                return Err(CorpusError::OutsideFolder {
                    manifest: path,
                    entry: e.file.clone(),
                });
            }
        }
        Ok(Some(m))
    }

    /// Write `dir/manifest.json` (via a temporary file and a rename).
    pub fn write_to_dir(&self, dir: &Path) -> Result<(), CorpusError> {
        let path = dir.join(MANIFEST_NAME);
        let tmp = dir.join(format!(".{MANIFEST_NAME}.tmp"));
        let mut text =
            serde_json::to_string_pretty(self).map_err(|source| CorpusError::Manifest {
                path: path.clone(),
                source,
            })?;
        text.push('\n');
        let written = std::fs::write(&tmp, text)
            .map_err(|e| CorpusError::io(&path, e))
            .and_then(|()| std::fs::rename(&tmp, &path).map_err(|e| CorpusError::io(&path, e)));
        // A failed write or rename must not leave the temporary file behind.
        if written.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        written
    }

    /// Does the manifest list this file (image or contact sheet)?
    pub fn owns(&self, file: &str) -> bool {
        self.images.iter().any(|e| e.file == file) || self.contact_sheet.as_deref() == Some(file)
    }
}

/// `dir/manifest.json`'s path and text; `None` if there is none.
fn read_manifest_text(dir: &Path) -> Result<Option<(PathBuf, String)>, CorpusError> {
    let path = dir.join(MANIFEST_NAME);
    match std::fs::read_to_string(&path) {
        Ok(text) => Ok(Some((path, text))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(CorpusError::io(path, e)),
    }
}
