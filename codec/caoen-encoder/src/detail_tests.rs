//! The detail layer coded by the encoder and read back by the decoder: every block,
//! group and plane kind round trips, and evaluation paths agree.

use crate::quantise::{code_layer, Quantiser};
use caoen_decoder::detail::adaptive::BlockSteps;
use caoen_decoder::detail::dct::{COEFFS, N};
use caoen_decoder::detail::deblock::Deblock;
use caoen_decoder::detail::lapping::Lapping;
use caoen_decoder::detail::weights::FrequencyWeights;
use caoen_decoder::detail::*;
use caoen_decoder::geometry::Frame;
use caoen_decoder::keyset::Grid;

/// A 21x13 three-channel residual with edges, texture and a flat part.
fn residuals() -> (Vec<Vec<f64>>, (u32, u32)) {
    let (w, h) = (21u32, 13u32);
    let planes = (0..3)
        .map(|c| {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    let edge = if x > 9.0 + c as f64 { 0.3 } else { -0.1 };
                    let texture = 0.05 * ((x * 1.7 + y * 0.9).sin());
                    if y > 9.0 {
                        0.0
                    } else {
                        edge + texture
                    }
                })
                .collect()
        })
        .collect();
    (planes, (w, h))
}

/// Class 0 (the smallest cells) for every block of a `w x h` plane.
fn no_classes(w: u32, h: u32) -> Vec<u8> {
    let (cols, rows) = blocks(w, h);
    vec![0; cols * rows]
}

fn quantisers(step: f64) -> Vec<Quantiser> {
    vec![
        Quantiser {
            step,
            deadzone: 0.2,
            lambda: 0.12,
            per_coefficient: true,
        };
        3
    ]
}

/// The summed squared difference of the residual planes `r` and an evaluated layer.
fn squared_error(r: &[Vec<f64>], layer: &[Vec<f32>]) -> f64 {
    r.iter()
        .zip(layer)
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(&a, &b)| (a - b as f64).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// `detail`'s payload is `payload` and reads back as `detail`.
fn assert_reads_back(detail: &Detail, payload: &[u8], classes: &[u8], (w, h): (u32, u32)) {
    assert_eq!(detail.to_payload(classes), payload);
    let back = Detail::read(payload, w, h, detail.steps.clone(), classes, None)
        .unwrap()
        .0;
    assert_eq!(&back, detail);
}

#[test]
fn the_searched_payload_is_the_plain_coding_of_its_levels_and_reads_back() {
    let (r, (w, h)) = residuals();
    let (cols, rows) = blocks(w, h);
    let classes: Vec<u8> = (0..cols * rows).map(|i| (i % 3) as u8).collect();
    let (detail, payload) = code_layer(&r, (w, h), &quantisers(0.02), &classes, None, None, None);
    assert!(detail.planes.iter().all(|p| p.coded_blocks() > 0));
    assert_reads_back(&detail, &payload, &classes, (w, h));
    // The classes are contexts: read with others, the payload is another layer.
    let others = vec![0u8; cols * rows];
    assert_ne!(
        Detail::read(&payload, w, h, detail.steps.clone(), &others, None)
            .ok()
            .map(|(d, _)| d),
        Some(detail)
    );
}

/// A 40x32 three-channel residual under cells of class `class`: smooth on the
/// left, where the encoder merges groups, a fine checkerboard on the right, where
/// it does not.
fn groups_layer(step: f64, class: u8) -> (Detail, Vec<u8>, Vec<u8>, (u32, u32)) {
    groups_layer_weighted(step, class, None)
}

/// [`groups_layer`] with frequency weights.
fn groups_layer_weighted(
    step: f64,
    class: u8,
    weights: Option<FrequencyWeights>,
) -> (Detail, Vec<u8>, Vec<u8>, (u32, u32)) {
    let (w, h) = (40u32, 32u32);
    let planes: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f64, (i / w) as f64);
                    if x < 16.0 || (class == 2 && x < 32.0) {
                        0.2 * ((x + 2.0 * y) / 13.0 + c as f64).sin()
                    } else {
                        0.2 * if (i % w + i / w) % 2 == 0 { 1.0 } else { -1.0 }
                    }
                })
                .collect()
        })
        .collect();
    let (cols, rows) = blocks(w, h);
    let classes = vec![class; cols * rows];
    let (detail, payload) = code_layer(
        &planes,
        (w, h),
        &quantisers(step),
        &classes,
        None,
        weights,
        None,
    );
    (detail, payload, classes, (w, h))
}

