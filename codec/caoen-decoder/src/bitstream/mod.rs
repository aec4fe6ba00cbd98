//! The container: magic, version, then CRC-checked sections (see `docs/format.md`).

mod parse;
#[cfg(test)]
mod tests;
mod write;

pub use parse::parse;
pub use write::{metadata_bytes, push_section, write};

use super::colour::ColourBasis;
use super::deringing::Deringing;
use super::detail::adaptive::AdaptiveSteps;
use super::detail::deblock::Deblock;
use super::detail::lapping::Lapping;
use super::detail::weights::FrequencyWeights;
use super::keyset::KernelParams;
use super::quadtree::TreeShape;
use super::restoration::Restoration;
use super::syntax::LevelSteps;
use super::tiling::{TileRect, Tiling};
use caoen_base::metadata::Metadata;
use caoen_base::raster::{ChannelLayout, SampleFormat};

/// File signature.
pub const MAGIC: [u8; 4] = *b"CAOE";
/// Format version this code writes and reads.
pub const VERSION: u8 = 21;

/// Section tags, in the order they must appear.
pub mod tag {
    /// Header.
    pub const HEADER: u8 = b'H';
    /// ICC colour profile (optional).
    pub const ICC: u8 = b'I';
    /// EXIF (optional).
    pub const EXIF: u8 = b'X';
    /// XMP (optional).
    pub const XMP: u8 = b'M';
    /// One tile: its tree, key-point values and detail blocks, in raster order of tiles.
    pub const TILE: u8 = b'G';
    /// The restoration filters (optional).
    pub const RESTORATION: u8 = b'R';
    /// End of file.
    pub const END: u8 = b'E';
}

/// The step the header stores for a channel the image lacks (grey images' chroma,
/// opaque images' alpha): none is written, and parsing gives this.
pub const ABSENT_STEP: f32 = 1.0;

/// A quantiser step as the header stores it: the upper 16 bits of its `f32`
/// (sign, exponent and 7 bits of mantissa), rounded to nearest.
fn step_bits(step: f32) -> u16 {
    (step.to_bits().saturating_add(0x8000) >> 16) as u16
}

/// The step that 16 stored bits stand for.
fn step_from_bits(bits: u16) -> f32 {
    f32::from_bits(u32::from(bits) << 16)
}

/// `step` rounded to what the header can store: the encoder quantises with exactly
/// the step the decoder will read.
pub fn stored_step(step: f64) -> f64 {
    f64::from(step_from_bits(step_bits(step as f32)))
}

/// Everything the header records, and the restoration filters of their own section.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Channel layout.
    pub layout: ChannelLayout,
    /// Source sample format (decides the output format and the HDR curve).
    pub format: SampleFormat,
    /// Root block side, log2.
    pub block_log2: u8,
    /// Smallest cell side, log2.
    pub min_log2: u8,
    /// Kernel parameters (stored quantised: sigma in 1/1024, exponent in 1/16).
    pub kernel: KernelParams,
    /// Whether chroma uses the luma tree pruned one level.
    pub chroma_pruned: bool,
    /// Quantiser step of the luma-set colour channel.
    pub step_luma: f32,
    /// Quantiser step of the chroma channels.
    pub step_chroma: f32,
    /// Quantiser step of alpha.
    pub step_alpha: f32,
    /// Number of luma key points (all tiles).
    pub luma_count: u32,
    /// Number of chroma key points (all tiles).
    pub chroma_count: u32,
    /// Tile side in pixels (a multiple of [`SIDE_UNIT`](super::tiling::SIDE_UNIT)).
    pub tile_side: u32,
    /// Quantiser steps of the detail layer's luma (or grey) and chroma coefficients,
    /// if the file has the layer (flag bit 1; a file whose layer would be all zero
    /// leaves it out).
    pub detail_steps: Option<[f32; 2]>,
    /// Deblocking of the detail layer (flag bit 2, only with the layer).
    pub deblock: Option<Deblock>,
    /// Step factors of the detail layer by network cell size (flag bit 3, only with
    /// the layer).
    pub adaptive: Option<AdaptiveSteps>,
    /// Lapping of the detail layer (flag bit 4, only with the layer).
    pub lapping: Option<Lapping>,
    /// How the colour channels are coded (flag bit 5: the luma basis, only with three
    /// colour channels).
    pub basis: ColourBasis,
    /// Whether the key points' steps double per cell level below the roots (flag bit
    /// 6; the steps above are then the roots').
    pub level_steps: bool,
    /// The detail layer's steps' tilt with frequency (flag bit 7, only with the layer).
    pub weights: Option<FrequencyWeights>,
    /// The restoration filters (the restoration section, after the tiles).
    pub restoration: Option<Restoration>,
    /// The deringing after the restoration (the channel byte's bit 6).
    pub deringing: Option<Deringing>,
    /// The image's own size when it was coded at a smaller one (`width x height`),
    /// which the decoder then outputs by default: the last 8 bytes of the header.
    pub display: Option<(u32, u32)>,
}

