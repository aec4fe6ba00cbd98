//! Meshes of F-rep solids: marching tetrahedra over the model's box, then every vertex
//! moved onto the surface by Newton steps along the gradient (linear interpolation on
//! a cell edge only approximates the crossing), with normals from the exact gradient.
//! Where sharp set operations (`a = 1`: max and min) meet, and along a box's or a
//! cylinder's edges, the crease is made sharp as for convex-solid CSG
//! (`render::crease`): the field's pieces below the sharp operations are its leaves.

use super::interval::Aabb;
use super::node::Node;
use super::primitive::Primitive;
use super::rfunction::SetOp;
use caoen_base::budget::{Limits, OverBudget};
use caoen_geometry::crease::{sharpen_with, Leaves};
use caoen_geometry::decimate::decimate;
use caoen_geometry::flat::snap_flat_faces;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::polygonise::{grid_points, polygonise, polygonise_closed_admitted, MeshSize};
use caoen_geometry::printable::{make_printable, Repair};
use caoen_geometry::untangle::{crossing_pairs, untangle};

/// One smooth piece of a field below its sharp set operations.
#[derive(Debug, Clone, Copy)]
enum Piece<'a> {
    /// A whole sub-model (smooth, or sharp in ways not split further).
    Whole(&'a Node),
    /// `h^2 - (p - c)_axis^2`: a box's or a cylinder's pair of faces across `axis`.
    Slab {
        centre: [f64; 3],
        half: f64,
        axis: usize,
    },
    /// `r^2 - (p - c)_x^2 - (p - c)_y^2`: a cylinder's side.
    Side { centre: [f64; 3], radius: f64 },
}

impl Piece<'_> {
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match *self {
            Piece::Whole(n) => n.value_gradient(p),
            Piece::Slab { centre, half, axis } => {
                let q = p[axis] - centre[axis];
                let mut g = [0.0; 3];
                g[axis] = -2.0 * q;
                (half * half - q * q, g)
            }
            Piece::Side { centre, radius } => {
                let (x, y) = (p[0] - centre[0], p[1] - centre[1]);
                (radius * radius - x * x - y * y, [-2.0 * x, -2.0 * y, 0.0])
            }
        }
    }
}

/// A model's leaves for sharpening: its pieces in depth-first order, each with the sign
/// it enters the model with (-1 below an odd number of subtractions).
struct FieldLeaves<'a> {
    root: &'a Node,
    pieces: Vec<(Piece<'a>, f64)>,
}

/// Whether `node` is a set operation computed as max or min.
fn sharp_op(node: &Node) -> Option<(SetOp, &[Node])> {
    match node {
        Node::SetOp { op, a, operands } if *a == 1.0 => Some((*op, operands)),
        _ => None,
    }
}

fn collect<'a>(node: &'a Node, sign: f64, out: &mut Vec<(Piece<'a>, f64)>) {
    if let Some((op, operands)) = sharp_op(node) {
        for (k, n) in operands.iter().enumerate() {
            let flip = op == SetOp::Difference && k > 0;
            collect(n, if flip { -sign } else { sign }, out);
        }
        return;
    }
    match node {
        Node::Primitive(Primitive::Box { centre, half }) => {
            for (axis, h) in half.iter().enumerate() {
                let piece = Piece::Slab {
                    centre: *centre,
                    half: *h,
                    axis,
                };
                out.push((piece, sign));
            }
        }
        Node::Primitive(Primitive::Cylinder {
            centre,
            radius,
            length,
        }) => {
            let side = Piece::Side {
                centre: *centre,
                radius: *radius,
            };
            let caps = Piece::Slab {
                centre: *centre,
                half: 0.5 * length,
                axis: 2,
            };
            out.push((side, sign));
            out.push((caps, sign));
        }
        _ => out.push((Piece::Whole(node), sign)),
    }
}

impl FieldLeaves<'_> {
    /// The model's value at `p` (as `Node::value`: max and min are exact) and the piece
    /// it comes from; `next` is the index of the first piece of `node`.
    fn eval(&self, node: &Node, p: [f64; 3], next: &mut usize) -> (f64, usize) {
        if let Some((op, operands)) = sharp_op(node) {
            let mut acc: Option<(f64, usize)> = None;
            for (k, n) in operands.iter().enumerate() {
                let (v, i) = self.eval(n, p, next);
                let v = if op == SetOp::Difference && k > 0 {
                    -v
                } else {
                    v
                };
                acc = Some(match acc {
                    None => (v, i),
                    Some(a) => {
                        let take = match op {
                            SetOp::Union => v > a.0,
                            SetOp::Intersection | SetOp::Difference => v < a.0,
                        };
                        if take {
                            (v, i)
                        } else {
                            a
                        }
                    }
                });
            }
            return acc.expect("set operations have operands");
        }
        let count = match node {
            Node::Primitive(Primitive::Box { .. }) => 3,
            Node::Primitive(Primitive::Cylinder { .. }) => 2,
            _ => 1,
        };
        let first = *next;
        *next += count;
        (first..first + count)
            .map(|i| (self.pieces[i].0.value_gradient(p).0, i))
            .fold((f64::INFINITY, first), |a, b| if b.0 < a.0 { b } else { a })
    }
}

