//! Quadrics in the polygon-conversion paper's form (its eq. 4) and the base quadric
//! fitted through a mesh's points with the constant fixed (its eq. 7).

use nalgebra::{DMatrix, DVector};

/// The ten monomials at `p`, in the order of the F-rep `quadric` coefficients:
/// `x², y², z², xy, yz, xz, x, y, z, 1`.
pub fn monomials(p: [f64; 3]) -> [f64; 10] {
    let [x, y, z] = p;
    [x * x, y * y, z * z, x * y, y * z, x * z, x, y, z, 1.0]
}

/// The quadric's value at `p`.
pub fn value(c: &[f64; 10], p: [f64; 3]) -> f64 {
    monomials(p).iter().zip(c).map(|(m, c)| m * c).sum()
}

/// The quadric's gradient at `p`.
pub fn gradient(c: &[f64; 10], p: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = p;
    [
        2.0 * c[0] * x + c[3] * y + c[5] * z + c[6],
        2.0 * c[1] * y + c[3] * x + c[4] * z + c[7],
        2.0 * c[2] * z + c[4] * y + c[5] * x + c[8],
    ]
}

/// The base quadric of a point set with outward normals, as an F-rep field (`>= 0`
/// inside) scaled so that its gradient has mean length 1 on the points.
///
/// The paper passes the quadric through nine mesh points with the constant fixed at
/// `-K`; with all the points instead of nine, the same nine unknowns solve the 9 x 9
/// normal equations of the least-squares fit, which does not depend on which nine
/// points are picked. A sphere or ellipsoid is reproduced exactly. When the fit is a
/// worse start than the bounding sphere of the points (mean distance `|Q| / |grad Q|`
/// larger), that sphere is used instead.
pub fn fit_base(points: &[[f64; 3]], normals: &[[f64; 3]]) -> [f64; 10] {
    let mut a = DMatrix::<f64>::zeros(9, 9);
    let mut b = DVector::<f64>::zeros(9);
    for p in points {
        let m = monomials(*p);
        for i in 0..9 {
            b[i] += m[i];
            for j in 0..9 {
                a[(i, j)] += m[i] * m[j];
            }
        }
    }
    // A relative ridge keeps a planar or degenerate point set solvable.
    let trace = (0..9).map(|i| a[(i, i)]).sum::<f64>() / 9.0;
    for i in 0..9 {
        a[(i, i)] += 1e-12 * trace;
    }
    let fitted = a.lu().solve(&b).map(|s| {
        let mut c = [0.0; 10];
        c[..9].copy_from_slice(s.as_slice());
        c[9] = -1.0;
        c
    });
    let n = points.len() as f64;
    let centre = [0, 1, 2].map(|k| points.iter().map(|p| p[k]).sum::<f64>() / n);
    let radius = points
        .iter()
        .map(|p| {
            (0..3)
                .map(|k| (p[k] - centre[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum::<f64>()
        / n;
    let sphere = {
        let r2 = radius * radius;
        let c2: f64 = centre.iter().map(|v| v * v).sum();
        [
            -1.0,
            -1.0,
            -1.0,
            0.0,
            0.0,
            0.0,
            2.0 * centre[0],
            2.0 * centre[1],
            2.0 * centre[2],
            r2 - c2,
        ]
    };
    let oriented = |c: [f64; 10]| -> Option<([f64; 10], f64)> {
        // Sign: the gradient points inward (F grows inside); scale: mean |grad| = 1.
        let (mut along, mut len, mut dist) = (0.0, 0.0, 0.0);
        for (p, nrm) in points.iter().zip(normals) {
            let g = gradient(&c, *p);
            let l = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            along += g[0] * nrm[0] + g[1] * nrm[1] + g[2] * nrm[2];
            len += l;
            dist += value(&c, *p).abs() / l.max(1e-12);
        }
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let s = if along > 0.0 { -n / len } else { n / len };
        Some((c.map(|v| v * s), dist / n))
    };
    let sphere = oriented(sphere).expect("the points are not all at one place");
    match fitted.and_then(oriented) {
        Some((c, d)) if d <= sphere.1 => c,
        _ => sphere.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_geometry::vector::central_difference;

    #[test]
    fn an_ellipsoid_is_reproduced_with_unit_mean_gradient_and_positive_inside() {
        let (r, c) = ([0.3, 0.2, 0.1], [0.05, -0.02, 0.01]);
        let mut pts = Vec::new();
        let mut nrm = Vec::new();
        for i in 0..40 {
            for j in 0..20 {
                let (u, v) = (i as f64 * 0.157, 0.1 + j as f64 * 0.15);
                let d = [u.cos() * v.sin(), u.sin() * v.sin(), v.cos()];
                pts.push([0, 1, 2].map(|k| c[k] + r[k] * d[k]));
                nrm.push([0, 1, 2].map(|k| d[k] / r[k]));
            }
        }
        let q = fit_base(&pts, &nrm);
        for p in &pts {
            assert!(value(&q, *p).abs() < 1e-9);
        }
        assert!(value(&q, c) > 0.0 && value(&q, [0.5, 0.5, 0.5]) < 0.0);
        let mean: f64 = pts
            .iter()
            .map(|p| {
                let g = gradient(&q, *p);
                (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
            })
            .sum::<f64>()
            / pts.len() as f64;
        assert!((mean - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_gradient_is_the_derivative_of_the_value() {
        let c = [0.3, -0.2, 0.5, 0.1, -0.4, 0.25, 0.7, -0.1, 0.2, -0.3];
        let p = [0.2, -0.3, 0.4];
        let g = gradient(&c, p);
        let fd = central_difference(|q| value(&c, q), p, 1e-6);
        for k in 0..3 {
            assert!((fd[k] - g[k]).abs() < 1e-8);
        }
    }
}
