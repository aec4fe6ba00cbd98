//! Projections through the network (paper section 5, formulas 14–16).
//!
//! `y . z = sum_i k_i (t_i . z)`: projecting every shape vector onto an axis gives a
//! one-output network (an extra *generator*) whose value is exactly the projection of
//! the surface point. Two perpendicular axes give orthographic screen coordinates.
//! Projecting shape vectors through a perspective camera instead gives a network that
//! interpolates an approximation of the true perspective image.

use super::error::{check_finite, check_len, Result, SurfaceError};
use super::network::Network;
use caoen_geometry::vector::dot_n;

/// A network with one generator per axis: output `j` is `y(x) . axes[j]`.
pub fn axis_generators(net: &Network, axes: &[&[f64]]) -> Result<Network> {
    let p = net.output_dim();
    if axes.is_empty() {
        return Err(SurfaceError::Parameter {
            what: "axis count".into(),
            value: 0.0,
            reason: "need at least one axis",
        });
    }
    for (j, z) in axes.iter().enumerate() {
        check_len(|| format!("axis[{j}]"), p, z.len())?;
        check_finite(|| format!("axis[{j}]"), z)?;
    }
    let shapes = net
        .shapes()
        .chunks_exact(p)
        .flat_map(|t| {
            axes.iter()
                .map(move |z| t.iter().zip(z.iter()).map(|(a, b)| a * b).sum())
        })
        .collect();
    net.with_shapes(axes.len(), shapes)
}

/// A pinhole camera: screen `(u, v) = focal * (r . right, r . up) / (r . forward)`
/// with `r = y - eye`, and depth `r . forward`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerspectiveCamera {
    /// Eye position.
    pub eye: [f64; 3],
    /// Unit viewing direction.
    pub forward: [f64; 3],
    /// Unit screen x axis.
    pub right: [f64; 3],
    /// Unit screen y axis.
    pub up: [f64; 3],
    /// Focal length in screen units.
    pub focal: f64,
}

impl PerspectiveCamera {
    /// A camera at `eye` looking at `target`, `up` roughly up.
    pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3], focal: f64) -> Result<Self> {
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let norm = |v: [f64; 3]| {
            let n = dot_n(&v, &v).sqrt();
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let f = sub(target, eye);
        let right = cross(f, up);
        if dot_n(&f, &f) == 0.0 || dot_n(&right, &right) < 1e-24 || focal.is_nan() || focal <= 0.0 {
            return Err(SurfaceError::Parameter {
                what: "camera".into(),
                value: focal,
                reason:
                    "eye must differ from target, up must not be parallel to the view, focal > 0",
            });
        }
        let forward = norm(f);
        let right = norm(right);
        let up = cross(right, forward);
        Ok(PerspectiveCamera {
            eye,
            forward,
            right,
            up,
            focal,
        })
    }

    /// True perspective projection of a 3-D point: `(u, v, depth)`.
    pub fn project(&self, y: &[f64]) -> [f64; 3] {
        let r = [y[0] - self.eye[0], y[1] - self.eye[1], y[2] - self.eye[2]];
        let d = dot_n(&r, &self.forward);
        [
            self.focal * dot_n(&r, &self.right) / d,
            self.focal * dot_n(&r, &self.up) / d,
            d,
        ]
    }

    /// The approximate perspective network: shape vectors projected, outputs `(u, v, depth)`.
    pub fn approximate_network(&self, net: &Network) -> Result<Network> {
        check_len(
            || "shape dimension for a 3-D camera".into(),
            3,
            net.output_dim(),
        )?;
        let mut shapes = Vec::with_capacity(net.len() * 3);
        for t in net.shapes().chunks_exact(3) {
            let s = self.project(t);
            if s[2].is_nan() || s[2] <= 0.0 {
                return Err(SurfaceError::Parameter {
                    what: "key point depth".into(),
                    value: s[2],
                    reason: "every shape vector must lie in front of the camera",
                });
            }
            shapes.extend(s);
        }
        net.with_shapes(3, shapes)
    }
}

/// Screen-space error of the approximate perspective network against the true
/// projection, over the given domain points: `(max, rms)` distance in screen units.
pub fn perspective_error(
    net: &Network,
    cam: &PerspectiveCamera,
    points: &[f64],
) -> Result<(f64, f64)> {
    let approx = cam.approximate_network(net)?;
    let exact = net.eval_batch(points)?;
    let approx = approx.eval_batch(points)?;
    let (mut max, mut sum2) = (0.0f64, 0.0);
    let count = exact.len() / 3;
    for (y, a) in exact.chunks_exact(3).zip(approx.chunks_exact(3)) {
        let t = cam.project(y);
        let e = ((t[0] - a[0]).powi(2) + (t[1] - a[1]).powi(2)).sqrt();
        max = max.max(e);
        sum2 += e * e;
    }
    Ok((max, (sum2 / count.max(1) as f64).sqrt()))
}