impl Leaves for FieldLeaves<'_> {
    fn leaf(&self, i: usize, p: [f64; 3]) -> (f64, [f64; 3]) {
        // The crease module's fields are negative inside.
        let (piece, sign) = &self.pieces[i];
        let (v, g) = piece.value_gradient(p);
        (-sign * v, g.map(|x| -sign * x))
    }

    fn active(&self, p: [f64; 3]) -> usize {
        self.eval(self.root, p, &mut 0).1
    }
}

/// Newton steps per vertex: each roughly squares the relative error of a smooth field.
const PROJECTION_STEPS: u32 = 4;

/// The closed mesh of `node`'s boundary within `bounds`, `cells` cells along the
/// longest side, with vertices on the creases where the model's pieces below its sharp
/// set operations meet (one normal per vertex).
pub fn mesh(node: &Node, bounds: &Aabb, cells: usize) -> Mesh {
    sharp(node, bounds, cells, false)
}

/// As [`mesh`], with the vertices on a crease split between the pieces that meet there,
/// each with its own piece's normal, so shading keeps the crease sharp (for rendering).
pub fn render_mesh(node: &Node, bounds: &Aabb, cells: usize) -> Mesh {
    sharp(node, bounds, cells, true)
}

fn sharp(node: &Node, bounds: &Aabb, cells: usize, split: bool) -> Mesh {
    let m = smooth_mesh(node, bounds, cells);
    let mut pieces = Vec::new();
    collect(node, 1.0, &mut pieces);
    if pieces.len() < 2 {
        return m;
    }
    let cells = cells.max(1) as f64;
    let cell = bounds.padded(bounds.longest() / cells).longest() / cells;
    sharpen_with(m, &FieldLeaves { root: node, pieces }, cell, split)
}

/// Why a solid's mesh cannot be printed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolidMeshError {
    /// No triangles at all.
    #[error(
        "the mesh is empty: no grid point of {cells} cells along the longest side (cell {cell:.3e}) \
         is inside the model; the solid is empty or thinner than a cell (try more cells)"
    )]
    Empty {
        /// Cells along the longest side.
        cells: usize,
        /// The cell's side.
        cell: f64,
    },
    /// Edges not shared by exactly two consistently wound triangles.
    #[error("the mesh is not closed: {bad_edges} edges are not shared by exactly two consistently wound triangles")]
    Open {
        /// How many.
        bad_edges: usize,
    },
    /// Zero-area triangles no collapse could remove.
    #[error("{0} zero-area triangles could not be removed without breaking the surface")]
    Degenerate(usize),
    /// The mesh, counted once the field was sampled, needs more memory than allowed.
    #[error(transparent)]
    OverBudget(#[from] OverBudget),
}

/// Pieces smaller than this fraction of the largest piece's volume are specks of the
/// polygonisation (a spike thinner than a cell), not parts of the model.
pub const SPECK_FRACTION: f64 = 1e-3;

/// Peak memory of polygonising on `cells`^3 cells: the grid (its values and the
/// polygoniser's bookkeeping per corner) dominates, vertices and triangles follow the
/// area. 16 bytes a corner bound the peak measured (874 MiB for 400 cells).
pub fn polygonise_memory(cells: u32) -> u64 {
    (u64::from(cells) + 2).pow(3).saturating_mul(16)
}

/// Bytes per grid point while a mesh is built: the field's value, whether the point was
/// forced outside, and the vector's growth while it is collected.
const GRID_POINT_BYTES: u64 = 16;

/// Bytes per counted triangle while the grid mesh is built beside the grid: its
/// positions, the map from grid edges to vertices and the triangles, each as a vector
/// that may have doubled.
const BUILD_TRIANGLE_BYTES: u64 = 160;