#[test]
fn smooth_groups_merge_and_their_payload_reads_back() {
    let (detail, payload, classes, (w, h)) = groups_layer(0.05, 1);
    let (cols, _) = blocks(w, h);
    for p in &detail.planes {
        assert!(p.merged_groups() > 0, "the smooth half merges");
        // Blocks 2 and 3 of the first two rows are the checkerboard's group.
        assert!(
            p.merged[2] == 0 && p.merged[cols + 3] == 0,
            "a checkerboard group is coded apart"
        );
    }
    assert_reads_back(&detail, &payload, &classes, (w, h));
}

#[test]
fn chroma_groups_merge_under_the_smallest_cells_and_luma_groups_do_not() {
    let (detail, payload, classes, (w, h)) = groups_layer(0.05, 0);
    assert_eq!(
        detail.planes[0].merged_groups(),
        0,
        "luma merges under 16-pixel cells only"
    );
    for p in &detail.planes[1..] {
        assert!(p.merged_groups() > 0, "the smooth chroma half merges");
        assert!(
            p.merged.iter().all(|&m| m <= 1),
            "4x4 groups need 32-pixel cells"
        );
    }
    assert_reads_back(&detail, &payload, &classes, (w, h));
}

#[test]
fn a_tilt_codes_fewer_high_frequencies_and_its_layer_reads_back() {
    let (r, (w, h)) = residuals();
    let classes = no_classes(w, h);
    let tilt = Some(FrequencyWeights { tilts: [32, 32] });
    let (flat, flat_payload) =
        code_layer(&r, (w, h), &quantisers(0.01), &classes, None, None, None);
    let (tilted, payload) = code_layer(&r, (w, h), &quantisers(0.01), &classes, None, tilt, None);
    assert!(
        payload.len() < flat_payload.len(),
        "{} vs {}",
        payload.len(),
        flat_payload.len()
    );
    // The weights live in the header: the payload is the plain coding of the levels.
    assert_eq!(tilted.to_payload(&classes), payload);
    let mut back = Detail::read(&payload, w, h, tilted.steps.clone(), &classes, None)
        .unwrap()
        .0;
    back.weights = tilt;
    assert_eq!(back, tilted);
    // The DC keeps its step: the coarser high frequencies cost error.
    let frame = Frame::new(w, h);
    let grid = Grid::pixel_centres(&frame, w, h);
    let error = |d: &Detail| squared_error(&r, &DetailEval::new(d, &grid).eval());
    assert!(error(&tilted) > error(&flat));
    assert_grid_equals_scalar(
        &tilted,
        (w, h),
        [(w, h), (2 * w + 1, h + 3), (w / 2, h / 2)],
    );
}

#[test]
fn smooth_4x4_groups_under_large_cells_merge_and_read_back() {
    let (detail, payload, classes, (w, h)) = groups_layer(0.08, 2);
    for p in &detail.planes {
        // The smooth 32 pixels on the left are one 4x4 group.
        assert_eq!(p.merged[0], 2, "the smooth 4x4 group merges whole");
        assert!((0..4).all(|y| (0..4).all(|x| p.merged[y * p.cols + x] == 2)));
        assert_eq!(p.merged_groups(), 1);
        assert!(p.block(0, 0).is_some() && (1..4).all(|x| p.block(x, 0).is_none()));
    }
    assert_reads_back(&detail, &payload, &classes, (w, h));
    // Read as 16-pixel cells, the bins mean other things: another layer or an error.
    let small = vec![1u8; classes.len()];
    assert_ne!(
        Detail::read(&payload, w, h, detail.steps.clone(), &small, None)
            .ok()
            .map(|(d, _)| d),
        Some(detail)
    );
}

#[test]
fn a_merged_group_evaluates_to_its_16x16_inverse_transform_at_pixel_centres() {
    for tilts in [[0, 0], [24, 8]] {
        merged_group_is_its_inverse_transform(FrequencyWeights { tilts });
    }
}

