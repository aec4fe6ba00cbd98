//! Constructive solid geometry on ray intervals (paper section 7).
//!
//! A convex solid meets a ray in at most one interval. Union, intersection and
//! difference of any number of solids are then set operations on sorted interval
//! lists: a sweep over the interval ends in ray order, keeping which operand the ray is
//! inside. Every end remembers the solid it lies on and whether that solid's normal
//! must be flipped (a subtracted solid's surface faces into the result).
//!
//! Expressions over convex solids are drawn by ray tracing their intervals, or meshed
//! from their signed field by marching tetrahedra with sharp rims.

use super::camera::Camera;
use super::framebuffer::Hit;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::polygonise::polygonise;
use caoen_geometry::vector::scale;
use caoen_surface::tracer::{ImplicitTracer, RayMethod};
use caoen_surface::ConvexSolid;

/// One end of a ray interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Boundary {
    /// Ray parameter.
    pub t: f64,
    /// Index of the solid whose surface this is.
    pub solid: u32,
    /// Whether the solid's outward normal points into the result here.
    pub flip: bool,
}

/// A ray interval inside a solid: `enter.t < exit.t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Where the ray enters.
    pub enter: Boundary,
    /// Where the ray leaves.
    pub exit: Boundary,
}

/// A CSG expression over solids `0..n`.
#[derive(Debug, Clone, PartialEq)]
pub enum CsgNode {
    /// One solid, by index.
    Solid(u32),
    /// Inside any operand.
    Union(Vec<CsgNode>),
    /// Inside every operand.
    Intersection(Vec<CsgNode>),
    /// Inside the first operand and no other.
    Difference(Vec<CsgNode>),
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Op {
    Union,
    Intersection,
    Difference,
}

impl CsgNode {
    /// The solids this expression uses, in order of first appearance.
    pub fn solids(&self) -> Vec<u32> {
        let mut out = Vec::new();
        self.collect(&mut out);
        out
    }

    fn collect(&self, out: &mut Vec<u32>) {
        match self {
            CsgNode::Solid(i) => {
                if !out.contains(i) {
                    out.push(*i)
                }
            }
            CsgNode::Union(c) | CsgNode::Intersection(c) | CsgNode::Difference(c) => {
                c.iter().for_each(|n| n.collect(out))
            }
        }
    }

    /// The intervals of this expression along a ray, given each solid's interval
    /// (`leaf(i)`: None if the ray misses solid `i`).
    pub fn spans(&self, leaf: &dyn Fn(u32) -> Option<Span>) -> Vec<Span> {
        match self {
            CsgNode::Solid(i) => leaf(*i).into_iter().collect(),
            CsgNode::Union(c) => fold(c, leaf, Op::Union),
            CsgNode::Intersection(c) => fold(c, leaf, Op::Intersection),
            CsgNode::Difference(c) => {
                let Some((first, rest)) = c.split_first() else {
                    return Vec::new();
                };
                let base = first.spans(leaf);
                if rest.is_empty() {
                    return base;
                }
                combine(&base, &fold(rest, leaf, Op::Union), Op::Difference)
            }
        }
    }
}

fn fold(c: &[CsgNode], leaf: &dyn Fn(u32) -> Option<Span>, op: Op) -> Vec<Span> {
    let mut it = c.iter();
    let Some(first) = it.next() else {
        return Vec::new();
    };
    it.fold(first.spans(leaf), |acc, n| {
        combine(&acc, &n.spans(leaf), op)
    })
}

/// Combines two sorted, disjoint span lists.
pub fn union(a: &[Span], b: &[Span]) -> Vec<Span> {
    combine(a, b, Op::Union)
}

/// Combines two sorted, disjoint span lists.
pub fn intersection(a: &[Span], b: &[Span]) -> Vec<Span> {
    combine(a, b, Op::Intersection)
}

/// `a` minus `b`, both sorted and disjoint.
pub fn difference(a: &[Span], b: &[Span]) -> Vec<Span> {
    combine(a, b, Op::Difference)
}

fn combine(a: &[Span], b: &[Span], op: Op) -> Vec<Span> {
    // Events: (t, from_b, entering, boundary); at equal t exits go first, so touching
    // intervals do not produce zero-length pieces.
    let mut events: Vec<(f64, bool, bool, Boundary)> = Vec::with_capacity(2 * (a.len() + b.len()));
    for (list, from_b) in [(a, false), (b, true)] {
        for s in list {
            events.push((s.enter.t, from_b, true, s.enter));
            events.push((s.exit.t, from_b, false, s.exit));
        }
    }
    events.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)).then(x.1.cmp(&y.1)));
    let test = |ia: bool, ib: bool| match op {
        Op::Union => ia || ib,
        Op::Intersection => ia && ib,
        Op::Difference => ia && !ib,
    };
    let (mut ia, mut ib) = (false, false);
    let mut open: Option<Boundary> = None;
    let mut out = Vec::new();
    for (_, from_b, entering, mut bd) in events {
        if from_b {
            ib = entering;
            if op == Op::Difference {
                bd.flip = !bd.flip;
            }
        } else {
            ia = entering;
        }
        let now = test(ia, ib);
        match (open, now) {
            (None, true) => open = Some(bd),
            (Some(enter), false) => {
                if bd.t > enter.t {
                    out.push(Span { enter, exit: bd });
                }
                open = None;
            }
            _ => {}
        }
    }
    out
}

