//! The connected parts of a converted model, each matched to the mesh: the fitted
//! field is sampled on a grid over the mesh's box, the inside points are grouped by
//! 6-connectivity, and a part whose boundary points mostly lie away from the mesh's
//! triangles is spurious (a floating ball or sheet the fit made between conditions).
//! A spurious part away from the real ones is cut out with a box; one that cannot be
//! cut is reported.

use std::path::Path;

use caoen_base::budget::Limits;
use rayon::prelude::*;
use serde_json::{json, Value};

use crate::distance::{self, SurfaceDistance};
use crate::{ImplicitField, InUnitCube, PolygonMesh, UnitFrame};

/// Grid cells along the mesh box's longest side.
pub const GRID: usize = 64;

/// A part matches the mesh when at least this fraction of its boundary points lie
/// within [`NEAR_CELLS`] cells of the mesh's triangles.
pub const MATCHED_FRACTION: f64 = 0.5;

/// How near (in grid cells) a boundary point must be to the mesh to count as on it:
/// the model's surface lies within a cell of its boundary points, and the fit's
/// surface within a fraction of a cell of the mesh.
pub const NEAR_CELLS: f64 = 1.5;

/// Most spurious parts cut out of one model (each adds two nodes).
pub const MAX_CUTS: usize = 32;

/// One connected part of a model's inside.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Grid points inside it.
    pub points: usize,
    /// Its volume in the mesh's units (points times a cell's volume).
    pub volume: f64,
    /// Least corner of its box (mesh coordinates).
    pub lo: [f64; 3],
    /// Greatest corner of its box (mesh coordinates).
    pub hi: [f64; 3],
    /// The fraction of its boundary points near the mesh.
    pub near_fraction: f64,
    /// Whether it matches a part of the mesh.
    pub matched: bool,
}

/// A model's connected parts, largest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Components {
    /// The parts.
    pub parts: Vec<Part>,
    /// The grid's cell side (mesh units).
    pub cell: f64,
}

impl Components {
    /// The parts that match no part of the mesh.
    pub fn spurious(&self) -> Vec<&Part> {
        self.parts.iter().filter(|p| !p.matched).collect()
    }
}

/// Bytes [`components`] allocates for a mesh of `triangles`, an upper bound: the
/// grid's values and labels (a few cells of margin each side), the distance tree and
/// the copy of the mesh it is matched against (a triangle and half a vertex's position).
pub fn components_memory(triangles: usize) -> u64 {
    let side = (GRID + 8) as u64;
    side * side * side * (8 + 4 + 4) + triangles as u64 * (distance::BYTES_PER_TRIANGLE + 24)
}

/// The grid over the unit mesh's box with two cells of margin: its corner, cell and
/// point counts.
fn grid_of(unit: &PolygonMesh) -> ([f64; 3], f64, [usize; 3]) {
    let (lo, hi) = unit.bounds();
    let cell = 1.0 / GRID as f64;
    let lo = lo.map(|v| v - 2.0 * cell);
    let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / cell).ceil() as usize + 3).min(GRID + 8));
    (lo, cell, dims)
}

