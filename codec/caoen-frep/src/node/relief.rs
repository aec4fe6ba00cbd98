//! The warp of a relief node: the point `W(p)` a relief reads its base at, its
//! Jacobian, and a box holding the warped points of a box.

use super::Node;
use crate::height_map::HeightMap;
use crate::interval::{Aabb, Interval};

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
    /// Planar: the base's z range, over which the push fades in from nothing at
    /// the bottom (so the bottom keeps its shape) to all of it at the top.
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

/// The fade of a planar relief's push over the base's z range `ramp`: 0 below, 1
/// above, smoothstep between (C1, slope at most `1.5 / (z1 - z0)`), and its slope.
fn ramp_of(ramp: [f64; 2], z: f64) -> (f64, f64) {
    let span = ramp[1] - ramp[0];
    let t = (z - ramp[0]) / span;
    if t.is_nan() || t <= 0.0 {
        (0.0, 0.0)
    } else if t >= 1.0 {
        (1.0, 0.0)
    } else {
        (t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t) / span)
    }
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
/// Planar: `W = p - depth h s(z) e_z` (`s` the ramp); cylindrical and spherical:
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
            let (s, ds) = ramp_of(ramp, p[2]);
            for k in 0..3 {
                j[2][k] -= depth * gh[k] * s;
            }
            j[2][2] -= depth * h * ds;
            ([p[0], p[1], p[2] - depth * h * s], j)
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
        crate::height_map::Base::Plane => {
            let (s, _) = ramp_of(ramp, p[2]);
            [p[0], p[1], p[2] - depth * h * s]
        }
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
            // s is increasing in z, in [0, 1].
            let s = Interval::new(ramp_of(ramp, b.lo[2]).0, ramp_of(ramp, b.hi[2]).0);
            let z = Interval::new(b.lo[2], b.hi[2]) - push * s;
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
