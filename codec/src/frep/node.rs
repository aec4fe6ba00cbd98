//! The F-rep model: a tree of field nodes (primitives, R-function set operations,
//! blends, offsets, affine transforms), its value, exact gradient (chain rule through
//! every node), interval bound over a box and bounding box, and its JSON form
//! (`docs/frep.md`).

use serde_json::Value;

use super::height_map::{Base, HeightMap, Interp};
use super::interval::{Aabb, Interval};
use super::mesh_field::MeshField;
use super::patch_index::PatchIndex;
use super::polygon_patch::PolygonSupport;
use super::primitive::Primitive;
use super::rfunction::{self, SetOp};
use crate::geometry::transform::Affine;

/// Deepest nesting a model may have.
pub const MAX_DEPTH: usize = 64;
/// Most nodes a model may have.
pub const MAX_NODES: usize = 10_000;
/// Largest coordinate or length a model may use (as for the other solids).
pub const WORLD_LIMIT: f64 = crate::surface::implicit::WORLD_LIMIT;
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
        /// Height of the blend (positive adds material).
        a0: f64,
        /// Fall-off along the first operand's function.
        a1: f64,
        /// Fall-off along the second operand's function.
        a2: f64,
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
    /// Relief: the base displaced along its normal by a picture's grey levels,
    /// `f + gain h(u(p), v(p))`, where `gain` is the depth times the base function's
    /// mean gradient length on its surface (so the offset is about `depth h`).
    Relief {
        /// The base.
        base: Box<Node>,
        /// The picture and its projection.
        map: HeightMap,
        /// Depth times the base's mean gradient length on the surface.
        gain: f64,
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

/// A malformed or out-of-range model, with the JSON path of the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}: {reason}")]
pub struct ModelError {
    /// Where, e.g. `model.union[1].sphere.radius`.
    pub path: String,
    /// What is wrong.
    pub reason: String,
}

fn err<T>(path: &str, reason: impl Into<String>) -> Result<T, ModelError> {
    Err(ModelError {
        path: path.to_string(),
        reason: reason.into(),
    })
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
            Node::HeightMap(h) => h.value_gradient(p).0,
            Node::Surface(m) => m.value_gradient(p).0,
            Node::SetOp { op, a, operands } => {
                let mut it = operands.iter();
                let first = it.next().map_or(f64::NEG_INFINITY, |n| n.value(p));
                it.fold(first, |acc, n| rfunction::apply(*op, acc, n.value(p), *a))
            }
            Node::Blend {
                op,
                a,
                a0,
                a1,
                a2,
                operands,
            } => {
                let (f1, f2) = (operands[0].value(p), operands[1].value(p));
                rfunction::apply(*op, f1, f2, *a)
                    + rfunction::blend_partials(f1, f2, *a0, *a1, *a2).0
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
            Node::Pattern { map, level } => map.perturbation(p).0 - level,
            Node::Relief { base, map, gain } => base.value(p) + gain * map.perturbation(p).0,
            Node::Offset { by, operand } => operand.value(p) + by,
            Node::Transform {
                inverse, operand, ..
            } => operand.value(inverse.point(p)),
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
                a0,
                a1,
                a2,
                operands,
            } => {
                let (f1, g1) = operands[0].value_gradient(p);
                let (f2, g2) = operands[1].value_gradient(p);
                let (r, d1, d2) = rfunction::partials(*op, f1, f2, *a);
                let (b, e1, e2) = rfunction::blend_partials(f1, f2, *a0, *a1, *a2);
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
            Node::Relief { base, map, gain } => {
                let (v, g) = base.value_gradient(p);
                let (h, gh) = map.perturbation(p);
                (v + gain * h, [0, 1, 2].map(|k| g[k] + gain * gh[k]))
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
                a0,
                a1,
                a2,
                operands,
            } => {
                let (i1, i2) = (operands[0].interval(b), operands[1].interval(b));
                rfunction::interval(*op, i1, i2, *a)
                    + rfunction::blend_interval(i1, i2, *a0, *a1, *a2)
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
            Node::Relief { base, map, gain } => {
                base.interval(b) + map.perturbation_range(b).scale(*gain)
            }
            Node::Offset { by, operand } => operand.interval(b) + Interval::point(*by),
            Node::Transform {
                inverse, operand, ..
            } => operand.interval(&map_box(inverse, b)),
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
                a1,
                a2,
                operands,
                ..
            } => {
                let (b1, b2) = (operands[0].bounds(), operands[1].bounds());
                let joined = match op {
                    SetOp::Union => b1.zip(b2).map(|(x, y)| x.union(&y)),
                    _ => match (b1, b2) {
                        (Some(x), Some(y)) => Some(x.intersection(&y).unwrap_or(x)),
                        (x, y) => x.or(y),
                    },
                }?;
                // The blend adds material only where both functions are within a few
                // fall-off ranges of zero; a margin of a quarter of the box (at least
                // the ranges) holds it for the usual scales.
                Some(
                    joined.padded((0.25 * joined.longest()).max(a1.max(*a2).min(joined.longest()))),
                )
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
            Node::Relief { base, map, gain } => {
                let b = base.bounds()?;
                // Raised by at most depth * max h, in the base's own length units.
                let top = map.perturbation_range(&b).hi.max(0.0) * gain;
                let g = mean_surface_gradient(base, &b);
                Some(b.padded(if g > 0.0 { 1.5 * top / g } else { 0.0 }))
            }
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
            Node::Offset { operand, .. } | Node::Transform { operand, .. } => operand.count(),
        }
    }

    /// Parses a node from its JSON form; `path` names it in errors. Image files (height
    /// maps) are relative to `base_dir`.
    pub fn from_json(
        v: &Value,
        path: &str,
        base_dir: &std::path::Path,
    ) -> Result<Node, ModelError> {
        let mut ctx = Context { count: 0, base_dir };
        parse(v, path, 0, &mut ctx)
    }
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

fn number(v: &Value, path: &str, lo: f64, hi: f64) -> Result<f64, ModelError> {
    let Some(x) = v.as_f64() else {
        return err(path, format!("expected a number, found {v}"));
    };
    if !(x >= lo && x <= hi) {
        return err(
            path,
            format!("{x} is outside the allowed range [{lo}, {hi}]"),
        );
    }
    Ok(x)
}

/// `N` numbers in `lo..=hi` as a JSON list; `shape` names the list in the error.
fn numbers<const N: usize>(
    v: &Value,
    path: &str,
    lo: f64,
    hi: f64,
    shape: &str,
) -> Result<[f64; N], ModelError> {
    let Some(a) = v.as_array().filter(|a| a.len() == N) else {
        return err(path, format!("expected {shape}"));
    };
    let mut out = [0.0; N];
    for k in 0..N {
        out[k] = number(&a[k], &format!("{path}[{k}]"), lo, hi)?;
    }
    Ok(out)
}

/// The `interp` field of a picture: bilinear (the default) or bicubic.
fn interp_of(o: &serde_json::Map<String, Value>, here: &str) -> Result<Interp, ModelError> {
    match o.get("interp").map(|v| v.as_str()) {
        None | Some(Some("bilinear")) => Ok(Interp::Bilinear),
        Some(Some("bicubic")) => Ok(Interp::Bicubic),
        Some(_) => err(
            &format!("{here}.interp"),
            "expected \"bilinear\" or \"bicubic\"",
        ),
    }
}

/// The `image` field of a picture, as a file relative to `base_dir`.
fn image_file(
    o: &serde_json::Map<String, Value>,
    here: &str,
    base_dir: &std::path::Path,
) -> Result<std::path::PathBuf, ModelError> {
    match get(o, "image", here)?.as_str() {
        Some(name) => Ok(base_dir.join(name)),
        None => err(&format!("{here}.image"), "expected a file name"),
    }
}

fn vec3(v: &Value, path: &str, lo: f64, hi: f64) -> Result<[f64; 3], ModelError> {
    match v.as_array() {
        Some(a) if a.len() == 3 => {
            let mut out = [0.0; 3];
            for k in 0..3 {
                out[k] = number(&a[k], &format!("{path}[{k}]"), lo, hi)?;
            }
            Ok(out)
        }
        _ => err(path, "expected three numbers [x, y, z]"),
    }
}

/// The fields of a parameter object: each key once, no others than `allowed`.
fn fields<'a>(
    v: &'a Value,
    path: &str,
    allowed: &[&str],
) -> Result<&'a serde_json::Map<String, Value>, ModelError> {
    let Some(o) = v.as_object() else {
        return err(path, "expected an object");
    };
    for k in o.keys() {
        if !allowed.contains(&k.as_str()) {
            return err(
                path,
                format!(
                    "unknown field `{k}` (expected one of: {})",
                    allowed.join(", ")
                ),
            );
        }
    }
    Ok(o)
}

