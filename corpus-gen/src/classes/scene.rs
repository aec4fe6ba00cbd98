//! Scene class (placeholder, replaced below).
use super::{format, rng_for};
use crate::canvas::{Canvas, Encoding};
use crate::image::CorpusImage;
use crate::math::Col;
use crate::Class;

pub(super) fn render(w: usize, h: usize, seed: u64) -> CorpusImage {
    let _ = rng_for(Class::Scene, seed);
    let c = Canvas::new(w, h, Col::gray(0.3));
    let (ch, fmt) = format(Class::Scene, seed);
    c.to_image(ch, fmt.bit_depth(), Encoding::Srgb)
}
