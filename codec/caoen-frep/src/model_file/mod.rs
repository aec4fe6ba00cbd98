//! The JSON form of F-rep models (`docs/frep.md`): each node an object named by its
//! kind, read by serde into its written form (`form`, with `values` for what serde's
//! own types read too loosely), then checked against the model's limits and built into
//! the tree (`build`), errors naming the JSON path of the offending value.

mod build;
mod form;
mod values;

use serde_json::Value;

use super::node::Node;
use caoen_surface::json::FieldError;

pub(crate) use form::{FileBase, FileHeightMap, FileSurface};
pub(crate) use values::Projection;

/// Largest twist, in degrees per unit of z.
pub const MAX_TWIST_DEG: f64 = 1e5;
/// Smallest taper scale (the largest is its inverse).
pub const MIN_TAPER: f64 = 1e-3;
/// Smallest bend radius: the bend's gradient grows as its inverse.
pub const MIN_BEND_RADIUS: f64 = 1e-6;
/// Smallest noise scale: the noise's gradient grows as its inverse.
pub const MIN_NOISE_SCALE: f64 = 1e-6;
/// Largest noise seed.
pub const MAX_SEED: u64 = 1_000_000;

impl Node {
    /// Parses a node from its JSON form; `path` names it in errors. Image files (height
    /// maps) are relative to `base_dir`.
    pub fn from_json(
        v: &Value,
        path: &str,
        base_dir: &std::path::Path,
        limits: &caoen_base::budget::Limits,
    ) -> Result<Node, FieldError> {
        let read = || {
            let file: form::FileNode = serde_path_to_error::deserialize(v)
                .map_err(|e| FieldError::from_path_error(path, &e))?;
            file.check_limits(path, &mut 0)?;
            file.build(path, base_dir, limits)
        };
        // Field names and values from the file reach the messages: one printable line.
        read().map_err(FieldError::printable)
    }
}

/// `reason` about the value at `path`.
pub(super) fn bad(path: &str, reason: impl Into<String>) -> FieldError {
    FieldError::from_reason(path, reason)
}

pub(super) fn err<T>(path: &str, reason: impl Into<String>) -> Result<T, FieldError> {
    Err(bad(path, reason))
}

/// `x`, if it lies in `[lo, hi]`.
pub(super) fn number(x: impl Into<f64>, path: &str, lo: f64, hi: f64) -> Result<f64, FieldError> {
    let x = x.into();
    if !(x >= lo && x <= hi) {
        return err(
            path,
            format!("{x} is outside the allowed range [{lo}, {hi}]"),
        );
    }
    Ok(x)
}

/// `v`, if each of its numbers lies in `[lo, hi]` (`path[k]` names the one that does
/// not).
pub(super) fn numbers<const N: usize>(
    v: impl Into<[f64; N]>,
    path: &str,
    lo: f64,
    hi: f64,
) -> Result<[f64; N], FieldError> {
    let v = v.into();
    for (k, x) in v.iter().enumerate() {
        number(*x, &format!("{path}[{k}]"), lo, hi)?;
    }
    Ok(v)
}

#[cfg(test)]
mod tests;