/// The connected parts of `field` (in the unit cube of `frame`, the frame of the mesh
/// whose unit-cube copy is `unit`), matched against `unit`'s triangles.
pub fn components(field: &dyn ImplicitField, unit: &PolygonMesh, frame: &UnitFrame) -> Components {
    let (lo, cell, [nx, ny, nz]) = grid_of(unit);
    let at = |i: usize, j: usize, k: usize| {
        [
            lo[0] + i as f64 * cell,
            lo[1] + j as f64 * cell,
            lo[2] + k as f64 * cell,
        ]
    };
    let inside: Vec<bool> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|n| {
            let (i, j, k) = (n % nx, n / nx % ny, n / (nx * ny));
            field.value(at(i, j, k)) >= 0.0
        })
        .collect();
    let tree = SurfaceDistance::new(unit);
    let mut label = vec![u32::MAX; inside.len()];
    let mut parts = Vec::new();
    let mut queue = Vec::new();
    for seed in 0..inside.len() {
        if !inside[seed] || label[seed] != u32::MAX {
            continue;
        }
        let id = parts.len() as u32;
        label[seed] = id;
        queue.push(seed);
        let (mut points, mut boundary) = (0usize, Vec::new());
        let (mut plo, mut phi) = ([usize::MAX; 3], [0usize; 3]);
        while let Some(n) = queue.pop() {
            points += 1;
            let c = [n % nx, n / nx % ny, n / (nx * ny)];
            for k in 0..3 {
                plo[k] = plo[k].min(c[k]);
                phi[k] = phi[k].max(c[k]);
            }
            let dims = [nx, ny, nz];
            let stride = [1, nx, nx * ny];
            let mut on_boundary = false;
            for k in 0..3 {
                for down in [true, false] {
                    if (down && c[k] == 0) || (!down && c[k] + 1 == dims[k]) {
                        on_boundary = true;
                        continue;
                    }
                    let m = if down { n - stride[k] } else { n + stride[k] };
                    if !inside[m] {
                        on_boundary = true;
                    } else if label[m] == u32::MAX {
                        label[m] = id;
                        queue.push(m);
                    }
                }
            }
            if on_boundary {
                boundary.push(at(c[0], c[1], c[2]));
            }
        }
        let near = boundary
            .par_iter()
            .filter(|p| tree.distance(**p) <= NEAR_CELLS * cell)
            .count();
        let near_fraction = near as f64 / boundary.len().max(1) as f64;
        let back = |p: [f64; 3]| [0, 1, 2].map(|k| p[k] / frame.scale + frame.centre[k]);
        parts.push(Part {
            points,
            volume: points as f64 * (cell / frame.scale).powi(3),
            lo: back(at(plo[0], plo[1], plo[2])),
            hi: back(at(phi[0], phi[1], phi[2])),
            near_fraction,
            matched: near_fraction >= MATCHED_FRACTION,
        });
    }
    parts.sort_by_key(|p| std::cmp::Reverse(p.points));
    Components {
        parts,
        cell: cell / frame.scale,
    }
}

/// Boxes that cut `found`'s spurious parts out of its model, each one cell larger than
/// the part's own, or `None` when a box would reach the mesh (the sphere about it meets
/// a triangle) or the box of a part that matches it, or the cuts are too many.
pub fn cut_boxes(found: &Components, unit: &PolygonMesh, frame: &UnitFrame) -> Option<Vec<Value>> {
    let spurious = found.spurious();
    if spurious.is_empty() || spurious.len() > MAX_CUTS {
        return None;
    }
    let tree = SurfaceDistance::new(unit);
    let overlaps =
        |a: &Part, lo: [f64; 3], hi: [f64; 3]| (0..3).all(|k| a.lo[k] <= hi[k] && a.hi[k] >= lo[k]);
    let mut boxes = Vec::new();
    for p in spurious {
        let lo = p.lo.map(|v| v - found.cell);
        let hi = p.hi.map(|v| v + found.cell);
        let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let size = [0, 1, 2].map(|k| hi[k] - lo[k]);
        let half_diagonal = 0.5 * size.iter().map(|s| s * s).sum::<f64>().sqrt();
        let reaches_mesh = tree.distance(frame.to_unit(centre)) <= half_diagonal * frame.scale;
        let reaches_part = found.parts.iter().any(|q| q.matched && overlaps(q, lo, hi));
        if reaches_mesh || reaches_part {
            return None;
        }
        boxes.push(json!({"box": {"centre": centre, "size": size}}));
    }
    Some(boxes)
}

/// The model file `file` with `boxes` (from [`cut_boxes`]) cut out of its model.
pub fn without(file: &Value, boxes: &[Value]) -> Value {
    let mut out = file.clone();
    let model = out["model"].take();
    let operands: Vec<Value> = std::iter::once(model)
        .chain(boxes.iter().cloned())
        .collect();
    out["model"] = json!({"difference": operands, "a": 1});
    out
}