fn get<'a>(
    o: &'a serde_json::Map<String, Value>,
    key: &str,
    path: &str,
) -> Result<&'a Value, ModelError> {
    o.get(key).ok_or_else(|| ModelError {
        path: path.to_string(),
        reason: format!("missing field `{key}`"),
    })
}

const PRIMITIVES: [&str; 11] = [
    "cao_en_solid",
    "caoen_surface",
    "height_map",
    "sphere",
    "box",
    "cylinder",
    "cone",
    "torus",
    "half_space",
    "quadric",
    "superellipsoid",
];
const OPERATIONS: [&str; 10] = [
    "pattern",
    "relief",
    "perturb",
    "union",
    "intersection",
    "difference",
    "blend_union",
    "blend_intersection",
    "offset",
    "transform",
];

/// What parsing carries through the tree.
struct Context<'a> {
    count: usize,
    base_dir: &'a std::path::Path,
}

fn parse(v: &Value, path: &str, depth: usize, count: &mut Context<'_>) -> Result<Node, ModelError> {
    if depth > MAX_DEPTH {
        return err(path, format!("nested deeper than {MAX_DEPTH} levels"));
    }
    count.count += 1;
    if count.count > MAX_NODES {
        return err(path, format!("the model has more than {MAX_NODES} nodes"));
    }
    let Some(o) = v.as_object() else {
        return err(path, "expected a node object like {\"sphere\": {...}}");
    };
    let kind = o
        .keys()
        .find(|k| PRIMITIVES.contains(&k.as_str()) || OPERATIONS.contains(&k.as_str()))
        .ok_or_else(|| ModelError {
            path: path.to_string(),
            reason: format!(
                "no node kind; expected one of: {}, {}",
                PRIMITIVES.join(", "),
                OPERATIONS.join(", ")
            ),
        })?
        .clone();
    let here = format!("{path}.{kind}");
    let body = &o[&kind];
    let w = WORLD_LIMIT;
    let length = |v: &Value, p: &str| number(v, p, MIN_LENGTH, w);
    if PRIMITIVES.contains(&kind.as_str()) {
        if o.len() != 1 {
            return err(
                path,
                format!("a `{kind}` node takes no fields beside `{kind}`"),
            );
        }
        let centre = |o: &serde_json::Map<String, Value>| match o.get("centre") {
            Some(c) => vec3(c, &format!("{here}.centre"), -w, w),
            None => Ok([0.0; 3]),
        };
        let prim = match kind.as_str() {
            "height_map" => return height_map(body, &here, count.base_dir).map(Node::HeightMap),
            "caoen_surface" => return surface_field(body, &here, count.base_dir),
            "cao_en_solid" => {
                let solid =
                    super::convex_solid::convex_solid_from_json(body, &here).map_err(|e| {
                        let reason = match e.expected.as_str() {
                            "" => e.found,
                            expected => format!("{}, expected {expected}", e.found),
                        };
                        ModelError {
                            path: e.field,
                            reason,
                        }
                    })?;
                Primitive::CaoEn(super::primitive::CaoEnSolid::new(&solid))
            }
            "sphere" => {
                let f = fields(body, &here, &["centre", "radius"])?;
                Primitive::Sphere {
                    centre: centre(f)?,
                    radius: length(get(f, "radius", &here)?, &format!("{here}.radius"))?,
                }
            }
            "box" => {
                let f = fields(body, &here, &["centre", "size"])?;
                let size = vec3(
                    get(f, "size", &here)?,
                    &format!("{here}.size"),
                    MIN_LENGTH,
                    w,
                )?;
                Primitive::Box {
                    centre: centre(f)?,
                    half: size.map(|s| 0.5 * s),
                }
            }
            "cylinder" | "cone" => {
                let f = fields(body, &here, &["centre", "radius", "length"])?;
                let (c, r, l) = (
                    centre(f)?,
                    length(get(f, "radius", &here)?, &format!("{here}.radius"))?,
                    length(get(f, "length", &here)?, &format!("{here}.length"))?,
                );
                if kind == "cylinder" {
                    Primitive::Cylinder {
                        centre: c,
                        radius: r,
                        length: l,
                    }
                } else {
                    Primitive::Cone {
                        centre: c,
                        radius: r,
                        length: l,
                    }
                }
            }
            "torus" => {
                let f = fields(body, &here, &["centre", "major", "minor"])?;
                Primitive::Torus {
                    centre: centre(f)?,
                    major: length(get(f, "major", &here)?, &format!("{here}.major"))?,
                    minor: length(get(f, "minor", &here)?, &format!("{here}.minor"))?,
                }
            }
            "half_space" => {
                let f = fields(body, &here, &["point", "normal"])?;
                let point = match f.get("point") {
                    Some(p) => vec3(p, &format!("{here}.point"), -w, w)?,
                    None => [0.0; 3],
                };
                let n = vec3(get(f, "normal", &here)?, &format!("{here}.normal"), -w, w)?;
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if len < MIN_LENGTH {
                    return err(&format!("{here}.normal"), "must not be zero");
                }
                Primitive::HalfSpace {
                    point,
                    normal: n.map(|v| v / len),
                }
            }
            "quadric" => {
                let c: [f64; 10] = numbers(
                    body,
                    &here,
                    -w,
                    w,
                    "ten coefficients [a, b, c, d, e, f, g, h, i, j]",
                )?;
                if c.iter().all(|v| *v == 0.0) {
                    return err(&here, "all coefficients are zero");
                }
                Primitive::Quadric { coefficients: c }
            }
            _ => {
                let f = fields(body, &here, &["centre", "radii", "exponents"])?;
                let e = match f.get("exponents") {
                    Some(Value::Array(a)) if a.len() == 2 => [
                        number(&a[0], &format!("{here}.exponents[0]"), 0.05, 8.0)?,
                        number(&a[1], &format!("{here}.exponents[1]"), 0.05, 8.0)?,
                    ],
                    Some(_) => return err(&format!("{here}.exponents"), "expected [e1, e2]"),
                    None => [1.0, 1.0],
                };
                Primitive::Superellipsoid {
                    centre: centre(f)?,
                    radii: vec3(
                        get(f, "radii", &here)?,
                        &format!("{here}.radii"),
                        MIN_LENGTH,
                        w,
                    )?,
                    exponents: e,
                }
            }
        };
        return Ok(Node::Primitive(prim));
    }
    if kind == "pattern" {
        if o.len() != 1 {
            return err(path, "a `pattern` node takes no fields beside `pattern`");
        }
        let f = fields(
            body,
            &here,
            &["image", "projection", "rect", "level", "interp"],
        )?;
        let level = match f.get("level") {
            Some(l) => number(l, &format!("{here}.level"), -w, w)?,
            None => 0.5,
        };
        let map = picture(body, &here, count.base_dir, None)?;
        return Ok(Node::Pattern { map, level });
    }
    // Operations: the operands under the kind's key, parameters beside it.
    let op_fields: &[&str] = match kind.as_str() {
        "union" | "intersection" | "difference" => &["a"],
        "blend_union" | "blend_intersection" => &["a", "a0", "a1", "a2"],
        "offset" => &["by"],
        "perturb" => &["patches", "power"],
        "relief" => &["image", "projection", "rect", "depth", "interp"],
        _ => &["scale", "rotate_deg", "translate"],
    };
    for k in o.keys() {
        if *k != kind && !op_fields.contains(&k.as_str()) {
            return err(
                path,
                format!(
                    "unknown field `{k}` beside `{kind}` (expected: {})",
                    op_fields.join(", ")
                ),
            );
        }
    }
    let a = match o.get("a") {
        Some(v) => number(v, &format!("{path}.a"), 0.0, 1.0)?,
        None => 0.0,
    };
    let mut operands = |min: usize, max: usize| -> Result<Vec<Node>, ModelError> {
        let Some(list) = body.as_array() else {
            return err(&here, "expected a list of operand nodes");
        };
        if list.len() < min || list.len() > max {
            return err(
                &here,
                format!("has {} operands; expected {min} to {max}", list.len()),
            );
        }
        list.iter()
            .enumerate()
            .map(|(i, n)| parse(n, &format!("{here}[{i}]"), depth + 1, count))
            .collect()
    };
    Ok(match kind.as_str() {
        "union" | "intersection" | "difference" => Node::SetOp {
            op: match kind.as_str() {
                "union" => SetOp::Union,
                "intersection" => SetOp::Intersection,
                _ => SetOp::Difference,
            },
            a,
            operands: operands(2, MAX_NODES)?,
        },
        "blend_union" | "blend_intersection" => {
            let [x, y]: [Node; 2] = operands(2, 2)?.try_into().expect("two operands");
            Node::Blend {
                op: if kind == "blend_union" {
                    SetOp::Union
                } else {
                    SetOp::Intersection
                },
                a,
                a0: number(get(o, "a0", path)?, &format!("{path}.a0"), -w, w)?,
                a1: length(get(o, "a1", path)?, &format!("{path}.a1"))?,
                a2: length(get(o, "a2", path)?, &format!("{path}.a2"))?,
                operands: Box::new([x, y]),
            }
        }
        "perturb" => {
            let power = match o.get("power") {
                None => 2,
                Some(v) => match v.as_i64() {
                    Some(p @ 2..=3) => p as i32,
                    _ => return err(&format!("{path}.power"), format!("{v}: expected 2 or 3")),
                },
            };
            let Some(list) = o.get("patches").and_then(Value::as_array) else {
                return err(path, "`perturb` needs `patches`: a list of patches");
            };
            if list.is_empty() || list.len() > MAX_NODES {
                return err(
                    &format!("{path}.patches"),
                    format!("{} patches: expected 1 to {MAX_NODES}", list.len()),
                );
            }
            count.count += list.len();
            if count.count > MAX_NODES {
                return err(path, format!("the model has more than {MAX_NODES} nodes"));
            }
            let terms = list
                .iter()
                .enumerate()
                .map(|(i, t)| patch(t, &format!("{path}.patches[{i}]")))
                .collect::<Result<Vec<_>, _>>()?;
            Node::perturb(parse(body, &here, depth + 1, count)?, terms, power)
        }
        "relief" => {
            let base = parse(body, &here, depth + 1, count)?;
            let b = base.bounds().ok_or_else(|| ModelError {
                path: here.clone(),
                reason: "the relief's base must be bounded".into(),
            })?;
            let d = number(get(o, "depth", path)?, &format!("{path}.depth"), -w, w)?;
            let map = picture(&Value::Object(o.clone()), path, count.base_dir, Some(&b))?;
            let gain = d * mean_surface_gradient(&base, &b);
            Node::Relief {
                base: Box::new(base),
                map,
                gain,
            }
        }
        "offset" => Node::Offset {
            by: number(get(o, "by", path)?, &format!("{path}.by"), -w, w)?,
            operand: Box::new(parse(body, &here, depth + 1, count)?),
        },
        _ => {
            let scale = match o.get("scale") {
                None => [1.0; 3],
                Some(Value::Number(_)) => {
                    [number(&o["scale"], &format!("{path}.scale"), 1e-6, 1e6)?; 3]
                }
                Some(s) => vec3(s, &format!("{path}.scale"), 1e-6, 1e6)?,
            };
            let rot = match o.get("rotate_deg") {
                Some(r) => vec3(r, &format!("{path}.rotate_deg"), -1e4, 1e4)?,
                None => [0.0; 3],
            };
            let t = match o.get("translate") {
                Some(t) => vec3(t, &format!("{path}.translate"), -w, w)?,
                None => [0.0; 3],
            };
            let forward = Affine::from_parts(scale, rot, t);
            let Some(inverse) = forward.inverse() else {
                return err(path, "the transform is singular");
            };
            Node::Transform {
                forward,
                inverse,
                operand: Box::new(parse(body, &here, depth + 1, count)?),
            }
        }
    })
}

