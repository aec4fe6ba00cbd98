//! The baseline users know: radial basis function interpolation of mesh vertices with
//! normal offsets (Turk and O'Brien; Carr et al.): `F(p) = sum_i w_i |p - c_i|^3 +
//! a . p + b` through the value 0 at vertices and `+d` / `-d` a step inside and
//! outside, solved as one dense linear system.

use nalgebra::{DMatrix, DVector};

use super::model::ImplicitField;
use super::polygon_mesh::PolygonMesh;

/// Why the baseline could not be fitted.
#[derive(Debug, thiserror::Error)]
pub enum RbfError {
    /// The dense system is over the memory budget.
    #[error(transparent)]
    OverBudget(#[from] caoen_base::budget::OverBudget),
    /// The system has no unique solution.
    #[error("the RBF system of {centres} centres is singular")]
    Singular {
        /// How many centres.
        centres: usize,
    },
}

/// A fitted triharmonic RBF (unit-cube coordinates).
#[derive(Debug, Clone)]
pub struct RbfBaseline {
    /// The centres.
    pub centres: Vec<[f64; 3]>,
    /// Their weights.
    pub weights: Vec<f64>,
    /// The linear part `[a_x, a_y, a_z, b]`.
    pub linear: [f64; 4],
}

impl RbfBaseline {
    /// Numbers stored: three coordinates and a weight per centre, plus the linear part.
    pub fn numbers(&self) -> usize {
        4 * self.centres.len() + 4
    }
}

/// Fits the baseline on every `k`-th vertex of `mesh` (unit cube, outward `normals`),
/// `k` chosen so that there are at most `max_centres` centres; `step` is the offset.
/// The dense system takes `8 n^2` bytes, checked against `limits`.
pub fn fit(
    mesh: &PolygonMesh,
    normals: &[[f64; 3]],
    max_centres: usize,
    step: f64,
    limits: &caoen_base::budget::Limits,
) -> Result<RbfBaseline, RbfError> {
    let per = max_centres.max(3) / 3;
    let stride = mesh.positions.len().div_ceil(per).max(1);
    let mut centres = Vec::new();
    let mut targets = Vec::new();
    // Coincident vertices (split at seams) would make the system singular.
    let mut seen = std::collections::HashSet::new();
    for i in (0..mesh.positions.len()).step_by(stride) {
        let (p, n) = (mesh.positions[i], normals[i]);
        if n == [0.0; 3] || !seen.insert(p.map(f64::to_bits)) {
            continue;
        }
        centres.push(p);
        targets.push(0.0);
        for side in [1.0, -1.0] {
            centres.push([0, 1, 2].map(|k| p[k] + side * step * n[k]));
            targets.push(-side * step);
        }
    }
    let m = centres.len();
    let size = m + 4;
    limits.check(
        || format!("the RBF system of {m} centres"),
        (size * size * 8 * 2) as u64,
    )?;
    let mut a = DMatrix::<f64>::zeros(size, size);
    for i in 0..m {
        for j in 0..m {
            let d = (0..3)
                .map(|k| (centres[i][k] - centres[j][k]).powi(2))
                .sum::<f64>()
                .sqrt();
            a[(i, j)] = d * d * d;
        }
        for k in 0..3 {
            a[(i, m + k)] = centres[i][k];
            a[(m + k, i)] = centres[i][k];
        }
        a[(i, m + 3)] = 1.0;
        a[(m + 3, i)] = 1.0;
    }
    let mut b = DVector::<f64>::zeros(size);
    for i in 0..m {
        b[i] = targets[i];
    }
    let x = a.lu().solve(&b).ok_or(RbfError::Singular { centres: m })?;
    Ok(RbfBaseline {
        weights: x.as_slice()[..m].to_vec(),
        linear: [x[m], x[m + 1], x[m + 2], x[m + 3]],
        centres,
    })
}

impl ImplicitField for RbfBaseline {
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let l = &self.linear;
        let mut v = l[0] * p[0] + l[1] * p[1] + l[2] * p[2] + l[3];
        let mut g = [l[0], l[1], l[2]];
        for (c, w) in self.centres.iter().zip(&self.weights) {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            v += w * r * r * r;
            let s = 3.0 * w * r;
            for k in 0..3 {
                g[k] += s * d[k];
            }
        }
        (v, g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_baseline_interpolates_its_conditions_and_recovers_a_sphere() {
        let mesh = PolygonMesh::ellipsoid([0.4; 3], 2);
        let normals = mesh.outward_normals();
        let rbf = fit(
            &mesh,
            &normals,
            600,
            0.01,
            &caoen_base::budget::Limits::default(),
        )
        .unwrap();
        for (i, p) in mesh.positions.iter().enumerate() {
            assert!(rbf.value(*p).abs() < 1e-8, "{i}");
        }
        assert!(rbf.value([0.0; 3]) > 0.0 && rbf.value([0.5, 0.0, 0.0]) < 0.0);
        // Gradient equals finite differences.
        let p = [0.1, 0.2, -0.3];
        let (_, g) = rbf.value_gradient(p);
        for k in 0..3 {
            let (mut a, mut b) = (p, p);
            a[k] += 1e-6;
            b[k] -= 1e-6;
            assert!(((rbf.value(a) - rbf.value(b)) / 2e-6 - g[k]).abs() < 1e-5);
        }
    }
}
