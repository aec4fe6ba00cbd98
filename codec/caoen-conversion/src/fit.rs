//! Fitting a converted model to a mesh: the base quadric, then perturbations added
//! level by level where the error is largest, each level's form factors solved
//! together by least squares (`docs/conversion.md`).
//!
//! Constraints are the mesh's points (`F = 0`), points a short step inside and outside
//! along the normal (`F = +d`, `F = -d`: without them a sum that is zero on the points
//! could also be zero everywhere near them) and a coarse grid of far points whose side
//! the mesh's winding number tells (`F` = clamped signed distance), so no spurious
//! surface appears away from the mesh.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::model::{Bump, ImplicitField, ImplicitModel};
use super::polygon_mesh::PolygonMesh;
use super::quadric;
use super::support::Supports;
use super::winding::WindingTree;
use caoen_frep::patch_index::PatchIndex;
use caoen_geometry::vector::{dot, norm, sub};

/// What the fit aims for and may spend.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConvertOptions {
    /// The most functions (the base quadric and the perturbations).
    pub max_functions: usize,
    /// The deviation target: every vertex within this distance of the surface (along
    /// the gradient), as a fraction of the bounding box's longest side.
    pub target: f64,
    /// Vertices whose normal is further than this from the gradient (degrees) are
    /// refined too.
    pub max_angle_deg: f64,
    /// The radius of the first level of perturbations (fraction of the box).
    pub first_radius: f64,
    /// The smallest radius a perturbation may have (fraction of the box).
    pub min_radius: f64,
    /// Sweeps of the paper's local descent after the fit (0: none).
    pub descent_sweeps: usize,
    /// The fit stops once the mean vertex angle (degrees) is at most this and the mean
    /// vertex distance at most [`ConvertOptions::fit_distance`].
    pub fit_angle_deg: f64,
    /// The mean vertex distance that, with [`ConvertOptions::fit_angle_deg`], stops the
    /// fit (unit cube).
    pub fit_distance: f64,
    /// Rounds at the smallest radius after the levels reach it.
    pub smallest_rounds: usize,
    /// Weight of the tangent conditions at the vertices (0: none).
    pub tangent_weight: f64,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            max_functions: 6000,
            target: 0.001,
            max_angle_deg: 10.0,
            first_radius: 0.32,
            min_radius: 0.0035,
            descent_sweeps: 8,
            fit_angle_deg: 2.4,
            fit_distance: 0.0003,
            smallest_rounds: 4,
            tangent_weight: 1e-2,
        }
    }
}

/// What one level of the fit did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelReport {
    /// The perturbations' radius (unit cube).
    pub radius: f64,
    /// Perturbations added.
    pub added: usize,
    /// Mean and largest vertex distance `|F| / |grad F|` after the level.
    pub mean_distance: f64,
    /// Largest vertex distance after the level.
    pub max_distance: f64,
    /// Vertices still over the targets.
    pub over_target: usize,
    /// Off-surface conditions on the wrong side of the surface.
    pub wrong_side: usize,
}

/// Why the fit stopped adding perturbations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// Every vertex met the per-vertex targets and no off-surface condition was on the
    /// wrong side.
    Met,
    /// The mean normal angle and mean distance met their targets.
    MeanMet,
    /// `max_functions` was spent.
    Budget,
    /// The levels reached the smallest radius and further rounds there stopped helping.
    SmallestRadius,
}