/// The signed field of a CSG expression: `ln(f_i / s_i)` per solid (negative inside;
/// the logarithm of a sum of exponentials is nearly piecewise linear, which suits the
/// linear interpolation of marching tetrahedra), min for union, max for intersection,
/// `max(a, -b)` for difference.
pub fn csg_field(tracers: &[ImplicitTracer], levels: &[f64], node: &CsgNode, x: [f64; 3]) -> f64 {
    match node {
        CsgNode::Solid(i) => {
            let i = *i as usize;
            (tracers[i].value(x).max(1e-300) / levels[i]).ln()
        }
        CsgNode::Union(c) => c
            .iter()
            .map(|n| csg_field(tracers, levels, n, x))
            .fold(f64::INFINITY, f64::min),
        CsgNode::Intersection(c) => c
            .iter()
            .map(|n| csg_field(tracers, levels, n, x))
            .fold(f64::NEG_INFINITY, f64::max),
        CsgNode::Difference(c) => {
            let mut it = c.iter();
            let first = it
                .next()
                .map_or(f64::INFINITY, |n| csg_field(tracers, levels, n, x));
            it.fold(first, |acc, n| acc.max(-csg_field(tracers, levels, n, x)))
        }
    }
}

/// The leaves of a CSG expression over convex solids, for sharpening its mesh.
struct CsgLeaves<'a> {
    tracers: &'a [ImplicitTracer],
    levels: &'a [f64],
    csg: &'a CsgNode,
    /// The sign each solid's field enters the expression with (-1 for subtracted).
    signs: Vec<f64>,
}

impl CsgLeaves<'_> {
    /// The expression's value at `x` and the solid it comes from.
    fn eval(&self, node: &CsgNode, x: [f64; 3]) -> (f64, usize) {
        match node {
            CsgNode::Solid(i) => {
                let i = *i as usize;
                (
                    (self.tracers[i].value(x).max(1e-300) / self.levels[i]).ln(),
                    i,
                )
            }
            CsgNode::Union(c) => c
                .iter()
                .map(|n| self.eval(n, x))
                .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a }),
            CsgNode::Intersection(c) => c
                .iter()
                .map(|n| self.eval(n, x))
                .fold((f64::NEG_INFINITY, 0), |a, b| if b.0 > a.0 { b } else { a }),
            CsgNode::Difference(c) => {
                let mut it = c.iter();
                let first = it.next().map_or((f64::INFINITY, 0), |n| self.eval(n, x));
                it.fold(first, |a, n| {
                    let (v, i) = self.eval(n, x);
                    if -v > a.0 {
                        (-v, i)
                    } else {
                        a
                    }
                })
            }
        }
    }
}

fn leaf_signs(node: &CsgNode, sign: f64, out: &mut [f64], seen: &mut [bool]) {
    match node {
        CsgNode::Solid(i) => {
            let i = *i as usize;
            if !seen[i] {
                seen[i] = true;
                out[i] = sign;
            }
        }
        CsgNode::Union(c) | CsgNode::Intersection(c) => {
            c.iter().for_each(|n| leaf_signs(n, sign, out, seen))
        }
        CsgNode::Difference(c) => {
            for (k, n) in c.iter().enumerate() {
                leaf_signs(n, if k == 0 { sign } else { -sign }, out, seen);
            }
        }
    }
}