/// Parses a height map node and reads its image (grey level in [0, 1] times `height`).
fn height_map(v: &Value, here: &str, base_dir: &std::path::Path) -> Result<HeightMap, ModelError> {
    let w = WORLD_LIMIT;
    let f = fields(
        v,
        here,
        &["image", "base", "rect", "height", "threshold", "interp"],
    )?;
    let base = match get(f, "base", here)? {
        Value::String(s) if s == "plane" => Base::Plane,
        Value::Object(o) if o.len() == 1 && o.contains_key("ellipsoid") => Base::Ellipsoid(vec3(
            &o["ellipsoid"],
            &format!("{here}.base.ellipsoid"),
            MIN_LENGTH,
            w,
        )?),
        Value::Object(o) if o.len() == 1 && o.contains_key("cylinder") => Base::Cylinder(number(
            &o["cylinder"],
            &format!("{here}.base.cylinder"),
            MIN_LENGTH,
            w,
        )?),
        other => {
            return err(
                &format!("{here}.base"),
                format!(
                "{other}: expected \"plane\", {{\"ellipsoid\": [a, b, c]}} or {{\"cylinder\": r}}"
            ),
            )
        }
    };
    let rect = numbers(
        get(f, "rect", here)?,
        &format!("{here}.rect"),
        -w,
        w,
        "[u0, v0, u1, v1]",
    )?;
    let height = match f.get("height") {
        Some(h) => number(h, &format!("{here}.height"), -w, w)?,
        None => 1.0,
    };
    let threshold = match f.get("threshold") {
        Some(t) => number(t, &format!("{here}.threshold"), -w, w)?,
        None => f64::NEG_INFINITY,
    };
    let interp = interp_of(f, here)?;
    let file = image_file(f, here, base_dir)?;
    let (iw, ih, values) = grey_levels(&file, &format!("{here}.image"), height)?;
    HeightMap::new(base, rect, iw, ih, values, threshold, interp)
        .map(|m| m.with_source(file, height))
        .map_err(|e| ModelError {
            path: here.to_string(),
            reason: e,
        })
}

