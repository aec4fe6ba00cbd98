//! A sheet given a thickness: the solid within `T` of the mesh's triangles by their
//! unsigned distance (`T - dist >= 0` inside), polygonised on a grid and decimated
//! within a fraction of the fit's target, so the fit converts a closed surface.

use caoen_geometry::decimate::decimate;
use caoen_geometry::polygonise::polygonise;

use crate::distance::{self, SurfaceDistance};
use crate::PolygonMesh;

/// The thinnest thickness `--thicken` takes, as a fraction of the box's longest side:
/// thinner, the fit's smallest perturbation (0.0035 of the box) cannot follow the
/// solid's two sides apart.
pub const MIN_THICKNESS: f64 = 0.01;

/// The thickest, as a fraction of the box's longest side: beyond it the solid is a
/// blob that no longer shows the sheet.
pub const MAX_THICKNESS: f64 = 0.25;

/// Most grid cells along the longest side of the thickened solid's box.
pub const MAX_CELLS: usize = 160;

/// The thickened surface's vertices lie within this fraction of a grid cell of the
/// thickness after decimation.
const DECIMATION_DEVIATION: f64 = 0.05;

/// Why a thickness is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "--thicken {thickness}: expected a thickness from {min:.4e} to {max:.4e} in the mesh's \
     units ({min_fraction} to {max_fraction} of the box's longest side, {side:.4e}): \
     thinner the fit cannot follow the solid's two sides, thicker it hides the sheet"
)]
pub struct ThicknessError {
    /// The thickness asked (mesh units).
    pub thickness: f64,
    /// The least taken (mesh units).
    pub min: f64,
    /// The most taken (mesh units).
    pub max: f64,
    /// The box's longest side (mesh units).
    pub side: f64,
    /// [`MIN_THICKNESS`].
    pub min_fraction: f64,
    /// [`MAX_THICKNESS`].
    pub max_fraction: f64,
}

/// `thickness` (mesh units) as a fraction of the longest side of `mesh`'s box, if it
/// is within [`MIN_THICKNESS`] and [`MAX_THICKNESS`].
pub fn relative(mesh: &PolygonMesh, thickness: f64) -> Result<f64, ThicknessError> {
    let side = 1.0 / mesh.unit_frame().scale;
    let t = thickness / side;
    if t.is_finite() && (MIN_THICKNESS..=MAX_THICKNESS).contains(&t) {
        return Ok(t);
    }
    Err(ThicknessError {
        thickness,
        min: MIN_THICKNESS * side,
        max: MAX_THICKNESS * side,
        side,
        min_fraction: MIN_THICKNESS,
        max_fraction: MAX_THICKNESS,
    })
}

/// The grid's corner, cell and cells along the longest side for the solid within `t`
/// (unit cube) of the unit mesh with box `[lo, hi]`: half the thickness a cell, at
/// most [`MAX_CELLS`], and two cells of margin.
fn grid(lo: [f64; 3], hi: [f64; 3], t: f64) -> ([f64; 3], [f64; 3], usize) {
    let longest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) + 2.0 * t;
    let cell = (0.5 * t).max(longest / (MAX_CELLS - 4) as f64);
    let pad = t + 2.0 * cell;
    let cells = ((longest + 4.0 * cell) / cell).ceil() as usize;
    (lo.map(|v| v - pad), hi.map(|v| v + pad), cells)
}

/// Bytes [`thickened`] allocates for `mesh` at thickness `t` (fraction of the box),
/// an upper bound: the distance tree, the grid's values, and per cell the surface
/// passes through (at most three times the sheet's two sides' area over a cell's face,
/// plus the rim) up to twelve triangles and seven vertices with the polygoniser's and
/// the decimation's tables beside them (2,000 bytes).
pub fn thicken_memory(mesh: &PolygonMesh, t: f64) -> u64 {
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let (lo, hi) = unit.bounds();
    let (glo, ghi, cells) = grid(lo, hi, t);
    let cell = (0..3).map(|k| ghi[k] - glo[k]).fold(0.0, f64::max) / cells as f64;
    let n = cells as f64 + 1.0;
    let surface_cells = (6.0 * unit.area() / (cell * cell) + 6.0 * n * n).min(n * n * n);
    mesh.triangles.len() as u64 * distance::BYTES_PER_TRIANGLE
        + (n * n * n * 9.0 + surface_cells * 2000.0) as u64
}

/// The closed surface of the solid within `thickness` (mesh units, checked by
/// [`relative`]) of `mesh`'s triangles, in the mesh's coordinates; `t` is the
/// thickness as a fraction of the box.
pub fn thickened(mesh: &PolygonMesh, t: f64) -> PolygonMesh {
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let tree = SurfaceDistance::new(&unit);
    let (ulo, uhi) = unit.bounds();
    let (lo, hi, cells) = grid(ulo, uhi, t);
    let field = |p: [f64; 3]| tree.distance(p) - t;
    let surface = polygonise(&field, lo, hi, cells);
    let cell = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) / cells as f64;
    let distance = |p: [f64; 3]| (tree.distance(p) - t).abs();
    let (surface, _) = decimate(surface, &distance, DECIMATION_DEVIATION * cell, &[]);
    PolygonMesh {
        positions: surface
            .positions
            .iter()
            .map(|p| [0, 1, 2].map(|k| p[k] / frame.scale + frame.centre[k]))
            .collect(),
        triangles: surface.triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thickened_square_is_a_closed_slab_at_the_thickness() {
        let n = 8;
        let mut sheet = PolygonMesh::default();
        for j in 0..=n {
            for i in 0..=n {
                sheet
                    .positions
                    .push([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = (j * (n + 1) + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
                sheet.triangles.extend([[a, b, d], [a, d, c]]);
            }
        }
        assert!(relative(&sheet, 0.001).is_err());
        assert!(relative(&sheet, 0.5).is_err());
        assert!(relative(&sheet, f64::NAN).is_err());
        let e = relative(&sheet, -1.0).unwrap_err().to_string();
        assert!(e.contains("-1") && e.contains("1.0000e-2"), "{e}");
        let t = relative(&sheet, 0.05).unwrap();
        let slab = thickened(&sheet, t);
        assert!(slab.topology().is_closed(), "{:?}", slab.topology());
        let tree = SurfaceDistance::new(&sheet);
        // Within a tenth of the thickness everywhere (the rounded rim's corners sag
        // between grid edges), within a fiftieth on average.
        let off: Vec<f64> = slab
            .positions
            .iter()
            .map(|p| (tree.distance(*p) - 0.05).abs())
            .collect();
        assert!(
            off.iter().all(|d| *d < 0.005),
            "{:?}",
            off.iter().cloned().fold(0.0, f64::max)
        );
        assert!(off.iter().sum::<f64>() / (off.len() as f64) < 0.001);
        // Twice the square's area and the rim, a half cylinder of radius T along the
        // four sides (4 pi T = 0.63).
        let area = slab.area();
        assert!((area - 2.63).abs() < 0.05, "{area}");
    }
}
