//! Exact Jacobians and normals against central finite differences (property tests).

mod common;

use caoen::surface::normals::point_and_normal;
use caoen::surface::{Blend, Domain, KeyPoint, Network};
use proptest::prelude::*;

fn unit(v: Vec<f64>) -> Vec<f64> {
    let n = v.iter().map(|a| a * a).sum::<f64>().sqrt().max(1e-9);
    v.into_iter().map(|a| a / n).collect()
}

fn blend_strategy() -> impl Strategy<Value = Blend> {
    prop_oneof![
        Just(Blend::Power),
        Just(Blend::Exponential),
        Just(Blend::Compact)
    ]
}

prop_compose! {
    /// A random network with m in 2..=6, p in 1..=6 and every blending function.
    fn random_network()(m in 2usize..=6, p in 1usize..=6, n in 1usize..24, normalised in any::<bool>())
        (kps in prop::collection::vec(
            (prop::collection::vec(-1.0f64..1.0, m), prop::collection::vec(-2.0f64..2.0, p),
             blend_strategy(), 3.0f64..9.0, 0.2f64..2.0), n),
         x in prop::collection::vec(-1.0f64..1.0, m),
         m in Just(m), p in Just(p), normalised in Just(normalised))
        -> (Network, Vec<f64>)
    {
        let kps: Vec<KeyPoint> = kps.into_iter().map(|(w, t, blend, q, a)| KeyPoint {
            source: unit(w), shape: t, blend, q, weight: a }).collect();
        (Network::new(m, p, &kps, normalised).unwrap(), unit(x))
    }
}

/// Whether a central-difference stencil of step `h` around `x` stays clear of every
/// kernel's kink (the compact support edge, `s = 0` for the power blend), where finite
/// differences lose their O(h^2) accuracy and stop being a valid reference.
fn stencil_is_smooth(net: &Network, x: &[f64], h: f64) -> bool {
    let m = net.input_dim();
    net.sources()
        .chunks_exact(m)
        .zip(net.blends())
        .zip(net.sharpness())
        .all(|((w, b), &q)| {
            let s: f64 = x.iter().zip(w).map(|(a, c)| a * c).sum();
            let wn = w.iter().map(|v| v * v).sum::<f64>().sqrt();
            let kink = match b {
                Blend::Power => Some(0.0),
                other => other.support_threshold(q),
            };
            kink.is_none_or(|k| (s - k).abs() > 100.0 * h * wn)
        })
}

/// Central-difference Jacobian, p x m.
fn fd_jacobian(net: &Network, x: &[f64], h: f64) -> Vec<f64> {
    let (m, p) = (net.input_dim(), net.output_dim());
    let mut jac = vec![0.0; p * m];
    for k in 0..m {
        let mut xp = x.to_vec();
        let mut xm = x.to_vec();
        xp[k] += h;
        xm[k] -= h;
        let (yp, ym) = (net.eval(&xp).unwrap(), net.eval(&xm).unwrap());
        for g in 0..p {
            jac[g * m + k] = (yp[g] - ym[g]) / (2.0 * h);
        }
    }
    jac
}

fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let diff = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    diff / norm.max(1e-300)
}