/// One patch: `{"quadric": [10 coefficients], "factor": f}`, a bump
/// `{"bump": {"centre", "radius", "height"}}` (`Q = height (1 - |p - centre|^2 / radius^2)`,
/// positive in the ball), or a `polygon` or `spherical_polygon` (`polygon_support`).
fn patch(v: &Value, path: &str) -> Result<Patch, ModelError> {
    let w = WORLD_LIMIT;
    let kinds = ["quadric", "bump", "polygon", "spherical_polygon"];
    let f = fields(v, path, &[&kinds[..], &["factor"]].concat())?;
    let factor = match f.get("factor") {
        Some(x) => number(x, &format!("{path}.factor"), -w, w)?,
        None => 1.0,
    };
    let given: Vec<&str> = kinds.into_iter().filter(|k| f.contains_key(*k)).collect();
    let [kind] = given[..] else {
        return err(
            path,
            format!("give exactly one of `{}`", kinds.join("`, `")),
        );
    };
    if kind == "polygon" || kind == "spherical_polygon" {
        let here = format!("{path}.{kind}");
        let support = polygon_support(&f[kind], &here, kind == "spherical_polygon")?;
        return Ok(Patch {
            support: Support::Polygon(support),
            factor,
        });
    }
    let coefficients = match (f.get("quadric"), f.get("bump")) {
        (Some(q), None) => numbers(q, &format!("{path}.quadric"), -w, w, "ten coefficients")?,
        (None, Some(b)) => {
            let here = format!("{path}.bump");
            let g = fields(b, &here, &["centre", "radius", "height"])?;
            let c = match g.get("centre") {
                Some(c) => vec3(c, &format!("{here}.centre"), -w, w)?,
                None => [0.0; 3],
            };
            let r = number(
                get(g, "radius", &here)?,
                &format!("{here}.radius"),
                MIN_LENGTH,
                w,
            )?;
            let h = number(
                get(g, "height", &here)?,
                &format!("{here}.height"),
                MIN_LENGTH,
                w,
            )?;
            bump_quadric(c, r, h)
        }
        _ => unreachable!("exactly one kind, checked above"),
    };
    Ok(Patch {
        support: Support::Quadric(Primitive::Quadric { coefficients }),
        factor,
    })
}

