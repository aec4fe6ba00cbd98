//! The trained starts, the contexts' mixing by step, the pricers against coding on a
//! copy, and blocks read back as written.

use super::*;
use crate::entropy::{valid_cdf, AnsSink, CostSink, OverlayCostSink};

/// Every anchor holds one valid start per model, in the models' order, and the
/// anchors' steps rise.
#[test]
fn the_trained_tables_hold_a_valid_start_for_every_model() {
    let plain = DetailContexts::default().models();
    assert_eq!(plain.iter().map(|(p, _)| p.len()).sum::<usize>(), STATE_LEN);
    assert!(ANCHOR_STEPS.windows(2).all(|w| w[0] < w[1]));
    for table in ANCHORS.iter() {
        let mut at = 0;
        for (p, _) in &plain {
            let part = &table[at..at + p.len()];
            if p.len() == 1 {
                assert!(
                    (64..=65536 - 64).contains(&(part[0] as u32)),
                    "a binary model's P(0) within its limits"
                );
            } else {
                assert!(valid_cdf(part), "a trained distribution keeps the floor");
            }
            at += p.len();
        }
    }
}

/// At an anchor's step the contexts start from that anchor's table; between two
/// anchors from their mix, each entry between the two; past the ends from the
/// nearest; and every model as if it had seen the trained count.
#[test]
fn contexts_start_from_the_anchors_mixed_by_the_step() {
    let flat =
        |c: &DetailContexts| -> Vec<u16> { c.models().into_iter().flat_map(|(p, _)| p).collect() };
    for (k, &s) in ANCHOR_STEPS.iter().enumerate() {
        assert_eq!(
            flat(&DetailContexts::for_step(s as f64)),
            ANCHORS[k].to_vec()
        );
    }
    let last = ANCHOR_STEPS.len() - 1;
    assert_eq!(flat(&DetailContexts::for_step(1e-6)), ANCHORS[0].to_vec());
    assert_eq!(
        flat(&DetailContexts::for_step(100.0)),
        ANCHORS[last].to_vec()
    );
    let (lo, hi) = (ANCHOR_STEPS[1] as f64, ANCHOR_STEPS[2] as f64);
    let mid = flat(&DetailContexts::for_step((lo + hi) / 2.0));
    for ((&m, &a), &b) in mid.iter().zip(&ANCHORS[1]).zip(&ANCHORS[2]) {
        assert_eq!(m as u32, (a as u32 + b as u32) / 2, "halfway is the mean");
    }
    assert!(DetailContexts::for_step(lo)
        .models()
        .iter()
        .all(|(_, seen)| *seen == TRAINED_SEEN as u32));
}

/// Sparse, mostly small levels as the quantiser makes, with an escape-sized one at
/// about one position in `escape_every`.
fn sparse_levels(rng: &mut caoen_base::rng::Lcg, escape_every: u32) -> [i32; COEFFS] {
    let mut q = [0i32; COEFFS];
    for (k, v) in q.iter_mut().enumerate() {
        let r = rng.next_u31();
        if r.is_multiple_of(2 + k as u32 / 4) {
            let m = if r.is_multiple_of(escape_every) {
                (r >> 8) % 5000
            } else {
                (r >> 8) % 4
            };
            *v = if r & 1 == 1 { -(m as i32) } else { m as i32 };
        }
    }
    q
}

#[test]
fn overlay_pricing_equals_pricing_a_copy_and_leaves_the_contexts_alone() {
    let mut ctx = DetailContexts::default();
    let mut overlay = OverlayCostSink::default();
    let mut sink = AnsSink::new();
    let mut rng = caoen_base::rng::Lcg::new(12345);
    for i in 0..400 {
        let q = sparse_levels(&mut rng, 97);
        let at = BlockContext::varied(i);
        let mut copy = CostSink::default();
        write_block(&mut ctx.clone(), at, &q, &mut copy);
        let before = ctx.clone();
        overlay.reset();
        write_block(&mut ctx, at, &q, &mut overlay);
        assert!(ctx == before, "block {i}: pricing changed the contexts");
        assert_eq!(overlay.cost, copy.cost, "block {i}");
        write_block(&mut ctx, at, &q, &mut sink);
    }
}

