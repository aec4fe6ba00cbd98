//! The surface description file: a model (domain, blending, key points) as JSON.
//!
//! The format is specified in `docs/surface-format.md`. Loading checks every field
//! and names the offending one in its error (`key_points[3].q: ...`).

use crate::json::FieldError;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::blend::Blend;
use super::domain::Domain;
use super::error::{Result, SurfaceError};
use super::network::{KeyPoint, Network};

/// The format tag every surface file starts with.
pub const FORMAT_TAG: &str = "caoen-surface/1";

/// A surface model: a network over a domain.
#[derive(Debug, Clone)]
pub struct SurfaceModel {
    /// Free-form name.
    pub name: String,
    /// The domain the network's input lives on.
    pub domain: Domain,
    /// The network.
    pub network: Network,
    /// Optional texture image on the domain (equirectangular for the sphere, `(t, f)`
    /// for the torus), as written in the file: relative paths are relative to the
    /// model file's directory (see [`SurfaceModel::texture_path`]).
    pub texture: Option<String>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileKeyPoint {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    source: Option<Vec<f64>>,
    /// Domain parameters instead of a source vector (angles in radians, or a ball point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    param: Option<Vec<f64>>,
    shape: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    blend: Option<Blend>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    q: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    weight: Option<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileModel {
    format: String,
    #[serde(default)]
    name: String,
    domain: Domain,
    #[serde(default)]
    normalised: bool,
    /// Blending function of key points that do not name one.
    #[serde(default = "default_blend")]
    blend: Blend,
    /// Sharpness of key points that do not give one.
    #[serde(default = "default_q")]
    q: f64,
    key_points: Vec<FileKeyPoint>,
    /// Texture image file (PNG or JPEG) on the domain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    texture: Option<String>,
}

fn default_blend() -> Blend {
    Blend::Exponential
}

fn default_q() -> f64 {
    4.0
}

/// Largest source vector length: every domain lies on the unit sphere, so `x . w` is
/// at most `|w|`.
pub const MAX_SOURCE_NORM: f64 = 1e3;
/// Largest shape vector component (output coordinates, colours).
pub const MAX_SHAPE: f64 = 1e6;
/// Largest sharpness of a compact kernel (support radius about 2.4e-6).
const MAX_COMPACT_Q: f64 = 1e12;
/// Largest kernel slope on the domain: sums over millions of key points, times shapes,
/// and the Jacobian's products stay finite.
const MAX_SLOPE: f64 = 1e200;

/// Whether a kernel of sharpness `q` stays finite with headroom for `x . w <= reach`.
fn kernel_finite(blend: Blend, q: f64, reach: f64) -> bool {
    let (f, slope) = blend.value_and_slope(reach.max(1.0), q);
    q.is_finite() && q > 0.0 && q <= MAX_COMPACT_Q && f.is_finite() && slope.abs() <= MAX_SLOPE
}

/// Checks every key point's numbers against the range where the model's values,
/// normals and Jacobians stay finite on its domain.
fn check_ranges(network: &Network) -> Result<()> {
    let (m, p) = (network.input_dim(), network.output_dim());
    let sources = network.sources();
    let shapes = network.shapes();
    for (i, (&q, &blend)) in network.sharpness().iter().zip(network.blends()).enumerate() {
        let w = &sources[i * m..(i + 1) * m];
        let reach = w.iter().map(|v| v * v).sum::<f64>().sqrt();
        super::error::check_range(
            || format!("key_points[{i}].source length"),
            reach,
            0.0,
            MAX_SOURCE_NORM,
        )?;
        for (k, &t) in shapes[i * p..(i + 1) * p].iter().enumerate() {
            super::error::check_range(
                || format!("key_points[{i}].shape[{k}]"),
                t,
                -MAX_SHAPE,
                MAX_SHAPE,
            )?;
        }
        if !kernel_finite(blend, q, reach) {
            // The finite sharpnesses are (0, hi]: find hi by bisection on log2 q.
            let (mut good, mut bad) = (-1100.0f64, 40.0f64);
            for _ in 0..80 {
                let mid = 0.5 * (good + bad);
                if kernel_finite(blend, mid.exp2(), reach) {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            return Err(SurfaceError::OutOfRange {
                what: format!("key_points[{i}].q"),
                value: q,
                lo: f64::MIN_POSITIVE,
                hi: good.exp2(),
            });
        }
    }
    Ok(())
}

impl SurfaceModel {
    /// Builds a model, checking the network against the domain.
    pub fn new(name: impl Into<String>, domain: Domain, network: Network) -> Result<Self> {
        domain.validate()?;
        super::error::check_len(
            || "network input dimension vs domain".into(),
            domain.ambient_dim(),
            network.input_dim(),
        )?;
        check_ranges(&network)?;
        Ok(SurfaceModel {
            name: name.into(),
            domain,
            network,
            texture: None,
        })
    }

    /// Parses a model from JSON text: exactly one JSON value, nothing after it.
    pub fn from_json(text: &str) -> Result<Self> {
        Self::parse_json(text).map_err(SurfaceError::printable)
    }

    fn parse_json(text: &str) -> Result<Self> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let file: FileModel = serde_path_to_error::deserialize(&mut *de)
            .map_err(|e| SurfaceError::Field(FieldError::from_path_error("", &e)))?;
        // Data after the value is a damaged or concatenated file, not a model to trust.
        de.end()
            .map_err(|e| FieldError::parse("", &format!("after the model: {e}")))?;
        if file.format != FORMAT_TAG {
            return Err(FieldError::new(
                "format",
                format!("\"{FORMAT_TAG}\""),
                format!("\"{}\"", file.format),
            )
            .into());
        }
        file.domain
            .validate()
            .map_err(|e| FieldError::new("domain", "", e.to_string()))?;
        let domain = file.domain;
        let mut kps = Vec::with_capacity(file.key_points.len());
        let mut p = None;
        for (i, k) in file.key_points.into_iter().enumerate() {
            let field = |what: &str, msg: String| -> SurfaceError {
                FieldError::from_reason(format!("key_points[{i}].{what}"), msg).into()
            };
            let source = match (k.source, k.param) {
                (Some(s), None) => s,
                (None, Some(a)) => domain
                    .point(&a)
                    .map_err(|e| field("param", e.to_string()))?,
                _ => {
                    return Err(field(
                        "source",
                        "give exactly one of `source` or `param`".into(),
                    ))
                }
            };
            if source.len() != domain.ambient_dim() {
                return Err(field(
                    "source",
                    format!(
                        "expected {} components for domain {:?}, got {}",
                        domain.ambient_dim(),
                        domain,
                        source.len()
                    ),
                ));
            }
            let pk = *p.get_or_insert(k.shape.len());
            if k.shape.len() != pk {
                return Err(field(
                    "shape",
                    format!(
                        "expected {pk} components like key_points[0], got {}",
                        k.shape.len()
                    ),
                ));
            }
            kps.push(KeyPoint {
                source,
                shape: k.shape,
                blend: k.blend.unwrap_or(file.blend),
                q: k.q.unwrap_or(file.q),
                weight: k.weight.unwrap_or(1.0),
            });
        }
        let p = p.ok_or_else(|| {
            FieldError::new("key_points", "at least one key point", "an empty model")
        })?;
        let network = Network::new(domain.ambient_dim(), p, &kps, file.normalised)
            .map_err(|e| FieldError::new("key_points", "", e.to_string()))?;
        check_ranges(&network).map_err(|e| FieldError::new("key_points", "", e.to_string()))?;
        if let Some(t) = &file.texture {
            if t.trim().is_empty() {
                return Err(FieldError::new(
                    "texture",
                    "a file name (omit the field for no texture)",
                    "an empty name",
                )
                .into());
            }
        }
        Ok(SurfaceModel {
            name: file.name,
            domain,
            network,
            texture: file.texture,
        })
    }

    /// Serialises the model as pretty JSON (every key point explicit).
    pub fn to_json(&self) -> String {
        let net = &self.network;
        let file = FileModel {
            format: FORMAT_TAG.into(),
            name: self.name.clone(),
            domain: self.domain,
            normalised: net.is_normalised(),
            blend: default_blend(),
            q: default_q(),
            key_points: net
                .key_points()
                .into_iter()
                .map(|k| FileKeyPoint {
                    source: Some(k.source),
                    param: None,
                    shape: k.shape,
                    blend: Some(k.blend),
                    q: Some(k.q),
                    weight: (k.weight != 1.0).then_some(k.weight),
                })
                .collect(),
            texture: self.texture.clone(),
        };
        serde_json::to_string_pretty(&file).expect("a model of finite numbers always serialises")
    }

    /// The same model with a texture reference (see [`SurfaceModel::texture`]).
    pub fn with_texture(mut self, texture: impl Into<String>) -> Self {
        self.texture = Some(texture.into());
        self
    }

    /// The texture file resolved against the directory of the model file it came from
    /// (`model_file`; None for a model that was not loaded from a file).
    pub fn texture_path(&self, model_file: Option<&Path>) -> Option<std::path::PathBuf> {
        let t = Path::new(self.texture.as_deref()?);
        Some(match model_file.and_then(Path::parent) {
            Some(dir) if t.is_relative() => dir.join(t),
            _ => t.to_path_buf(),
        })
    }

    /// Loads a model from a file, read within `limits`.
    pub fn load(path: &Path, limits: &caoen_base::budget::Limits) -> Result<Self> {
        let text = limits
            .read_to_string(path)
            .map_err(|e| SurfaceError::io(path, e))?;
        Self::from_json(&text).map_err(|e| match e {
            SurfaceError::Field(f) => SurfaceError::Field(f.in_file(path).printable()),
            other => other,
        })
    }

    /// Saves the model to a file.
    pub fn save(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_json() + "\n").map_err(|e| SurfaceError::io(path, e))
    }
}