/// A polygon patch's support: `{"vertices": [[x, y, z], ...], "depth": d}` (3 or 4
/// vertices on a plane), or on a sphere with `"centre"` (default the origin) and
/// `"radius"` as well.
fn polygon_support(v: &Value, here: &str, spherical: bool) -> Result<PolygonSupport, ModelError> {
    let w = WORLD_LIMIT;
    let allowed: &[&str] = if spherical {
        &["vertices", "depth", "centre", "radius"]
    } else {
        &["vertices", "depth"]
    };
    let g = fields(v, here, allowed)?;
    let at = format!("{here}.vertices");
    let Some(list) = get(g, "vertices", here)?
        .as_array()
        .filter(|a| (3..=4).contains(&a.len()))
    else {
        return err(&at, "expected 3 or 4 vertices [[x, y, z], ...]");
    };
    let vertices = list
        .iter()
        .enumerate()
        .map(|(i, p)| vec3(p, &format!("{at}[{i}]"), -w, w))
        .collect::<Result<Vec<_>, _>>()?;
    let depth = number(
        get(g, "depth", here)?,
        &format!("{here}.depth"),
        MIN_LENGTH,
        w,
    )?;
    let made = if spherical {
        let centre = match g.get("centre") {
            Some(c) => vec3(c, &format!("{here}.centre"), -w, w)?,
            None => [0.0; 3],
        };
        let radius = number(
            get(g, "radius", here)?,
            &format!("{here}.radius"),
            MIN_LENGTH,
            w,
        )?;
        PolygonSupport::spherical(centre, radius, &vertices, depth)
    } else {
        PolygonSupport::planar(&vertices, depth)
    };
    made.map_err(|reason| ModelError {
        path: here.to_string(),
        reason,
    })
}

