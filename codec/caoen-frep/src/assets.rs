//! The files an F-rep model names: pictures (height maps, patterns and reliefs, grey
//! levels of any image the library reads) and closed Cao En surfaces (tessellated into
//! the field of their inside).

use serde_json::Value;

use super::height_map::{Base, HeightMap, SamplesHandle, SAMPLE_BYTES};
use super::interval::Aabb;
use super::mesh_field::MeshField;
use super::model_file::{bad, err, fields, get, image_file, interp_of, number, numbers, vec3};
use super::node::{Node, MIN_LENGTH, WORLD_LIMIT};
use caoen_surface::json::FieldError;

/// Parses a height map node and reads its image (grey level in [0, 1] times `height`).
pub(super) fn height_map(
    v: &Value,
    here: &str,
    base_dir: &std::path::Path,
) -> Result<HeightMap, FieldError> {
    let w = WORLD_LIMIT;
    let f = fields(
        v,
        here,
        &["image", "base", "rect", "height", "threshold", "interp"],
    )?;
    let base = match get(f, "base", here)? {
        Value::String(s) if s == "plane" => Base::Plane,
        Value::Object(o) if o.len() == 1 && o.contains_key("ellipsoid") => Base::Ellipsoid(vec3(
            &o["ellipsoid"],
            &format!("{here}.base.ellipsoid"),
            MIN_LENGTH,
            w,
        )?),
        Value::Object(o) if o.len() == 1 && o.contains_key("cylinder") => Base::Cylinder(number(
            &o["cylinder"],
            &format!("{here}.base.cylinder"),
            MIN_LENGTH,
            w,
        )?),
        other => {
            return err(
                &format!("{here}.base"),
                format!(
                "{other}: expected \"plane\", {{\"ellipsoid\": [a, b, c]}} or {{\"cylinder\": r}}"
            ),
            )
        }
    };
    let rect = numbers(
        get(f, "rect", here)?,
        &format!("{here}.rect"),
        -w,
        w,
        "[u0, v0, u1, v1]",
    )?;
    let height = match f.get("height") {
        Some(h) => number(h, &format!("{here}.height"), -w, w)?,
        None => 1.0,
    };
    let threshold = match f.get("threshold") {
        Some(t) => number(t, &format!("{here}.threshold"), -w, w)?,
        None => f64::NEG_INFINITY,
    };
    let interp = interp_of(f, here)?;
    let file = image_file(f, here, base_dir)?;
    load_map(&file, here, height, base, rect, threshold, interp)
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
    base: Base,
    rect: [f64; 4],
    threshold: f64,
    interp: super::height_map::Interp,
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
            let (iw, ih, values) = grey_levels(file, &format!("{here}.image"), scale)?;
            let m = HeightMap::new(base, rect, iw, ih, values, threshold, interp)
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
    v: &Value,
    here: &str,
    base_dir: &std::path::Path,
) -> Result<Node, FieldError> {
    use caoen_surface::tessellate::{tessellate, NormalMode};
    let f = fields(v, here, &["file", "detail"])?;
    let Some(name) = get(f, "file", here)?.as_str() else {
        return err(&format!("{here}.file"), "expected a file name");
    };
    let detail = match f.get("detail") {
        Some(d) => number(
            d,
            &format!("{here}.detail"),
            0.0,
            f64::from(MAX_SURFACE_DETAIL),
        )?,
        None => 5.0,
    };
    if detail.fract() != 0.0 {
        return err(
            &format!("{here}.detail"),
            format!("{detail}: expected a whole number"),
        );
    }
    let fail = |at: &str, e: String| bad(at, e);
    let model = caoen_surface::model_file::SurfaceModel::load(&base_dir.join(name))
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
    let mesh = tessellate(&model, detail as u32, NormalMode::Exact)
        .map_err(|e| fail(here, e.to_string()))?;
    // The mesh lives while its field is built: the field's checks count it.
    let _mesh_held = caoen_base::budget::reserve(|| format!("{name}: its mesh"), mesh.heap_bytes())
        .map_err(|e| fail(here, e.to_string()))?;
    let field = MeshField::new(&mesh).map_err(|e| fail(here, format!("{name}: {e}")))?;
    Ok(Node::Surface(std::sync::Arc::new(field)))
}

/// A picture with its projection (`pattern` and `relief` nodes): `image` (grey levels
/// in [0, 1]), `projection` planar (along z), cylindrical (around z) or spherical
/// (around the origin), `rect` in the projection's parameters (default: the box's x, y
/// for planar, all angles and the box's z for cylindrical, all angles for spherical),
/// `interp`.
pub(super) fn picture(
    v: &Value,
    here: &str,
    base_dir: &std::path::Path,
    bounds: Option<&Aabb>,
) -> Result<HeightMap, FieldError> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let w = WORLD_LIMIT;
    let o = v.as_object().expect("checked by the caller");
    let base = match o.get("projection").and_then(Value::as_str) {
        Some("planar") | None => Base::Plane,
        Some("cylindrical") => Base::Cylinder(1.0),
        Some("spherical") => Base::Ellipsoid([1.0; 3]),
        Some(other) => {
            return err(
                &format!("{here}.projection"),
                format!("`{other}`: expected planar, cylindrical or spherical"),
            )
        }
    };
    let rect = match (o.get("rect"), bounds, base) {
        (Some(r), _, _) => numbers(r, &format!("{here}.rect"), -w, w, "[u0, v0, u1, v1]")?,
        (None, Some(b), Base::Plane) => [b.lo[0], b.lo[1], b.hi[0], b.hi[1]],
        (None, Some(b), Base::Cylinder(_)) => [-PI, b.lo[2], PI, b.hi[2]],
        (None, _, Base::Ellipsoid(_)) => [-PI, -FRAC_PI_2, PI, FRAC_PI_2],
        (None, None, _) => return err(here, "needs `rect` (the picture's place)"),
    };
    let interp = interp_of(o, here)?;
    let file = image_file(o, here, base_dir)?;
    load_map(&file, here, 1.0, base, rect, f64::NEG_INFINITY, interp)
}

/// An image's grey levels (the mean of its colour channels, in [0, 1]) times `scale`.
fn grey_levels(
    path: &std::path::Path,
    at: &str,
    scale: f64,
) -> Result<(usize, usize, Vec<f64>), FieldError> {
    let raster = caoen_io::load(path).map_err(|e| bad(at, e.to_string()))?;
    let (iw, ih) = (raster.width() as usize, raster.height() as usize);
    // Alpha is not a colour: a grey image with alpha is its grey channel.
    let channels = raster.layout().colour_channels();
    // The samples and their pyramid, while the decoded image still lives.
    caoen_base::budget::check(
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
