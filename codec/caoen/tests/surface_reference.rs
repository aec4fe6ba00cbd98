//! Golden values from the math: the paper's six-point reference family (figures 2, 3).

use caoen::surface::gallery::six_point;
use caoen::surface::Blend;

const S: f64 = 0.577_350_269_189_625_8; // 1/sqrt(3)

fn diagonal_radius(blend: Blend, q: f64, normalised: bool) -> f64 {
    let model = six_point(blend, q, normalised).unwrap();
    let y = model.network.eval(&[S, S, S]).unwrap();
    // By symmetry the image of the diagonal stays on the diagonal.
    assert!(
        (y[0] - y[1]).abs() < 1e-15 && (y[1] - y[2]).abs() < 1e-15,
        "{y:?}"
    );
    (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt()
}

#[test]
fn power_blend_diagonal_radius_is_3_to_the_half_of_1_minus_q() {
    // Three positive axes see s = 1/sqrt(3), the negative ones s < 0 (weight 0):
    // y = s^q (1,1,1), so |y| = sqrt(3) s^q = 3^((1-q)/2).
    for q in 1..=6 {
        let q = q as f64;
        let want = 3f64.powf((1.0 - q) / 2.0);
        let got = diagonal_radius(Blend::Power, q, false);
        assert!((got - want).abs() < 1e-14, "q={q}: {got} vs {want}");
    }
}

#[test]
fn exponential_blend_diagonal_radius_golden() {
    // y = (e^{q(s-1)} - e^{q(-s-1)}) (1,1,1).
    for q in 1..=6 {
        let q = q as f64;
        let want = 3f64.sqrt() * ((q * (S - 1.0)).exp() - (q * (-S - 1.0)).exp());
        let got = diagonal_radius(Blend::Exponential, q, false);
        assert!((got - want).abs() < 1e-14, "q={q}: {got} vs {want}");
    }
    // Figure 2: the diagonal pulls in as q grows, from round (q = 1) to pointed (q = 6).
    let radii: Vec<f64> = (1..=6)
        .map(|q| diagonal_radius(Blend::Exponential, q as f64, false))
        .collect();
    assert!(radii.windows(2).all(|w| w[1] < w[0]), "{radii:?}");
}

#[test]
fn normalised_exponential_tends_to_the_octahedron() {
    // Normalised: y = tanh(q s) (1,1,1) / 3; the face x+y+z = 1 is at radius 1/sqrt(3).
    let mut last = f64::INFINITY;
    for q in 1..=6 {
        let q = q as f64;
        let r = diagonal_radius(Blend::Exponential, q, true);
        let want = 3f64.sqrt() / 3.0 * (q * S).tanh();
        assert!((r - want).abs() < 1e-14, "q={q}: {r} vs {want}");
        let gap = S - r;
        assert!(
            gap > 0.0 && gap < last,
            "distance to the face must shrink: q={q} gap={gap} last={last}"
        );
        last = gap;
    }
    assert!(last < 0.02, "q = 6 is within 2% of the face, gap {last}");
    // And the axis points stay fixed as vertices.
    let model = six_point(Blend::Exponential, 6.0, true).unwrap();
    let y = model.network.eval(&[1.0, 0.0, 0.0]).unwrap();
    let want = ((6.0f64).exp() - (-6.0f64).exp()) / ((6.0f64).exp() + (-6.0f64).exp() + 4.0);
    assert!((y[0] - want).abs() < 1e-14 && y[1].abs() < 1e-15 && y[2].abs() < 1e-15);
}

#[test]
fn normalised_power_lies_exactly_on_the_face_along_the_diagonal() {
    for q in 1..=6 {
        let r = diagonal_radius(Blend::Power, q as f64, true);
        assert!((r - S).abs() < 1e-15, "q={q}: {r}");
    }
}

#[test]
fn compact_blend_is_local() {
    // q = 12: support s > 0.75; the diagonal (s = 0.577) sees no key point at all.
    let model = six_point(Blend::Compact, 12.0, false).unwrap();
    let (y, coverage) = model.network.eval_with_coverage(&[S, S, S]).unwrap();
    assert_eq!((y, coverage), (vec![0.0; 3], 0.0));
    let y = model.network.eval(&[0.0, 0.0, 1.0]).unwrap();
    assert_eq!(y, vec![0.0, 0.0, 1.0]);
}
