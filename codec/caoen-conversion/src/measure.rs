//! How far an implicit model is from its mesh, as `caoen convert` and `caoen deviation`
//! report it: vertex distances and normal angles, and depth buffers from axis views,
//! with an optional picture of the views (mesh, model, difference).

use caoen_base::budget::{Limits, OverBudget};
use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};

use crate::deviation::{self, DepthDeviation, FieldGrid, VertexDeviation};
use crate::{ImplicitField, PolygonMesh};

/// Everything a deviation measures.
#[derive(Debug, Clone)]
pub struct Measured {
    /// Distances and normal angles at the mesh's vertices.
    pub vertex: VertexDeviation,
    /// Each view's depth-buffer comparison, by the view's name.
    pub depth: Vec<(&'static str, DepthDeviation)>,
    /// Mean over the views of the depth error where either sees the model.
    pub mean_depth: f64,
    /// Mean over the views of the depth error over all pixels.
    pub mean_all: f64,
    /// Mean over the views of the depth error where both see the model.
    pub mean_both: f64,
}

/// What [`measure`] is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeasureOptions {
    /// Depth buffers of `size x size` pixels.
    pub size: usize,
    /// Axis views, 1..=6.
    pub views: usize,
    /// Whether to draw the picture of the views.
    pub picture: bool,
    /// The side of the field lattice, at least 2 ([`grid_side`] of `size` unless a
    /// costly field asks for a coarser one).
    pub grid: usize,
}

/// The side of the field grid the depth buffers of `size` pixels are cast through.
pub fn grid_side(size: usize) -> usize {
    (size / 2 + 1).clamp(65, 257)
}

/// Field evaluations [`measure`] makes at most, about: the grid, then per view and
/// pixel the steps near the surface and the root search (24), and per vertex its
/// projection onto the surface (20).
pub fn measure_evaluations(opts: &MeasureOptions, vertices: usize) -> f64 {
    let (size, views) = (opts.size, opts.views);
    (opts.grid as f64).powi(3) + (views * size * size) as f64 * 24.0 + vertices as f64 * 20.0
}

/// Seconds of one core per evaluation of `field`, timed on points spread over the box
/// the grid covers (for at most about 50 ms, so a costly field is timed on fewer).
pub fn evaluation_seconds(field: &dyn ImplicitField) -> f64 {
    let start = std::time::Instant::now();
    let mut count = 0u32;
    let mut sink = 0.0;
    'outer: for z in 0..8 {
        for y in 0..8 {
            for x in 0..8 {
                let c = |i: i32| -0.6 + 1.2 * f64::from(i) / 7.0;
                sink += field.value([c(x), c(y), c(z)]);
                count += 1;
                if count >= 8 && start.elapsed().as_secs_f64() > 0.05 {
                    break 'outer;
                }
            }
        }
    }
    std::hint::black_box(sink);
    start.elapsed().as_secs_f64() / f64::from(count)
}

/// Bytes [`measure`] holds: the grid's values (8 bytes a point), then per cell its top
/// value and step (16) and its flag while the flags are made, and the views' buffers.
pub fn measure_memory(size: usize, grid: usize) -> u64 {
    (grid as u64)
        .pow(3)
        .saturating_mul(25)
        .saturating_add((size * size * 64 * 6) as u64)
}

/// Measures `field` against `unit` (the mesh in the unit frame the field lives in),
/// within `limits`; the picture (when asked) has one row per view: the mesh shaded,
/// the model shaded and their depth difference.
pub fn measure(
    field: &dyn ImplicitField,
    unit: &PolygonMesh,
    opts: MeasureOptions,
    limits: &Limits,
) -> Result<(Measured, Option<Raster>), OverBudget> {
    let size = opts.size;
    let n = opts.grid.max(2);
    limits.check(|| format!("a {n}^3 field grid"), measure_memory(size, n))?;
    let normals = unit.outward_normals();
    let vertex = deviation::vertex_deviation(field, unit, &normals);
    let grid = FieldGrid::new(field, n);
    let views = deviation::views(opts.views);
    let mut depth = Vec::new();
    let mut tiles = Vec::new();
    for v in &views {
        let m = deviation::mesh_depth(unit, v, size);
        let f = deviation::field_depth(field, &grid, v, size);
        depth.push((v.name, deviation::compare_depth(&m, &f)));
        if opts.picture {
            tiles.push((
                deviation::shade(&m, v),
                deviation::shade(&f, v),
                deviation::difference_picture(&m, &f, 0.02),
            ));
        }
    }
    let over_views = |f: fn(&DepthDeviation) -> f64| {
        depth.iter().map(|d| f(&d.1)).sum::<f64>() / depth.len() as f64
    };
    let (mean_depth, mean_all, mean_both) = (
        over_views(|d| d.mean),
        over_views(|d| d.mean_all),
        over_views(|d| d.mean_both),
    );
    let picture = opts.picture.then(|| views_picture(&tiles, size));
    Ok((
        Measured {
            vertex,
            depth,
            mean_depth,
            mean_all,
            mean_both,
        },
        picture,
    ))
}

/// One view's tiles: the mesh shaded, the model shaded (grey), their difference (RGB).
type ViewTiles = (Vec<u8>, Vec<u8>, Vec<[u8; 3]>);

/// The views' tiles side by side (mesh, model, difference), one view a row, as an
/// 8-bit RGB raster.
fn views_picture(tiles: &[ViewTiles], size: usize) -> Raster {
    let (w, h) = (3 * size, tiles.len() * size);
    let n = w * h;
    let mut samples = vec![0.0f32; 3 * n];
    let mut put = |x: usize, y: usize, rgb: [u8; 3]| {
        for (c, v) in rgb.into_iter().enumerate() {
            samples[c * n + y * w + x] = f32::from(v) / 255.0;
        }
    };
    for (row, (mesh, model, diff)) in tiles.iter().enumerate() {
        for k in 0..size * size {
            let (x, y) = (k % size, row * size + k / size);
            put(x, y, [mesh[k]; 3]);
            put(x + size, y, [model[k]; 3]);
            put(x + 2 * size, y, diff[k]);
        }
    }
    Raster::new(
        w as u32,
        h as u32,
        ChannelLayout::Rgb,
        SampleFormat::U8,
        samples,
    )
    .expect("a picture of finite samples in 0..=1")
}