/// What the fit reports while it works.
#[derive(Debug, Clone, Copy)]
pub enum Progress<'a> {
    /// A step that takes a while starts (sampling, conditions, descent).
    Phase(&'a str),
    /// A level is done: its number, the model's functions and the level's report.
    Level(usize, usize, &'a LevelReport),
}

/// A fit's result and its history.
#[derive(Debug, Clone)]
pub struct Conversion {
    /// The model.
    pub model: ImplicitModel,
    /// One report per level.
    pub levels: Vec<LevelReport>,
    /// Whether every vertex met the per-vertex targets (distance and angle) and no
    /// off-surface condition is on the wrong side, after the descent.
    pub met_target: bool,
    /// Vertices over the per-vertex targets after the descent.
    pub over_target: usize,
    /// Mean vertex distance `|F| / |grad F|` after the descent (unit cube).
    pub mean_distance: f64,
    /// Mean angle (degrees) between vertex normal and `-grad F` after the descent.
    pub mean_angle_deg: f64,
    /// Why the levels stopped.
    pub stop: Stop,
}

/// One least-squares condition `F(p) = target`, weighted.
#[derive(Debug, Clone, Copy)]
struct Condition {
    p: [f64; 3],
    target: f64,
    weight: f64,
    /// Zero for a value condition `F(p) = target`; otherwise a unit direction and the
    /// condition is on the derivative along it, `grad F(p) . dir = target`.
    dir: [f64; 3],
}

impl Condition {
    /// What the condition constrains, of a bump with unit factor.
    fn of_bump(&self, b: &Bump) -> f64 {
        if self.dir == [0.0; 3] {
            b.kernel(self.p).0
        } else {
            dot(b.kernel(self.p).1, self.dir)
        }
    }

    /// What the condition constrains, of the model.
    fn of_model(&self, m: &ImplicitModel) -> f64 {
        if self.dir == [0.0; 3] {
            m.value(self.p)
        } else {
            dot(m.value_gradient(self.p).1, self.dir)
        }
    }
}

/// The spacing of surface samples on large triangles (unit cube).
const SAMPLE_SPACING: f64 = 0.015;
/// The spacing on large triangles of a flat face (see [`flat_faces`]): where a face is
/// truly flat its triangles' normal is the surface's, and the conditions must hold the
/// field's zero set to the plane between distant vertices, which a wall seen edge-on
/// shows to the pixel.
const FLAT_SAMPLE_SPACING: f64 = 0.004;
/// Neighbours whose normals are closer than this (degrees) lie on one flat face...
const FLAT_DEG: f64 = 1.0;
/// ...and an edge sharper than this is a crease between faces.
const CREASE_DEG: f64 = 60.0;

/// Per triangle, whether it is large (longer than three [`FLAT_SAMPLE_SPACING`]) and
/// lies on a flat face: a neighbour across an edge is coplanar with it, and each other
/// one is coplanar too or meets it at a crease. A faceted smooth surface (a low-polygon model shaded smooth) has
/// neighbours at in-between angles: its face normals are not its surface's.
fn flat_faces(mesh: &PolygonMesh, longest: impl Fn(usize) -> f64) -> Vec<bool> {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let large: Vec<usize> = (0..mesh.triangles.len())
        .filter(|&t| longest(t) > 3.0 * FLAT_SAMPLE_SPACING)
        .collect();
    let mut edges: std::collections::HashMap<(u32, u32), Vec<u32>> = Default::default();
    for &t in &large {
        let [a, b, c] = mesh.triangles[t];
        for e in [key(a, b), key(b, c), key(c, a)] {
            edges.insert(e, Vec::new());
        }
    }
    for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        for e in [key(a, b), key(b, c), key(c, a)] {
            if let Some(list) = edges.get_mut(&e) {
                list.push(t as u32);
            }
        }
    }
    let unit = |t: usize| {
        let n = mesh.face_normal(t);
        let l = norm(n).max(1e-300);
        n.map(|v| v / l)
    };
    let (flat, crease) = (FLAT_DEG.to_radians().cos(), CREASE_DEG.to_radians().cos());
    let mut out = vec![false; mesh.triangles.len()];
    for &t in &large {
        let n = unit(t);
        let [a, b, c] = mesh.triangles[t];
        let cosines: Vec<f64> = [key(a, b), key(b, c), key(c, a)]
            .iter()
            .flat_map(|e| edges[e].iter().filter(|&&o| o as usize != t))
            .map(|&o| dot(n, unit(o as usize)))
            .collect();
        out[t] =
            cosines.iter().any(|&c| c >= flat) && cosines.iter().all(|&c| c >= flat || c <= crease);
    }
    out
}
/// About the most points sampled inside triangles.
pub const MAX_SAMPLES: f64 = 400_000.0;

/// Most mesh vertices the fit works on. A denser mesh is fitted on a spread subset
/// (one vertex per cell of a grid sized to this count): its vertices are closer than
/// the smallest perturbation, so more of them add conditions, time and memory but no
/// detail the model can hold.
pub const MAX_FIT_VERTICES: usize = 200_000;

