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
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .expect("the facade crate sits two folders below the workspace root")
        .to_path_buf()
}

/// `rel`, a path from the repository's root.
pub fn repo_path(rel: &str) -> PathBuf {
    repo_root().join(rel)
}
