//! Affine placement of objects in the scene: scale, then rotate, then translate.
//!
//! Surfaces are placed by transforming evaluated points (not shape vectors): for an
//! unnormalised network `sum k_i` is not 1, so moving the shape vectors would not move
//! the surface rigidly.

use super::vector::{cross, dot, unit};

/// `x -> m x + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Linear part, row-major.
    pub m: [[f64; 3]; 3],
    /// Translation.
    pub t: [f64; 3],
}

impl Default for Affine {
    fn default() -> Self {
        Affine::IDENTITY
    }
}

impl Affine {
    /// The identity.
    pub const IDENTITY: Affine = Affine {
        m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    /// Scale by `s` (per axis), rotate by Euler angles `rotate_deg` (about x, then y,
    /// then z, in degrees), then translate by `t`.
    pub fn from_parts(s: [f64; 3], rotate_deg: [f64; 3], t: [f64; 3]) -> Self {
        let [ax, ay, az] = rotate_deg.map(f64::to_radians);
        let rx = [
            [1.0, 0.0, 0.0],
            [0.0, ax.cos(), -ax.sin()],
            [0.0, ax.sin(), ax.cos()],
        ];
        let ry = [
            [ay.cos(), 0.0, ay.sin()],
            [0.0, 1.0, 0.0],
            [-ay.sin(), 0.0, ay.cos()],
        ];
        let rz = [
            [az.cos(), -az.sin(), 0.0],
            [az.sin(), az.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ];
        let r = matmul(rz, matmul(ry, rx));
        let mut m = r;
        for row in &mut m {
            for (k, v) in row.iter_mut().enumerate() {
                *v *= s[k];
            }
        }
        Affine { m, t }
    }

    /// Whether this is the identity.
    pub fn is_identity(&self) -> bool {
        *self == Affine::IDENTITY
    }

    /// Transforms a point.
    #[inline]
    pub fn point(&self, p: [f64; 3]) -> [f64; 3] {
        [
            dot(self.m[0], p) + self.t[0],
            dot(self.m[1], p) + self.t[1],
            dot(self.m[2], p) + self.t[2],
        ]
    }

    /// Transforms a normal (by the inverse transpose, i.e. the cofactor matrix, which
    /// has the same direction for any invertible linear part), renormalised.
    #[inline]
    pub fn normal(&self, n: [f64; 3]) -> [f64; 3] {
        let c = self.cofactor();
        let sign = if self.det() < 0.0 { -1.0 } else { 1.0 };
        unit([
            sign * dot(c[0], n),
            sign * dot(c[1], n),
            sign * dot(c[2], n),
        ])
    }

    /// Determinant of the linear part.
    pub fn det(&self) -> f64 {
        dot(self.m[0], cross(self.m[1], self.m[2]))
    }

    /// Cofactor matrix of the linear part (`det * inverse transpose`).
    fn cofactor(&self) -> [[f64; 3]; 3] {
        // Columns of m are c_k; cof rows are cross products of the other two columns.
        let col = |k: usize| [self.m[0][k], self.m[1][k], self.m[2][k]];
        let (c0, c1, c2) = (col(0), col(1), col(2));
        let r0 = cross(c1, c2);
        let r1 = cross(c2, c0);
        let r2 = cross(c0, c1);
        // (cof)_{ij} such that cof * n = sum_k r_k n_k  ->  transpose of [r0 r1 r2].
        [
            [r0[0], r1[0], r2[0]],
            [r0[1], r1[1], r2[1]],
            [r0[2], r1[2], r2[2]],
        ]
    }

    /// The largest factor by which lengths can grow (a bound, for bounding spheres).
    pub fn max_stretch(&self) -> f64 {
        // Frobenius norm bounds the spectral norm.
        self.m.iter().flatten().map(|v| v * v).sum::<f64>().sqrt()
    }
}

fn matmul(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

impl Affine {
    /// The inverse map, or None if the linear part is singular.
    pub fn inverse(&self) -> Option<Affine> {
        let det = self.det();
        if det.abs() < 1e-300 || !det.is_finite() {
            return None;
        }
        let c = self.cofactor();
        // m^-1 = (det m^-T)^T / det.
        let m = [0, 1, 2].map(|i| [0, 1, 2].map(|j| c[j][i] / det));
        let t = [0, 1, 2].map(|i| -dot(m[i], self.t));
        Some(Affine { m, t })
    }

    /// The transpose of the linear part applied to `v` (pulls a gradient back through
    /// the map: the gradient of `f(A x)` is `m^T grad f`).
    pub fn transpose_mul(&self, v: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|j| (0..3).map(|i| self.m[i][j] * v[i]).sum())
    }

    /// `m^-T n` exactly (not renormalised): how a plane normal transforms so that
    /// `n . x <= d` becomes `(m^-T n) . (m x) <= d`. None if `m` is singular.
    pub fn plane_normal(&self, n: [f64; 3]) -> Option<[f64; 3]> {
        let det = self.det();
        if det.abs() < 1e-300 || !det.is_finite() {
            return None;
        }
        let c = self.cofactor();
        Some([dot(c[0], n) / det, dot(c[1], n) / det, dot(c[2], n) / det])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_stay_perpendicular_to_transformed_tangents() {
        let a = Affine::from_parts([2.0, 0.5, 1.5], [30.0, -20.0, 70.0], [1.0, 2.0, 3.0]);
        let (u, v) = ([1.0, 0.2, -0.3], [0.1, 1.0, 0.4]);
        let n = cross(u, v);
        let lin = |p: [f64; 3]| {
            let q = a.point(p);
            [q[0] - a.t[0], q[1] - a.t[1], q[2] - a.t[2]]
        };
        let (tu, tv) = (lin(u), lin(v));
        let tn = a.normal(n);
        assert!(dot(tn, tu).abs() < 1e-12 && dot(tn, tv).abs() < 1e-12);
        assert!(dot(tn, cross(tu, tv)) > 0.0);
    }
}
