//! Property-test settings shared by the library's and the command line's tests.

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
