//! Same bytes for the same (class, size, seed), whatever the thread count, and
//! the same bytes as when the golden hashes were recorded.

mod common;

use caoen_corpus::{generate, test_subset, Class, Spec};

fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
}

fn specs() -> Vec<Spec> {
    let mut v = test_subset();
    // A few larger images, so rows really are split between workers.
    for class in [Class::Scene, Class::Natural, Class::Hdr, Class::FlatEdges] {
        for seed in 0..class.variant_count() {
            v.push(Spec::new(class, 160, 120, seed));
        }
    }
    v
}

#[test]
fn identical_hashes_with_one_and_two_threads() {
    let specs = specs();
    let one: Vec<String> =
        pool(1).install(|| specs.iter().map(|s| s.generate().sha256()).collect());
    // Two threads, and images generated concurrently in a different order.
    let two: Vec<String> = pool(2).install(|| {
        use rayon::prelude::*;
        let mut v: Vec<(usize, String)> = specs
            .par_iter()
            .enumerate()
            .rev()
            .map(|(i, s)| (i, s.generate().sha256()))
            .collect();
        v.sort();
        v.into_iter().map(|(_, h)| h).collect()
    });
    for ((s, a), b) in specs.iter().zip(&one).zip(&two) {
        assert_eq!(a, b, "{s}: hash differs between 1 and 2 threads");
    }
}

#[test]
fn repeated_calls_are_identical() {
    for s in test_subset() {
        let a = s.generate();
        let b = generate(s.class, s.width, s.height, s.seed);
        assert!(a == b, "{s}");
    }
}

#[test]
fn different_seeds_differ() {
    for class in Class::ALL {
        let a = generate(class, 64, 48, 0).sha256();
        let b = generate(class, 64, 48, class.variant_count()).sha256();
        assert_ne!(
            a,
            b,
            "{class}: seed 0 and seed {} are identical",
            class.variant_count()
        );
    }
}

/// Golden SHA-256 of every image of `test_subset()`, recorded on x86_64 Linux.
/// A mismatch means the generator's output changed (or is not portable): if the
/// change is intended, re-record with `CAOEN_CORPUS_BLESS=1 cargo test -p caoen-corpus --test determinism`.
#[test]
fn golden_hashes_of_the_test_subset() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden_test_subset.txt");
    let actual: Vec<String> = test_subset()
        .iter()
        .map(|s| format!("{} {}", s.stem(), s.generate().sha256()))
        .collect();
    if std::env::var_os("CAOEN_CORPUS_BLESS").is_some() {
        std::fs::write(&path, actual.join("\n") + "\n").unwrap();
        return;
    }
    let expected = std::fs::read_to_string(&path).expect("golden file (bless to create it)");
    let expected: Vec<&str> = expected.lines().collect();
    let diff: Vec<String> = actual
        .iter()
        .zip(expected.iter().chain(std::iter::repeat(&"<missing>")))
        .filter(|(a, e)| a.as_str() != **e)
        .map(|(a, e)| format!("  got {a}\n  expected {e}"))
        .collect();
    assert!(
        diff.is_empty() && actual.len() == expected.len(),
        "golden hashes differ:\n{}",
        diff.join("\n")
    );
}
