//! The encoder's input: any image it can read a tile at a time.
//!
//! The encoder converts one tile's pixels to coding planes when it works on that tile,
//! so the whole image never exists as double-precision planes: its memory is the input
//! as the caller holds it (a [`Raster`], or a decoded 8/16-bit image, see
//! `image_io::EncodeSource`) plus one tile's working set per worker.

use super::tiling::TileRect;
use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};

/// Pixels the encoder reads a rectangle at a time.
pub trait PixelSource: Sync {
    /// Width in pixels.
    fn width(&self) -> u32;
    /// Height in pixels.
    fn height(&self) -> u32;
    /// Channel layout.
    fn layout(&self) -> ChannelLayout;
    /// Source sample format.
    fn format(&self) -> SampleFormat;
    /// The pixels of `rect` (inside the image) as a raster of the same layout and
    /// format, with the samples a [`Raster`] of the whole image would hold there.
    fn region(&self, rect: TileRect) -> Raster;
    /// Bytes the source itself holds (its share of a memory budget is already spent).
    fn held_bytes(&self) -> u64;
}

impl PixelSource for Raster {
    fn width(&self) -> u32 {
        Raster::width(self)
    }

    fn height(&self) -> u32 {
        Raster::height(self)
    }

    fn layout(&self) -> ChannelLayout {
        Raster::layout(self)
    }

    fn format(&self) -> SampleFormat {
        Raster::format(self)
    }

    fn region(&self, r: TileRect) -> Raster {
        let (w, x0, x1) = (
            Raster::width(self) as usize,
            r.x0 as usize,
            (r.x0 + r.width) as usize,
        );
        let mut samples =
            Vec::with_capacity(r.width as usize * r.height as usize * self.layout().channels());
        for c in 0..self.layout().channels() {
            let plane = self.plane(c);
            for y in r.y0 as usize..(r.y0 + r.height) as usize {
                samples.extend_from_slice(&plane[y * w + x0..y * w + x1]);
            }
        }
        Raster::from_finite(r.width, r.height, self.layout(), self.format(), samples)
            .expect("a rectangle inside the raster")
    }

    fn held_bytes(&self) -> u64 {
        4 * self.samples().len() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_region_holds_the_rasters_own_samples() {
        let (w, h) = (7u32, 5u32);
        let samples: Vec<f32> = (0..w * h * 3).map(|i| i as f32).collect();
        let r = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::F32, samples).unwrap();
        let t = r.region(TileRect {
            x0: 2,
            y0: 1,
            width: 4,
            height: 3,
        });
        assert_eq!((t.width(), t.height()), (4, 3));
        for c in 0..3 {
            for y in 0..3 {
                for x in 0..4 {
                    let want = r.plane(c)[(y + 1) * 7 + x + 2];
                    assert_eq!(t.plane(c)[y * 4 + x], want);
                }
            }
        }
    }
}