/// The first merged group of a layer with `weights` evaluates to the 16x16 inverse
/// transform of its levels times the step and each coefficient's weight.
fn merged_group_is_its_inverse_transform(weights: FrequencyWeights) {
    let (detail, _, _, (w, h)) = groups_layer_weighted(0.05, 1, Some(weights));
    let table = weights.table(0);
    let p = &detail.planes[0];
    let step = detail.steps[0];
    let (bx, by) = (0..p.rows)
        .flat_map(|by| (0..p.cols).map(move |bx| (bx, by)))
        .find(|&(bx, by)| p.merged[by * p.cols + bx] == 1)
        .unwrap();
    let levels = p.block(bx, by).unwrap();
    let plain = Detail {
        deblock: None,
        lapping: None,
        block_steps: None,
        ..detail.clone()
    };
    let frame = Frame::new(w, h);
    let layer = DetailEval::new(&plain, &Grid::pixel_centres(&frame, w, h)).eval();
    // The 16-point basis B_u(t) = a_u cos(pi u t / 16), by its definition.
    let basis = |u: usize, t: f64| {
        let a = if u == 0 {
            0.25
        } else {
            std::f64::consts::SQRT_2 / 4.0
        };
        a * (std::f64::consts::PI * u as f64 * t / 16.0).cos()
    };
    for y in 0..16 {
        for x in 0..16 {
            let expected: f64 = (0..COEFFS)
                .map(|z| {
                    levels[z] as f64
                        * step
                        * table[1][z]
                        * basis(z / N, y as f64 + 0.5)
                        * basis(z % N, x as f64 + 0.5)
                })
                .sum();
            let (px, py) = (bx * N + x, by * N + y);
            let got = layer[0][py * w as usize + px] as f64;
            assert!(
                (got - expected).abs() < 1e-5,
                "({px}, {py}): {got} vs {expected}"
            );
        }
    }
}

#[test]
fn a_finer_step_leaves_less_error_and_costs_more() {
    let (r, (w, h)) = residuals();
    let frame = Frame::new(w, h);
    let grid = Grid::pixel_centres(&frame, w, h);
    let error = |step: f64| {
        let (detail, payload) = code_layer(
            &r,
            (w, h),
            &quantisers(step),
            &no_classes(w, h),
            None,
            None,
            None,
        );
        let e = squared_error(&r, &DetailEval::new(&detail, &grid).eval());
        (e / (3 * w * h) as f64, payload.len())
    };
    let (coarse, coarse_bytes) = error(0.05);
    let (fine, fine_bytes) = error(0.002);
    assert!(fine < coarse / 20.0, "{fine} vs {coarse}");
    assert!(fine < 1e-5, "{fine}");
    assert!(fine_bytes > coarse_bytes);
}

#[test]
fn evaluation_at_pixel_centres_is_the_inverse_transform() {
    let mut levels = [0i32; COEFFS];
    for (i, l) in levels.iter_mut().enumerate() {
        *l = (i as i32 * 7 % 9) - 4;
    }
    for weights in [None, Some(FrequencyWeights { tilts: [20, 0] })] {
        let plane = DetailPlane::from_blocks(1, 1, vec![levels]);
        let detail = Detail {
            planes: vec![plane],
            steps: vec![0.5],
            deblock: None,
            lapping: None,
            block_steps: None,
            weights,
            field: None,
        };
        let frame = Frame::new(8, 8);
        let out = DetailEval::new(&detail, &Grid::pixel_centres(&frame, 8, 8)).eval();
        // Coefficient (u, v) of luma takes 1 + 1.25 (u + v) / 14 times the step.
        let coeffs: [f64; COEFFS] = std::array::from_fn(|i| {
            let w = weights.map_or(1.0, |_| 1.0 + 1.25 * (i % N + i / N) as f64 / 14.0);
            levels[i] as f64 * 0.5 * w
        });
        let reference = dct::inverse(&coeffs);
        for i in 0..COEFFS {
            assert!((out[0][i] as f64 - reference[i]).abs() < 1e-4, "{i}");
        }
    }
}

