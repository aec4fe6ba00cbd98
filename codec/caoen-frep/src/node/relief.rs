//! The warp of a relief node: the point `W(p)` a relief reads its base at, its
//! Jacobian, and a box holding the warped points of a box.

use super::Node;
use crate::height_map::HeightMap;
use crate::interval::{Aabb, Interval};

/// The thinnest floor a planar relief may leave, as a fraction of its base's height.
pub const MIN_FLOOR: f64 = 1e-3;

/// Relief: the base's space pushed along the picture's projection by `depth` times
/// its grey level, `f(W(p))` ([`relief_warp`]): the surface moves by `depth h`
/// along the projection's rays (up for planar, away from the axis or the centre
/// otherwise), so the offset means the same length on every face.
#[derive(Debug, Clone, PartialEq)]
pub struct Relief {
    /// The base.
    pub base: Box<Node>,
    /// The picture and its projection.
    pub map: HeightMap,
    /// Height of white, in the model's units (negative engraves).
    pub depth: f64,
    /// Planar: the base's z range `[z0, z1]`; each column is stretched so `z1` moves
    /// by the push and `z0` stays (the bottom keeps its shape).
    pub ramp: [f64; 2],
}

impl Relief {
    /// The function's value at `p`.
    pub fn value(&self, p: [f64; 3]) -> f64 {
        self.base
            .value(relief_point(&self.map, self.depth, self.ramp, p))
    }

    /// The function's value and exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (w, j) = relief_warp(&self.map, self.depth, self.ramp, p);
        let (v, g) = self.base.value_gradient(w);
        // The chain rule: grad_k = sum_i dW_i/dp_k g_i.
        (v, [0, 1, 2].map(|k| (0..3).map(|i| j[i][k] * g[i]).sum()))
    }

    /// Bounds of the function over the box `b`.
    pub fn interval(&self, b: &Aabb) -> Interval {
        self.base
            .interval(&relief_warp_box(&self.map, self.depth, self.ramp, b))
    }

    /// A box holding the solid: the base's, grown by the furthest push.
    pub fn bounds(&self) -> Option<Aabb> {
        let b = self.base.bounds()?;
        // Every point moves by at most |depth| max |h|.
        let h = self.map.perturbation_range(&b);
        Some(b.padded(self.depth.abs() * h.lo.abs().max(h.hi.abs())))
    }
}

/// The planar stretch over the base's z range `ramp` under a push `d h`: `W_z = z0 +
/// (z - z0) k` with `k = H / (H + d h)`, `H = z1 - z0`, so `z1 + d h` reads the base at
/// `z1` and `z0` at `z0`. Returns `k` and `dk / d(d h)`; `None` where `H + d h <= 0`
/// (the push would reach through the bottom; the model reader refuses such depths).
fn stretch(ramp: [f64; 2], push: f64) -> Option<(f64, f64)> {
    let span = ramp[1] - ramp[0];
    let q = span + push;
    (q > 0.0).then(|| (span / q, -span / (q * q)))
}

/// The push direction of a cylindrical or spherical relief at `p`: the mask `m` of the
/// axes it acts on (x and y, or all three), `q = m p` and `|q|`.
fn radial(base: crate::height_map::Base, p: [f64; 3]) -> ([f64; 3], [f64; 3], f64) {
    let m = if matches!(base, crate::height_map::Base::Cylinder(_)) {
        [1.0, 1.0, 0.0]
    } else {
        [1.0; 3]
    };
    let q = [0, 1, 2].map(|k| m[k] * p[k]);
    (m, q, (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt())
}

/// The point a relief reads its base at, `W(p)`, and the Jacobian `dW_i / dp_k`.
/// Planar: `W_z = z0 + (z - z0) H / (H + depth h)`; cylindrical and spherical:
/// `W = p - depth h q / |q|` with `q` the part of `p` off the z axis or all of it.
pub fn relief_warp(
    map: &HeightMap,
    depth: f64,
    ramp: [f64; 2],
    p: [f64; 3],
) -> ([f64; 3], [[f64; 3]; 3]) {
    let (h, gh) = map.perturbation(p);
    let mut j = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    match map.parts().0 {
        crate::height_map::Base::Plane => {
            let Some((k, dk)) = stretch(ramp, depth * h) else {
                return ([p[0], p[1], f64::INFINITY], j);
            };
            let rise = p[2] - ramp[0];
            for c in 0..3 {
                j[2][c] = rise * dk * depth * gh[c];
            }
            j[2][2] += k;
            ([p[0], p[1], ramp[0] + rise * k], j)
        }
        base => {
            let (m, q, r) = radial(base, p);
            if r.is_nan() || r <= 0.0 || h == 0.0 && gh == [0.0; 3] {
                return (p, j);
            }
            // W_i = p_i + (c - 1) q_i with c = 1 - depth h / r.
            let c1 = -depth * h / r;
            let dc = [0, 1, 2].map(|k| -depth * (gh[k] / r - h * q[k] / (r * r * r)));
            for i in 0..3 {
                for k in 0..3 {
                    j[i][k] = if i == k { 1.0 + c1 * m[i] } else { 0.0 } + q[i] * dc[k];
                }
            }
            ([0, 1, 2].map(|k| p[k] + c1 * q[k]), j)
        }
    }
}

/// `W(p)` of [`relief_warp`] alone, without the Jacobian (for point values).
fn relief_point(map: &HeightMap, depth: f64, ramp: [f64; 2], p: [f64; 3]) -> [f64; 3] {
    let h = map.perturbation_value(p);
    match map.parts().0 {
        crate::height_map::Base::Plane => match stretch(ramp, depth * h) {
            Some((k, _)) => [p[0], p[1], ramp[0] + (p[2] - ramp[0]) * k],
            None => [p[0], p[1], f64::INFINITY],
        },
        base => {
            let (_, q, r) = radial(base, p);
            // No push: the point itself (where relief_warp also moves it by zero).
            if r.is_nan() || r <= 0.0 || h == 0.0 {
                return p;
            }
            let c1 = -depth * h / r;
            [0, 1, 2].map(|k| p[k] + c1 * q[k])
        }
    }
}

/// A box holding `W(p)` for every `p` in `b`.
fn relief_warp_box(map: &HeightMap, depth: f64, ramp: [f64; 2], b: &Aabb) -> Aabb {
    let push = map.perturbation_range(b).scale(depth);
    match map.parts().0 {
        crate::height_map::Base::Plane => {
            // k = H / (H + push) is decreasing in the push, positive while H + push is.
            let z = match (stretch(ramp, push.hi), stretch(ramp, push.lo)) {
                (Some((k0, _)), Some((k1, _))) => {
                    let rise = Interval::new(b.lo[2] - ramp[0], b.hi[2] - ramp[0]);
                    Interval::point(ramp[0]) + rise * Interval::new(k0, k1)
                }
                _ => Interval::new(f64::NEG_INFINITY, f64::INFINITY),
            };
            Aabb {
                lo: [b.lo[0], b.lo[1], z.lo],
                hi: [b.hi[0], b.hi[1], z.hi],
            }
        }
        base => {
            // Each component of q / |q| lies in [-1, 1].
            let most = push.lo.abs().max(push.hi.abs());
            let axes = if matches!(base, crate::height_map::Base::Cylinder(_)) {
                2
            } else {
                3
            };
            let mut w = *b;
            for k in 0..axes {
                w.lo[k] -= most;
                w.hi[k] += most;
            }
            w
        }
    }
}