/// Bit of the header's channel byte: the display size ends the header.
const KIND_DISPLAY: u8 = 32;
/// Bit of the header's channel byte: the deringing strengths precede the display size.
const KIND_DERINGING: u8 = 64;
/// Flag bit: chroma on the pruned tree.
const FLAG_PRUNED: u8 = 1;
/// Flag bit: the detail layer is present.
const FLAG_DETAIL: u8 = 2;
/// Flag bit: the detail layer is deblocked (only with [`FLAG_DETAIL`]).
const FLAG_DEBLOCK: u8 = 4;
/// Flag bit: the detail layer's steps adapt to the network's cells (only with
/// [`FLAG_DETAIL`]).
const FLAG_ADAPTIVE: u8 = 8;
/// Flag bit: the detail layer is lapped (only with [`FLAG_DETAIL`]).
const FLAG_LAPPED: u8 = 16;
/// Flag bit: the colour channels are coded in the luma basis (only with three).
const FLAG_LUMA_BASIS: u8 = 32;
/// Flag bit: the key points' steps double per cell level below the roots.
const FLAG_LEVEL_STEPS: u8 = 64;
/// Flag bit: the detail layer's steps grow with frequency (only with [`FLAG_DETAIL`]).
const FLAG_WEIGHTED: u8 = 128;
impl Header {
    /// The size the decoder outputs by default: the image's own size.
    pub fn display_size(&self) -> (u32, u32) {
        self.display.unwrap_or((self.width, self.height))
    }

    /// Whether the decoded planes are filtered after their evaluation (restoration or
    /// deringing): both reach across rows, so the decoder evaluates whole planes first.
    pub fn post_filtered(&self) -> bool {
        self.restoration.as_ref().is_some_and(|r| r.any())
            || self.deringing.is_some_and(|d| d.any())
    }

    /// The steps the deringing strengths are stored in units of, luma's and chroma's:
    /// the detail layer's, else the key points'.
    pub fn deringing_steps(&self) -> [f32; 2] {
        self.detail_steps
            .unwrap_or([self.step_luma, self.step_chroma])
    }

    /// How the key points' steps follow their cell sizes.
    pub fn level_steps(&self) -> LevelSteps {
        LevelSteps {
            root_log2: self.block_log2,
            on: self.level_steps,
        }
    }

    /// The tree geometry.
    pub fn shape(&self) -> TreeShape {
        TreeShape {
            width: self.width,
            height: self.height,
            block_log2: self.block_log2,
            min_log2: self.min_log2,
        }
    }

    /// Rounds the kernel parameters to what the header can store.
    pub fn quantise_kernel(k: KernelParams) -> KernelParams {
        KernelParams {
            sigma_factor: (k.sigma_factor * 1024.0).round().clamp(0.0, 65535.0) / 1024.0,
            weight_exponent: (k.weight_exponent * 16.0).round().clamp(0.0, 255.0) / 16.0,
        }
    }

