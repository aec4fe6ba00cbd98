//! The F-rep model: a tree of field nodes (primitives, R-function set operations,
//! blends, offsets, affine transforms), its value, exact gradient (chain rule through
//! every node), interval bound over a box and bounding box (`docs/frep.md`; its JSON
//! form is `model_file`).

use super::deform::{Noise, Warp};
use super::height_map::HeightMap;
use super::interval::{Aabb, Interval};
use super::mesh_field::MeshField;
use super::patch_index::PatchIndex;
use super::polygon_patch::PolygonSupport;
use super::primitive::Primitive;
use super::rfunction::{self, SetOp};
use caoen_geometry::transform::Affine;

mod combined;
mod relief;

pub use combined::{Blended, Perturbation};
pub use relief::{relief_warp, Relief, MIN_FLOOR};

/// Deepest nesting a model may have.
pub const MAX_DEPTH: usize = 64;
/// Most nodes a model may have.
pub const MAX_NODES: usize = 10_000;
/// Largest coordinate or length a model may use (as for the other solids).
pub const WORLD_LIMIT: f64 = caoen_surface::implicit::WORLD_LIMIT;
/// Smallest length (radius, side, blend range) a model may use.
pub const MIN_LENGTH: f64 = 1e-9;

/// A field node: `f >= 0` inside.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    /// A primitive.
    Primitive(Primitive),
    /// A base solid perturbed by a height map.
    HeightMap(HeightMap),
    /// The inside of a closed Cao En surface: the signed distance to its tessellation.
    Surface(std::sync::Arc<MeshField>),
    /// An R-function set operation folded over two or more operands, left to right.
    SetOp {
        /// Which operation.
        op: SetOp,
        /// The R-function parameter in [0, 1] (1: max/min).
        a: f64,
        /// The operands.
        operands: Vec<Node>,
    },
    /// A blending union or intersection of two operands.
    Blend(Blended),
    /// A base perturbed by quadric patches.
    Perturb(Perturbation),
    /// A picture swept through space along its projection: `h(u(p), v(p)) - level`
    /// (positive where the picture is brighter than `level`), for carving.
    Pattern {
        /// The picture and its projection.
        map: HeightMap,
        /// The grey level of the boundary.
        level: f64,
    },
    /// A base pushed along a picture's projection.
    Relief(Relief),
    /// `-f`: the complement (outside becomes inside).
    Negate(Box<Node>),
    /// The operand read at a warped point (twist, taper, bend): `f(W(p))`.
    Warp {
        /// The warp.
        warp: Warp,
        /// The operand.
        operand: Box<Node>,
    },
    /// `f + amplitude n(p / scale)`: the operand roughened by gradient noise.
    Noise {
        /// The noise.
        noise: Noise,
        /// The operand.
        operand: Box<Node>,
    },
    /// `min(f, thickness - f)`: the solid between the operand's surface and the one
    /// where `f = thickness` inside it (a wall about `thickness / |grad f|` thick), with
    /// the operand evaluated once.
    Shell {
        /// The level of the inner surface.
        thickness: f64,
        /// The operand.
        operand: Box<Node>,
    },
    /// `f + by`: grows the solid (shrinks it for a negative amount).
    Offset {
        /// Added to the function.
        by: f64,
        /// The operand.
        operand: Box<Node>,
    },
    /// The operand moved by an affine map: `f(A^-1 p)`.
    Transform {
        /// The map from the operand's space into the model's.
        forward: Affine,
        /// Its inverse.
        inverse: Affine,
        /// The operand.
        operand: Box<Node>,
    },
}

/// One patch of a perturbation: `factor * max(Q, 0)^power`.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    /// `Q`, positive over the patch.
    pub support: Support,
    /// The form factor (positive adds material).
    pub factor: f64,
}

/// The function `Q` of a patch.
#[derive(Debug, Clone, PartialEq)]
pub enum Support {
    /// A quadric primitive (its ten coefficients).
    Quadric(Primitive),
    /// A convex triangle or quad on a plane or a sphere.
    Polygon(PolygonSupport),
}

impl Support {
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self {
            Support::Quadric(q) => q.value_gradient(p),
            Support::Polygon(s) => s.value_gradient(p),
        }
    }

    fn interval(&self, b: &Aabb) -> Interval {
        match self {
            Support::Quadric(q) => q.interval(b),
            Support::Polygon(s) => s.interval(b),
        }
    }
}

