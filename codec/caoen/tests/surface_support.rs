//! Compact-support evaluation through the spatial index (and the SIMD batch kernel)
//! equals brute force, and batch evaluation is independent of the thread count.

mod common;
use common::{with_threads, SplitMix as Rng};

use caoen::surface::{Blend, Domain, KeyPoint, Network};
use proptest::prelude::*;

fn random_model(
    rng: &mut Rng,
    m: usize,
    p: usize,
    n: usize,
    q_lo: f64,
    q_hi: f64,
    mixed: bool,
) -> Network {
    let kps: Vec<KeyPoint> = (0..n)
        .map(|i| {
            let blend = if mixed && i % 7 == 3 {
                Blend::Exponential
            } else {
                Blend::Compact
            };
            let q = q_lo + (q_hi - q_lo) * rng.next();
            KeyPoint::new(rng.unit(m), (0..p).map(|_| rng.next()).collect(), blend, q)
        })
        .collect();
    Network::new(m, p, &kps, true).unwrap()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

proptest! {
    #![proptest_config(common::proptest_config(64))]
    #[test]
    fn indexed_evaluation_equals_brute_force(seed in any::<u64>(), m in 2usize..=6, p in 1usize..=6,
                                            n in 1usize..400, mixed in any::<bool>(), ordered in any::<bool>()) {
        let mut rng = Rng(seed);
        let net = random_model(&mut rng, m, p, n, 4.0, 400.0, mixed);
        prop_assert!(net.uses_support_index());
        // Either spatially coherent (a walk with small steps) or random order.
        let mut xs = Vec::new();
        let mut x = rng.unit(m);
        for _ in 0..300 {
            if ordered {
                let step: Vec<f64> = (0..m).map(|_| 0.05 * (rng.next() - 0.5)).collect();
                let v: Vec<f64> = x.iter().zip(&step).map(|(a, b)| a + b).collect();
                let nrm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
                x = v.into_iter().map(|a| a / nrm).collect();
            } else {
                x = rng.unit(m);
            }
            xs.extend_from_slice(&x);
        }
        let batch = net.eval_batch(&xs).unwrap();
        for (j, x) in xs.chunks_exact(m).enumerate() {
            let brute = net.eval_brute_force(x).unwrap();
            let single = net.eval(x).unwrap();
            prop_assert!(max_abs_diff(&brute, &single) <= 1e-12, "single {:?} vs {:?}", single, brute);
            prop_assert!(max_abs_diff(&brute, &batch[j * p..(j + 1) * p]) <= 1e-12);
        }
    }
}

#[test]
fn off_sphere_inputs_and_sources_are_still_exact() {
    // The index must stay a superset for points and sources of any length.
    let mut rng = Rng(7);
    let kps: Vec<KeyPoint> = (0..300)
        .map(|_| {
            let s = 0.5 + rng.next();
            let w: Vec<f64> = rng.unit(3).into_iter().map(|a| a * s).collect();
            KeyPoint::new(w, vec![rng.next()], Blend::Compact, 5.0 + 50.0 * rng.next())
        })
        .collect();
    let net = Network::new(3, 1, &kps, false).unwrap();
    let xs: Vec<f64> = (0..3000).map(|_| 3.0 * (rng.next() - 0.5)).collect();
    let batch = net.eval_batch(&xs).unwrap();
    for (j, x) in xs.chunks_exact(3).enumerate() {
        let brute = net.eval_brute_force(x).unwrap();
        assert!(
            (brute[0] - batch[j]).abs() <= 1e-12 * brute[0].abs().max(1.0),
            "{x:?}"
        );
    }
}

#[test]
fn batch_output_is_identical_for_one_and_two_threads() {
    // p = 3 runs the paired SIMD kernel, p = 5 the general one.
    for p in [3, 5] {
        let mut rng = Rng(11);
        let net = random_model(&mut rng, 3, p, 5000, 300.0, 3000.0, false);
        let grid = Domain::SPHERE.grid(300, 200).unwrap();
        let run = |threads| with_threads(threads, || net.eval_batch(&grid.points).unwrap());
        let (a, b) = (run(1), run(2));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn sphere_batch_with_sparse_coverage_equals_brute_force() {
    // m = 3, compact only (the SIMD path), weights other than 1, n not a multiple of any
    // lane count, and supports so narrow that many grid points are reached by nothing.
    // (Much sharper kernels are ill-conditioned: `1 - x . w` loses ~q ulps either way.)
    let mut rng = Rng(23);
    let kps: Vec<KeyPoint> = (0..1001)
        .map(|i| {
            let mut k = KeyPoint::new(
                rng.unit(3),
                vec![rng.next(), rng.next() - 0.5, 2.0 * rng.next()],
                Blend::Compact,
                500.0 + 1000.0 * rng.next(),
            );
            k.weight = [1.0, 0.5, 0.0, 3.0][i % 4];
            k
        })
        .collect();
    let net = Network::new(3, 3, &kps, true).unwrap();
    let grid = Domain::SPHERE.grid(240, 160).unwrap();
    let batch = net.eval_batch(&grid.points).unwrap();
    let mut empty = 0;
    for (j, x) in grid.points.chunks_exact(3).enumerate() {
        let brute = net.eval_brute_force(x).unwrap();
        empty += usize::from(brute.iter().all(|v| *v == 0.0));
        assert!(
            max_abs_diff(&brute, &batch[j * 3..j * 3 + 3]) <= 1e-12,
            "{x:?}: {brute:?} vs {:?}",
            &batch[j * 3..j * 3 + 3]
        );
    }
    assert!(empty > 100, "{empty} inputs without neighbours");
}