#[test]
fn a_doubled_grid_interpolates_between_pixel_centres() {
    // A smooth (lowest-frequency) block: the series halfway between two centres is
    // between their values.
    let mut levels = [0i32; COEFFS];
    levels[1] = 10;
    let detail = Detail {
        planes: vec![DetailPlane::from_blocks(1, 1, vec![levels])],
        steps: vec![0.1],
        deblock: None,
        lapping: None,
        block_steps: None,
        weights: None,
        field: None,
    };
    let frame = Frame::new(8, 8);
    let one = DetailEval::new(&detail, &Grid::pixel_centres(&frame, 8, 8)).eval();
    let two = DetailEval::new(&detail, &Grid::pixel_centres(&frame, 16, 16)).eval();
    // Output pixel 2i + 2 of the doubled grid sits at coded x = i + 1.25, between
    // the centres of coded pixels i and i + 1.
    for i in 0..7 {
        let (a, b) = (one[0][i], one[0][i + 1]);
        let m = two[0][2 * i + 2];
        assert!(m <= a.max(b) + 1e-6 && m >= a.min(b) - 1e-6);
    }
}

/// The layer coded coarsely, so that its blocks step at their edges.
fn deblocked(strength: u8, radius: u8) -> (Detail, (u32, u32)) {
    let (r, (w, h)) = residuals();
    let (mut detail, _) = code_layer(
        &r,
        (w, h),
        &quantisers(0.3),
        &no_classes(w, h),
        None,
        None,
        None,
    );
    detail.deblock = Some(Deblock { strength, radius });
    (detail, (w, h))
}

#[test]
fn deblocked_and_lapped_grid_evaluation_equals_the_scalar_reference_at_any_scale() {
    let lap = Some(Lapping::DEFAULT);
    for (strength, radius, adaptive, lapping) in [
        (25, 16, false, None),
        (255, 16, false, None),
        (60, 3, false, None),
        (60, 3, true, None),
        (60, 3, true, lap),
        (25, 16, false, Some(Lapping { weight: 127 })),
    ] {
        let (mut detail, (w, h)) = deblocked(strength, radius);
        detail.lapping = lapping;
        if adaptive {
            let (cols, rows) = blocks(w, h);
            detail.block_steps = Some(BlockSteps {
                steps: adaptive::AdaptiveSteps {
                    factors: [40, 32, 9],
                    field_log2: 0,
                },
                classes: (0..cols * rows).map(|i| (i * 7 % 3) as u8).collect(),
                field: (0..cols * rows)
                    .map(|i| (i * 5 % 9) as i8 - field::LIMIT)
                    .collect(),
            });
        }
        assert_grid_equals_scalar(
            &detail,
            (w, h),
            [(w, h), (3 * w, 2 * h + 1), (w / 2, h / 2)],
        );
    }
}

/// The grid evaluation of `detail` (coded size `w x h`) at each output size equals
/// [`Detail::at`] at every grid position.
fn assert_grid_equals_scalar(detail: &Detail, (w, h): (u32, u32), sizes: [(u32, u32); 3]) {
    let frame = Frame::new(w, h);
    for (ow, oh) in sizes {
        let grid = Grid::pixel_centres(&frame, ow, oh);
        let layer = DetailEval::new(detail, &grid).eval();
        for j in 0..grid.ny {
            for i in 0..grid.nx {
                let at = detail.at(grid.x(i), grid.y(j));
                for (c, plane) in layer.iter().enumerate() {
                    let fast = plane[j * grid.nx + i] as f64;
                    assert!(
                        (fast - at[c]).abs() < 1e-4,
                        "{ow}x{oh} ({i}, {j}) plane {c}: {fast} vs {}",
                        at[c]
                    );
                }
            }
        }
    }
}

/// A layer, its payload, the residual it codes and the image size.
type CodedResidual = (Detail, Vec<u8>, Vec<Vec<f64>>, (u32, u32));