/// Bytes per counted triangle from the grid mesh to the file, once the grid is gone:
/// normals, the sharpening, untangling, cleaning and decimation's bookkeeping. The
/// most measured is 360 (a carved lattice, 421k triangles, decimated; a lithophane, a
/// spherical shell and a ball between 310 and 340).
const MESH_TRIANGLE_BYTES: u64 = 440;

/// The process and the model around the mesh (the executable, the field's tables).
const MESH_BASE_BYTES: u64 = 24 << 20;

/// Upper bound of the memory [`solid_mesh_with`] needs before it samples the field:
/// the grid of the largest of its tries (`cells` + 2), on `bounds` as it pads them.
pub fn solid_mesh_grid_memory(bounds: &Aabb, cells: usize) -> u64 {
    let cells = cells.max(1) + 2;
    let b = bounds.padded(bounds.longest() / cells as f64);
    grid_points(b.lo, b.hi, cells).saturating_mul(GRID_POINT_BYTES)
}

/// Upper bound of the memory a printable mesh of `size` (as counted from the sampled
/// grid) needs from then on: the grid while the mesh is built, then the mesh through
/// every stage to the file.
pub fn solid_mesh_memory(size: MeshSize) -> u64 {
    let grid = (size.grid_points as u64).saturating_mul(GRID_POINT_BYTES);
    let t = size.triangles as u64;
    let building = grid.saturating_add(t.saturating_mul(BUILD_TRIANGLE_BYTES));
    building
        .max(t.saturating_mul(MESH_TRIANGLE_BYTES))
        .saturating_add(MESH_BASE_BYTES)
}

/// A mesh to print: as [`mesh`] on a grid whose outer layer is outside (closed even
/// where the solid reaches `bounds`, which then cuts it), vertices clamped into
/// `bounds`, zero-area triangles collapsed away and specks dropped; an error if the
/// result is empty or not a closed, consistently wound manifold.
///
/// A grid whose vertices fold onto one line where no collapse or flip can undo it (a
/// rare coincidence of the grid with the surface) is replaced by one with a cell more
/// (at most two more); `Repair::cells` says which grid made the mesh.
pub fn solid_mesh(
    node: &Node,
    bounds: &Aabb,
    cells: usize,
) -> Result<(Mesh, Repair), SolidMeshError> {
    solid_mesh_with(node, bounds, cells, true, &Limits::new(u64::MAX))
}

/// Farthest a decimated triangle's checked points may be from the surface, in cells
/// (by `|f| / |grad f|`): about what the grid mesh's own triangles are off a gently
/// curved surface, so decimation keeps the grid's accuracy.
pub const DECIMATION_DEVIATION: f64 = 0.02;

/// As [`solid_mesh`]; with `adaptive` the mesh is decimated by quadric error
/// (`geometry::decimate`) within [`DECIMATION_DEVIATION`] of a cell of the surface,
/// without it every grid cell the surface crosses keeps its triangles. Once the field
/// is sampled, the mesh's memory ([`solid_mesh_memory`]) is checked against `limits`
/// before it is built.
pub fn solid_mesh_with(
    node: &Node,
    bounds: &Aabb,
    cells: usize,
    adaptive: bool,
    limits: &Limits,
) -> Result<(Mesh, Repair), SolidMeshError> {
    let cells = cells.max(1);
    let mut first = None;
    for c in cells..cells + 3 {
        match solid_mesh_on(node, bounds, c, adaptive, limits) {
            Ok((m, mut rep)) => {
                rep.cells = c;
                return Ok((m, rep));
            }
            Err(e @ (SolidMeshError::Empty { .. } | SolidMeshError::OverBudget(_))) => {
                return Err(e)
            }
            Err(e) => {
                first.get_or_insert(e);
            }
        }
    }
    Err(first.expect("three tries"))
}

