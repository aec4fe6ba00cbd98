//! The two nodes that combine fields beyond a plain set operation: a blend of two
//! operands and a base perturbed by quadric patches, each with its value, gradient,
//! interval and bounding box in one place.

use super::{with_candidates, Node, Patch};
use crate::interval::{Aabb, Interval};
use crate::patch_index::PatchIndex;
use crate::rfunction::{self, BlendShape, SetOp};

/// A blending union or intersection of two operands.
#[derive(Debug, Clone, PartialEq)]
pub struct Blended {
    /// Union or intersection.
    pub op: SetOp,
    /// The R-function parameter.
    pub a: f64,
    /// The added term's height and fall-offs.
    pub shape: BlendShape,
    /// The two operands.
    pub operands: Box<[Node; 2]>,
}

impl Blended {
    /// The function's value at `p`.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        let (f1, f2) = (self.operands[0].value(p), self.operands[1].value(p));
        rfunction::apply(self.op, f1, f2, self.a) + rfunction::blend_partials(f1, f2, self.shape).0
    }

    /// The function's value and exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (f1, g1) = self.operands[0].value_gradient(p);
        let (f2, g2) = self.operands[1].value_gradient(p);
        let (r, d1, d2) = rfunction::partials(self.op, f1, f2, self.a);
        let (b, e1, e2) = rfunction::blend_partials(f1, f2, self.shape);
        (
            r + b,
            [0, 1, 2].map(|k| (d1 + e1) * g1[k] + (d2 + e2) * g2[k]),
        )
    }

    /// Bounds of the function over the box `b`.
    pub fn interval(&self, b: &Aabb) -> Interval {
        let (i1, i2) = (self.operands[0].interval(b), self.operands[1].interval(b));
        rfunction::interval(self.op, i1, i2, self.a) + rfunction::blend_interval(i1, i2, self.shape)
    }

    /// A box holding the solid, or None if the operands cannot bound it.
    pub fn bounds(&self) -> Option<Aabb> {
        let (b1, b2) = (self.operands[0].bounds(), self.operands[1].bounds());
        let joined = match self.op {
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
        let shape = self.shape;
        Some(
            joined.padded(
                (0.25 * joined.longest()).max(shape.a1.max(shape.a2).min(joined.longest())),
            ),
        )
    }
}

/// `f + sum_i factor_i max(Q_i, 0)^power`: the base perturbed by quadric patches
/// (power 2: C1 where a patch ends; power 3: C2).
#[derive(Debug, Clone, PartialEq)]
pub struct Perturbation {
    /// The base.
    pub base: Box<Node>,
    /// The perturbing quadrics with their form factors.
    pub terms: Vec<Patch>,
    /// The exponent (2 or 3).
    pub power: i32,
    /// Which terms reach a point or a box (built by [`Node::perturb`]).
    pub index: PatchIndex,
}

impl Perturbation {
    /// The function's value at `p`.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        // Added one by one, in the same order as value_gradient.
        with_candidates(|near| {
            self.index.at_point(p, near);
            near.iter().fold(self.base.value(p), |v, &t| {
                v + self.terms[t as usize].value_gradient(p, self.power).0
            })
        })
    }

    /// The function's value and exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (mut v, mut g) = self.base.value_gradient(p);
        with_candidates(|near| {
            self.index.at_point(p, near);
            for &t in near.iter() {
                let (r, gr) = self.terms[t as usize].value_gradient(p, self.power);
                v += r;
                for k in 0..3 {
                    g[k] += gr[k];
                }
            }
        });
        (v, g)
    }

    /// Bounds of the function over the box `b`.
    pub fn interval(&self, b: &Aabb) -> Interval {
        with_candidates(|near| {
            self.index.in_box(b, near);
            near.iter().fold(self.base.interval(b), |acc, &t| {
                acc + self.terms[t as usize].interval(b, self.power)
            })
        })
    }

    /// A box holding the solid: the base's and the patches that add material.
    pub fn bounds(&self) -> Option<Aabb> {
        let mut b = self.base.bounds()?;
        for t in self.terms.iter().filter(|t| t.factor > 0.0) {
            b = b.union(&t.positive_box()?);
        }
        Some(b)
    }
}
