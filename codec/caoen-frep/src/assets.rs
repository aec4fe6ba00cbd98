//! The files an F-rep model names: pictures (height maps, patterns and reliefs, grey
//! levels of any image the library reads) and closed Cao En surfaces (tessellated into
//! the field of their inside).

use super::height_map::{Base, HeightMap, Interp, SamplesHandle, SAMPLE_BYTES};
use super::interval::Aabb;
use super::mesh_field::MeshField;
use super::model_file::{
    bad, err, number, numbers, FileBase, FileHeightMap, FileSurface, Projection,
};
use super::node::{Node, MIN_LENGTH, WORLD_LIMIT};
use caoen_surface::json::FieldError;

/// Checks a height map node's numbers and reads its image (grey level in [0, 1] times
/// `height`).
pub(super) fn height_map(
    h: &FileHeightMap,
    here: &str,
    base_dir: &std::path::Path,
    limits: &caoen_base::budget::Limits,
) -> Result<HeightMap, FieldError> {
    let w = WORLD_LIMIT;
    let base = match h.base {
        FileBase::Plane => Base::Plane,
        FileBase::Ellipsoid(r) => Base::Ellipsoid(numbers(
            r,
            &format!("{here}.base.ellipsoid"),
            MIN_LENGTH,
            w,
        )?),
        FileBase::Cylinder(r) => {
            Base::Cylinder(number(r, &format!("{here}.base.cylinder"), MIN_LENGTH, w)?)
        }
    };
    let rect = numbers(h.rect, &format!("{here}.rect"), -w, w)?;
    let height = number(h.height, &format!("{here}.height"), -w, w)?;
    let threshold = match h.threshold {
        Some(t) => number(t, &format!("{here}.threshold"), -w, w)?,
        None => f64::NEG_INFINITY,
    };
    let file = base_dir.join(&h.image);
    load_map(
        &file,
        here,
        height,
        (base, rect),
        threshold,
        h.interp,
        limits,
    )
}

/// Samples of the height maps and pictures loaded and still alive, by file and scale:
/// a model that names one image many times holds its samples once.
static LOADED: std::sync::Mutex<Vec<(std::path::PathBuf, u64, SamplesHandle)>> =
    std::sync::Mutex::new(Vec::new());

/// A height map of `file`'s grey levels times `scale`, sharing the samples of a live
/// map of the same file and scale.
fn load_map(
    file: &std::path::Path,
    here: &str,
    scale: f64,
    (base, rect): (Base, [f64; 4]),
    threshold: f64,
    interp: Interp,
    limits: &caoen_base::budget::Limits,
) -> Result<HeightMap, FieldError> {
    let key = std::fs::canonicalize(file).unwrap_or_else(|_| file.to_path_buf());
    let lock = || {
        LOADED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    };
    // The lock is not held while an image loads (the decoder may run on other threads).
    let handle = {
        let mut loaded = lock();
        loaded.retain(|(_, _, h)| h.is_alive());
        loaded
            .iter()
            .find(|(p, s, _)| *p == key && *s == scale.to_bits())
            .map(|(_, _, h)| h.clone())
    };
    let shared = handle.and_then(|h| HeightMap::from_shared(base, rect, &h, threshold, interp));
    let map = match shared {
        Some(m) => m.map_err(|e| bad(here, e.to_string()))?,
        None => {
            let (iw, ih, values) = grey_levels(file, &format!("{here}.image"), scale, limits)?;
            let m = HeightMap::new(base, rect, (iw, ih), values, threshold, interp, limits)
                .map_err(|e| bad(here, e.to_string()))?;
            lock().push((key, scale.to_bits(), m.samples_handle()));
            m
        }
    };
    Ok(map.with_source(file.to_path_buf(), scale))
}

/// Finest tessellation a `caoen_surface` node may ask for (an icosphere of 20 4^7
/// triangles, 327,680).
pub const MAX_SURFACE_DETAIL: u32 = 7;