#[test]
fn the_block_pricer_equals_pricing_a_copy_within_limits_or_not() {
    let mut ctx = DetailContexts::default();
    let mut pricer = BlockPricer::default();
    let mut sink = AnsSink::new();
    let mut rng = caoen_base::rng::Lcg::new(777);
    for i in 0..300 {
        let q = sparse_levels(&mut rng, 53);
        let at = BlockContext::varied(i);
        // Candidates as the quantiser makes them (one level moved at a time, from
        // the highest position down, with good and bad hints), trims and the empty
        // block.
        let mut candidates = vec![(q, COEFFS)];
        let mut cur = q;
        for k in (0..COEFFS).rev() {
            let z = ZIGZAG[k] as usize;
            let r = rng.next_u31();
            if r.is_multiple_of(3) {
                continue;
            }
            let mut trial = cur;
            trial[z] += [-1, 1, 20, -300][r as usize / 3 % 4];
            let keep = if r.is_multiple_of(7) {
                rng.next_u31() as usize % (COEFFS + 1)
            } else {
                k + 1
            };
            candidates.push((trial, keep));
            if r.is_multiple_of(2) {
                cur = trial;
            }
        }
        let mut trimmed = cur;
        for k in (0..COEFFS)
            .rev()
            .filter(|&k| cur[ZIGZAG[k] as usize] != 0)
            .take(4)
        {
            trimmed[ZIGZAG[k] as usize] = 0;
            candidates.push((trimmed, COEFFS));
        }
        candidates.push(([0; COEFFS], COEFFS));
        let expected: Vec<u64> = candidates
            .iter()
            .map(|(c, _)| {
                let mut copy = CostSink::default();
                write_block(&mut ctx.clone(), at, c, &mut copy);
                copy.cost
            })
            .collect();
        let mut rates = pricer.block(&ctx, at);
        for (j, ((c, keep), e)) in candidates.iter().zip(&expected).enumerate() {
            // A priced limit answers at its edge, and a call stopped part way
            // leaves nothing behind that changes the next price.
            match rng.next_u31() % 3 {
                0 => assert_eq!(
                    rates.rate_within(c, *keep, e - 1),
                    None,
                    "block {i} candidate {j} over"
                ),
                1 => assert_eq!(
                    rates.rate_within(c, *keep, *e),
                    Some(*e),
                    "block {i} candidate {j} at"
                ),
                _ => {}
            }
            assert_eq!(rates.rate(c, *keep), *e, "block {i} candidate {j}");
        }
        write_block(&mut ctx, at, &cur, &mut sink);
    }
}

#[test]
fn a_block_context_holds_its_neighbours_signs_and_sizes_at_the_low_positions() {
    let at = |k: usize| ZIGZAG[k] as usize;
    let mut left = [0i32; COEFFS];
    (left[0], left[at(1)], left[at(9)], left[at(10)]) = (-5, 1, -2, 7);
    let mut above = [0i32; COEFFS];
    (above[0], above[at(1)]) = (3, 2);
    let (l, a) = (Summary::of(&left), Summary::of(&above));
    assert_eq!(
        (l.reach, a.reach),
        (1 + 4, 1 + 1),
        "one more than the last's bit length"
    );
    assert_eq!(
        (l.signs[0], l.signs[1], l.signs[2], l.signs[9]),
        (2, 1, 0, 2)
    );
    assert_eq!(
        (l.levels[0], l.levels[1], l.levels[9]),
        (2, 1, 2),
        "sizes capped at 2"
    );
    let c = BlockContext::new(1, 2, l, a);
    assert_eq!((c.kind, c.class, c.neighbours), (1, 2, 4));
    assert_eq!(c.signs[0], 3 * 2 + 1, "left negative, above positive");
    assert_eq!(c.signs[1], 3 + 1);
    assert_eq!(c.signs[9], 3 * 2);
    assert_eq!(c.signs[2], 0);
    assert_eq!(
        (c.level(0), c.level(1), c.level(2), c.level(9)),
        (2, 2, 0, 1)
    );
    assert_eq!(
        c.level(10),
        0,
        "position 10 is past the contexts, whatever is there"
    );
    let none = BlockContext::new(0, 0, Summary::default(), Summary::default());
    assert_eq!(
        (none.neighbours, none.signs, none.levels),
        (0, [0; SIGNED], [0; SIGNED])
    );
}

#[test]
fn initial_tables_are_valid_cdfs() {
    for (m, r) in [(8, 0.8), (16, 0.2), (16, 0.8), (24, 0.7)] {
        let f = geometric(m, r);
        assert_eq!(f.len(), m);
        assert!(f[0] >= CDF_FLOOR);
        for w in f.windows(2) {
            assert!(w[1] >= w[0] + CDF_FLOOR);
        }
        assert!(*f.last().unwrap() <= CDF_ONE - CDF_FLOOR);
    }
}

#[test]
fn blocks_round_trip() {
    let mut blocks = vec![[0i32; COEFFS]; 6];
    blocks[1][0] = 3;
    blocks[2][63] = -1;
    blocks[2][5] = 40_000;
    blocks[3][ZIGZAG[1] as usize] = -17;
    blocks[3][ZIGZAG[2] as usize] = 1;
    for (i, v) in blocks[4].iter_mut().enumerate() {
        *v = (i as i32 % 7) - 3;
    }
    blocks[5][0] = -(MAX_LEVEL as i32);
    let mut ctx = DetailContexts::default();
    let mut sink = AnsSink::new();
    for (i, b) in blocks.iter().enumerate() {
        let at = BlockContext::varied(i);
        write_block(&mut ctx, at, b, &mut sink);
    }
    let bytes = sink.finish();
    let mut src = AnsSource::new(&bytes, 10_000).unwrap();
    let mut ctx = DetailContexts::default();
    for (i, b) in blocks.iter().enumerate() {
        let at = BlockContext::varied(i);
        let mut q = [0; COEFFS];
        let coded = read_block(&mut ctx, at, &mut q, &mut src).unwrap();
        assert_eq!(coded, b.iter().any(|&v| v != 0));
        assert_eq!(&q, b);
    }
    assert!(src.finished_cleanly());
}