/// A 48x40 residual whose chroma planes are luma's texture times 0.5 and -0.25,
/// plus a faint texture of their own, and its layer (step 0.01, every block of
/// class 0), with or without frequency weights.
fn following_chroma(weights: Option<FrequencyWeights>) -> CodedResidual {
    let (w, h) = (48u32, 40u32);
    let luma: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            0.2 * (x * 0.9 + y * 0.4).sin() + 0.1 * (x * 0.3 - y * 1.3).cos()
        })
        .collect();
    let own = |k: f64| -> Vec<f64> { (0..w * h).map(|i| 0.01 * ((i as f64) * k).sin()).collect() };
    let planes = vec![
        luma.clone(),
        luma.iter()
            .zip(own(0.37))
            .map(|(l, o)| 0.5 * l + o)
            .collect(),
        luma.iter()
            .zip(own(0.71))
            .map(|(l, o)| -0.25 * l + o)
            .collect(),
    ];
    let (detail, payload) = code_layer(
        &planes,
        (w, h),
        &quantisers(0.01),
        &no_classes(w, h),
        None,
        weights,
        None,
    );
    (detail, payload, planes, (w, h))
}

#[test]
fn chroma_that_follows_luma_takes_luma_factors_and_its_payload_reads_back() {
    for weights in [None, Some(FrequencyWeights { tilts: [16, 8] })] {
        let (detail, payload, planes, (w, h)) = following_chroma(weights);
        let classes = no_classes(w, h);
        let (cols, rows) = blocks(w, h);
        // Most blocks fit their factor: 0.5 (4 eighths) for C1, -0.25 (-2) for C2.
        for (pi, want) in [(1, 4), (2, -2)] {
            let hits = (0..cols * rows)
                .filter(|&i| detail.planes[pi].factor(i) == want)
                .count();
            assert!(
                hits * 2 > cols * rows,
                "plane {pi}: {hits} of {} blocks at {want}",
                cols * rows
            );
        }
        assert_eq!(detail.planes[0].factors, Vec::<i8>::new());
        assert_eq!(detail.to_payload(&classes), payload);
        // The reader leaves the header's fields (the weights) to its caller.
        let mut back = Detail::read(&payload, w, h, detail.steps.clone(), &classes, None)
            .unwrap()
            .0;
        back.weights = weights;
        assert_eq!(back, detail);
        // The decoded chroma is the chroma coded, within a step, at every pixel centre.
        let grid = Grid::pixel_centres(&Frame::new(w, h), w, h);
        let layer = DetailEval::new(&detail, &grid).eval();
        for c in 1..3 {
            let worst = (0..(w * h) as usize)
                .map(|i| (layer[c][i] as f64 - planes[c][i]).abs())
                .fold(0.0, f64::max);
            assert!(worst < 0.03, "plane {c}: {worst}");
        }
        assert_grid_equals_scalar(
            &detail,
            (w, h),
            [(w, h), (2 * w, 2 * h), (w / 2 + 3, h / 3)],
        );
    }
}

#[test]
fn a_luma_factor_adds_its_eighths_of_the_luma_coefficients() {
    let mut luma = [0; COEFFS];
    luma[0] = 3;
    luma[1] = -5;
    luma[9] = 2;
    let mut chroma = [0; COEFFS];
    chroma[8] = 7;
    let detail = Detail {
        planes: vec![
            DetailPlane::from_blocks(1, 1, vec![luma]),
            DetailPlane::from_blocks(1, 1, vec![chroma]).with_factors(vec![-12]),
            DetailPlane::from_blocks(1, 1, vec![[0; COEFFS]]).with_factors(vec![3]),
        ],
        steps: vec![0.5, 0.25, 0.25],
        deblock: None,
        lapping: None,
        block_steps: None,
        weights: None,
        field: None,
    };
    let tables = weights::plane_tables(None, 3);
    let c1 = detail.block_coefficients(1, 0, 0, &tables).unwrap();
    let c2 = detail.block_coefficients(2, 0, 0, &tables).unwrap();
    for z in 0..COEFFS {
        let y = luma[z] as f64 * 0.5;
        assert_eq!(c1[z], chroma[z] as f64 * 0.25 - 1.5 * y, "C1 at {z}");
        assert_eq!(c2[z], 0.375 * y, "C2 at {z}");
    }
    // A coded chroma block with no level of its own still carries the luma part.
    assert_grid_equals_scalar(&detail, (8, 8), [(8, 8), (13, 5), (3, 3)]);
    let grid = Grid::pixel_centres(&Frame::new(8, 8), 8, 8);
    let layer = DetailEval::new(&detail, &grid).eval();
    let inverse = dct::inverse(&c2);
    for (i, &v) in inverse.iter().enumerate() {
        assert!((layer[2][i] as f64 - v).abs() < 1e-5, "C2 pixel {i}");
    }
}

