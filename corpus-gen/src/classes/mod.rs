//! The image classes. Each class module exposes `render(w, h, seed)`.
//!
//! Conventions: all random choices come from a [`Rng`] seeded with
//! `derive(seed, class tag)`, drawn in a fixed order before any pixel is
//! computed; per-pixel randomness comes from stateless hashes of the pixel
//! coordinates. Pixel passes run in parallel over rows (see `canvas`).

use crate::image::{CorpusImage, SampleFormat};
use crate::rng::{derive, Rng};
use crate::Class;

mod edge;
mod flat;
mod hdr;
mod natural;
mod scene;
mod smooth;
mod text;
mod texture;

pub(crate) fn render(class: Class, w: usize, h: usize, seed: u64) -> CorpusImage {
    match class {
        Class::Smooth => smooth::render(w, h, seed),
        Class::FlatEdges => flat::render(w, h, seed),
        Class::Texture => texture::render(w, h, seed),
        Class::Natural => natural::render(w, h, seed),
        Class::Scene => scene::render(w, h, seed),
        Class::Hdr => hdr::render(w, h, seed),
        Class::EdgeCases => edge::render(w, h, seed),
    }
}

/// `seed / variant_count` odd selects the 16-bit version for classes that have one.
fn deep(class: Class, seed: u64) -> bool {
    (seed / class.variant_count()) % 2 == 1
}

pub(crate) fn format(class: Class, seed: u64) -> (u8, SampleFormat) {
    use SampleFormat::*;
    let v = seed % class.variant_count();
    match class {
        Class::Smooth | Class::Natural => (3, if deep(class, seed) { U16 } else { U8 }),
        Class::FlatEdges => (if v == 2 { 1 } else { 3 }, U8),
        Class::Texture => match v {
            0 => (1, if deep(class, seed) { U16 } else { U8 }),
            2 => (1, U8),
            _ => (3, U8),
        },
        Class::Scene => (3, U8),
        Class::Hdr => (3, F32),
        Class::EdgeCases => match v {
            0 | 1 => (3, U8),
            2 => (1, U8),
            3 => (4, U8),
            4 => (1, U16),
            5 => (2, U8),
            6 => (1, U16),
            _ => (4, U16),
        },
    }
}

pub(crate) fn variant_name(class: Class, seed: u64) -> &'static str {
    let v = seed % class.variant_count();
    match class {
        Class::Smooth => [
            "linear gradient",
            "radial gradients",
            "gaussian blobs",
            "low-frequency waves",
        ][v as usize],
        Class::FlatEdges => [
            "geometric shapes",
            "curves and thin lines",
            "text page (gray)",
            "user interface",
        ][v as usize],
        Class::Texture => [
            "zone plate (gray)",
            "stripes",
            "checkerboards (gray)",
            "bricks, dots, plaid, hexagons",
        ][v as usize],
        Class::Natural => ["shaded terrain", "clouds", "marble", "wood planks"][v as usize],
        Class::Scene => [
            "countryside",
            "mountain lake at sunset",
            "still life",
            "coast with lighthouse",
        ][v as usize],
        Class::Hdr => [
            "sunlit landscape",
            "interior with window and lamp",
            "night street",
        ][v as usize],
        Class::EdgeCases => [
            "flat RGB",
            "pure noise RGB",
            "gray gradient with shapes",
            "RGBA shapes on transparent",
            "16-bit gray noise",
            "gray + alpha",
            "flat 16-bit gray",
            "16-bit RGBA gradient",
        ][v as usize],
    }
}

/// The parameter generator of a class image.
fn rng_for(class: Class, seed: u64) -> Rng {
    Rng::new(derive(seed, class as u64 + 1))
}

/// A seed for stateless noise fields of a class image.
fn noise_seed(class: Class, seed: u64, k: u64) -> u64 {
    derive(derive(seed, class as u64 + 1), 1000 + k)
}