/// The vertices the fit works on: all of them, or on a mesh of more than `cap`, the
/// lowest-numbered vertex of each occupied cell of a grid coarsened until at most
/// `cap` cells are occupied (in index order, the same on every run).
pub fn spread_vertices(mesh: &PolygonMesh, cap: usize) -> Vec<u32> {
    let n = mesh.positions.len();
    if n <= cap {
        return (0..n as u32).collect();
    }
    let area = mesh.area();
    let (lo, hi) = mesh.bounds();
    let side = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // A surface of area A holds about A / h^2 cells of side h.
    let mut h = (area / cap as f64).sqrt().max(1e-9 * side);
    loop {
        let mut first: std::collections::HashMap<[i64; 3], u32> = Default::default();
        for (i, p) in mesh.positions.iter().enumerate() {
            let c = [0, 1, 2].map(|k| ((p[k] - lo[k]) / h).floor() as i64);
            first.entry(c).or_insert(i as u32);
        }
        if first.len() <= cap {
            let mut out: Vec<u32> = first.into_values().collect();
            out.sort_unstable();
            return out;
        }
        h *= 1.15;
    }
}

/// The surface samples: the fit's vertices (first, in the order of `fit_vertices`),
/// then points inside each triangle
/// (its centroid, or a barycentric grid at about [`SAMPLE_SPACING`] on a large one, or
/// [`FLAT_SAMPLE_SPACING`] on a flat face, so that a coarse mesh's flat faces hold the
/// surface too; on a mesh of more than [`MAX_SAMPLES`] triangles, the centroids of an
/// evenly strided subset, fewer when the vertices were thinned), with outward unit
/// normals.
fn samples(
    mesh: &PolygonMesh,
    winding: &WindingTree<'_>,
    fit_vertices: &[u32],
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let all_normals = mesh.outward_normals_by(winding);
    let mut normals: Vec<[f64; 3]> = fit_vertices
        .iter()
        .map(|&i| all_normals[i as usize])
        .collect();
    // Face normals follow the winding; turn them the way the vertex normals went.
    let flip = all_normals
        .iter()
        .zip(mesh.vertex_normals())
        .any(|(a, b)| dot(*a, b) < 0.0);
    drop(all_normals);
    let longest = |t: usize| {
        let tri = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
        (0..3)
            .map(|k| norm(sub(tri[(k + 1) % 3], tri[k])))
            .fold(0.0, f64::max)
    };
    let flat = flat_faces(mesh, longest);
    // A flat face's triangles at the finer spacing, the others at the plain one; both
    // wider when the grid would pass MAX_SAMPLES points.
    let ratio = FLAT_SAMPLE_SPACING / SAMPLE_SPACING;
    let parts_at = |t: usize, h: f64| {
        let h = if flat[t] { h * ratio } else { h };
        (longest(t) / h).ceil().min(64.0)
    };
    let count = |h: f64| -> f64 {
        (0..mesh.triangles.len())
            .map(|t| (parts_at(t, h) - 1.0).max(1.0).powi(2) / 2.0)
            .sum()
    };
    let mut spacing = SAMPLE_SPACING;
    let widest = (0..mesh.triangles.len()).map(longest).fold(0.0, f64::max);
    while spacing * ratio < widest && count(spacing) > MAX_SAMPLES {
        spacing *= 1.25;
    }
    // On a mesh with more triangles than that, the vertices already sample the surface
    // densely: every k-th triangle gives its centroid. When the vertices were thinned,
    // the centroids fill only what is left of MAX_SAMPLES.
    let room = if fit_vertices.len() < mesh.positions.len() {
        MAX_SAMPLES - fit_vertices.len() as f64
    } else {
        MAX_SAMPLES
    };
    let stride = (mesh.triangles.len() as f64 / room).ceil().max(1.0) as usize;
    let mut pts: Vec<[f64; 3]> = fit_vertices
        .iter()
        .map(|&i| mesh.positions[i as usize])
        .collect();
    for t in (0..mesh.triangles.len()).step_by(stride) {
        let tri = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
        let n = mesh.face_normal(t);
        let l = norm(n).max(1e-300);
        let n = n.map(|v| if flip { -v / l } else { v / l });
        let parts = parts_at(t, spacing) as usize;
        if parts < 3 {
            pts.push([0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0));
            normals.push(n);
            continue;
        }
        for i in 1..parts {
            for j in 1..parts - i {
                let (a, b) = (i as f64 / parts as f64, j as f64 / parts as f64);
                let c = 1.0 - a - b;
                pts.push([0, 1, 2].map(|k| a * tri[0][k] + b * tri[1][k] + c * tri[2][k]));
                normals.push(n);
            }
        }
    }
    (pts, normals)
}

