//! The stored steps' rounding and the header's fields read back as written.

use super::*;
use crate::deringing::Strengths;
use crate::CodecError;

#[test]
fn steps_round_to_the_nearest_stored_value_and_keep_their_range() {
    let mut s = 1e-7f64;
    while s <= 1e4 {
        let r = stored_step(s);
        // Seven bits of mantissa: within half a unit, 2^-8 of the value.
        assert!((r - s).abs() <= s * (1.0 / 256.0) * 1.0000001, "{s} -> {r}");
        assert!((1e-7..=1e4).contains(&r), "{s} -> {r}");
        assert_eq!(stored_step(r), r, "stored steps are fixed points");
        assert_eq!(f64::from(step_from_bits(step_bits(r as f32))), r);
        s *= 1.0137;
    }
    assert_eq!(stored_step(0.5), 0.5);
    assert_eq!(stored_step(1.0 + 1.0 / 128.0), 1.0 + 1.0 / 128.0);
    assert_eq!(stored_step(1.0 + 1.0 / 512.0), 1.0);
}

/// A 300x20 RGB header with a detail layer, deringing and a display size.
fn rgb_header() -> Header {
    Header {
        width: 300,
        height: 20,
        layout: ChannelLayout::Rgb,
        format: SampleFormat::U8,
        block_log2: 5,
        min_log2: 3,
        kernel: KernelParams {
            sigma_factor: 0.5,
            weight_exponent: 1.0,
        },
        chroma_pruned: true,
        step_luma: 0.25,
        step_chroma: 0.375,
        step_alpha: ABSENT_STEP,
        luma_count: 100,
        chroma_count: 40,
        tile_side: 384,
        detail_steps: Some([0.5, 0.625]),
        deblock: None,
        adaptive: None,
        lapping: None,
        basis: ColourBasis::Luma,
        level_steps: true,
        weights: None,
        restoration: None,
        deringing: Some(Deringing {
            luma: Strengths {
                primary: 96,
                secondary: 16,
                cutoff: 80,
            },
            chroma: Strengths::OFF,
        }),
        display: Some((600, 40)),
    }
}

#[test]
fn headers_read_back_with_only_the_steps_their_channels_use() {
    let base = rgb_header();
    let grey = Header {
        layout: ChannelLayout::GreyAlpha,
        step_chroma: ABSENT_STEP,
        step_alpha: 2.0,
        chroma_count: 0,
        basis: ColourBasis::Grey,
        display: None,
        ..base.clone()
    };
    let plain = Header {
        deringing: None,
        ..base.clone()
    };
    for h in [base.clone(), grey, plain] {
        let b = h.to_bytes();
        // Width 300 takes two bytes, the height one; the steps present two each.
        let steps =
            2 * (1 + h.layout.colour_channels() / 3 + usize::from(h.layout.has_alpha()) + 2);
        let display = if h.display.is_some() { 3 } else { 0 };
        let deringing = h
            .deringing
            .map_or(0, |_| 3 * (1 + h.layout.colour_channels() / 3));
        assert_eq!(
            b.len(),
            3 + 1 + 1 + 2 + 1 + 1 + steps + 2 + 1 + deringing + display,
            "{h:?}"
        );
        assert_eq!(Header::parse(&b, 0, u64::MAX).unwrap(), h);
        // One byte more than the fields call for.
        let e = Header::parse(&[&b[..], &[0]].concat(), 0, u64::MAX).unwrap_err();
        assert!(
            matches!(e, CodecError::HeaderLength { found, expected } if found == expected + 1),
            "{e}"
        );
    }
}

#[test]
fn deringing_strengths_that_make_no_filter_are_refused() {
    let base = Header {
        width: 64,
        height: 64,
        luma_count: 16,
        chroma_count: 4,
        tile_side: 128,
        detail_steps: None,
        deringing: None,
        display: None,
        ..rgb_header()
    };
    let on = Strengths {
        primary: 32,
        secondary: 8,
        cutoff: 128,
    };
    let ok = Header {
        deringing: Some(Deringing {
            luma: on,
            chroma: on,
        }),
        ..base.clone()
    };
    assert_eq!(Header::parse(&ok.to_bytes(), 0, u64::MAX).unwrap(), ok);
    for (luma, chroma) in [
        // A strength without a cutoff.
        (Strengths { cutoff: 0, ..on }, on),
        // A cutoff without a strength.
        (
            on,
            Strengths {
                cutoff: 9,
                ..Strengths::OFF
            },
        ),
        // Nothing filtered at all.
        (Strengths::OFF, Strengths::OFF),
    ] {
        let h = Header {
            deringing: Some(Deringing { luma, chroma }),
            ..base.clone()
        };
        let e = Header::parse(&h.to_bytes(), 0, u64::MAX).unwrap_err();
        assert!(matches!(e, CodecError::Deringing { .. }), "{e}");
    }
    // The channel byte's last bit stays reserved.
    let mut b = base.to_bytes();
    b[2] |= 128;
    let e = Header::parse(&b, 0, u64::MAX).unwrap_err();
    assert!(e.to_string().contains("reserved bit"), "{e}");
}