proptest! {
    #![proptest_config(common::proptest_config(400))]

    #[test]
    fn jacobian_matches_central_differences((net, x) in random_network()) {
        let (_, coverage) = net.eval_with_coverage(&x).unwrap();
        // Where a normalised compact network is barely covered the map is ill-conditioned
        // (y = N/D with D -> 0): finite differences, not the analytic form, break down.
        prop_assume!(!net.is_normalised() || coverage > 1e-2);
        prop_assume!(stencil_is_smooth(&net, &x, 1e-5));
        let (y, jac) = net.eval_with_jacobian(&x).unwrap();
        prop_assert_eq!(&y, &net.eval(&x).unwrap());
        let fd = fd_jacobian(&net, &x, 1e-5);
        let norm = jac.iter().map(|v| v * v).sum::<f64>().sqrt();
        // The reference's own error: truncation O(h^2), relative to |J|, plus rounding of
        // the evaluations divided by 2h, relative to the size of the outputs. A wrong
        // analytic term is off by a multiple of |J| and fails both.
        let scale = 1.0 + y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let tolerance = 1e-6 * norm + 1e-8 * scale;
        let abs = jac.iter().zip(&fd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        prop_assert!(abs < tolerance, "error {} over tolerance {} (|J| = {}, |y| = {})", abs, tolerance, norm, scale - 1.0);
    }

    #[test]
    fn normals_match_finite_differences_of_the_parameterisation(
        kps in prop::collection::vec(
            ((0.0f64..std::f64::consts::TAU, 0.1f64..3.0), prop::collection::vec(-1.5f64..1.5, 3), blend_strategy(), 3.0f64..8.0), 6..20),
        torus in any::<bool>(), normalised in any::<bool>(), t in 0.0f64..std::f64::consts::TAU, f in 0.2f64..2.9,
    ) {
        let domain = if torus { Domain::Torus } else { Domain::SPHERE };
        let kps: Vec<KeyPoint> = kps.into_iter().map(|((a, b), shape, blend, q)| {
            // Power and compact blends need broad kernels for the domain to be covered.
            let q = if blend == Blend::Exponential { q } else { q / 3.0 + 1.0 };
            let q = if blend == Blend::Power { q.max(3.0) } else { q };
            KeyPoint::new(domain.point(&[a, b]).unwrap(), shape, blend, q)
        }).collect();
        let net = Network::new(domain.ambient_dim(), 3, &kps, normalised).unwrap();
        let x = domain.point(&[t, f]).unwrap();
        let (_, coverage) = net.eval_with_coverage(&x).unwrap();
        prop_assume!(!normalised || coverage > 1e-2);
        prop_assume!(stencil_is_smooth(&net, &x, 1e-5));
        let (_, n) = point_and_normal(&net, &domain, &x).unwrap();
        // Tangent order of Domain::tangents: sphere (d/df, d/dt), torus (d/dt, d/df).
        let h = 1e-5;
        let map = |t: f64, f: f64| net.eval(&domain.point(&[t, f]).unwrap()).unwrap();
        let d_dt: Vec<f64> = map(t + h, f).iter().zip(map(t - h, f)).map(|(a, b)| (a - b) / (2.0 * h)).collect();
        let d_df: Vec<f64> = map(t, f + h).iter().zip(map(t, f - h)).map(|(a, b)| (a - b) / (2.0 * h)).collect();
        let (a, b) = if torus { (d_dt, d_df) } else { (d_df, d_dt) };
        let fd = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        let norm = n.iter().map(|v| v * v).sum::<f64>().sqrt();
        prop_assume!(norm > 1e-3);
        let e = rel_err(&n, &fd);
        prop_assert!(e < 1e-6, "normal relative error {} (|N| = {})", e, norm);
    }
}

#[test]
fn identity_sphere_normals_point_outward_including_the_poles() {
    let model = caoen::surface::gallery::six_point(Blend::Exponential, 1.0, true).unwrap();
    // Not the identity, but a convex symmetric shape: normals at the axes are the axes.
    for a in caoen::surface::gallery::axis_points() {
        let n = caoen::surface::normals::exact_normal(&model.network, &Domain::SPHERE, &a).unwrap();
        let d: f64 = n.iter().zip(a).map(|(x, y)| x * y).sum();
        assert!((d - 1.0).abs() < 1e-12, "axis {a:?} normal {n:?}");
    }
}

/// `count` key points spread evenly (Fibonacci sphere) with shapes on the blob surface.
fn blob_resampled(count: usize) -> Network {
    let blob = caoen::surface::gallery::blob().unwrap();
    let spacing = (4.0 * std::f64::consts::PI / count as f64).sqrt();
    // Kernel width ~ key point spacing: sigma^2 = 1/q.
    common::resampled(&blob, count, 1.0 / (0.7 * spacing).powi(2))
}

#[test]
fn interpolated_normals_converge_to_exact_normals_as_key_points_densify() {
    let grid = Domain::SPHERE.grid(48, 25).unwrap();
    let mut last = f64::INFINITY;
    for count in [40, 160, 640] {
        let net = blob_resampled(count);
        let nn = caoen::surface::normals::NormalNetwork::new(&net, &Domain::SPHERE).unwrap();
        let mut sum_angle = 0.0;
        for x in grid.points.chunks_exact(3) {
            let e = caoen::surface::normals::exact_normal(&net, &Domain::SPHERE, x).unwrap();
            let i = nn.normal(x).unwrap();
            let c: f64 = e.iter().zip(i).map(|(a, b)| a * b).sum();
            sum_angle += c.clamp(-1.0, 1.0).acos();
        }
        let mean_deg = (sum_angle / (grid.points.len() / 3) as f64).to_degrees();
        eprintln!("{count} key points: mean angle interpolated vs exact normal {mean_deg:.3} deg");
        assert!(
            mean_deg < last,
            "{count}: {mean_deg} did not shrink from {last}"
        );
        last = mean_deg;
    }
    assert!(last < 4.0, "640 key points: mean normal error {last} deg");
}