/// Builds the conditions. `pts`/`normals` are the surface samples; the first
/// `vertices` of them are mesh vertices; `winding` tells the far grid's sides.
fn conditions(
    winding: &WindingTree<'_>,
    pts: &[[f64; 3]],
    normals: &[[f64; 3]],
    vertices: usize,
    step: f64,
) -> Vec<Condition> {
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(pts).expect("the mesh has points");
    let nearest = |q: [f64; 3]| -> (f64, usize) {
        let n = tree
            .query(&q)
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        (n.distance.sqrt(), n.item as usize)
    };
    let mut out: Vec<Condition> = pts
        .iter()
        .map(|&p| Condition {
            p,
            target: 0.0,
            weight: 1.0,
            dir: [0.0; 3],
        })
        .collect();
    // Off-surface pairs at the vertices, at several distances so that the sign of
    // the field is pinned from the surface out to the far grid. The smallest step
    // halves until nothing else on the surface is nearer than the vertex (thin parts
    // and creases); a larger one that fails that test is left out.
    let pairs: Vec<Vec<Condition>> = (0..pts.len())
        .into_par_iter()
        .map(|i| {
            let mut list = Vec::new();
            for side in [1.0, -1.0] {
                let offset = |d: f64| [0, 1, 2].map(|k| pts[i][k] + side * d * normals[i][k]);
                let mut d = step;
                for _ in 0..4 {
                    if nearest(offset(d)).0 >= 0.99 * d {
                        list.push(Condition {
                            p: offset(d),
                            target: -side * d,
                            weight: 1.0,
                            dir: [0.0; 3],
                        });
                        break;
                    }
                    d *= 0.5;
                }
                for d in [0.03, 0.07] {
                    if i < vertices && d > step && nearest(offset(d)).0 >= 0.99 * d {
                        list.push(Condition {
                            p: offset(d),
                            target: -side * d,
                            weight: 0.5,
                            dir: [0.0; 3],
                        });
                    }
                }
            }
            list
        })
        .collect();
    out.extend(pairs.into_iter().flatten());
    // Far points: a grid over the cube, with the side from the winding number.
    let n = 14;
    let grid: Vec<[f64; 3]> = (0..n * n * n)
        .map(|i| {
            [i % n, (i / n) % n, i / (n * n)].map(|c| -0.6 + 1.2 * (c as f64 + 0.5) / n as f64)
        })
        .collect();
    let far: Vec<Option<Condition>> = grid
        .par_iter()
        .map(|&q| {
            let (d, _) = nearest(q);
            if d < 4.0 * step {
                return None;
            }
            let inside = winding.winding_number(q).abs() > 0.5;
            let dist = d.min(0.15);
            Some(Condition {
                p: q,
                target: if inside { dist } else { -dist },
                weight: 0.3,
                dir: [0.0; 3],
            })
        })
        .collect();
    out.extend(far.into_iter().flatten());
    out
}

/// Tangent conditions at the vertices: the derivative of `F` along two directions
/// across the vertex normal is 0, so the gradient follows the normal (the mean
/// normal angle) where a coarse mesh's facets would tilt it.
fn tangent_conditions(pts: &[[f64; 3]], normals: &[[f64; 3]], weight: f64) -> Vec<Condition> {
    let mut out = Vec::with_capacity(2 * pts.len());
    for (p, n) in pts.iter().zip(normals) {
        if *n == [0.0; 3] {
            continue;
        }
        // Any vector not along n, crossed with it, and n crossed with that.
        let a = if n[0].abs() < 0.6 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let t1 = caoen_geometry::vector::unit(caoen_geometry::vector::cross(*n, a));
        let t2 = caoen_geometry::vector::cross(*n, t1);
        for t in [t1, t2] {
            out.push(Condition {
                p: *p,
                target: 0.0,
                weight,
                dir: t,
            });
        }
    }
    out
}

