//! Ray casting of an F-rep model by interval subdivision: a stretch of the ray whose
//! bounding box gives an interval of `f` entirely below zero holds no solid and is
//! skipped whole; one entirely at or above zero is solid; the rest is halved until it
//! is short, and there a sign change is located by bisection. So every span where
//! `f >= 0` is found (down to the resolution, a thousandth of the model's box by
//! default), whatever the function's gradient, with no Lipschitz constant to guess.

use super::interval::Aabb;
use super::node::Node;

/// A stretch `[enter, exit]` of ray parameter inside the solid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Where the ray enters (or where the search started, if it starts inside).
    pub enter: f64,
    /// Where it leaves (or where the search ended).
    pub exit: f64,
}

/// How finely the caster looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CastOptions {
    /// Shortest stretch subdivided further, as a fraction of the model box's longest side.
    pub resolution: f64,
    /// Bisection steps that place a crossing within the shortest stretch.
    pub refine_steps: u32,
}

impl Default for CastOptions {
    fn default() -> Self {
        CastOptions {
            resolution: 1e-3,
            refine_steps: 40,
        }
    }
}

/// Casts rays through one model inside its box.
#[derive(Debug, Clone)]
pub struct Caster<'a> {
    node: &'a Node,
    bounds: Aabb,
    min_step: f64,
    refine_steps: u32,
}

impl<'a> Caster<'a> {
    /// A caster for `node` inside `bounds` (the solid must lie within it).
    pub fn new(node: &'a Node, bounds: Aabb, opts: CastOptions) -> Self {
        Caster {
            node,
            bounds,
            min_step: (opts.resolution * bounds.longest()).max(1e-12),
            refine_steps: opts.refine_steps,
        }
    }

    /// Every span along `origin + t dir` (unit `dir`) with `t` in `[t_min, t_max]`, in ray
    /// order.
    pub fn spans(&self, origin: [f64; 3], dir: [f64; 3], t_min: f64, t_max: f64) -> Vec<Span> {
        let mut out: Vec<Span> = Vec::new();
        self.walk(origin, dir, t_min, t_max, &mut |s| {
            match out.last_mut() {
                // Adjacent pieces of one span (a subdivision seam) are joined.
                Some(last) if (s.enter - last.exit).abs() <= 1e-12 * (1.0 + s.enter.abs()) => {
                    last.exit = s.exit;
                }
                _ => out.push(s),
            }
            true
        });
        out
    }

    /// The first point at `t >= t_min` where the ray is in the solid: the entry of the
    /// first span (or `t_min` itself if the ray starts inside).
    pub fn first_hit(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        t_min: f64,
        t_max: f64,
    ) -> Option<f64> {
        let mut hit = None;
        self.walk(origin, dir, t_min, t_max, &mut |s| {
            hit = Some(s.enter);
            false
        });
        hit
    }

    /// Visits spans in ray order until `visit` returns false.
    fn walk(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        t_min: f64,
        t_max: f64,
        visit: &mut dyn FnMut(Span) -> bool,
    ) {
        let Some((a, b)) = self.bounds.clip_ray(origin, dir) else {
            return;
        };
        let (a, b) = (a.max(t_min), b.min(t_max));
        if a.is_nan() || b.is_nan() || a > b {
            return;
        }
        let at = |t: f64| [0, 1, 2].map(|k| origin[k] + t * dir[k]);
        // Explicit stack (far half pushed first) so deep subdivision cannot overflow.
        let mut stack = vec![(a, b)];
        let mut open: Option<f64> = None;
        // The value at the end of the last stretch looked at closely.
        let mut last: Option<(f64, f64)> = None;
        let finish = |open: &mut Option<f64>, end: f64, visit: &mut dyn FnMut(Span) -> bool| {
            if let Some(s) = open.take() {
                return visit(Span {
                    enter: s,
                    exit: end,
                });
            }
            true
        };
        while let Some((t0, t1)) = stack.pop() {
            let (p0, p1) = (at(t0), at(t1));
            let range = self.node.interval(&Aabb::new(p0, p1));
            if range.hi < 0.0 {
                if !finish(&mut open, t0, visit) {
                    return;
                }
                continue;
            }
            if range.lo >= 0.0 {
                open.get_or_insert(t0);
                continue;
            }
            if t1 - t0 > self.min_step {
                let m = 0.5 * (t0 + t1);
                stack.push((m, t1));
                stack.push((t0, m));
                continue;
            }
            // A short stretch the bound cannot decide: the signs at its ends. Stretches
            // come in ray order, so one often starts where the last one looked.
            let f0 = match last {
                Some((t, f)) if t == t0 => f,
                _ => self.node.value(p0),
            };
            let f1 = self.node.value(p1);
            last = Some((t1, f1));
            match (f0 >= 0.0, f1 >= 0.0) {
                (true, true) => {
                    open.get_or_insert(t0);
                }
                (false, false) => {
                    if !finish(&mut open, t0, visit) {
                        return;
                    }
                }
                (false, true) => {
                    if !finish(&mut open, t0, visit) {
                        return;
                    }
                    open = Some(self.crossing(&at, (t0, f0), (t1, f1), false));
                }
                (true, false) => {
                    open.get_or_insert(t0);
                    let t = self.crossing(&at, (t0, f0), (t1, f1), true);
                    if !finish(&mut open, t, visit) {
                        return;
                    }
                }
            }
        }
        finish(&mut open, b, visit);
    }

    /// The sign change in `[t0, t1]` (values `f0`, `f1`; `inside_first` says which end
    /// is in), to the precision of `refine_steps` bisection steps: a bracket at most
    /// `(t1 - t0) / 2^refine_steps` wide. Illinois steps (false position, halving the
    /// value of an end kept twice) get there in a few evaluations on a smooth
    /// function; a step that does not halve the bracket is followed by a bisection, so
    /// a rough or non-finite function costs at most twice the bisection's evaluations.
    fn crossing(
        &self,
        at: &dyn Fn(f64) -> [f64; 3],
        (mut t0, mut f0): (f64, f64),
        (mut t1, mut f1): (f64, f64),
        inside_first: bool,
    ) -> f64 {
        let tol = (t1 - t0) * 0.5f64.powi(self.refine_steps as i32);
        // Whether the last step moved the low end (Some(true)) or the high one.
        let mut moved_low = None;
        let mut bisect = false;
        for _ in 0..2 * self.refine_steps {
            let width = t1 - t0;
            // A NaN width (a damaged field) ends the search like a narrow one.
            if width.partial_cmp(&tol) != Some(std::cmp::Ordering::Greater) {
                break;
            }
            let secant = t0 + width * f0 / (f0 - f1);
            let m = if !bisect && secant > t0 && secant < t1 {
                secant
            } else {
                0.5 * (t0 + t1)
            };
            let f = self.node.value(at(m));
            if (f >= 0.0) == inside_first {
                t0 = m;
                f0 = f;
                // The high end stays a second time: its weight halves.
                if moved_low == Some(true) {
                    f1 *= 0.5;
                }
                moved_low = Some(true);
            } else {
                t1 = m;
                f1 = f;
                if moved_low == Some(false) {
                    f0 *= 0.5;
                }
                moved_low = Some(false);
            }
            // A step that kept more than half the bracket: bisect next.
            bisect = !bisect && t1 - t0 > 0.5 * width;
        }
        // The inside end, so the reported point is in the solid.
        if inside_first {
            t0
        } else {
            t1
        }
    }
}
