//! The filters against their definition at every size and in any band of rows, and the
//! pixels' classes against theirs.

use super::classes::classify_sampled;
use super::scaled::{scaled_rows, scaled_rows_reference};
use super::*;
use caoen_base::rng::Lcg;

/// The definition, pixel by pixel.
fn reference(plane: &[f32], (w, h): (usize, usize), c: usize, taps: &[i32]) -> Vec<f32> {
    let get = |x: isize, y: isize| {
        plane[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
    };
    let wt = weights(taps);
    let mut out = vec![0.0; w * h];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let f = get(x, y);
            let mut acc = 0.0f32;
            for (&(dx, dy), &k) in shape(c).iter().zip(&wt) {
                acc += k
                    * (get(x + dx as isize, y + dy as isize)
                        + get(x - dx as isize, y - dy as isize)
                        - 2.0 * f);
            }
            out[y as usize * w + x as usize] = f + acc;
        }
    }
    out
}

fn noise(n: usize, rng: &mut Lcg) -> Vec<f32> {
    (0..n).map(|_| rng.unit_f32()).collect()
}

/// Rows `rows` of `plane` through the luma filter `f`, classified on the plane itself.
fn luma_rows(
    plane: &[f32],
    size: (usize, usize),
    spacing: (f64, f64),
    f: &PlaneFilter,
    rows: std::ops::Range<usize>,
    out: &mut [f32],
) {
    filter_rows(
        plane,
        (plane, None),
        size,
        spacing,
        &LUMA_SHAPE,
        f,
        rows,
        out,
    )
}

/// `n` samples of noise seeded with `seed`, sample `i` scaled by `scale(i)`: areas of
/// different contrast, so that the pixels fall in different classes.
fn scaled_noise(seed: u64, n: usize, scale: impl Fn(usize) -> f32) -> Vec<f32> {
    let mut rng = Lcg::new(seed);
    (0..n).map(|i| rng.unit_f32() * scale(i)).collect()
}

#[test]
fn the_native_filter_is_the_definition_at_every_pixel_and_size() {
    let mut seed = Lcg::new(7);
    for &(w, h) in &[(1, 1), (2, 5), (5, 2), (6, 7), (7, 6), (13, 9), (40, 3)] {
        let plane = noise(w * h, &mut seed);
        for c in [0, 1] {
            let taps: Vec<i32> = (0..shape(c).len())
                .map(|k| (k as i32 * 37 % 61) - 30)
                .collect();
            let f = PlaneFilter::single(taps.clone());
            let run = |rows: std::ops::Range<usize>, out: &mut [f32]| {
                filter_rows(
                    &plane,
                    (&plane, None),
                    (w, h),
                    (1.0, 1.0),
                    shape(c),
                    &f,
                    rows,
                    out,
                )
            };
            let mut out = vec![0.0; w * h];
            run(0..h, &mut out);
            assert_eq!(
                out,
                reference(&plane, (w, h), c, &taps),
                "{w}x{h} plane {c}"
            );
            // A band of rows is the same rows of the whole.
            if h > 2 {
                let mut band = vec![0.0; w];
                run(1..2, &mut band);
                assert_eq!(band, out[w..2 * w]);
            }
        }
    }
}

#[test]
fn scaled_sampling_at_unit_spacing_equals_the_native_filter() {
    let mut seed = Lcg::new(11);
    let (w, h) = (17, 11);
    let plane = noise(w * h, &mut seed);
    let taps: Vec<i32> = (0..12).map(|k| 20 - 3 * k).collect();
    let mut native = vec![0.0; w * h];
    native_rows(
        &plane,
        (w, h),
        &LUMA_SHAPE,
        &weights(&taps),
        0..h,
        &mut native,
    );
    let mut scaled = vec![0.0; w * h];
    let wt = weights(&taps);
    scaled_rows(
        &plane,
        (w, h),
        (1.0, 1.0),
        &LUMA_SHAPE,
        &Weights::every(&wt),
        0..h,
        &mut scaled,
    );
    for (a, b) in native.iter().zip(&scaled) {
        assert!((a - b).abs() < 1e-5, "{a} {b}");
    }
}