fn solid_mesh_on(
    node: &Node,
    bounds: &Aabb,
    cells: usize,
    adaptive: bool,
    limits: &Limits,
) -> Result<(Mesh, Repair), SolidMeshError> {
    let pad = bounds.longest() / cells as f64;
    let b = bounds.padded(pad);
    let refused = std::cell::Cell::new(None);
    let admit = |size: MeshSize| {
        let need = solid_mesh_memory(size);
        let what = || format!("a mesh of {} triangles on {cells} cells", size.triangles);
        limits
            .check(what, need)
            .map_err(|e| refused.set(Some(e)))
            .is_ok()
    };
    let Some((mut m, on_cut)) =
        polygonise_closed_admitted(&|p| -node.value(p), b.lo, b.hi, cells, &admit)
    else {
        return Err(refused.take().expect("refused by the budget").into());
    };
    let cell = b.longest() / cells as f64;
    if m.triangles.is_empty() {
        return Err(SolidMeshError::Empty { cells, cell });
    }
    // The grid's own placement cannot cross itself (see `untangle`): the way back.
    let mut rest = m.positions.clone();
    project(node, &mut m, pad, &on_cut);
    let mut pieces = Vec::new();
    collect(node, 1.0, &mut pieces);
    if pieces.len() >= 2 {
        rest = first_use_order(&m.triangles, &rest);
        m = sharpen_with(m, &FieldLeaves { root: node, pieces }, cell, false);
    }
    let untangled = untangle(&mut m.positions, &rest, &m.triangles);
    // Thinner than a hundred-thousandth of a cell: zero area to any slicer.
    let (m, rep) = make_printable(m, bounds.lo, bounds.hi, 1e-5 * cell, SPECK_FRACTION);
    if m.triangles.is_empty() {
        return Err(SolidMeshError::Empty { cells, cell });
    }
    if rep.bad_edges > 0 {
        return Err(SolidMeshError::Open {
            bad_edges: rep.bad_edges,
        });
    }
    if rep.degenerate_left > 0 {
        return Err(SolidMeshError::Degenerate(rep.degenerate_left));
    }
    let mut rep = rep;
    rep.untangled = untangled.moved;
    // Within rounding of a plane is not on it, to a slicer's crossing test.
    let mut m = m;
    snap_flat_faces(&mut m.positions, &m.triangles, 1e-7 * cell);
    let m = if adaptive {
        let (lo, hi) = (bounds.lo, bounds.hi);
        // A cut face lies on the box: its distance is to the box's nearest face.
        let distance = |p: [f64; 3]| {
            let (f, g) = node.value_gradient(p);
            let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            let to_surface = if len > 0.0 {
                f.abs() / len
            } else {
                f64::INFINITY
            };
            let to_box = (0..3)
                .map(|k| (p[k] - lo[k]).abs().min((hi[k] - p[k]).abs()))
                .fold(f64::INFINITY, f64::min);
            to_surface.min(to_box)
        };
        let (d, _) = decimate(m, &distance, DECIMATION_DEVIATION * cell, &[]);
        d
    } else {
        m
    };
    rep.crossings = crossing_pairs(&m.positions, &m.triangles).len();
    Ok((m, rep))
}

/// `values` renumbered as `sharpen_with` renumbers vertices when it does not split
/// them: in the order the triangles first use them.
fn first_use_order(tris: &[[u32; 3]], values: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut seen = vec![false; values.len()];
    let mut out = Vec::with_capacity(values.len());
    for &v in tris.iter().flatten() {
        if !std::mem::replace(&mut seen[v as usize], true) {
            out.push(values[v as usize]);
        }
    }
    out
}

/// The mesh without sharpened creases: every vertex projected onto the surface, with
/// the gradient's direction as its normal.
pub fn smooth_mesh(node: &Node, bounds: &Aabb, cells: usize) -> Mesh {
    // One cell of margin so the surface never touches the grid's faces.
    let pad = bounds.longest() / cells.max(1) as f64;
    let b = bounds.padded(pad);
    // polygonise puts the inside where the field is negative.
    let mut m = polygonise(&|p| -node.value(p), b.lo, b.hi, cells);
    project(node, &mut m, pad, &[]);
    m
}

/// Moves every vertex not flagged in `fixed` onto the surface by Newton steps (at most
/// `limit` from where it starts) and sets every normal from the gradient.
fn project(node: &Node, m: &mut Mesh, limit: f64, fixed: &[bool]) {
    for (i, (p, n)) in m.positions.iter_mut().zip(m.normals.iter_mut()).enumerate() {
        let start = *p;
        let steps = if fixed.get(i).copied().unwrap_or(false) {
            0
        } else {
            PROJECTION_STEPS
        };
        for _ in 0..steps {
            let (f, g) = node.value_gradient(*p);
            let g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            if g2.is_nan() || g2 <= 0.0 || !f.is_finite() {
                break;
            }
            let q = [0, 1, 2].map(|k| p[k] - f * g[k] / g2);
            // A step that leaves the vertex's cell would jump to another sheet of the
            // surface (near a sharp edge or a thin part): keep the last good point.
            let moved = (0..3)
                .map(|k| (q[k] - start[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if moved.is_nan() || moved > limit {
                break;
            }
            *p = q;
        }
        let (_, g) = node.value_gradient(*p);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if len > 0.0 {
            // Outward: f decreases outwards.
            *n = g.map(|v| -v / len);
        }
    }
}
