//! Bjontegaard deltas against hand-computed cases and SciPy reference values.

use caoen_cli::bench::bd_rate::{bd_quality, bd_rate, quality_at_rate, rd_points, Pchip, RdPoint};

const RATES: [f64; 5] = [0.11, 0.27, 0.52, 0.95, 1.6];
const PSNR: [f64; 5] = [26.3, 29.1, 31.6, 34.0, 36.2];

#[test]
fn constant_rate_ratio_gives_exactly_that_bd_rate() {
    // Test needs k times the reference's bits at every quality: ln-rate curves differ
    // by ln k everywhere, PCHIP commutes with the shift, so BD-rate = k - 1 exactly.
    let reference = rd_points(&RATES, &PSNR);
    for k in [0.5, 0.8, 1.0, 1.25, 3.0] {
        let scaled: Vec<f64> = RATES.iter().map(|r| r * k).collect();
        let got = bd_rate(&reference, &rd_points(&scaled, &PSNR)).unwrap();
        assert!((got - (k - 1.0) * 100.0).abs() < 1e-9, "k={k}: {got}");
    }
}

#[test]
fn constant_quality_offset_gives_exactly_that_bd_psnr() {
    let reference = rd_points(&RATES, &PSNR);
    for delta in [-1.5, 0.0, 0.25, 2.0] {
        let shifted: Vec<f64> = PSNR.iter().map(|p| p + delta).collect();
        let got = bd_quality(&reference, &rd_points(&RATES, &shifted)).unwrap();
        assert!((got - delta).abs() < 1e-12, "delta={delta}: {got}");
    }
}

#[test]
fn two_point_curves_by_hand() {
    // Two points interpolate linearly. Reference: rate 1 -> 30 dB, 4 -> 40 dB; test:
    // 2 -> 30 dB, 4 -> 40 dB. ln-rate gap: ln 2 at 30 dB falling linearly to 0 at 40 dB,
    // average ln 2 / 2, so BD-rate = exp(ln 2 / 2) - 1 = sqrt(2) - 1.
    let a = rd_points(&[1.0, 4.0], &[30.0, 40.0]);
    let b = rd_points(&[2.0, 4.0], &[30.0, 40.0]);
    let got = bd_rate(&a, &b).unwrap();
    assert!((got - (2f64.sqrt() - 1.0) * 100.0).abs() < 1e-10, "{got}");
    // BD-PSNR over the common ln-rate range [ln 2, ln 4]: the reference is
    // 30 + 10 x / ln 4 in x = ln r, the test 30 + 10 (x - ln 2) / ln 2. Averages over
    // [ln 2, ln 4]: reference 30 + 10 (1.5 ln 2) / (2 ln 2) = 37.5, test 35.
    let got = bd_quality(&a, &b).unwrap();
    assert!((got - (35.0 - 37.5)).abs() < 1e-10, "{got}");
}

#[test]
fn matches_scipy_pchip() {
    // Reference values from SciPy 1.x: PchipInterpolator in ln(rate) (BD-rate: of
    // ln-rate over PSNR) and its exact `integrate`, over the curves' overlap.
    let r1 = rd_points(
        &[9487.76, 4593.60, 2258.43, 1083.84],
        &[40.037, 38.615, 36.845, 34.851],
    );
    let r2 = rd_points(
        &[9787.80, 4469.00, 2451.20, 1147.20],
        &[40.121, 38.651, 36.826, 34.698],
    );
    assert!((bd_rate(&r1, &r2).unwrap() - 3.939_708_562_543_642_3).abs() < 1e-9);
    assert!((bd_quality(&r1, &r2).unwrap() - -0.088_019_123_924_251_26).abs() < 1e-11);
    let r3 = rd_points(
        &[0.12, 0.3, 0.55, 1.4, 2.0],
        &[24.0, 28.5, 31.0, 35.5, 36.2],
    );
    let r4 = rd_points(&[0.1, 0.2, 0.6, 1.0, 1.8], &[25.0, 27.9, 32.4, 34.0, 36.9]);
    assert!((bd_rate(&r3, &r4).unwrap() - -17.566_575_152_409_513).abs() < 1e-9);
    assert!((bd_quality(&r3, &r4).unwrap() - 0.843_208_959_076_570_6).abs() < 1e-11);

    let p = Pchip::new(&[0.0, 1.0, 2.5, 3.0, 5.0], &[1.0, 2.0, 2.2, 4.0, 4.1]).unwrap();
    assert!((p.eval(0.7) - 1.832_393_719_008_264_6).abs() < 1e-12);
    assert!((p.eval(2.9) - 3.809_830_870_939_925_3).abs() < 1e-12);
    assert!((p.eval(4.4) - 4.093_828_571_428_570_5).abs() < 1e-12);
    assert!((p.integral(0.3, 4.6) - 12.425_631_884_034_89).abs() < 1e-11);
}

#[test]
fn dominated_points_and_ties_are_ignored() {
    // A point with more bits and less quality than its neighbour is not on the
    // frontier; adding it changes nothing.
    let a = rd_points(&RATES, &PSNR);
    let mut b = a.clone();
    b.push(RdPoint {
        rate: 0.6,
        quality: 30.0,
    });
    assert!(bd_rate(&a, &b).unwrap().abs() < 1e-12);
}

#[test]
fn interpolated_quality_at_rates() {
    let a = rd_points(&RATES, &PSNR);
    for (r, p) in RATES.iter().zip(PSNR) {
        assert!((quality_at_rate(&a, *r).unwrap() - p).abs() < 1e-9);
    }
    assert!(quality_at_rate(&a, 0.1).is_none(), "no extrapolation below");
    assert!(quality_at_rate(&a, 2.0).is_none(), "no extrapolation above");
    let mid = quality_at_rate(&a, 0.4).unwrap();
    assert!(mid > 29.1 && mid < 31.6);
}