/// Solves `min sum_j w_j (sum_k a_jk f_k - r_j)^2 + lambda |f|^2` by conjugate
/// gradients on the normal equations (Jacobi-preconditioned). `rows[j]` holds the
/// non-zero `(k, a_jk)` of condition `j`.
fn least_squares(
    rows: &[Vec<(u32, f64)>],
    weights: &[f64],
    rhs: &[f64],
    unknowns: usize,
) -> Vec<f64> {
    // Columns, for the transposed product without scattering.
    let mut cols: Vec<Vec<(u32, f64)>> = vec![Vec::new(); unknowns];
    for (j, row) in rows.iter().enumerate() {
        for &(k, a) in row {
            cols[k as usize].push((j as u32, a * weights[j]));
        }
    }
    let diag: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|&(j, wa)| wa * wa / weights[j as usize]).sum())
        .collect();
    let mean_diag = diag.iter().sum::<f64>() / unknowns.max(1) as f64;
    let lambda = 1e-5 * mean_diag;
    let apply = |f: &[f64]| -> Vec<f64> {
        let af: Vec<f64> = rows
            .par_iter()
            .map(|row| row.iter().map(|&(k, a)| a * f[k as usize]).sum())
            .collect();
        cols.par_iter()
            .enumerate()
            .map(|(k, c)| c.iter().map(|&(j, wa)| wa * af[j as usize]).sum::<f64>() + lambda * f[k])
            .collect()
    };
    let b: Vec<f64> = cols
        .par_iter()
        .map(|c| c.iter().map(|&(j, wa)| wa * rhs[j as usize]).sum())
        .collect();
    let precond: Vec<f64> = diag
        .iter()
        .map(|d| 1.0 / (d + lambda).max(1e-300))
        .collect();
    let mut x = vec![0.0; unknowns];
    let mut r = b.clone();
    let mut z: Vec<f64> = r.iter().zip(&precond).map(|(r, m)| r * m).collect();
    let mut p = z.clone();
    let mut rz: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
    let b_norm: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    for _ in 0..400 {
        let r_norm: f64 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if r_norm <= 1e-7 * b_norm || rz == 0.0 {
            break;
        }
        let ap = apply(&p);
        let pap: f64 = p.iter().zip(&ap).map(|(a, b)| a * b).sum();
        if pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        for k in 0..unknowns {
            x[k] += alpha * p[k];
            r[k] -= alpha * ap[k];
        }
        for k in 0..unknowns {
            z[k] = r[k] * precond[k];
        }
        let rz_new: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let beta = rz_new / rz;
        rz = rz_new;
        for k in 0..unknowns {
            p[k] = z[k] + beta * p[k];
        }
    }
    x
}

/// The per-vertex distance `|F| / |grad F|` and the angle (degrees) between the
/// outward normal and `-grad F`.
fn vertex_errors(model: &ImplicitModel, pts: &[[f64; 3]], normals: &[[f64; 3]]) -> Vec<(f64, f64)> {
    pts.par_iter()
        .zip(normals)
        .map(|(p, n)| {
            let (v, g) = model.value_gradient(*p);
            let l = norm(g);
            if l <= 1e-12 {
                return (f64::INFINITY, 180.0);
            }
            let cos = (-dot(g, *n) / l).clamp(-1.0, 1.0);
            (v.abs() / l, cos.acos().to_degrees())
        })
        .collect()
}

