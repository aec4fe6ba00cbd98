//! The level search's moves and choices against the plain search, and the merged
//! option's answers against its full search.

use super::*;
use caoen_base::rng::Lcg;
use caoen_decoder::detail::syntax::GroupContext;
use caoen_decoder::entropy::OverlayCostSink;

/// Moves the contexts past a block coded with `levels`, as the encoder does.
fn advance(ctx: &mut DetailContexts, at: syntax::BlockContext, levels: &[i32; COEFFS]) {
    syntax::write_block(ctx, at, levels, &mut caoen_decoder::entropy::AnsSink::new());
}

/// Coefficients falling off with frequency, as a photograph's residual does.
fn residual_block(rng: &mut Lcg, scale: f64) -> [f64; COEFFS] {
    std::array::from_fn(|i| {
        let u = rng.unit() - 0.5;
        u * scale / (1.0 + (i / N + i % N) as f64)
    })
}

/// A step towards zero adds `2e + 1` squared steps (`e` the coefficient's distance
/// past its level): offered while the bits it may save can pay for that, at 19 bits
/// from a level of one and 14 from larger ones; a step away only past half a step.
#[test]
fn the_search_offers_the_moves_that_can_pay() {
    let lambda = 0.05;
    // From one to zero, 19 bits pay for 0.95 squared steps: e up to -0.025.
    assert_eq!(moves(1, 0.97, lambda), [Some(0), None]);
    assert_eq!(moves(-1, -0.97, lambda), [Some(0), None]);
    assert_eq!(moves(1, 0.98, lambda), [None, None]);
    // From three, 14 bits pay for 0.7 squared steps: e up to -0.15.
    assert_eq!(moves(3, 2.84, lambda), [Some(2), None]);
    assert_eq!(moves(-3, -2.86, lambda), [None, None]);
    // Away from zero past half a step, whatever the multiplier.
    assert_eq!(moves(0, -0.6, lambda), [None, Some(-1)]);
    assert_eq!(moves(2, 2.55, 0.0), [None, Some(3)]);
    assert_eq!(moves(2, 2.55, lambda), [None, Some(3)]);
    assert_eq!(moves(1, 1.51, 1.0), [Some(0), Some(2)]);
    assert_eq!(moves(0, 0.4, lambda), [None, None]);
}

#[test]
fn the_level_search_only_takes_cheaper_blocks_one_step_from_rounding() {
    let q = Quantiser {
        step: 1.0,
        deadzone: 0.2,
        lambda: 0.12,
        per_coefficient: true,
    };
    let mut ctx = DetailContexts::default();
    let mut cost = OverlayCostSink::default();
    let at = caoen_decoder::detail::syntax::BlockContext {
        kind: 0,
        class: 1,
        neighbours: 1,
        signs: [4, 2, 0, 8, 1, 5, 0, 3, 7, 6],
        levels: [0, 1, 2, 0, 1, 2, 2, 1, 0, 0],
    };
    let mut seed = Lcg::new(99);
    let mut moved = 0;
    for _ in 0..300 {
        let c = residual_block(&mut seed, 12.0);
        let start: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
        let mut price = |l: &[i32; COEFFS]| {
            cost.reset();
            syntax::write_block(&mut ctx, at, l, &mut cost);
            distortion(&c, l) + q.lambda * cost.cost as f64 / 256.0
        };
        let j0 = price(&start);
        let (j, levels) = reference::search_levels(&c, q.lambda, (j0, start), &mut price);
        assert!(j <= j0);
        assert_eq!(j, price(&levels), "the cost returned is the levels' cost");
        for k in 0..COEFFS {
            let nearest = c[k].round() as i32;
            assert!(
                (levels[k] - nearest).abs() <= 1,
                "{} from {}",
                levels[k],
                c[k]
            );
        }
        moved += usize::from(levels != start);
        advance(&mut ctx, at, &levels);
    }
    assert!(
        moved > 30,
        "the search changes some blocks ({moved} of 300)"
    );
}