impl Patch {
    /// The patch's value and gradient for `power`.
    fn value_gradient(&self, p: [f64; 3], power: i32) -> (f64, [f64; 3]) {
        let (q, g) = self.support.value_gradient(p);
        if q <= 0.0 {
            return (0.0, [0.0; 3]);
        }
        let r = self.factor * q.powi(power);
        let d = self.factor * f64::from(power) * q.powi(power - 1);
        (r, g.map(|v| d * v))
    }

    fn interval(&self, b: &Aabb, power: i32) -> Interval {
        let q = self.support.interval(b);
        let (lo, hi) = (q.lo.max(0.0), q.hi.max(0.0));
        Interval::new(lo.powi(power), hi.powi(power)).scale(self.factor)
    }

    /// The box of the region where `Q > 0`, if it is bounded (an ellipsoid's inside,
    /// a polygon's band).
    pub fn positive_box(&self) -> Option<Aabb> {
        let quadric = match &self.support {
            Support::Polygon(s) => return Some(s.positive_box()),
            Support::Quadric(q) => q,
        };
        let Primitive::Quadric { coefficients: c } = quadric else {
            return None;
        };
        // Q = x^T A x + b . x + k with A symmetric.
        let a = [
            [c[0], 0.5 * c[3], 0.5 * c[5]],
            [0.5 * c[3], c[1], 0.5 * c[4]],
            [0.5 * c[5], 0.5 * c[4], c[2]],
        ];
        let b = [c[6], c[7], c[8]];
        // Bounded only if -A is positive definite (leading minors of -A positive).
        let m1 = -a[0][0];
        let m2 = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
        if !(m1 > 0.0 && m2 > 0.0 && -det > 0.0) {
            return None;
        }
        // Inverse of A by cofactors.
        let inv = |i: usize, j: usize| {
            let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
            let (c0, c1) = ((i + 1) % 3, (i + 2) % 3);
            (a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]) / det
        };
        let centre = [0, 1, 2].map(|i| -0.5 * (0..3).map(|j| inv(i, j) * b[j]).sum::<f64>());
        let (top, _) = quadric.value_gradient(centre);
        if top <= 0.0 {
            return None;
        }
        // Half-width along axis k: sqrt(top * ((-A)^-1)_kk).
        let half = [0, 1, 2].map(|k| (top * -inv(k, k)).max(0.0).sqrt());
        Some(Aabb::new(
            [0, 1, 2].map(|k| centre[k] - half[k]),
            [0, 1, 2].map(|k| centre[k] + half[k]),
        ))
    }
}

