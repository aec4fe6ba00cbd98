//! Render throughput, each beside a plain baseline measured in the same run:
//! - rays/s of the convex implicit ray tracer (20-plane solid, 512x512, 1 sample), the
//!   paper's crossing search and the fast one, against analytic sphere ray tracing of
//!   the same image;
//! - triangles/s of tessellation (domain triangulation + network + exact normals)
//!   against building the bare icosphere;
//! - samples/s of the depth buffer against splatting the same number of precomputed
//!   points into a z-buffer.
//!
//! All loops are single-threaded so the ratios compare work, not scheduling. A summary
//! with the ratios prints first; criterion's own report follows.

mod common;

use std::hint::black_box;
use std::time::Instant;

use caoen::geometry::transform::Affine;
use caoen::render::camera::{Camera, Projection};
use caoen::render::depth_buffer::{depth_buffer, DepthBufferOptions};
use caoen::render::mesh::{icosphere, tessellate, NormalMode};
use caoen::render::raytrace::{ray_sphere, ImplicitTracer, RayMethod};
use caoen::render::scene::polyhedron_solid;
use caoen::surface::{gallery, Blend};
use criterion::{criterion_group, Criterion, Throughput};

const SIDE: u32 = 512;

fn camera(w: u32, h: u32) -> Camera {
    Camera::framing(
        [0.0; 3],
        1.25,
        [1.0, -1.4, 0.9],
        Projection::Perspective { fov_y_deg: 30.0 },
        w,
        h,
    )
    .unwrap()
}

/// Traces every pixel; returns the number of hits (so nothing is optimised away).
fn trace_implicit(t: &ImplicitTracer, cam: &Camera, m: RayMethod) -> usize {
    let mut scratch = Vec::new();
    let mut hits = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let r = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
            hits += t.crossings(&r, m, &mut scratch).is_some() as usize;
        }
    }
    hits
}

fn trace_sphere(cam: &Camera, radius: f64) -> usize {
    let mut hits = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let r = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
            hits += ray_sphere(&r, [0.0; 3], radius).is_some() as usize;
        }
    }
    hits
}

/// Projects and splats points into a plain z-buffer.
fn splat(points: &[[f64; 3]], cam: &Camera, z: &mut [f64]) -> usize {
    z.fill(f64::INFINITY);
    let w = cam.width as usize;
    let mut n = 0;
    for p in points {
        if let Some([x, y, d]) = cam.project(*p) {
            if x >= 0.0 && y >= 0.0 && x < cam.width as f64 && y < cam.height as f64 {
                let i = y as usize * w + x as usize;
                if d < z[i] {
                    z[i] = d;
                    n += 1;
                }
            }
        }
    }
    n
}

fn solid() -> ImplicitTracer {
    let s = polyhedron_solid(
        "icosahedron",
        1.0,
        [0.0; 3],
        [1.0; 3],
        [0.0; 3],
        Blend::Exponential,
        8.0,
        2.0,
    )
    .unwrap();
    assert_eq!(s.face_feet().len(), 20);
    ImplicitTracer::new(&s)
}

fn depth_points(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = k as f64 * 2.399_963_229_728_653;
            [r * a.cos(), r * a.sin(), z]
        })
        .collect()
}

fn time<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

fn serial<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(f)
}