/// The connected parts of the model file `file`'s model, measured against the mesh's
/// unit-cube copy `unit` (`None` when the file's model cannot be loaded).
pub fn of_file(
    file: &Value,
    unit: &PolygonMesh,
    frame: UnitFrame,
    limits: &Limits,
) -> Option<Components> {
    let node = caoen_frep::Node::from_json(&file["model"], "model", Path::new("."), limits).ok()?;
    let field = InUnitCube {
        field: &node,
        frame,
    };
    Some(components(&field, unit, &frame))
}

/// A part's size and place in words.
pub fn part_text(p: &Part) -> String {
    let f = |v: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]);
    format!(
        "a part of volume {:.4e} from {} to {}, {:.0}% of its boundary near the mesh",
        p.volume,
        f(p.lo),
        f(p.hi),
        100.0 * p.near_fraction
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two balls of radius 0.3 at x = -0.6 and 0.6, the mesh's and the model's.
    fn two_balls() -> (PolygonMesh, Value) {
        let mut mesh = PolygonMesh::ellipsoid([0.3, 0.3, 0.3], 4);
        let n = mesh.positions.len() as u32;
        let mut right = mesh.clone();
        mesh.positions.iter_mut().for_each(|p| p[0] -= 0.6);
        right.positions.iter_mut().for_each(|p| p[0] += 0.6);
        mesh.positions.extend(right.positions);
        mesh.triangles
            .extend(right.triangles.iter().map(|t| t.map(|v| v + n)));
        let ball = |x: f64, r: f64| json!({"sphere": {"centre": [x, 0.0, 0.0], "radius": r}});
        let model = json!({"union": [ball(-0.6, 0.3), ball(0.6, 0.3)], "a": 1});
        (
            mesh,
            json!({"format": "caoen-frep/1", "name": "two", "model": model}),
        )
    }

    #[test]
    fn a_ball_the_mesh_lacks_is_found_and_cut_out() {
        let (mesh, clean) = two_balls();
        let frame = mesh.unit_frame();
        let unit = mesh.transformed(&frame);
        let limits = Limits::default();
        let found = of_file(&clean, &unit, frame, &limits).unwrap();
        assert_eq!(found.parts.len(), 2, "{found:?}");
        assert!(found.spurious().is_empty(), "{found:?}");
        // A ball between the two that the mesh lacks.
        let mut file = clean.clone();
        file["model"]["union"]
            .as_array_mut()
            .unwrap()
            .push(json!({"sphere": {"centre": [0.0, 0.05, 0.0], "radius": 0.1}}));
        let found = of_file(&file, &unit, frame, &limits).unwrap();
        let spurious = found.spurious();
        assert_eq!((found.parts.len(), spurious.len()), (3, 1), "{found:?}");
        let p = spurious[0];
        assert!(p.near_fraction < 0.1, "{p:?}");
        assert!((0..3).all(|k| p.lo[k] > -0.15 && p.hi[k] < 0.2), "{p:?}");
        let volume = 4.0 / 3.0 * std::f64::consts::PI * 1e-3;
        assert!(
            (p.volume / volume - 1.0).abs() < 0.5,
            "{} {volume}",
            p.volume
        );
        assert!(part_text(p).contains("volume"));
        let cut = without(&file, &cut_boxes(&found, &unit, &frame).expect("boxes"));
        let again = of_file(&cut, &unit, frame, &limits).unwrap();
        assert_eq!(again.parts.len(), 2, "{again:?}");
        assert!(again.spurious().is_empty());
        // A ball touching a real one merges with it: no separate part to cut.
        file["model"]["union"][2]["sphere"]["centre"] = json!([-0.3, 0.0, 0.0]);
        let found = of_file(&file, &unit, frame, &limits).unwrap();
        assert_eq!(found.parts.len(), 2, "{found:?}");
        // A ball that cannot be cut without reaching the mesh is left (and reported).
        file["model"]["union"][2]["sphere"]["centre"] = json!([0.0, 0.0, 0.0]);
        file["model"]["union"][2]["sphere"]["radius"] = json!(0.25);
        let found = of_file(&file, &unit, frame, &limits).unwrap();
        assert_eq!(found.spurious().len(), 1, "{found:?}");
        assert!(cut_boxes(&found, &unit, &frame).is_none());
    }
}