thread_local! {
    /// Scratch for the terms near a point, reused so evaluation does not allocate.
    static CANDIDATES: std::cell::RefCell<Vec<Vec<u32>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Runs `f` with an empty scratch list (one per nesting level: perturbations nest).
fn with_candidates<R>(f: impl FnOnce(&mut Vec<u32>) -> R) -> R {
    let mut list = CANDIDATES
        .with(|c| c.borrow_mut().pop())
        .unwrap_or_default();
    let r = f(&mut list);
    CANDIDATES.with(|c| c.borrow_mut().push(list));
    r
}

/// The quadric `height (1 - |p - centre|^2 / radius^2)` as ten coefficients: a bump
/// patch, positive in the ball.
pub fn bump_quadric(centre: [f64; 3], radius: f64, height: f64) -> [f64; 10] {
    let (c, k) = (centre, -height / (radius * radius));
    [
        k,
        k,
        k,
        0.0,
        0.0,
        0.0,
        -2.0 * k * c[0],
        -2.0 * k * c[1],
        -2.0 * k * c[2],
        height + k * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
    ]
}

impl Node {
    /// A perturbation `base + sum_i f_i max(Q_i, 0)^power`, indexed by the patches'
    /// supports so that a point or box only visits the patches that reach it.
    pub fn perturb(base: Node, terms: Vec<Patch>, power: i32) -> Node {
        let supports: Vec<Option<Aabb>> = terms.iter().map(Patch::positive_box).collect();
        Node::Perturb(Perturbation {
            base: Box::new(base),
            index: PatchIndex::new(&supports),
            terms,
            power,
        })
    }

    /// The function's value at `p`.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        match self {
            Node::Primitive(q) => q.value_gradient(p).0,
            Node::HeightMap(h) => h.value(p),
            Node::Surface(m) => m.value_gradient(p).0,
            Node::SetOp { op, a, operands } => fold(
                operands,
                f64::NEG_INFINITY,
                |n| n.value(p),
                |x, y| rfunction::apply(*op, x, y, *a),
            ),
            Node::Blend(n) => n.value(p),
            Node::Perturb(n) => n.value(p),
            Node::Pattern { map, level } => map.perturbation_value(p) - level,
            Node::Relief(r) => r.value(p),
            Node::Shell { thickness, operand } => {
                let f = operand.value(p);
                f.min(thickness - f)
            }
            Node::Offset { by, operand } => operand.value(p) + by,
            Node::Transform {
                inverse, operand, ..
            } => operand.value(inverse.point(p)),
            Node::Negate(n) => -n.value(p),
            Node::Warp { warp, operand } => operand.value(warp.apply(p).0),
            Node::Noise { noise, operand } => operand.value(p) + noise.value_gradient(p).0,
        }
    }

    /// The function's value and exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self {
            Node::Primitive(q) => q.value_gradient(p),
            Node::HeightMap(h) => h.value_gradient(p),
            Node::Surface(m) => m.value_gradient(p),
            Node::SetOp { op, a, operands } => {
                let empty = (f64::NEG_INFINITY, [0.0; 3]);
                fold(
                    operands,
                    empty,
                    |n| n.value_gradient(p),
                    |(u, gu), (v, gv)| {
                        let (r, d1, d2) = rfunction::partials(*op, u, v, *a);
                        (r, [0, 1, 2].map(|k| d1 * gu[k] + d2 * gv[k]))
                    },
                )
            }
            Node::Blend(n) => n.value_gradient(p),
            Node::Perturb(n) => n.value_gradient(p),
            Node::Pattern { map, level } => {
                let (h, g) = map.perturbation(p);
                (h - level, g)
            }
            Node::Relief(r) => r.value_gradient(p),
            Node::Shell { thickness, operand } => {
                let (v, g) = operand.value_gradient(p);
                // The same branch as `min` in `value` (ties to the outer surface).
                if v <= thickness - v {
                    (v, g)
                } else {
                    (thickness - v, g.map(|x| -x))
                }
            }
            Node::Offset { by, operand } => {
                let (v, g) = operand.value_gradient(p);
                (v + by, g)
            }
            Node::Transform {
                inverse, operand, ..
            } => {
                let (v, g) = operand.value_gradient(inverse.point(p));
                (v, inverse.transpose_mul(g))
            }
            Node::Negate(n) => {
                let (v, g) = n.value_gradient(p);
                (-v, g.map(|x| -x))
            }
            Node::Warp { warp, operand } => {
                let (w, j) = warp.apply(p);
                let (v, g) = operand.value_gradient(w);
                (v, [0, 1, 2].map(|k| (0..3).map(|i| j[i][k] * g[i]).sum()))
            }
            Node::Noise { noise, operand } => {
                let (v, g) = operand.value_gradient(p);
                let (n, gn) = noise.value_gradient(p);
                (v + n, [0, 1, 2].map(|k| g[k] + gn[k]))
            }
        }
    }

    /// Bounds of the function over the box `b`.
    pub fn interval(&self, b: &Aabb) -> Interval {
        match self {
            Node::Primitive(q) => q.interval(b),
            Node::HeightMap(h) => h.interval(b),
            Node::Surface(m) => m.interval(b),
            Node::SetOp { op, a, operands } => {
                let empty = Interval::point(f64::NEG_INFINITY);
                fold(
                    operands,
                    empty,
                    |n| n.interval(b),
                    |x, y| rfunction::interval(*op, x, y, *a),
                )
            }
            Node::Blend(n) => n.interval(b),
            Node::Perturb(n) => n.interval(b),
            Node::Pattern { map, level } => map.perturbation_range(b) - Interval::point(*level),
            Node::Relief(r) => r.interval(b),
            Node::Shell { thickness, operand } => shell_interval(operand.interval(b), *thickness),
            Node::Offset { by, operand } => operand.interval(b) + Interval::point(*by),
            Node::Transform {
                inverse, operand, ..
            } => operand.interval(&map_box(inverse, b)),
            Node::Negate(n) => -n.interval(b),
            Node::Warp { warp, operand } => operand.interval(&warp.apply_box(b)),
            Node::Noise { noise, operand } => operand.interval(b) + noise.interval(b),
        }
    }

    /// A box holding the solid, or None if the model cannot bound it.
    pub fn bounds(&self) -> Option<Aabb> {
        match self {
            Node::Primitive(q) => q.bounds(),
            Node::HeightMap(h) => h.bounds(),
            Node::Surface(m) => Some(m.bounds()),
            Node::SetOp { op, operands, .. } => match op {
                SetOp::Union => operands
                    .iter()
                    .map(Node::bounds)
                    .try_fold(None::<Aabb>, |acc, b| {
                        let b = b?;
                        Some(Some(acc.map_or(b, |a| a.union(&b))))
                    })
                    .flatten(),
                SetOp::Intersection => operands
                    .iter()
                    .filter_map(Node::bounds)
                    .reduce(|a, b| a.intersection(&b).unwrap_or(Aabb::new(a.lo, a.lo))),
                SetOp::Difference => operands.first().and_then(Node::bounds),
            },
            Node::Blend(n) => n.bounds(),
            Node::Perturb(n) => n.bounds(),
            // A swept picture reaches infinity along its projection.
            Node::Pattern { .. } => None,
            Node::Relief(r) => r.bounds(),
            // Inside the shell, f >= 0: inside the operand.
            Node::Shell { operand, .. } => operand.bounds(),
            Node::Offset { by, operand } => {
                let b = operand.bounds()?;
                // For the quadratic primitives, f + by moves the boundary by about
                // by / |grad f|; a margin proportional to the offset and the box covers it.
                let grow = if *by > 0.0 { by.sqrt() + by } else { 0.0 };
                Some(b.padded(grow))
            }
            Node::Transform {
                forward, operand, ..
            } => Some(map_box(forward, &operand.bounds()?)),
            // The complement of a bounded solid reaches infinity.
            Node::Negate(_) => None,
            Node::Warp { warp, operand } => Some(warp.inverse_box(&operand.bounds()?)),
            Node::Noise { noise, operand } => {
                // As an offset by the noise's largest value.
                let by = noise.amplitude.abs() * super::deform::NOISE_BOUND;
                Some(operand.bounds()?.padded(by.sqrt() + by))
            }
        }
    }

    /// Number of nodes.
    pub fn count(&self) -> usize {
        1 + match self {
            Node::Primitive(_) | Node::HeightMap(_) | Node::Surface(_) => 0,
            Node::SetOp { operands, .. } => operands.iter().map(Node::count).sum(),
            Node::Blend(n) => n.operands.iter().map(Node::count).sum(),
            Node::Perturb(n) => n.base.count() + n.terms.len(),
            Node::Pattern { .. } => 0,
            Node::Relief(r) => r.base.count(),
            Node::Offset { operand, .. }
            | Node::Shell { operand, .. }
            | Node::Transform { operand, .. }
            | Node::Warp { operand, .. }
            | Node::Noise { operand, .. } => operand.count(),
            Node::Negate(n) => n.count(),
        }
    }
}