/// Converts a mesh, reporting phases and levels through `progress`.
pub fn convert(
    mesh: &PolygonMesh,
    opts: &ConvertOptions,
    progress: &mut dyn FnMut(Progress<'_>),
) -> Conversion {
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    progress(Progress::Phase("sampling the surface"));
    let fit_vertices = spread_vertices(&unit, MAX_FIT_VERTICES);
    let vertices = fit_vertices.len();
    // One winding tree answers the outward vote and the far grid's sides.
    let winding = WindingTree::new(&unit);
    let (pts, normals) = samples(&unit, &winding, &fit_vertices);
    drop(fit_vertices);
    let surface = pts.len();
    let base = quadric::fit_base(&pts[..vertices], &normals[..vertices]);
    let step = (0.25 * opts.min_radius.max(0.004)).min(0.01);
    progress(Progress::Phase(
        "placing the off-surface conditions (winding numbers)",
    ));
    let mut conds = conditions(&winding, &pts, &normals, vertices, step);
    drop(winding);
    // The value conditions end here; tangent conditions follow.
    let values_end = conds.len();
    if opts.tangent_weight > 0.0 {
        conds.extend(tangent_conditions(
            &pts[..vertices],
            &normals[..vertices],
            opts.tangent_weight,
        ));
    }
    let mut model = ImplicitModel::new(frame, base, Vec::new());
    let mut levels: Vec<LevelReport> = Vec::new();
    let mut radius = opts.first_radius;
    let mut errors = vertex_errors(&model, &pts[..vertices], &normals[..vertices]);
    let over = |e: &(f64, f64)| e.0 > opts.target || e.1 > opts.max_angle_deg;
    let means_met = |errors: &[(f64, f64)]| {
        let n = errors.len().max(1) as f64;
        errors.iter().map(|e| e.1).sum::<f64>() / n <= opts.fit_angle_deg
            && errors.iter().map(|e| e.0).sum::<f64>() / n <= opts.fit_distance
    };
    let mut stop = if errors.iter().all(|e| !over(e)) {
        Stop::Met
    } else {
        Stop::SmallestRadius
    };
    let mut level = 0;
    let mut rounds_at_smallest = 0;
    while stop != Stop::Met {
        if model.functions() >= opts.max_functions {
            stop = Stop::Budget;
            break;
        }
        if level > 0 && means_met(&errors) {
            stop = Stop::MeanMet;
            break;
        }
        if radius < opts.min_radius {
            // Further rounds at the smallest radius while they still take vertices
            // off the list over the targets.
            let [.., a, b] = levels[..] else { break };
            if rounds_at_smallest >= opts.smallest_rounds
                || b.over_target as f64 > 0.97 * a.over_target as f64
            {
                break;
            }
            radius = opts.min_radius;
            rounds_at_smallest += 1;
        }
        // Centres: first the off-surface conditions on the wrong side (a spurious
        // piece of surface between them and the mesh), then the vertices over the
        // targets (every vertex on the first level), worst first, no two closer than
        // the spacing.
        let values: Vec<f64> = conds[surface..values_end]
            .par_iter()
            .map(|c| model.value(c.p))
            .collect();
        let mut wrong: Vec<(f64, usize)> = values
            .iter()
            .enumerate()
            .filter(|(j, v)| conds[surface + j].target * **v < 0.0)
            .map(|(j, v)| ((v - conds[surface + j].target).abs(), surface + j))
            .collect();
        wrong.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut order: Vec<usize> = (0..vertices)
            .filter(|&i| level == 0 || over(&errors[i]))
            .collect();
        let badness = |i: usize| errors[i].0 / opts.target + errors[i].1 / opts.max_angle_deg;
        order.sort_by(|&a, &b| badness(b).total_cmp(&badness(a)).then(a.cmp(&b)));
        let order: Vec<[f64; 3]> = wrong
            .iter()
            .map(|w| conds[w.1].p)
            .chain(order.iter().map(|&i| pts[i]))
            .collect();
        let spacing = 0.6 * radius;
        let mut taken: std::collections::HashMap<[i64; 3], Vec<[f64; 3]>> = Default::default();
        let cell = |p: [f64; 3]| p.map(|v| (v / spacing).floor() as i64);
        let mut centres = Vec::new();
        let room = opts.max_functions - model.functions();
        for &p in &order {
            if centres.len() >= room {
                break;
            }
            let c = cell(p);
            let mut near = false;
            'look: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(list) = taken.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                            if list.iter().any(|&q| norm(sub(q, p)) < spacing) {
                                near = true;
                                break 'look;
                            }
                        }
                    }
                }
            }
            if !near {
                taken.entry(c).or_default().push(p);
                centres.push(p);
            }
        }
        let new: Vec<Bump> = centres
            .iter()
            .map(|&p| Bump {
                centre: p,
                radius,
                factor: 0.0,
            })
            .collect();
        let index = PatchIndex::new(&new.iter().map(|b| Some(b.support())).collect::<Vec<_>>());
        // The conditions the new bumps reach, with the current model's residuals.
        // (condition, its row of kernel values, its residual)
        type Row = (usize, Vec<(u32, f64)>, f64);
        let rows: Vec<Row> = conds
            .par_iter()
            .enumerate()
            .filter_map(|(j, c)| {
                let mut near = Vec::new();
                index.at_point(c.p, &mut near);
                let row: Vec<(u32, f64)> = near
                    .iter()
                    .filter_map(|&k| {
                        let r = c.of_bump(&new[k as usize]);
                        (r != 0.0).then_some((k, r))
                    })
                    .collect();
                if row.is_empty() {
                    return None;
                }
                Some((j, row, c.target - c.of_model(&model)))
            })
            .collect();
        let weights: Vec<f64> = rows.iter().map(|r| conds[r.0].weight).collect();
        let rhs: Vec<f64> = rows.iter().map(|r| r.2).collect();
        let a: Vec<Vec<(u32, f64)>> = rows.into_iter().map(|r| r.1).collect();
        let f = least_squares(&a, &weights, &rhs, new.len());
        let mut bumps = model.bumps.clone();
        bumps.extend(new.iter().zip(&f).map(|(b, &factor)| Bump { factor, ..*b }));
        model = ImplicitModel::new(frame, base, bumps);
        errors = vertex_errors(&model, &pts[..vertices], &normals[..vertices]);
        let report = LevelReport {
            radius,
            added: new.len(),
            mean_distance: errors.iter().map(|e| e.0).sum::<f64>() / vertices as f64,
            max_distance: errors.iter().map(|e| e.0).fold(0.0, f64::max),
            over_target: errors.iter().filter(|e| over(e)).count(),
            wrong_side: conds[surface..values_end]
                .par_iter()
                .filter(|c| c.target * model.value(c.p) < 0.0)
                .count(),
        };
        progress(Progress::Level(level, model.functions(), &report));
        levels.push(report);
        if report.over_target == 0 && report.wrong_side == 0 {
            stop = Stop::Met;
        }
        level += 1;
        radius *= 0.5f64.sqrt();
    }
    if opts.descent_sweeps > 0 && !model.bumps.is_empty() {
        progress(Progress::Phase("local descent on the form factors"));
        let bumps = descend(&model, &conds, opts.descent_sweeps);
        model = ImplicitModel::new(frame, base, bumps);
        errors = vertex_errors(&model, &pts[..vertices], &normals[..vertices]);
    }
    let over_target = errors.iter().filter(|e| over(e)).count();
    let met = over_target == 0
        && conds[surface..values_end]
            .par_iter()
            .all(|c| c.target * model.value(c.p) >= 0.0);
    let n = vertices.max(1) as f64;
    Conversion {
        levels,
        met_target: met,
        over_target,
        mean_distance: errors.iter().map(|e| e.0).sum::<f64>() / n,
        mean_angle_deg: errors.iter().map(|e| e.1).sum::<f64>() / n,
        stop,
        model: model.with_supports(Supports::of(&unit)),
    }
}

