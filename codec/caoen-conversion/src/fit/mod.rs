//! Fitting a converted model to a mesh: the base quadric, then perturbations added
//! level by level where the error is largest, each level's form factors solved
//! together by least squares (`docs/conversion.md`).
//!
//! Constraints are the mesh's points (`F = 0`), points a short step inside and outside
//! along the normal (`F = +d`, `F = -d`: without them a sum that is zero on the points
//! could also be zero everywhere near them) and a coarse grid of far points whose side
//! the mesh's winding number tells (`F` = clamped signed distance), so no spurious
//! surface appears away from the mesh.

use rayon::prelude::*;

use super::model::{Bump, ImplicitField, ImplicitModel};
use super::polygon_mesh::PolygonMesh;
use super::quadric;
use super::support::Supports;
use super::winding::WindingTree;
use caoen_frep::patch_index::PatchIndex;
use caoen_geometry::vector::{dot, norm, sub};

mod conditions;

use conditions::{conditions, samples, tangent_conditions, Condition};
pub use conditions::{spread_vertices, MAX_FIT_VERTICES, MAX_SAMPLES};

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
mod tests;
