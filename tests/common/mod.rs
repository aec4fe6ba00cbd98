//! Helpers shared by the end-to-end tests.

use std::process::{Command, Output};

/// Runs the `caoen` binary built for these tests with `args`.
pub fn caoen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
        .output()
        .expect("run caoen")
}
