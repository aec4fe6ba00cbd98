//! Helpers shared by the library's tests.

// Each test crate includes this module and uses only part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The repository's root, where `examples/` and the shared test data (`tests/bad/`,
/// `tests/snapshots/`, `tests/fuzz/`) live.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the library sits one folder below the workspace root")
        .to_path_buf()
}

/// `rel`, a path from the repository's root.
pub fn repo_path(rel: &str) -> PathBuf {
    repo_root().join(rel)
}

/// Property-test settings with `cases` cases and a fixed seed, so that every run (and CI)
/// draws the same cases; set `PROPTEST_RNG_SEED` to explore others.
pub fn proptest_config(cases: u32) -> proptest::test_runner::Config {
    let base = proptest::test_runner::Config::with_cases(cases);
    if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
        base
    } else {
        proptest::test_runner::Config {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0xca0e),
            ..base
        }
    }
}