/// A merged option asked with rising costs apart (as a group's blocks are added)
/// answers as a full search compared with each would.
#[test]
fn a_merged_option_answers_as_its_full_search_would() {
    let mut seed = Lcg::new(31);
    let ctx = DetailContexts::default();
    let mut pricer = BlockPricer::default();
    let (mut searched, mut skipped) = (0, 0);
    for i in 0..400 {
        let q = Quantiser {
            step: [1.0, 0.4, 2.5][i % 3],
            deadzone: 0.2,
            lambda: 0.09,
            per_coefficient: i % 2 == 0,
        };
        let low = residual_block(&mut seed, if i % 4 == 0 { 40.0 } else { 6.0 });
        let high = (i % 7) as f64 * 0.8;
        let transforms = [Some([Some((low, high)), None])];
        let plane = Plane {
            coeffs: &[],
            transforms: &transforms,
            cols: 1,
            q,
            ctx: &ctx,
        };
        let g = GroupContext {
            kind: 0,
            level: 1,
            class: 1,
            merged: i % 3,
        };
        let at = syntax::BlockContext {
            kind: 0,
            ..syntax::BlockContext::varied(i)
        };
        let full = choose(&low, q, &ctx, at, &mut pricer);
        let j_full = full.cost(
            q,
            syntax::merge_cost(&ctx, g, true),
            high / (q.step * q.step),
        );
        let mut option = plane.merged(0, g, at);
        for f in [0.1, 0.5, 0.9, 1.0, 1.1, 2.0] {
            let apart = j_full * f;
            let expected = (j_full < apart).then_some((j_full, full.levels));
            assert_eq!(
                option.beats(apart, &mut pricer),
                expected,
                "group {i} at {f}"
            );
            // Answered by the bound alone, without a search.
            skipped += usize::from(option.found.is_none());
        }
        searched += usize::from(option.found.is_some());
    }
    assert!(
        searched > 100 && skipped > 10,
        "searched {searched}, skipped {skipped}"
    );
}

#[test]
fn choices_equal_the_reference_search() {
    let mut seed = Lcg::new(2024);
    for per_coefficient in [true, false] {
        let mut changed = 0;
        for (kind, step, lambda, scale) in [
            (0, 1.0, 0.09, 12.0),
            (1, 0.37, 0.09, 3.0),
            (0, 0.05, 0.2, 200.0),
            (1, 2.5, 0.03, 4.0),
        ] {
            let q = Quantiser {
                step,
                deadzone: 0.2,
                lambda,
                per_coefficient,
            };
            let mut ctx = DetailContexts::default();
            let mut cost = OverlayCostSink::default();
            let mut pricer = BlockPricer::default();
            for i in 0..400 {
                let c = residual_block(&mut seed, scale * if i % 5 == 0 { 8.0 } else { 1.0 });
                let at = syntax::BlockContext {
                    kind,
                    ..syntax::BlockContext::varied(i)
                };
                let expected = reference::choose(&c, q, &mut ctx, at, &mut cost);
                let chosen = choose(&c, q, &ctx, at, &mut pricer);
                assert_eq!(chosen.levels, expected, "block {i}");
                // The kept distortion and rate give the cost of pricing the levels
                // again, to the bit, with or without extra bits and dropped error.
                for (extra, dropped) in [(0, 0.0), (300, 0.0), (77, 1.25)] {
                    let again = block_cost(&c, &expected, q, &ctx, at, &mut pricer, extra, dropped);
                    assert_eq!(
                        chosen.cost(q, extra, dropped).to_bits(),
                        again.to_bits(),
                        "block {i}"
                    );
                }
                // What a merged group's search is skipped by stays below its cost.
                for (extra, dropped) in [(0, 0.0), (0, 3.5)] {
                    assert!(
                        unavoidable_error(&c, q) + dropped <= chosen.cost(q, extra, dropped),
                        "block {i}"
                    );
                }
                let rounded: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
                changed += usize::from(expected != rounded);
                advance(&mut ctx, at, &expected);
            }
        }
        assert!(changed > 100, "the search has choices to make ({changed})");
    }
}