/// The paper's local descent: each form factor in turn tries a step up and down and
/// keeps it only if the weighted sum of `|F - target|` over the conditions drops; the
/// step halves after a sweep. Sequential, so the result does not depend on threads.
fn descend(model: &ImplicitModel, conds: &[Condition], sweeps: usize) -> Vec<Bump> {
    let mut bumps = model.bumps.clone();
    let index = PatchIndex::new(&bumps.iter().map(|b| Some(b.support())).collect::<Vec<_>>());
    // Which conditions each perturbation reaches. Only their indices are kept: the
    // kernel values are found again for one perturbation at a time, so the lists take
    // a quarter of the memory (on a 200,000-vertex fit they are the largest table).
    let mut reach: Vec<Vec<u32>> = vec![Vec::new(); bumps.len()];
    let mut near = Vec::new();
    for (j, c) in conds.iter().enumerate() {
        index.at_point(c.p, &mut near);
        for &k in &near {
            if c.of_bump(&bumps[k as usize]) != 0.0 {
                reach[k as usize].push(j as u32);
            }
        }
    }
    let mut residual: Vec<f64> = conds
        .par_iter()
        .map(|c| c.of_model(model) - c.target)
        .collect();
    let mut step: Vec<f64> = bumps.iter().map(|b| 0.1 * b.factor.abs()).collect();
    let mut kernel: Vec<(u32, f64)> = Vec::new();
    for _ in 0..sweeps {
        for (k, b) in bumps.iter_mut().enumerate() {
            kernel.clear();
            kernel.extend(reach[k].iter().map(|&j| (j, conds[j as usize].of_bump(b))));
            let cost = |delta: f64| -> f64 {
                kernel
                    .iter()
                    .map(|&(j, r)| {
                        let w = conds[j as usize].weight;
                        w * ((residual[j as usize] + delta * r).abs() - residual[j as usize].abs())
                    })
                    .sum()
            };
            let s = step[k];
            let (up, down) = (cost(s), cost(-s));
            let delta = if up < 0.0 && up <= down {
                s
            } else if down < 0.0 {
                -s
            } else {
                step[k] *= 0.5;
                continue;
            };
            b.factor += delta;
            for &(j, r) in &kernel {
                residual[j as usize] += delta * r;
            }
        }
    }
    bumps
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `n x n` grid of vertices on the unit square, two triangles a cell.
    fn square(n: usize) -> PolygonMesh {
        let positions = (0..n * n)
            .map(|i| {
                [
                    (i % n) as f64 / (n - 1) as f64,
                    (i / n) as f64 / (n - 1) as f64,
                    0.0,
                ]
            })
            .collect();
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let a = (y * n + x) as u32;
                let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
                triangles.push([a, b, d]);
                triangles.push([a, d, c]);
            }
        }
        PolygonMesh {
            positions,
            triangles,
        }
    }

    #[test]
    fn flat_faces_are_a_cube_s_and_a_flat_sheet_s_not_a_faceted_sphere_s() {
        let longest = |mesh: &PolygonMesh| {
            let m = mesh.clone();
            move |t: usize| {
                let tri = m.triangles[t].map(|i| m.positions[i as usize]);
                (0..3)
                    .map(|k| norm(sub(tri[(k + 1) % 3], tri[k])))
                    .fold(0.0, f64::max)
            }
        };
        let cube = PolygonMesh {
            positions: (0..8)
                .map(|i| {
                    [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64].map(|v| v - 0.5)
                })
                .collect(),
            triangles: vec![
                [0, 2, 3],
                [0, 3, 1],
                [4, 5, 7],
                [4, 7, 6],
                [0, 1, 5],
                [0, 5, 4],
                [2, 6, 7],
                [2, 7, 3],
                [0, 4, 6],
                [0, 6, 2],
                [1, 3, 7],
                [1, 7, 5],
            ],
        };
        assert!(
            flat_faces(&cube, longest(&cube)).iter().all(|&f| f),
            "square faces meeting at right angles"
        );
        let sheet = square(5);
        assert!(flat_faces(&sheet, longest(&sheet)).iter().all(|&f| f));
        // 16 bands: neighbours meet at 11.25 degrees, neither one face nor a crease.
        let sphere = PolygonMesh::uv_sphere(16, 0.5);
        assert!(flat_faces(&sphere, longest(&sphere)).iter().all(|&f| !f));
    }

    #[test]
    fn spread_vertices_keep_all_under_the_cap_and_cover_the_surface_over_it() {
        let mesh = square(101);
        assert_eq!(spread_vertices(&mesh, 20_000).len(), 101 * 101);
        let cap = 1000;
        let chosen = spread_vertices(&mesh, cap);
        assert!(
            chosen.len() <= cap && chosen.len() > cap / 2,
            "{}",
            chosen.len()
        );
        assert!(chosen.windows(2).all(|w| w[0] < w[1]), "in index order");
        assert_eq!(chosen, spread_vertices(&mesh, cap), "the same on every run");
        // Every vertex has a chosen one within two of the grid's cells (side h, about
        // sqrt(area / cap) = 0.032, grown at most a few times by 1.15).
        for p in &mesh.positions {
            let nearest = chosen
                .iter()
                .map(|&i| norm(sub(mesh.positions[i as usize], *p)))
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 0.1,
                "{p:?} is {nearest} from the nearest kept vertex"
            );
        }
    }
}
