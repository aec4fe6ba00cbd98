//! The depth-buffer method (paper section 7): sample the domain, map every sample onto
//! the surface, project it, keep the nearest depth per pixel.
//!
//! The domain starts as a coarse triangulation (an icosphere, or the torus grid) and
//! every triangle whose projected edges are longer than `max_edge_px` is split at its
//! domain edge midpoints, which are mapped and projected in turn. This is the paper's
//! "insert intermediate samples where neighbours land on non-adjacent pixels", with a
//! threshold chosen so coverage is guaranteed: every point of a triangle whose longest
//! edge is `e` lies within `e / sqrt(3)` of one of its corners (the equilateral
//! triangle's centre is the worst case), so with `e <= sqrt(3)/2` a pixel centre inside
//! a projected triangle has a corner sample within half a pixel, i.e. in that very
//! pixel. No pixel whose centre lies inside the silhouette can stay empty.
//!
//! Root triangles are refined independently and in parallel; their samples are then
//! splatted in root order with ties keeping the first, so the image is independent of
//! the number of threads.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::camera::Camera;
use super::error::{RenderError, Result};
use caoen_geometry::mesh::icosphere;
use caoen_geometry::transform::Affine;
use caoen_surface::{Domain, SurfaceModel};

/// Depth-buffer parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthBufferOptions {
    /// Icosphere subdivisions of the starting triangulation (torus: `8 * 2^n` by
    /// `4 * 2^n` cells). Must be fine enough that no feature hides between its vertices.
    pub base_detail: u32,
    /// Split triangles with a projected edge longer than this (pixels); up to
    /// `sqrt(3)/2` guarantees full coverage, larger values are faster but may leave holes.
    pub max_edge_px: f64,
    /// Most subdivision levels below the starting triangulation.
    pub max_levels: u32,
    /// Refuse to take more than this many samples (a guard against runaway refinement).
    pub max_samples: usize,
}

impl Default for DepthBufferOptions {
    fn default() -> Self {
        DepthBufferOptions {
            base_detail: 3,
            max_edge_px: 0.86,
            max_levels: 16,
            max_samples: 200_000_000,
        }
    }
}

/// What the depth buffer did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DepthStats {
    /// Surface samples taken (network evaluations).
    pub samples: usize,
    /// Triangles still larger than the threshold when the level limit stopped them.
    pub unresolved: usize,
}

/// Nearest sample per pixel: its depth and domain point (padded to 4 components).
#[derive(Debug, Clone)]
pub struct DepthImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per pixel: `(depth, domain point)` of the nearest sample, or None.
    pub pixels: Vec<Option<(f64, [f64; 4])>>,
    /// Counters.
    pub stats: DepthStats,
}

/// Maps a batch of domain points to projected samples.
type Evaluator<'a> = dyn Fn(&[[f64; 4]]) -> Result<Vec<Vert>> + Sync + 'a;

#[derive(Clone, Copy)]
struct Vert {
    x: [f64; 4],
    /// Image position and depth; None behind the camera.
    s: Option<[f64; 3]>,
}