/// What `leaf` gives for each of `operands`, folded left to right by `join` (a set
/// operation's value, gradient or interval); `empty` when there are none.
fn fold<T>(operands: &[Node], empty: T, leaf: impl Fn(&Node) -> T, join: impl Fn(T, T) -> T) -> T {
    let mut it = operands.iter();
    let first = it.next().map_or(empty, &leaf);
    it.fold(first, |acc, n| join(acc, leaf(n)))
}

/// The range of `min(x, t - x)` for `x` in `f`: the function rises to `t / 2` at
/// `x = t / 2` and falls after it, so the ends give the low bound and the peak caps
/// the high one.
fn shell_interval(f: Interval, t: f64) -> Interval {
    Interval::new(f.lo.min(t - f.hi), f.hi.min(t - f.lo).min(0.5 * t))
}

/// The box holding the image of box `b` under `m` (interval arithmetic per row).
fn map_box(m: &Affine, b: &Aabb) -> Aabb {
    let axes = b.axes();
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for i in 0..3 {
        let r = (0..3)
            .map(|j| axes[j].scale(m.m[i][j]))
            .fold(Interval::point(m.t[i]), |acc, x| acc + x);
        lo[i] = r.lo;
        hi[i] = r.hi;
    }
    Aabb { lo, hi }
}

/// The mean gradient length of `node` near its surface: over a 24^3 grid on the box,
/// the points within half a cell of the surface (by `|f| / |grad f|`).
pub fn mean_surface_gradient(node: &Node, b: &Aabb) -> f64 {
    let n = 24;
    let cell = b.longest() / n as f64;
    let (mut sum, mut count) = (0.0, 0usize);
    for i in 0..=n {
        for j in 0..=n {
            for k in 0..=n {
                let t = [i, j, k].map(|v| v as f64 / n as f64);
                let p = [0, 1, 2].map(|a| b.lo[a] + t[a] * (b.hi[a] - b.lo[a]));
                let (f, g) = node.value_gradient(p);
                let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if len > 0.0 && len.is_finite() && f.abs() / len <= 0.5 * cell {
                    sum += len;
                    count += 1;
                }
            }
        }
    }
    if count == 0 {
        1.0
    } else {
        sum / count as f64
    }
}

#[cfg(test)]
mod tests;