#[test]
fn whole_pixel_offsets_read_directly_equal_the_interpolated_samples() {
    let (w, h) = (37, 45);
    let plane = scaled_noise(29, w * h, |i| [0.002, 0.02, 0.1, 0.5][(i / w / 3) % 4]);
    let classified = PlaneFilter {
        filters: vec![
            (0..12).map(|k| 40 - 7 * k).collect(),
            (0..12).map(|k| 3 * k - 9).collect(),
        ],
        classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
    };
    let single = PlaneFilter::single((0..12).map(|k| 25 - 4 * k).collect());
    for spacing in [(0.5, 0.5), (0.25, 0.5), (1.0, 0.5), (1.0 / 3.0, 0.5)] {
        let whole = whole_offsets(&LUMA_SHAPE, (w, h), spacing);
        if spacing.0 != 1.0 / 3.0 {
            assert!(whole.is_some(), "{spacing:?}");
        }
        let steps = whole_pixels((1.0 / spacing.0, 1.0 / spacing.1));
        assert_eq!(
            classify_sampled(&plane, (w, h), spacing, 0..h, steps),
            classify_sampled(&plane, (w, h), spacing, 0..h, None),
            "{spacing:?}"
        );
        // The interpolating path: every pixel's class, then its filter sampled
        // between pixels.
        let classes = classify_sampled(&plane, (w, h), spacing, 0..h, None);
        for f in [&classified, &single] {
            let mut direct = vec![0.0; w * h];
            luma_rows(&plane, (w, h), spacing, f, 0..h, &mut direct);
            let wts: Vec<Vec<f32>> = f.filters.iter().map(|t| weights(t)).collect();
            let pick = |i: usize| match &f.classes {
                None => Some(wts[0].as_slice()),
                Some(map) => match map[classes[i] as usize] {
                    0 => None,
                    m => Some(wts[m as usize - 1].as_slice()),
                },
            };
            let mut lerped = vec![0.0; w * h];
            scaled_rows(
                &plane,
                (w, h),
                spacing,
                &LUMA_SHAPE,
                &Weights::Each(pick),
                0..h,
                &mut lerped,
            );
            assert_eq!(direct, lerped, "{spacing:?}");
        }
    }
}

#[test]
fn a_flat_plane_passes_unchanged_whatever_the_taps() {
    let (w, h) = (9, 8);
    let plane = vec![0.37f32; w * h];
    let r = Restoration {
        planes: vec![
            Some(PlaneFilter::single(vec![MAX_TAP; 12])),
            Some(PlaneFilter {
                filters: vec![vec![-MAX_TAP; 6], vec![MAX_TAP; 6]],
                classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
            }),
            None,
        ],
        colour: None,
        last: None,
    };
    for spacing in [(1.0, 1.0), (0.5, 0.7), (3.0, 2.0)] {
        let mut planes = vec![plane.clone(); 3];
        r.apply(&mut planes, (w, h), spacing);
        for p in &planes {
            assert!(p.iter().all(|&v| (v - 0.37).abs() < 1e-5));
        }
    }
}