    /// The detail layer's step for each colour plane (Y, or Y, C1, C2), if the file has
    /// the layer.
    pub fn detail_plane_steps(&self) -> Option<Vec<f64>> {
        let [luma, chroma] = self.detail_steps?;
        let mut steps = vec![f64::from(luma)];
        if self.layout.colour_channels() == 3 {
            steps.extend([f64::from(chroma); 2]);
        }
        Some(steps)
    }

    /// The tiles of the image.
    pub fn tiling(&self) -> Tiling {
        Tiling {
            width: self.width,
            height: self.height,
            side: self.tile_side,
        }
    }
}

/// One tile's coded streams, as the encoder produces them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TileStreams {
    /// Luma key points in the tile.
    pub luma_count: u32,
    /// Chroma key points in the tile.
    pub chroma_count: u32,
    /// Split flags.
    pub tree: Vec<u8>,
    /// Luma-set values.
    pub luma: Vec<u8>,
    /// Chroma values (empty for grey images).
    pub chroma: Vec<u8>,
    /// Detail blocks (empty when the tile has no coded block).
    pub detail: Vec<u8>,
}

/// One tile's streams as found in a file.
#[derive(Debug, Clone, Copy)]
pub struct TilePayload<'a> {
    /// Where the tile lies in the image.
    pub rect: TileRect,
    /// Luma key points in the tile.
    pub luma_count: u32,
    /// Chroma key points in the tile.
    pub chroma_count: u32,
    /// Split flags.
    pub tree: &'a [u8],
    /// Luma-set values.
    pub luma: &'a [u8],
    /// Chroma values.
    pub chroma: &'a [u8],
    /// Detail blocks (empty: none coded in this tile).
    pub detail: &'a [u8],
}

impl<'a> TilePayload<'a> {
    /// The tile's streams, owned: what [`write()`] takes to write the tile again.
    pub fn to_streams(&self) -> TileStreams {
        TileStreams {
            luma_count: self.luma_count,
            chroma_count: self.chroma_count,
            tree: self.tree.to_vec(),
            luma: self.luma.to_vec(),
            chroma: self.chroma.to_vec(),
            detail: self.detail.to_vec(),
        }
    }
}

/// One section as found in a file.
#[derive(Debug, Clone, Copy)]
pub struct Section<'a> {
    /// Tag byte.
    pub tag: u8,
    /// Offset of the tag in the file.
    pub offset: usize,
    /// Offset of the payload in the file.
    pub payload_offset: usize,
    /// Payload.
    pub payload: &'a [u8],
}

impl Section<'_> {
    /// Bytes the section takes in the file: tag, length, payload and CRC.
    pub fn file_bytes(&self) -> usize {
        self.payload_offset - self.offset + self.payload.len() + 4
    }
}

/// A parsed file: header, section payloads and tiles (borrowed).
#[derive(Debug)]
pub struct Parsed<'a> {
    /// The header.
    pub header: Header,
    /// All sections in file order, the header and end included.
    pub sections: Vec<Section<'a>>,
    /// The tiles in raster order, split into their streams.
    pub tiles: Vec<TilePayload<'a>>,
}

impl<'a> Parsed<'a> {
    /// The payload of the (first) section with `tag`.
    pub fn payload(&self, tag: u8) -> Option<&'a [u8]> {
        self.sections
            .iter()
            .find(|s| s.tag == tag)
            .map(|s| s.payload)
    }

    /// The metadata sections' contents.
    pub fn metadata(&self) -> Metadata {
        let item = |t: u8| self.payload(t).map(<[u8]>::to_vec);
        Metadata {
            icc: item(tag::ICC),
            exif: item(tag::EXIF),
            xmp: item(tag::XMP),
        }
    }
}