#[test]
fn merged_groups_evaluate_on_a_grid_as_the_scalar_reference_does() {
    for class in [0, 1, 2] {
        merged_groups_evaluate_as_the_scalar_reference(class);
    }
}

fn merged_groups_evaluate_as_the_scalar_reference(class: u8) {
    let (mut detail, _, classes, (w, h)) = groups_layer(0.05, class);
    let merged = class.max(1);
    assert!(detail.planes[1..]
        .iter()
        .all(|p| p.merged.contains(&merged)));
    detail.deblock = Some(Deblock {
        strength: 60,
        radius: 3,
    });
    detail.lapping = Some(Lapping::DEFAULT);
    // Under the smallest cells, a chroma group's blocks can have other factors: the
    // group takes its first block's.
    let classes = if class == 0 {
        (0..classes.len()).map(|i| (i * 7 % 3) as u8).collect()
    } else {
        classes
    };
    detail.block_steps = Some(BlockSteps {
        steps: adaptive::AdaptiveSteps {
            factors: [40, 24, 9],
            field_log2: 0,
        },
        classes,
        field: Vec::new(),
    });
    assert_grid_equals_scalar(
        &detail,
        (w, h),
        [(w, h), (2 * w + 3, h + 5), (w / 3, h / 2)],
    );
}

#[test]
fn lapping_joins_the_blocks_at_every_edge_and_leaves_the_series_a_pixel_away() {
    let (mut detail, (_, h)) = deblocked(20, 12);
    detail.deblock = None;
    let plain = detail.clone();
    detail.lapping = Some(Lapping::DEFAULT);
    let mut stepped = 0;
    for c in 0..detail.planes.len() {
        for k in 0..40 {
            let y = k as f64 * h as f64 / 40.0;
            for e in [8.0, 16.0] {
                // Unlike deblocking, every step is joined, however large.
                let (l, r) = (detail.at(e - 1e-7, y)[c], detail.at(e + 1e-7, y)[c]);
                assert!((l - r).abs() < 1e-4, "plane {c} ({e}, {y}): {l} vs {r}");
                stepped +=
                    usize::from((plain.at(e - 1e-7, y)[c] - plain.at(e + 1e-7, y)[c]).abs() > 1e-3);
            }
            // A pixel or more from every edge the layer is the plain series.
            for x in [3.0, 4.5, 12.0, 19.5] {
                if (y - 8.0).abs() >= 1.0 {
                    assert_eq!(detail.at(x, y)[c], plain.at(x, y)[c]);
                }
            }
        }
    }
    assert!(stepped > 0, "the coarse layer steps somewhere");
}

#[test]
fn deblocking_joins_small_steps_and_leaves_the_series_away_from_edges() {
    let (detail, _) = deblocked(255, 16);
    let plain = Detail {
        deblock: None,
        lapping: None,
        block_steps: None,
        ..detail.clone()
    };
    let mut joined = 0;
    for c in 0..detail.planes.len() {
        for y in [0.5, 2.0, 3.5] {
            // Across the edge at x = 8 the deblocked layer is continuous where the
            // step is within the threshold (255% of the step: every step here).
            let (l, r) = (detail.at(8.0 - 1e-7, y)[c], detail.at(8.0 + 1e-7, y)[c]);
            let (pl, pr) = (plain.at(8.0 - 1e-7, y)[c], plain.at(8.0 + 1e-7, y)[c]);
            if (pr - pl).abs() > 1e-3 {
                joined += 1;
                assert!((l - r).abs() < 1e-4, "plane {c} y {y}: {l} vs {r}");
                assert!((l - 0.5 * (pl + pr)).abs() < 1e-4);
            }
            // Four pixels from every edge (and these rows are that far from the
            // edge at y = 8) the layer is the plain series.
            let (a, b) = (detail.at(4.0, y)[c], plain.at(4.0, y)[c]);
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }
    assert!(joined > 0, "the coarse layer steps somewhere");
}