#[test]
fn the_colour_map_follows_the_filters_in_bands_as_on_whole_planes() {
    let (w, h) = (23, 19);
    let planes: Vec<Vec<f32>> = (0..3)
        .map(|c| {
            (0..w * h)
                .map(|i| (((i * (7 + c)) % 13) as f32 / 13.0) * 0.8 + 0.1 * c as f32)
                .collect()
        })
        .collect();
    let map = colour_map::ColourMap {
        rows: vec![vec![40, -7, 3, 12], vec![0, -25, 9, -30], vec![5, 0, 60, 0]],
    };
    let r = Restoration {
        planes: vec![
            Some(PlaneFilter::single((0..12).map(|k| 20 - 3 * k).collect())),
            None,
            Some(PlaneFilter::single(vec![9, -4, 6, 1, 0, 2])),
        ],
        colour: Some(map.clone()),
        last: None,
    };
    for spacing in [(1.0, 1.0), (0.5, 0.7)] {
        let mut whole = planes.clone();
        r.apply(&mut whole, (w, h), spacing);
        // The filters alone, then the map by its definition at every pixel.
        let mut filtered = planes.clone();
        Restoration {
            colour: None,
            ..r.clone()
        }
        .apply(&mut filtered, (w, h), spacing);
        let m = map.real();
        for i in 0..w * h {
            for c in 0..3 {
                let want = filtered[c][i] as f64
                    + (0..3).map(|k| m[c][k] * filtered[k][i] as f64).sum::<f64>()
                    + m[c][3];
                assert!(
                    (whole[c][i] as f64 - want).abs() < 1e-5,
                    "pixel {i} plane {c}"
                );
            }
        }
        let src: Vec<&[f32]> = planes.iter().map(Vec::as_slice).collect();
        for rows in [0..5, 5..19] {
            let mut band: Vec<Vec<f32>> = vec![vec![0.0; rows.len() * w]; 3];
            let mut out: Vec<&mut [f32]> = band.iter_mut().map(Vec::as_mut_slice).collect();
            r.apply_rows(&src, (w, h), spacing, rows.clone(), &mut out);
            for c in 0..3 {
                assert_eq!(band[c], whole[c][rows.start * w..rows.end * w]);
            }
        }
    }
}

#[test]
fn the_last_filter_in_windows_is_the_filter_on_the_whole_plane() {
    let (w, h) = (21, 40);
    let plane: Vec<f32> = (0..w * h)
        .map(|i| (((i * 37) % 17) as f32 / 17.0) + 0.02 * (i / w) as f32)
        .collect();
    let r = Restoration {
        planes: vec![None],
        colour: None,
        last: Some(PlaneFilter {
            filters: vec![
                (0..12).map(|k| 30 - 7 * k).collect(),
                (0..12).map(|k| 5 * k - 20).collect(),
            ],
            classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
        }),
    };
    for spacing in [(1.0, 1.0), (0.5, 0.7), (2.0, 2.0), (1.0, 0.3)] {
        let mut whole = plane.clone();
        r.apply_last(&mut whole, (w, h), spacing);
        assert_ne!(whole, plane);
        let reach = Restoration::last_reach(spacing);
        for rows in [0..7usize, 7..19, 19..40, 13..14] {
            let window = rows.start.saturating_sub(reach)..(rows.end + reach).min(h);
            let mut out = vec![0.0f32; rows.len() * w];
            r.apply_last_rows(
                &plane[window.start * w..window.end * w],
                (w, h),
                window.start,
                spacing,
                rows.clone(),
                &mut out,
            );
            assert_eq!(
                out,
                whole[rows.start * w..rows.end * w],
                "rows {rows:?} at {spacing:?}"
            );
        }
    }
}

