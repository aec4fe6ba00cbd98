//! Network evaluation throughput: n = 64, 1024, 16384 key points, compact
//! support (~30 neighbours per input) and dense, on batches of sphere points, beside a
//! plain nalgebra matrix multiply of the dense network's shape measured in the same run.
//!
//! Compact batches run `Network::eval_batch`'s fast path: blocks of 16384 inputs binned
//! into cells of half the support radius, one k-d tree query per cell, and the cell's
//! candidates (~46 for ~30 true neighbours here) through a SIMD kernel that pulp
//! dispatches at run time (AVX2+FMA on x86-64 with it, scalar otherwise).
//!
//! Besides criterion's own report, a summary prints evaluations/s and the achieved
//! floating-point rate as a fraction of this machine's peak. Peak = cores x clock x
//! 16 double flops/cycle (two 256-bit FMA pipes: 2 x 4 lanes x 2 flops; Zen 4 runs
//! AVX-512 double-pumped, so 512-bit code does not raise it). Flops counted per visited
//! key point: 2m (dot product) + 2 (q (s - 1)) + 1 (weight) + 2p + 1 (accumulate),
//! transcendental calls not counted.

mod common;

use std::hint::black_box;
use std::time::Instant;

use caoen::surface::{Blend, Domain, KeyPoint, Network};
use criterion::{criterion_group, Criterion, Throughput};
use nalgebra::DMatrix;
use rayon::prelude::*;

const BATCH: usize = 1 << 20;

fn fibonacci_sphere(n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = k as f64 * 2.399_963_229_728_653;
            vec![r * a.cos(), r * a.sin(), z]
        })
        .collect()
}

/// `n` key points evenly on the sphere; compact ones sized for ~30 neighbours per input.
fn model(n: usize, compact: bool) -> Network {
    // A cap holding 30 of n evenly spread points has 1 - cos(angle) = 60 / n, and the
    // compact kernel's support is 1 - cos(angle) = 3 / q.
    let (blend, q) = if compact {
        (Blend::Compact, n as f64 / 20.0)
    } else {
        (Blend::Exponential, 8.0)
    };
    let kps: Vec<KeyPoint> = fibonacci_sphere(n)
        .into_iter()
        .enumerate()
        .map(|(i, w)| KeyPoint::new(w, vec![i as f64, 1.0, -(i as f64)], blend, q))
        .collect();
    Network::new(3, 3, &kps, true).unwrap()
}

/// A lat-long grid of about `count` sphere points in scanline order.
fn inputs(count: usize) -> Vec<f64> {
    let side = (count as f64).sqrt().ceil() as usize;
    let mut pts = Domain::SPHERE.grid(side, side).unwrap().points;
    pts.truncate(count * 3);
    pts
}

fn dense_inputs(n: usize) -> usize {
    // Dense n = 16384 over 1M inputs is 1.7e10 kernel calls per iteration; a smaller
    // batch measures the same per-evaluation rate in reasonable time.
    if n > 4096 {
        BATCH / 64
    } else {
        BATCH
    }
}

/// The dense network's arithmetic as two plain matrix products, chunked over inputs:
/// K = X W^T (N x n), then Y = K V (N x p).
fn matmul_baseline(x: &DMatrix<f64>, wt: &DMatrix<f64>, v: &DMatrix<f64>, rows: usize) -> f64 {
    (0..x.nrows().div_ceil(rows))
        .into_par_iter()
        .map(|c| {
            let r0 = c * rows;
            let r = rows.min(x.nrows() - r0);
            let k = x.rows(r0, r) * wt;
            let y = k * v;
            y[(0, 0)]
        })
        .sum()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("network_eval");
    g.sample_size(10);
    for n in [64usize, 1024, 16384] {
        for compact in [true, false] {
            let net = model(n, compact);
            let count = if compact { BATCH } else { dense_inputs(n) };
            let xs = inputs(count);
            g.throughput(Throughput::Elements(count as u64));
            let name = format!("{}_n{n}", if compact { "compact" } else { "dense" });
            g.bench_function(&name, |b| {
                b.iter(|| black_box(net.eval_batch(black_box(&xs)).unwrap()))
            });
        }
    }
    let n = 1024;
    let x = DMatrix::from_row_slice(BATCH, 3, &inputs(BATCH));
    let w = DMatrix::from_fn(3, n, |i, j| fibonacci_sphere(n)[j][i]);
    let v = DMatrix::from_fn(n, 3, |i, j| (i + j) as f64);
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("nalgebra_matmul_n1024", |b| {
        b.iter(|| black_box(matmul_baseline(&x, &w, &v, 4096)))
    });
    g.finish();
}

fn peak_flops() -> (f64, usize, f64) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mhz = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("cpu MHz"))
                .and_then(|l| l.split(':').nth(1)?.trim().parse::<f64>().ok())
        })
        .unwrap_or(2000.0);
    (cores as f64 * mhz * 1e6 * 16.0, cores, mhz)
}

fn time<T>(f: impl Fn() -> T) -> f64 {
    black_box(f());
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

/// One timed pass per configuration: evaluations/s, neighbours, fraction of peak.
fn summary() {
    let (peak, cores, mhz) = peak_flops();
    println!(
        "\n== network evaluation summary ({cores} cores at {mhz:.0} MHz, peak {:.1} GFLOP/s) ==",
        peak / 1e9
    );
    let flops_per_visit = (2 * 3 + 2 + 1 + 2 * 3 + 1) as f64;
    let mut dense1024 = 0.0;
    for n in [64usize, 1024, 16384] {
        for compact in [true, false] {
            let net = model(n, compact);
            let count = if compact { BATCH } else { dense_inputs(n) };
            let xs = inputs(count);
            let secs = time(|| net.eval_batch(&xs).unwrap());
            let rate = count as f64 / secs;
            // Mean active key points, from a sample of inputs.
            let neighbours = if compact {
                let sample: Vec<&[f64]> = xs.chunks_exact(3).step_by(997).collect();
                let active: usize = sample
                    .iter()
                    .map(|x| {
                        net.sources()
                            .chunks_exact(3)
                            .zip(net.sharpness())
                            .filter(|(w, q)| {
                                x.iter().zip(w.iter()).map(|(a, b)| a * b).sum::<f64>()
                                    > 1.0 - 3.0 / *q
                            })
                            .count()
                    })
                    .sum();
                active as f64 / sample.len() as f64
            } else {
                n as f64
            };
            let frac = rate * neighbours * flops_per_visit / peak;
            if !compact && n == 1024 {
                dense1024 = secs / count as f64;
            }
            println!(
                "{:>7} n={n:>5}: {:>8.2} M evals/s, {neighbours:>7.1} key points/eval, {:>5.2}% of peak",
                if compact { "compact" } else { "dense" },
                rate / 1e6,
                frac * 100.0
            );
        }
    }
    let n = 1024;
    let x = DMatrix::from_row_slice(BATCH, 3, &inputs(BATCH));
    let w = DMatrix::from_fn(3, n, |i, j| fibonacci_sphere(n)[j][i]);
    let v = DMatrix::from_fn(n, 3, |i, j| (i + j) as f64);
    let secs = time(|| matmul_baseline(&x, &w, &v, 4096)) / BATCH as f64;
    println!(
        "dense n=1024 vs nalgebra matmul of the same shape: {:.2}x the matmul's time (goal <= 4x)",
        dense1024 / secs
    );
}

criterion_group!(benches, bench);

fn main() {
    common::main(summary, benches);
}