fn summary() {
    let cam = camera(SIDE, SIDE);
    let t = solid();
    let rays = (SIDE * SIDE) as f64;
    println!("\n== render summary (single thread) ==");
    let base = time(3, || trace_sphere(&cam, 1.25));
    let paper = time(1, || trace_implicit(&t, &cam, RayMethod::Paper));
    let fast = time(3, || trace_implicit(&t, &cam, RayMethod::Fast));
    println!(
        "ray tracing 512x512, 1 sample ({} hits):",
        trace_implicit(&t, &cam, RayMethod::Fast)
    );
    println!(
        "  analytic sphere (baseline)  {:>10.3e} rays/s",
        rays / base
    );
    println!(
        "  implicit, paper's method    {:>10.3e} rays/s  = {:.4} x baseline",
        rays / paper,
        base / paper
    );
    println!(
        "  implicit, fast search       {:>10.3e} rays/s  = {:.4} x baseline",
        rays / fast,
        base / fast
    );

    let blob = gallery::blob().unwrap();
    let tris = 20.0 * 4f64.powi(5);
    let base = time(3, || icosphere(5));
    let tess = time(3, || {
        serial(|| tessellate(&blob, 5, NormalMode::Exact, &caoen::Limits::default()).unwrap())
    });
    println!("tessellation, blob, 20480 triangles, exact normals:");
    println!(
        "  bare icosphere (baseline)   {:>10.3e} triangles/s",
        tris / base
    );
    println!(
        "  tessellate                  {:>10.3e} triangles/s  = {:.4} x baseline",
        tris / tess,
        base / tess
    );

    let cam = camera(512, 384);
    let opts = DepthBufferOptions::default();
    let run =
        || serial(|| depth_buffer(&blob, &Affine::IDENTITY, &cam, &opts, &|_, _| {}).unwrap());
    let samples = run().stats.samples;
    let db = time(3, run);
    let pts = depth_points(samples);
    let mut z = vec![0.0; 512 * 384];
    let base = time(3, || splat(&pts, &cam, &mut z));
    println!("depth buffer, blob, 512x384 ({samples} samples):");
    println!(
        "  plain point splat (baseline){:>10.3e} samples/s",
        samples as f64 / base
    );
    println!(
        "  depth buffer                {:>10.3e} samples/s  = {:.4} x baseline\n",
        samples as f64 / db,
        base / db
    );
}

fn bench(c: &mut Criterion) {
    let cam = camera(SIDE, SIDE);
    let t = solid();
    let mut g = c.benchmark_group("raytrace_512x512");
    g.sample_size(10);
    g.throughput(Throughput::Elements((SIDE * SIDE) as u64));
    g.bench_function("analytic_sphere_baseline", |b| {
        b.iter(|| trace_sphere(&cam, 1.25))
    });
    g.bench_function("implicit_20_planes_paper", |b| {
        b.iter(|| trace_implicit(&t, &cam, RayMethod::Paper))
    });
    g.bench_function("implicit_20_planes_fast", |b| {
        b.iter(|| trace_implicit(&t, &cam, RayMethod::Fast))
    });
    g.finish();

    let blob = gallery::blob().unwrap();
    let mut g = c.benchmark_group("tessellate_detail5");
    g.sample_size(10);
    g.throughput(Throughput::Elements(20 * 4u64.pow(5)));
    g.bench_function("bare_icosphere_baseline", |b| b.iter(|| icosphere(5)));
    g.bench_function("tessellate_blob_exact", |b| {
        b.iter(|| {
            serial(|| tessellate(&blob, 5, NormalMode::Exact, &caoen::Limits::default()).unwrap())
        })
    });
    g.finish();

    let cam = camera(512, 384);
    let opts = DepthBufferOptions::default();
    let samples = depth_buffer(&blob, &Affine::IDENTITY, &cam, &opts, &|_, _| {})
        .unwrap()
        .stats
        .samples;
    let pts = depth_points(samples);
    let mut z = vec![0.0; 512 * 384];
    let mut g = c.benchmark_group("depth_buffer_512x384");
    g.sample_size(10);
    g.throughput(Throughput::Elements(samples as u64));
    g.bench_function("point_splat_baseline", |b| {
        b.iter(|| splat(&pts, &cam, &mut z))
    });
    g.bench_function("depth_buffer_blob", |b| {
        b.iter(|| {
            serial(|| depth_buffer(&blob, &Affine::IDENTITY, &cam, &opts, &|_, _| {}).unwrap())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    common::main(summary, benches);
}
