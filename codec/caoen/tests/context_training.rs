//! Trains the detail contexts' starting tables
//! (`codec/caoen-decoder/src/detail/context_tables.rs`, `docs/format.md`, "Starting
//! contexts"), on demand:
//!
//! `cargo test -p caoen --release --test context_training -- --ignored --nocapture`
//!
//! Each photograph in `PHOTOS` (default `../shared/photos`, PNG files) is encoded at
//! its own size at each anchor quality. Its detail streams are read back and every
//! model's probabilities taken as the stream ends. Per anchor, each model's table entry
//! is the mean of those, weighted by the symbols each stream coded with the model (up
//! to 256, where the models stop slowing their adaptation). A model no stream used
//! keeps its untrained start. The encodes start from the tables in the build, so
//! training again from new tables moves the rarely used models little.

mod common;

use caoen::codec::bitstream;
use caoen::codec::decoder::detail_models;
use caoen::codec::detail::context_tables::STATE_LEN;
use caoen::codec::detail::syntax::DetailContexts;
use caoen::codec::entropy::valid_cdf;
use caoen::codec::{EncodeOptions, Resampling};

/// The anchor qualities, from the finest step to the coarsest: the tables' steps are
/// theirs.
const ANCHOR_QUALITIES: [f32; 5] = [90.0, 70.0, 50.0, 30.0, 10.0];

/// Weight of one stream's model in the mean: its symbols, up to where the models'
/// adaptation stops slowing.
const MAX_WEIGHT: u32 = 256;

#[test]
#[ignore]
fn train_detail_contexts() {
    let dir = std::env::var("PHOTOS")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| common::repo_path("../shared/photos"));
    let mut photos: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    photos.sort();
    assert!(
        !photos.is_empty(),
        "no PNG photographs in {}",
        dir.display()
    );
    let images: Vec<_> = photos
        .iter()
        .map(|p| caoen::image_io::load(p).unwrap())
        .collect();
    let plain = DetailContexts::default().models();
    let mut steps = Vec::new();
    let mut tables = Vec::new();
    for q in ANCHOR_QUALITIES {
        // Per model and probability: the weighted sum and the total weight.
        let mut sums: Vec<Vec<f64>> = plain.iter().map(|(p, _)| vec![0.0; p.len()]).collect();
        let mut weights = vec![0u64; plain.len()];
        let mut step = None;
        for (path, img) in photos.iter().zip(&images) {
            let options = EncodeOptions {
                quality: q,
                resampling: Resampling::Off,
                ..Default::default()
            };
            let bytes = caoen::codec::encode(img, &options).unwrap();
            let parsed = bitstream::parse(&bytes, u64::MAX).unwrap();
            let Some([s, _]) = parsed.header.detail_steps else {
                eprintln!("{} at q{q}: no detail layer", path.display());
                continue;
            };
            assert!(step.is_none_or(|t| t == s), "one step per quality");
            step = Some(s);
            for stream in detail_models(&parsed).unwrap() {
                for (j, (p, seen)) in stream.iter().enumerate() {
                    let w = (*seen).min(MAX_WEIGHT);
                    weights[j] += w as u64;
                    for (sum, &x) in sums[j].iter_mut().zip(p) {
                        *sum += w as f64 * x as f64;
                    }
                }
            }
            eprintln!("{} at q{q}: {} bytes", path.display(), bytes.len());
        }
        steps.push(step.expect("a detail layer at every anchor"));
        // The floor of a weighted mean of distributions keeps every entry the floor
        // apart, and of binary models their limits: no repair is needed.
        let table: Vec<u16> = plain
            .iter()
            .zip(&sums)
            .zip(&weights)
            .flat_map(|(((p, _), sum), &w)| {
                if w == 0 {
                    p.clone()
                } else {
                    sum.iter().map(|s| (s / w as f64).floor() as u16).collect()
                }
            })
            .collect();
        tables.push(table);
    }
    assert!(
        steps.windows(2).all(|w| w[0] < w[1]),
        "steps rise as the quality falls"
    );
    for t in &tables {
        assert_eq!(t.len(), STATE_LEN);
        let mut at = 0;
        for (p, _) in &plain {
            let part = &t[at..at + p.len()];
            assert!(
                p.len() == 1 || valid_cdf(part),
                "a trained distribution is valid"
            );
            at += p.len();
        }
    }
    let out = std::env::var("TABLES")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|_| common::repo_path("codec/caoen-decoder/src/detail/context_tables.rs"));
    std::fs::write(&out, source(&steps, &tables)).unwrap();
    eprintln!("wrote {}", out.display());
}

/// The tables as Rust source.
fn source(steps: &[f32], tables: &[Vec<u16>]) -> String {
    let mut s = String::new();
    s.push_str(
        "//! @generated by `codec/caoen/tests/context_training.rs`: not edited by hand.\n\
         //!\n\
         //! The detail contexts' trained starting probabilities (`docs/format.md`, \"Starting\n\
         //! contexts\"): per anchor step, every model's probabilities in the order of\n\
         //! [`super::syntax::DetailContexts`]' models (a binary model's P(0) in 2^-16, a\n\
         //! distribution's entries in 2^-15).\n\n",
    );
    s.push_str(&format!(
        "/// Numbers per anchor: every model's probabilities.\npub const STATE_LEN: usize = {};\n\n",
        tables[0].len()
    ));
    s.push_str(&format!(
        "/// The luma detail steps of the anchors, rising (the steps of qualities {}).\npub const ANCHOR_STEPS: [f32; {}] = [{}];\n\n",
        ANCHOR_QUALITIES.iter().map(|q| format!("{q}")).collect::<Vec<_>>().join(", "),
        steps.len(),
        steps.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>().join(", ")
    ));
    s.push_str(&format!(
        "/// The probabilities at each anchor.\npub static ANCHORS: [[u16; STATE_LEN]; {}] = [\n",
        tables.len()
    ));
    for t in tables {
        s.push_str("    [\n");
        for row in t.chunks(16) {
            let nums: Vec<String> = row.iter().map(|x| x.to_string()).collect();
            s.push_str(&format!("        {},\n", nums.join(", ")));
        }
        s.push_str("    ],\n");
    }
    s.push_str("];\n");
    s
}
