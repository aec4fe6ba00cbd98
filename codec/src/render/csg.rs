//! Constructive solid geometry on ray intervals (paper section 7).
//!
//! A convex solid meets a ray in at most one interval. Union, intersection and
//! difference of any number of solids are then set operations on sorted interval
//! lists: a sweep over the interval ends in ray order, keeping which operand the ray is
//! inside. Every end remembers the solid it lies on and whether that solid's normal
//! must be flipped (a subtracted solid's surface faces into the result).

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