/// The classes by their definition, pixel by pixel, at the coded size.
fn reference_classes(plane: &[f32], (w, h): (usize, usize)) -> Vec<u8> {
    let get = |x: isize, y: isize| {
        plane[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
    };
    let second = |x: isize, y: isize, dx: isize, dy: isize| {
        (2.0 * get(x, y) - get(x + dx, y + dy) - get(x - dx, y - dy)).abs()
    };
    let mut out = Vec::new();
    for y in 0..h as isize {
        for x in 0..w as isize {
            let mut g = [0.0f32; 4];
            for j in -(WINDOW as isize)..=WINDOW as isize {
                for i in -(WINDOW as isize)..=WINDOW as isize {
                    let (px, py) = (
                        (x + i).clamp(0, w as isize - 1),
                        (y + j).clamp(0, h as isize - 1),
                    );
                    g[0] += second(px, py, 1, 0);
                    g[1] += second(px, py, 0, 1);
                    g[2] += second(px, py, 1, 1);
                    g[3] += second(px, py, -1, 1);
                }
            }
            let [gh, gv, g1, g2] = g;
            let level = ACTIVITY_BOUNDS.iter().filter(|&&b| gh + gv >= b).count();
            // The larger pair's ratio, cross-multiplied so that zeros compare.
            let direction = if gh.max(gv) * g1.min(g2) > g1.max(g2) * gh.min(gv) {
                if gh.max(gv) > 2.0 * gh.min(gv) {
                    if gh > gv {
                        1
                    } else {
                        2
                    }
                } else {
                    0
                }
            } else if g1.max(g2) > 2.0 * g1.min(g2) {
                if g1 > g2 {
                    3
                } else {
                    4
                }
            } else {
                0
            };
            out.push((DIRECTIONS * level + direction) as u8);
        }
    }
    out
}

#[test]
fn pixel_classes_are_their_definition_in_any_band() {
    let mut seed = Lcg::new(23);
    for &(w, h) in &[(1, 1), (3, 2), (9, 7), (31, 40)] {
        // Noise at several amplitudes: every activity level.
        let plane: Vec<f32> = noise(w * h, &mut seed)
            .iter()
            .enumerate()
            .map(|(i, v)| v * [0.001, 0.01, 0.05, 0.3][(i / w) % 4])
            .collect();
        let whole = classify_rows(&plane, (w, h), (1.0, 1.0), 0..h);
        assert_eq!(whole, reference_classes(&plane, (w, h)), "{w}x{h}");
        for start in 0..h {
            let band = classify_rows(&plane, (w, h), (1.0, 1.0), start..(start + 5).min(h));
            assert_eq!(
                band,
                whole[start * w..(start + 5).min(h) * w],
                "{w}x{h} from {start}"
            );
        }
    }
}

#[test]
fn stripes_take_their_direction_and_flat_planes_the_first_class() {
    let (w, h) = (24, 24);
    let at =
        |f: &dyn Fn(usize, usize) -> f32| (0..w * h).map(|i| f(i % w, i / w)).collect::<Vec<f32>>();
    let centre = |p: &[f32]| classify_rows(p, (w, h), (1.0, 1.0), 12..13)[12];
    let flat = at(&|_, _| 0.5);
    assert_eq!(centre(&flat), 0);
    // Columns alternate: the second differences across columns are large.
    let columns = at(&|x, _| (x % 2) as f32 * 0.2);
    assert_eq!(centre(&columns) as usize % DIRECTIONS, 1);
    assert_eq!(centre(&columns) as usize / DIRECTIONS, ACTIVITY_LEVELS - 1);
    let rows = at(&|_, y| (y % 2) as f32 * 0.2);
    assert_eq!(centre(&rows) as usize % DIRECTIONS, 2);
    // Diagonal stripes along the down-left diagonal: across them is down-right.
    let diagonal = at(&|x, y| ((x + y) % 4 / 2) as f32 * 0.1);
    assert_eq!(centre(&diagonal) as usize % DIRECTIONS, 3);
    let anti = at(&|x, y| ((x + h - y) % 4 / 2) as f32 * 0.1);
    assert_eq!(centre(&anti) as usize % DIRECTIONS, 4);
}

#[test]
fn the_classified_filter_is_each_pixels_class_filter_in_any_band() {
    let (w, h) = (37, 45);
    let plane = scaled_noise(31, w * h, |i| [0.002, 0.02, 0.2][(i / 7) % 3]);
    let filters: Vec<Vec<i32>> = (0..3)
        .map(|f| (0..12).map(|k| (k * 13 + f * 29) % 41 - 20).collect())
        .collect();
    let map: [u8; CLASSES] = std::array::from_fn(|k| (k * 7 % 4) as u8);
    let pf = PlaneFilter {
        filters: filters.clone(),
        classes: Some(map),
    };
    let mut out = vec![0.0; w * h];
    luma_rows(&plane, (w, h), (1.0, 1.0), &pf, 0..h, &mut out);
    let classes = reference_classes(&plane, (w, h));
    let each: Vec<Vec<f32>> = filters
        .iter()
        .map(|t| reference(&plane, (w, h), 0, t))
        .collect();
    for i in 0..w * h {
        let want = match map[classes[i] as usize] {
            0 => plane[i],
            m => each[m as usize - 1][i],
        };
        assert!(
            (out[i] - want).abs() < 1e-6,
            "pixel {i}: {} vs {want}",
            out[i]
        );
    }
    // Bands of any height give the same rows, at the coded size and scaled.
    for spacing in [(1.0, 1.0), (0.5, 0.75), (2.0, 1.5)] {
        let mut whole = vec![0.0; w * h];
        luma_rows(&plane, (w, h), spacing, &pf, 0..h, &mut whole);
        for start in (0..h).step_by(11) {
            let end = (start + 11).min(h);
            let mut band = vec![0.0; (end - start) * w];
            luma_rows(&plane, (w, h), spacing, &pf, start..end, &mut band);
            assert_eq!(band, whole[start * w..end * w], "{spacing:?} from {start}");
        }
    }
}

#[test]
fn the_row_wise_scaled_filter_equals_the_pixel_wise_reference_bit_for_bit() {
    let mut seed = Lcg::new(5);
    let twelve: Vec<f32> = weights(&(0..12).map(|k| 31 - 5 * k).collect::<Vec<_>>());
    let other: Vec<f32> = weights(&(0..12).map(|k| 4 * k - 17).collect::<Vec<_>>());
    let six: Vec<f32> = weights(&(0..6).map(|k| 9 - 2 * k).collect::<Vec<_>>());
    // (23, 70) at spacing 0.1 reaches 30 rows up and down: more than the kept rows.
    for (w, h) in [(1, 1), (2, 3), (7, 5), (33, 19), (64, 9), (23, 70)] {
        let plane = noise(w * h, &mut seed);
        for spacing in [
            (0.1, 0.1),
            (0.7, 0.7),
            (0.8, 0.55),
            (1.0 / 0.7, 1.3),
            (2.5, 0.25),
            (1.0, 1.0),
        ] {
            for (shape, class_weights) in [
                (
                    &LUMA_SHAPE[..],
                    vec![Some(twelve.as_slice()), None, Some(other.as_slice())],
                ),
                (&CHROMA_SHAPE[..], vec![Some(six.as_slice()), None]),
            ] {
                let pick = |i: usize| class_weights[(i * 7 + i / 3) % class_weights.len()];
                let first = class_weights[0].expect("weights");
                // Each pixel's weights, and one filter for every pixel.
                for (rows, every) in [(0..h, false), (h / 2..h, false), (0..h, true)] {
                    let n = rows.len() * w;
                    let (mut fast, mut reference) = (vec![0.0; n], vec![0.0; n]);
                    let pick = |i: usize| if every { Some(first) } else { pick(i) };
                    if every {
                        let weights = Weights::every(first);
                        scaled_rows(
                            &plane,
                            (w, h),
                            spacing,
                            shape,
                            &weights,
                            rows.clone(),
                            &mut fast,
                        );
                    } else {
                        let weights = Weights::Each(pick);
                        scaled_rows(
                            &plane,
                            (w, h),
                            spacing,
                            shape,
                            &weights,
                            rows.clone(),
                            &mut fast,
                        );
                    }
                    scaled_rows_reference(
                        &plane,
                        (w, h),
                        spacing,
                        shape,
                        &pick,
                        rows.clone(),
                        &mut reference,
                    );
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&fast),
                        bits(&reference),
                        "{w}x{h} {spacing:?} {rows:?}"
                    );
                }
            }
        }
    }
}