/// `{"caoen_surface": {"file": "surface.json", "detail": d}}`: a closed Cao En surface
/// (a `caoen-surface/1` file relative to the model, three shape components) tessellated
/// at `detail` (default 5) as the field of its inside.
pub(super) fn surface_field(
    s: &FileSurface,
    here: &str,
    base_dir: &std::path::Path,
    limits: &caoen_base::budget::Limits,
) -> Result<Node, FieldError> {
    use caoen_surface::tessellate::{tessellate, NormalMode};
    let name = &s.file;
    let detail = number(
        s.detail,
        &format!("{here}.detail"),
        0.0,
        f64::from(MAX_SURFACE_DETAIL),
    )?;
    if detail.fract() != 0.0 {
        return err(
            &format!("{here}.detail"),
            format!("{detail}: expected a whole number"),
        );
    }
    let fail = |at: &str, e: String| bad(at, e);
    let model = caoen_surface::model_file::SurfaceModel::load(&base_dir.join(name), limits)
        .map_err(|e| fail(&format!("{here}.file"), e.to_string()))?;
    if model.network.output_dim() != 3 {
        return err(
            &format!("{here}.file"),
            format!(
                "{name}: shape vectors have {} components; a solid needs 3",
                model.network.output_dim()
            ),
        );
    }
    let mesh = tessellate(&model, detail as u32, NormalMode::Exact, limits)
        .map_err(|e| fail(here, e.to_string()))?;
    // The mesh lives while its field is built: the field's checks count it.
    let _mesh_held = limits
        .reserve(|| format!("{name}: its mesh"), mesh.heap_bytes())
        .map_err(|e| fail(here, e.to_string()))?;
    let field = MeshField::new(&mesh, limits).map_err(|e| fail(here, format!("{name}: {e}")))?;
    Ok(Node::Surface(std::sync::Arc::new(field)))
}

/// A picture with its projection, as `pattern` and `relief` nodes give it.
pub(crate) struct Picture<'a> {
    /// The image file (grey levels in [0, 1]), relative to the model.
    pub image: &'a str,
    /// Planar (along z), cylindrical (around z) or spherical (around the origin).
    pub projection: Projection,
    /// Where the picture lies in the projection's parameters; None for the default
    /// (the box's x, y for planar, all angles and the box's z for cylindrical, all
    /// angles for spherical).
    pub rect: Option<[f64; 4]>,
    /// How grey levels between samples are interpolated.
    pub interp: Interp,
}

/// The height map of a picture; `bounds` is the box its default `rect` comes from.
pub(super) fn picture(
    p: &Picture<'_>,
    here: &str,
    base_dir: &std::path::Path,
    limits: &caoen_base::budget::Limits,
    bounds: Option<&Aabb>,
) -> Result<HeightMap, FieldError> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let w = WORLD_LIMIT;
    let base = match p.projection {
        Projection::Planar => Base::Plane,
        Projection::Cylindrical => Base::Cylinder(1.0),
        Projection::Spherical => Base::Ellipsoid([1.0; 3]),
    };
    let rect = match (p.rect, bounds, base) {
        (Some(r), _, _) => numbers(r, &format!("{here}.rect"), -w, w)?,
        (None, Some(b), Base::Plane) => [b.lo[0], b.lo[1], b.hi[0], b.hi[1]],
        (None, Some(b), Base::Cylinder(_)) => [-PI, b.lo[2], PI, b.hi[2]],
        (None, _, Base::Ellipsoid(_)) => [-PI, -FRAC_PI_2, PI, FRAC_PI_2],
        (None, None, _) => return err(here, "needs `rect` (the picture's place)"),
    };
    let file = base_dir.join(p.image);
    load_map(
        &file,
        here,
        1.0,
        (base, rect),
        f64::NEG_INFINITY,
        p.interp,
        limits,
    )
}

/// An image's grey levels (the mean of its colour channels, in [0, 1]) times `scale`:
/// width, height and the levels row by row (`at` names the image in errors).
pub fn grey_levels(
    path: &std::path::Path,
    at: &str,
    scale: f64,
    limits: &caoen_base::budget::Limits,
) -> Result<(usize, usize, Vec<f64>), FieldError> {
    let raster = caoen_io::load_with_limits(path, &caoen_io::LoadLimits::within(limits))
        .map_err(|e| bad(at, e.to_string()))?;
    let (iw, ih) = (raster.width() as usize, raster.height() as usize);
    // Alpha is not a colour: a grey image with alpha is its grey channel.
    let channels = raster.layout().colour_channels();
    // The samples and their pyramid, while the decoded image still lives.
    limits
        .check(
            || format!("{}: a {iw}x{ih} height map", path.display()),
            caoen_base::budget::bytes(
                iw as u64,
                ih as u64,
                SAMPLE_BYTES + 4 * raster.layout().channels() as u64,
            ),
        )
        .map_err(|e| bad(at, e.to_string()))?;
    let values = (0..iw * ih)
        .map(|i| {
            scale
                * (0..channels)
                    .map(|c| raster.plane(c)[i] as f64)
                    .sum::<f64>()
                / channels as f64
        })
        .collect();
    Ok((iw, ih, values))
}