/// Finest tessellation a `caoen_surface` node may ask for (an icosphere of 20 4^7
/// triangles, 327,680).
pub const MAX_SURFACE_DETAIL: u32 = 7;

/// `{"caoen_surface": {"file": "surface.json", "detail": d}}`: a closed Cao En surface
/// (a `caoen-surface/1` file relative to the model, three shape components) tessellated
/// at `detail` (default 5) as the field of its inside.
fn surface_field(v: &Value, here: &str, base_dir: &std::path::Path) -> Result<Node, ModelError> {
    use crate::surface::tessellate::{tessellate, NormalMode};
    let f = fields(v, here, &["file", "detail"])?;
    let Some(name) = get(f, "file", here)?.as_str() else {
        return err(&format!("{here}.file"), "expected a file name");
    };
    let detail = match f.get("detail") {
        Some(d) => number(
            d,
            &format!("{here}.detail"),
            0.0,
            f64::from(MAX_SURFACE_DETAIL),
        )?,
        None => 5.0,
    };
    if detail.fract() != 0.0 {
        return err(
            &format!("{here}.detail"),
            format!("{detail}: expected a whole number"),
        );
    }
    let fail = |at: &str, e: String| ModelError {
        path: at.to_string(),
        reason: e,
    };
    let model = crate::surface::model_file::SurfaceModel::load(&base_dir.join(name))
        .map_err(|e| fail(&format!("{here}.file"), e.to_string()))?;
    if model.network.output_dim() != 3 {
        return err(
            &format!("{here}.file"),
            format!(
                "{name}: shape vectors have {} components; a solid needs 3",
                model.network.output_dim()
            ),
        );
    }
    let mesh = tessellate(&model, detail as u32, NormalMode::Exact)
        .map_err(|e| fail(here, e.to_string()))?;
    let field = MeshField::new(&mesh).map_err(|e| fail(here, format!("{name}: {e}")))?;
    Ok(Node::Surface(std::sync::Arc::new(field)))
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

/// A picture with its projection (`pattern` and `relief` nodes): `image` (grey levels
/// in [0, 1]), `projection` planar (along z), cylindrical (around z) or spherical
/// (around the origin), `rect` in the projection's parameters (default: the box's x, y
/// for planar, all angles and the box's z for cylindrical, all angles for spherical),
/// `interp`.
fn picture(
    v: &Value,
    here: &str,
    base_dir: &std::path::Path,
    bounds: Option<&Aabb>,
) -> Result<HeightMap, ModelError> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let w = WORLD_LIMIT;
    let o = v.as_object().expect("checked by the caller");
    let base = match o.get("projection").and_then(Value::as_str) {
        Some("planar") | None => Base::Plane,
        Some("cylindrical") => Base::Cylinder(1.0),
        Some("spherical") => Base::Ellipsoid([1.0; 3]),
        Some(other) => {
            return err(
                &format!("{here}.projection"),
                format!("`{other}`: expected planar, cylindrical or spherical"),
            )
        }
    };
    let rect = match (o.get("rect"), bounds, base) {
        (Some(r), _, _) => numbers(r, &format!("{here}.rect"), -w, w, "[u0, v0, u1, v1]")?,
        (None, Some(b), Base::Plane) => [b.lo[0], b.lo[1], b.hi[0], b.hi[1]],
        (None, Some(b), Base::Cylinder(_)) => [-PI, b.lo[2], PI, b.hi[2]],
        (None, _, Base::Ellipsoid(_)) => [-PI, -FRAC_PI_2, PI, FRAC_PI_2],
        (None, None, _) => return err(here, "needs `rect` (the picture's place)"),
    };
    let interp = interp_of(o, here)?;
    let file = image_file(o, here, base_dir)?;
    let (iw, ih, values) = grey_levels(&file, &format!("{here}.image"), 1.0)?;
    HeightMap::new(base, rect, iw, ih, values, f64::NEG_INFINITY, interp)
        .map(|m| m.with_source(file, 1.0))
        .map_err(|e| ModelError {
            path: here.to_string(),
            reason: e,
        })
}

/// An image's grey levels (the mean of its colour channels, in [0, 1]) times `scale`.
fn grey_levels(
    path: &std::path::Path,
    at: &str,
    scale: f64,
) -> Result<(usize, usize, Vec<f64>), ModelError> {
    let raster = crate::image_io::load(path).map_err(|e| ModelError {
        path: at.to_string(),
        reason: e.to_string(),
    })?;
    let (iw, ih) = (raster.width() as usize, raster.height() as usize);
    // Alpha is not a colour: a grey image with alpha is its grey channel.
    let channels = raster.layout().colour_channels();
    let values = (0..iw * ih)
        .map(|i| {
            scale
                * (0..channels)
                    .map(|c| raster.plane(c)[i] as f64)
                    .sum::<f64>()
                / channels as f64
        })
        .collect();
    Ok((iw, ih, values))
}