impl caoen_geometry::crease::Leaves for CsgLeaves<'_> {
    fn leaf(&self, i: usize, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (f, g) = self.tracers[i].value_gradient(p);
        let f = f.max(1e-300);
        let s = self.signs[i];
        (s * (f / self.levels[i]).ln(), g.map(|v| s * v / f))
    }

    fn active(&self, p: [f64; 3]) -> usize {
        self.eval(self.csg, p).1
    }
}

/// The mesh of a CSG expression over convex solids: marching tetrahedra, then vertices
/// moved onto their solids and onto the rims where two solids meet, with each face's
/// normals from its own solid (sharp rims, `render::crease`).
pub fn polygonise_solids(solids: &[ConvexSolid], csg: &CsgNode, cells: usize) -> Mesh {
    let tracers = tracers(solids);
    let levels: Vec<f64> = solids.iter().map(|s| s.level()).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for i in csg.solids() {
        let (c, r) = (
            solids[i as usize].centre(),
            solids[i as usize].bounding_radius(),
        );
        for k in 0..3 {
            lo[k] = lo[k].min(c[k] - r);
            hi[k] = hi[k].max(c[k] + r);
        }
    }
    // One cell of margin so the surface never touches the box.
    let pad = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) / cells as f64;
    let lo = lo.map(|v| v - pad);
    let hi = hi.map(|v| v + pad);
    let mesh = polygonise(&|x| csg_field(&tracers, &levels, csg, x), lo, hi, cells);
    let mut signs = vec![1.0; solids.len()];
    leaf_signs(csg, 1.0, &mut signs, &mut vec![false; solids.len()]);
    let leaves = CsgLeaves {
        tracers: &tracers,
        levels: &levels,
        csg,
        signs,
    };
    let cell = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max) / cells as f64;
    caoen_geometry::crease::sharpen(mesh, &leaves, cell)
}

/// Each solid in its implicit form, as [`trace_solids`] traces them.
pub fn tracers(solids: &[ConvexSolid]) -> Vec<ImplicitTracer> {
    solids.iter().map(ImplicitTracer::new).collect()
}

/// Ray traces a CSG expression of convex solids (in their implicit form, [`tracers`])
/// through every pixel of `camera`; returns the hits and the number of rays.
pub fn trace_solids(
    tracers: &[ImplicitTracer],
    csg: &CsgNode,
    camera: &Camera,
    method: RayMethod,
    object: u32,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Vec<Option<Hit>>, usize) {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let hits = super::framebuffer::trace_rows(w, h, progress, |x, y, scratch: &mut Vec<_>| {
        let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
        let span = first_span(tracers, csg, &ray, method, scratch)?;
        let (bd, t) = if span.enter.t > 0.0 {
            (span.enter, span.enter.t)
        } else {
            (span.exit, span.exit.t)
        };
        let p = ray.at(t);
        let mut n = tracers[bd.solid as usize].normal(p);
        if bd.flip {
            n = scale(n, -1.0);
        }
        Some(Hit {
            depth: camera.depth(p),
            normal: n.map(|v| v as f32),
            uv: [f32::NAN; 2],
            object,
        })
    });
    (hits, w * h)
}

/// The first CSG interval along `ray` that is not entirely behind its origin.
pub fn first_span(
    tracers: &[ImplicitTracer],
    csg: &CsgNode,
    ray: &caoen_geometry::ray::Ray,
    method: RayMethod,
    scratch: &mut Vec<[f64; 2]>,
) -> Option<Span> {
    let leaves: Vec<Option<Span>> = tracers
        .iter()
        .enumerate()
        .map(|(i, tr)| {
            tr.crossings(ray, method, scratch).map(|c| Span {
                enter: Boundary {
                    t: c.t_in,
                    solid: i as u32,
                    flip: false,
                },
                exit: Boundary {
                    t: c.t_out,
                    solid: i as u32,
                    flip: false,
                },
            })
        })
        .collect();
    csg.spans(&|i| leaves.get(i as usize).copied().flatten())
        .into_iter()
        .find(|s| s.exit.t > 0.0)
}