/// Renders `model`, placed by `place`, through `camera` by the depth-buffer method.
///
/// `progress` is called with `(root triangles done, total)`.
pub fn depth_buffer(
    model: &SurfaceModel,
    place: &Affine,
    camera: &Camera,
    opts: &DepthBufferOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<DepthImage> {
    let domain = model.domain;
    let m = domain.ambient_dim();
    if model.network.output_dim() != 3 {
        return Err(RenderError::parameter(
            "shape dimension p",
            format!(
                "{}: the depth buffer needs a surface in 3-D",
                model.network.output_dim()
            ),
        ));
    }
    if !(opts.max_edge_px > 0.0) {
        return Err(RenderError::parameter("max_edge_px", "must be > 0"));
    }
    let (root_pts, root_tris): (Vec<[f64; 4]>, Vec<[u32; 3]>) = match domain {
        Domain::Sphere { dim: 3 } => {
            let (v, t) = icosphere(opts.base_detail.min(6));
            (v.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect(), t)
        }
        Domain::Torus => {
            let d = opts.base_detail.min(6);
            let grid = domain.grid(8 << d, 4 << d)?;
            let tris = grid.wrapped_triangles()?;
            let pts = grid
                .points
                .chunks_exact(4)
                .map(|p| [p[0], p[1], p[2], p[3]])
                .collect();
            (pts, tris)
        }
        other => {
            return Err(RenderError::parameter(
                format!("domain {other:?}"),
                "the depth buffer samples the sphere S^2 or the torus",
            ))
        }
    };
    let eval = |pts: &[[f64; 4]]| -> Result<Vec<Vert>> {
        let flat: Vec<f64> = pts.iter().flat_map(|p| p[..m].iter().copied()).collect();
        let ys = model.network.eval_batch(&flat)?;
        Ok(pts
            .iter()
            .zip(ys.chunks_exact(3))
            .map(|(x, y)| Vert {
                x: *x,
                s: camera.project(place.point([y[0], y[1], y[2]])),
            })
            .collect())
    };
    let roots = eval(&root_pts)?;
    let total = root_tris.len() as u64;
    let done = AtomicU64::new(0);
    let budget = AtomicU64::new(0);
    let refined: Vec<Result<(Vec<Vert>, usize)>> = root_tris
        .par_iter()
        .map(|t| {
            let r = refine(
                t.map(|i| roots[i as usize]),
                &domain,
                &eval,
                camera,
                opts,
                &budget,
            );
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            r
        })
        .collect();
    let (w, h) = (camera.width, camera.height);
    let mut pixels: Vec<Option<(f64, [f64; 4])>> = vec![None; w as usize * h as usize];
    let mut stats = DepthStats::default();
    let mut splat = |v: &Vert| {
        if let Some([x, y, z]) = v.s {
            if x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64 {
                let i = y as usize * w as usize + x as usize;
                if !matches!(&pixels[i], Some((d, _)) if *d <= z) {
                    pixels[i] = Some((z, v.x));
                }
            }
        }
    };
    roots.iter().for_each(&mut splat);
    stats.samples = roots.len();
    for r in refined {
        let (verts, unresolved) = r?;
        stats.samples += verts.len();
        stats.unresolved += unresolved;
        verts.iter().for_each(&mut splat);
    }
    Ok(DepthImage {
        width: w,
        height: h,
        pixels,
        stats,
    })
}

/// Refines one root triangle; returns the new samples (not the root's corners) and the
/// number of triangles left unresolved at the level limit.
fn refine(
    corners: [Vert; 3],
    domain: &Domain,
    eval: &Evaluator,
    camera: &Camera,
    opts: &DepthBufferOptions,
    budget: &AtomicU64,
) -> Result<(Vec<Vert>, usize)> {
    let mut verts: Vec<Vert> = corners.to_vec();
    let mut tris: Vec<[u32; 3]> = vec![[0, 1, 2]];
    let mut unresolved = 0;
    let (w, h) = (camera.width as f64, camera.height as f64);
    for level in 0..=opts.max_levels {
        let mut split = Vec::new();
        for t in &tris {
            let s = t.map(|i| verts[i as usize].s);
            let front: Vec<[f64; 3]> = s.iter().flatten().copied().collect();
            if front.is_empty() {
                continue;
            }
            if front.len() == 3 {
                let d = |a: [f64; 3], b: [f64; 3]| (a[0] - b[0]).hypot(a[1] - b[1]);
                let e = d(front[0], front[1])
                    .max(d(front[1], front[2]))
                    .max(d(front[2], front[0]));
                let (xs, ys) = (front.iter().map(|p| p[0]), front.iter().map(|p| p[1]));
                let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
                let (y0, y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
                // Off screen, even allowing the surface to bulge by an edge length.
                if x1 + e < 0.0 || y1 + e < 0.0 || x0 - e > w || y0 - e > h {
                    continue;
                }
                if e <= opts.max_edge_px {
                    continue;
                }
            }
            if level == opts.max_levels {
                unresolved += 1;
                continue;
            }
            split.push(*t);
        }
        if split.is_empty() {
            break;
        }
        // Midpoints, one per shared edge, mapped in one batch.
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut new_pts: Vec<[f64; 4]> = Vec::new();
        let base = verts.len() as u32;
        let mut midpoint = |a: u32, b: u32| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                new_pts.push(domain_midpoint(
                    domain,
                    &verts[a as usize].x,
                    &verts[b as usize].x,
                ));
                base + new_pts.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(split.len() * 4);
        for [a, b, c] in split {
            let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        let used = budget.fetch_add(new_pts.len() as u64, Ordering::Relaxed) + new_pts.len() as u64;
        if used > opts.max_samples as u64 {
            return Err(RenderError::parameter(
                "depth buffer samples",
                format!(
                    "more than {} needed; lower the image size or raise max_edge_px",
                    opts.max_samples
                ),
            ));
        }
        verts.extend(eval(&new_pts)?);
        tris = next;
    }
    verts.drain(..3);
    Ok((verts, unresolved))
}

/// The domain point halfway between two nearby domain points (the chord midpoint
/// projected back onto the domain).
fn domain_midpoint(domain: &Domain, a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    let mut c = [0.0; 4];
    for k in 0..4 {
        c[k] = 0.5 * (a[k] + b[k]);
    }
    match domain {
        Domain::Torus => {
            let r = std::f64::consts::FRAC_1_SQRT_2;
            let n1 = c[0].hypot(c[1]).max(1e-300);
            let n2 = c[2].hypot(c[3]).max(1e-300);
            [r * c[0] / n1, r * c[1] / n1, r * c[2] / n2, r * c[3] / n2]
        }
        _ => {
            let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt().max(1e-300);
            [c[0] / n, c[1] / n, c[2] / n, 0.0]
        }
    }
}
