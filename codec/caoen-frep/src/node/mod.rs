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
use super::rfunction::{self, BlendShape, SetOp};
use caoen_geometry::transform::Affine;

mod relief;

pub use relief::relief_warp;
use relief::{relief_point, relief_warp_box};

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
    Blend {
        /// Union or intersection.
        op: SetOp,
        /// The R-function parameter.
        a: f64,
        /// The added term's height and fall-offs.
        shape: BlendShape,
        /// The two operands.
        operands: Box<[Node; 2]>,
    },
    /// `f + sum_i factor_i max(Q_i, 0)^power`: the base perturbed by quadric patches
    /// (power 2: C1 where a patch ends; power 3: C2).
    Perturb {
        /// The base.
        base: Box<Node>,
        /// The perturbing quadrics with their form factors.
        terms: Vec<Patch>,
        /// The exponent (2 or 3).
        power: i32,
        /// Which terms reach a point or a box (built by [`Node::perturb`]).
        index: PatchIndex,
    },
    /// A picture swept through space along its projection: `h(u(p), v(p)) - level`
    /// (positive where the picture is brighter than `level`), for carving.
    Pattern {
        /// The picture and its projection.
        map: HeightMap,
        /// The grey level of the boundary.
        level: f64,
    },
    /// Relief: the base's space pushed along the picture's projection by `depth` times
    /// its grey level, `f(W(p))` ([`relief_warp`]): the surface moves by `depth h`
    /// along the projection's rays (up for planar, away from the axis or the centre
    /// otherwise), so the offset means the same length on every face.
    Relief {
        /// The base.
        base: Box<Node>,
        /// The picture and its projection.
        map: HeightMap,
        /// Height of white, in the model's units (negative engraves).
        depth: f64,
        /// Planar: the base's z range, over which the push fades in from nothing at
        /// the bottom (so the bottom keeps its shape) to all of it at the top.
        ramp: [f64; 2],
    },
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
        Node::Perturb {
            base: Box::new(base),
            index: PatchIndex::new(&supports),
            terms,
            power,
        }
    }

    /// The function's value at `p`.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        match self {
            Node::Primitive(q) => q.value_gradient(p).0,
            Node::HeightMap(h) => h.value(p),
            Node::Surface(m) => m.value_gradient(p).0,
            Node::SetOp { op, a, operands } => {
                let mut it = operands.iter();
                let first = it.next().map_or(f64::NEG_INFINITY, |n| n.value(p));
                it.fold(first, |acc, n| rfunction::apply(*op, acc, n.value(p), *a))
            }
            Node::Blend {
                op,
                a,
                shape,
                operands,
            } => {
                let (f1, f2) = (operands[0].value(p), operands[1].value(p));
                rfunction::apply(*op, f1, f2, *a) + rfunction::blend_partials(f1, f2, *shape).0
            }
            Node::Perturb {
                base,
                terms,
                power,
                index,
            } => {
                // Added one by one, in the same order as value_gradient.
                with_candidates(|near| {
                    index.at_point(p, near);
                    near.iter().fold(base.value(p), |v, &t| {
                        v + terms[t as usize].value_gradient(p, *power).0
                    })
                })
            }
            Node::Pattern { map, level } => map.perturbation_value(p) - level,
            Node::Relief {
                base,
                map,
                depth,
                ramp,
            } => base.value(relief_point(map, *depth, *ramp, p)),
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
                let mut it = operands.iter();
                let mut acc = it
                    .next()
                    .map_or((f64::NEG_INFINITY, [0.0; 3]), |n| n.value_gradient(p));
                for n in it {
                    let (v, g) = n.value_gradient(p);
                    let (r, d1, d2) = rfunction::partials(*op, acc.0, v, *a);
                    acc = (r, [0, 1, 2].map(|k| d1 * acc.1[k] + d2 * g[k]));
                }
                acc
            }
            Node::Blend {
                op,
                a,
                shape,
                operands,
            } => {
                let (f1, g1) = operands[0].value_gradient(p);
                let (f2, g2) = operands[1].value_gradient(p);
                let (r, d1, d2) = rfunction::partials(*op, f1, f2, *a);
                let (b, e1, e2) = rfunction::blend_partials(f1, f2, *shape);
                (
                    r + b,
                    [0, 1, 2].map(|k| (d1 + e1) * g1[k] + (d2 + e2) * g2[k]),
                )
            }
            Node::Perturb {
                base,
                terms,
                power,
                index,
            } => {
                let (mut v, mut g) = base.value_gradient(p);
                with_candidates(|near| {
                    index.at_point(p, near);
                    for &t in near.iter() {
                        let (r, gr) = terms[t as usize].value_gradient(p, *power);
                        v += r;
                        for k in 0..3 {
                            g[k] += gr[k];
                        }
                    }
                });
                (v, g)
            }
            Node::Pattern { map, level } => {
                let (h, g) = map.perturbation(p);
                (h - level, g)
            }
            Node::Relief {
                base,
                map,
                depth,
                ramp,
            } => {
                let (w, j) = relief_warp(map, *depth, *ramp, p);
                let (v, g) = base.value_gradient(w);
                // The chain rule: grad_k = sum_i dW_i/dp_k g_i.
                (v, [0, 1, 2].map(|k| (0..3).map(|i| j[i][k] * g[i]).sum()))
            }
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
                let mut it = operands.iter();
                let first = it
                    .next()
                    .map_or(Interval::point(f64::NEG_INFINITY), |n| n.interval(b));
                it.fold(first, |acc, n| {
                    rfunction::interval(*op, acc, n.interval(b), *a)
                })
            }
            Node::Blend {
                op,
                a,
                shape,
                operands,
            } => {
                let (i1, i2) = (operands[0].interval(b), operands[1].interval(b));
                rfunction::interval(*op, i1, i2, *a) + rfunction::blend_interval(i1, i2, *shape)
            }
            Node::Perturb {
                base,
                terms,
                power,
                index,
            } => with_candidates(|near| {
                index.in_box(b, near);
                near.iter().fold(base.interval(b), |acc, &t| {
                    acc + terms[t as usize].interval(b, *power)
                })
            }),
            Node::Pattern { map, level } => map.perturbation_range(b) - Interval::point(*level),
            Node::Relief {
                base,
                map,
                depth,
                ramp,
            } => base.interval(&relief_warp_box(map, *depth, *ramp, b)),
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
            Node::Blend {
                op,
                shape,
                operands,
                ..
            } => {
                let (b1, b2) = (operands[0].bounds(), operands[1].bounds());
                let joined = match op {
                    SetOp::Union => b1.zip(b2).map(|(x, y)| x.union(&y)),
                    SetOp::Difference => b1,
                    SetOp::Intersection => match (b1, b2) {
                        (Some(x), Some(y)) => Some(x.intersection(&y).unwrap_or(x)),
                        (x, y) => x.or(y),
                    },
                }?;
                // The blend adds material only where both functions are within a few
                // fall-off ranges of zero; a margin of a quarter of the box (at least
                // the ranges) holds it for the usual scales.
                Some(joined.padded(
                    (0.25 * joined.longest()).max(shape.a1.max(shape.a2).min(joined.longest())),
                ))
            }
            Node::Perturb { base, terms, .. } => {
                let mut b = base.bounds()?;
                for t in terms.iter().filter(|t| t.factor > 0.0) {
                    b = b.union(&t.positive_box()?);
                }
                Some(b)
            }
            // A swept picture reaches infinity along its projection.
            Node::Pattern { .. } => None,
            Node::Relief {
                base, map, depth, ..
            } => {
                let b = base.bounds()?;
                // Every point moves by at most |depth| max |h|.
                let h = map.perturbation_range(&b);
                Some(b.padded(depth.abs() * h.lo.abs().max(h.hi.abs())))
            }
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
            Node::Blend { operands, .. } => operands.iter().map(Node::count).sum(),
            Node::Perturb { base, terms, .. } => base.count() + terms.len(),
            Node::Pattern { .. } => 0,
            Node::Relief { base, .. } => base.count(),
            Node::Offset { operand, .. }
            | Node::Shell { operand, .. }
            | Node::Transform { operand, .. }
            | Node::Warp { operand, .. }
            | Node::Noise { operand, .. } => operand.count(),
            Node::Negate(n) => n.count(),
        }
    }
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
