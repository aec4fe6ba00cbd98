//! Helpers shared by the library's tests.

// Each test crate includes this module and uses only part of it.
#![allow(dead_code)]

mod proptest_seed;
#[allow(unused_imports)] // Only the property-test crates call it.
pub use proptest_seed::proptest_config;

use std::path::{Path, PathBuf};

/// The repository's root, where `examples/` and the shared test data (`tests/bad/`,
/// `tests/snapshots/`, `tests/fuzz/`) live.
pub fn repo_root() -> PathBuf {
    // The first folder up that holds the workspace's lock file, so that the command
    // line's tests (at the root) and the library's (two folders below) both find it.
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .find(|p| p.join("Cargo.lock").is_file())
        .expect("the tests run inside the workspace")
        .to_path_buf()
}

/// `rel`, a path from the repository's root.
pub fn repo_path(rel: &str) -> PathBuf {
    repo_root().join(rel)
}

/// The scene `examples/{name}`.
pub fn example_scene(name: &str) -> caoen::render::Scene {
    let path = repo_path("examples").join(name);
    caoen::render::Scene::load(&path, &caoen::Limits::default()).unwrap()
}

/// `f` run in a pool of `threads` threads.
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// The default encode at `quality`.
pub fn at_quality(quality: f32) -> caoen::codec::EncodeOptions {
    caoen::codec::EncodeOptions {
        quality,
        ..Default::default()
    }
}

/// `bytes` decoded at `width x height`.
pub fn decode_at(bytes: &[u8], width: u32, height: u32) -> caoen::raster::Raster {
    let opts = caoen::codec::DecodeOptions {
        size: Some((width, height)),
        ..Default::default()
    };
    caoen::codec::decode(bytes, &opts).unwrap()
}

/// The corpus image `spec` as a raster.
pub fn raster_of(spec: &caoen_corpus::Spec) -> caoen::raster::Raster {
    let img = spec.generate();
    caoen::image_io::from_dynamic(img.to_dynamic_image()).expect("corpus image converts")
}

/// The corpus image of `class`, `w x h`, `seed`, as a raster.
pub fn corpus(class: caoen_corpus::Class, w: u32, h: u32, seed: u64) -> caoen::raster::Raster {
    raster_of(&caoen_corpus::Spec {
        class,
        width: w,
        height: h,
        seed,
    })
}

/// The mean squared difference of two rasters' samples, each mapped by `f` first.
pub fn mse_by(a: &caoen::raster::Raster, b: &caoen::raster::Raster, f: impl Fn(f32) -> f64) -> f64 {
    a.samples()
        .iter()
        .zip(b.samples())
        .map(|(x, y)| (f(*x) - f(*y)).powi(2))
        .sum::<f64>()
        / a.samples().len() as f64
}

/// Deterministic pseudo-random numbers (SplitMix64) in [0, 1), for large fixed models.
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next number.
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A random unit vector of `m` components (see [`random_unit`]).
    pub fn unit(&mut self, m: usize) -> Vec<f64> {
        random_unit(m, || self.next())
    }

    /// A random unit vector in 3-D.
    pub fn unit3(&mut self) -> [f64; 3] {
        let v = self.unit(3);
        [v[0], v[1], v[2]]
    }
}

/// A random unit vector of `m` components from `next`'s numbers in [0, 1): the first
/// point of the cube [-1, 1)^m whose length is in (0.1, 1], normalised.
pub fn random_unit(m: usize, mut next: impl FnMut() -> f64) -> Vec<f64> {
    loop {
        let v: Vec<f64> = (0..m).map(|_| 2.0 * next() - 1.0).collect();
        let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if n > 0.1 && n <= 1.0 {
            return v.into_iter().map(|a| a / n).collect();
        }
    }
}

/// `count` key points spread evenly over the sphere (a Fibonacci spiral) with the
/// shapes `model` gives them, of kernel `q`.
pub fn resampled(
    model: &caoen::surface::SurfaceModel,
    count: usize,
    q: f64,
) -> caoen::surface::Network {
    use caoen::surface::{Blend, KeyPoint, Network};
    let golden = 2.399_963_229_728_653;
    let kps: Vec<KeyPoint> = (0..count)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let w = vec![
                r * (k as f64 * golden).cos(),
                r * (k as f64 * golden).sin(),
                z,
            ];
            let t = model.network.eval(&w).unwrap();
            KeyPoint::new(w, t, Blend::Exponential, q)
        })
        .collect();
    Network::new(3, 3, &kps, true).unwrap()
}
