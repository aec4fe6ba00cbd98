//! The container: magic, version, then CRC-checked sections (see `docs/format.md`).

use super::colour::ColourBasis;
use super::detail::adaptive::{AdaptiveSteps, CLASSES};
use super::detail::deblock::Deblock;
use super::detail::lapping::Lapping;
use super::detail::weights::FrequencyWeights;
use super::error::Tag;
use super::keyset::KernelParams;
use super::quadtree::TreeShape;
use super::restoration::{self, Restoration};
use super::syntax::LevelSteps;
use super::tiling::{TileRect, Tiling, SIDE_UNIT};
use super::{CodecError, MAX_SIDE};
use crate::metadata::{Metadata, MAX_ITEM_BYTES};
use crate::raster::{ChannelLayout, SampleFormat};

/// File signature.
pub const MAGIC: [u8; 4] = *b"CAOE";
/// Format version this code writes and reads.
pub const VERSION: u8 = 16;

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
    /// Tile side in pixels (a multiple of [`SIDE_UNIT`]).
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
    /// The image's own size when it was coded at a smaller one (`width x height`),
    /// which the decoder then outputs by default: the last 8 bytes of the header.
    pub display: Option<(u32, u32)>,
}

/// Header bytes without the detail layer's steps.
const HEADER_LEN: usize = 4 + 4 + 1 + 1 + 1 + 1 + 2 + 1 + 1 + 4 * 3 + 4 + 4 + 2;
/// Header bytes with them.
const HEADER_LEN_DETAIL: usize = HEADER_LEN + 4 * 2;
/// Bytes of the display size, when the image was coded at a smaller size.
const DISPLAY_LEN: usize = 8;
/// Bytes of the deblocking parameters.
const DEBLOCK_LEN: usize = 2;
/// Bytes of the adaptive step factors and the activity field's region side.
const ADAPTIVE_LEN: usize = CLASSES + 1;
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
/// Bytes of the lapping parameter.
const LAPPING_LEN: usize = 1;
/// Bytes of the frequency weights' tilts.
const WEIGHTS_LEN: usize = 2;

impl Header {
    /// The size the decoder outputs by default: the image's own size.
    pub fn display_size(&self) -> (u32, u32) {
        self.display.unwrap_or((self.width, self.height))
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

    fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER_LEN);
        b.extend(self.width.to_le_bytes());
        b.extend(self.height.to_le_bytes());
        b.push(self.layout.channels() as u8);
        b.push(match self.format {
            SampleFormat::U8 => 0,
            SampleFormat::U16 => 1,
            SampleFormat::F32 => 2,
        });
        b.push(self.block_log2);
        b.push(self.min_log2);
        b.extend(((self.kernel.sigma_factor * 1024.0).round() as u16).to_le_bytes());
        b.push((self.kernel.weight_exponent * 16.0).round() as u8);
        b.push(
            if self.chroma_pruned { FLAG_PRUNED } else { 0 }
                | if self.detail_steps.is_some() {
                    FLAG_DETAIL
                } else {
                    0
                }
                | if self.deblock.is_some() {
                    FLAG_DEBLOCK
                } else {
                    0
                }
                | if self.adaptive.is_some() {
                    FLAG_ADAPTIVE
                } else {
                    0
                }
                | if self.lapping.is_some() {
                    FLAG_LAPPED
                } else {
                    0
                }
                | if self.basis == ColourBasis::Luma {
                    FLAG_LUMA_BASIS
                } else {
                    0
                }
                | if self.level_steps {
                    FLAG_LEVEL_STEPS
                } else {
                    0
                }
                | if self.weights.is_some() {
                    FLAG_WEIGHTED
                } else {
                    0
                },
        );
        for s in [self.step_luma, self.step_chroma, self.step_alpha] {
            b.extend(s.to_le_bytes());
        }
        b.extend(self.luma_count.to_le_bytes());
        b.extend(self.chroma_count.to_le_bytes());
        b.extend((self.tile_side as u16).to_le_bytes());
        for s in self.detail_steps.iter().flatten() {
            b.extend(s.to_le_bytes());
        }
        if let Some(d) = self.deblock {
            b.extend([d.strength, d.radius]);
        }
        if let Some(a) = self.adaptive {
            b.extend(a.factors);
            b.push(a.field_log2);
        }
        if let Some(l) = self.lapping {
            b.push(l.weight);
        }
        if let Some(w) = self.weights {
            b.extend(w.tilts);
        }
        if let Some((w, h)) = self.display {
            b.extend(w.to_le_bytes());
            b.extend(h.to_le_bytes());
        }
        b
    }

    fn parse(p: &[u8], max_pixels: u64) -> Result<Self, CodecError> {
        let flags = p.get(15).copied().unwrap_or(0);
        let colour_channels = ChannelLayout::from_channels(p.get(8).copied().unwrap_or(0) as usize)
            .map_or(0, |l| l.colour_channels());
        // Every bit of the flags byte has a meaning: only combinations are invalid.
        if (flags & (FLAG_DEBLOCK | FLAG_ADAPTIVE | FLAG_LAPPED | FLAG_WEIGHTED) != 0
            && flags & FLAG_DETAIL == 0)
            || (flags & FLAG_LUMA_BASIS != 0 && colour_channels != 3)
        {
            return Err(CodecError::Flags { flags });
        }
        // The optional fields follow in flag order.
        let deblock_at = HEADER_LEN_DETAIL;
        let adaptive_at = deblock_at
            + if flags & FLAG_DEBLOCK != 0 {
                DEBLOCK_LEN
            } else {
                0
            };
        let lapping_at = adaptive_at
            + if flags & FLAG_ADAPTIVE != 0 {
                ADAPTIVE_LEN
            } else {
                0
            };
        let weights_at = lapping_at
            + if flags & FLAG_LAPPED != 0 {
                LAPPING_LEN
            } else {
                0
            };
        let len = if flags & FLAG_DETAIL == 0 {
            HEADER_LEN
        } else {
            weights_at
                + if flags & FLAG_WEIGHTED != 0 {
                    WEIGHTS_LEN
                } else {
                    0
                }
        };
        if p.len() != len && p.len() != len + DISPLAY_LEN {
            return Err(CodecError::HeaderLength {
                found: p.len() as u64,
                expected: len as u64,
            });
        }
        let u32_at = |i: usize| u32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
        let display = (p.len() == len + DISPLAY_LEN).then(|| (u32_at(len), u32_at(len + 4)));
        let f32_at = |i: usize| f32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
        let (width, height) = (u32_at(0), u32_at(4));
        for (what, side) in [("width", width), ("height", height)] {
            if side == 0 || side > MAX_SIDE {
                return Err(CodecError::range(what, side, 1.0, MAX_SIDE.into()));
            }
        }
        if let Some((dw, dh)) = display {
            // Coded smaller on some side and larger on none: one canonical form.
            for (what, side, coded) in
                [("display width", dw, width), ("display height", dh, height)]
            {
                if side < coded || side > MAX_SIDE {
                    return Err(CodecError::range(what, side, coded.into(), MAX_SIDE.into()));
                }
            }
            if (dw, dh) == (width, height) {
                return Err(CodecError::range(
                    "display width",
                    dw,
                    f64::from(width) + 1.0,
                    MAX_SIDE.into(),
                ));
            }
        }
        let (dw, dh) = display.unwrap_or((width, height));
        let pixels = u64::from(dw) * u64::from(dh);
        if pixels > max_pixels {
            return Err(CodecError::Limit {
                what: "pixels",
                value: pixels,
                limit: max_pixels,
            });
        }
        let layout = ChannelLayout::from_channels(p[8] as usize)
            .ok_or_else(|| CodecError::range("channel count", p[8], 1.0, 4.0))?;
        let format = match p[9] {
            0 => SampleFormat::U8,
            1 => SampleFormat::U16,
            2 => SampleFormat::F32,
            v => return Err(CodecError::range("sample format", v, 0.0, 2.0)),
        };
        let (block_log2, min_log2) = (p[10], p[11]);
        if !(1..=7).contains(&block_log2) {
            return Err(CodecError::range("root block level", block_log2, 1.0, 7.0));
        }
        if min_log2 > block_log2.min(4) {
            return Err(CodecError::range(
                "smallest cell level",
                min_log2,
                0.0,
                block_log2.min(4).into(),
            ));
        }
        let kernel = KernelParams {
            sigma_factor: u16::from_le_bytes([p[12], p[13]]) as f64 / 1024.0,
            weight_exponent: p[14] as f64 / 16.0,
        };
        if !(0.3..=4.0).contains(&kernel.sigma_factor) {
            return Err(CodecError::range(
                "kernel footprint",
                kernel.sigma_factor,
                0.3,
                4.0,
            ));
        }
        let (step_luma, step_chroma, step_alpha) = (f32_at(16), f32_at(20), f32_at(24));
        let detail_steps = (flags & FLAG_DETAIL != 0).then(|| [f32_at(38), f32_at(42)]);
        let deblock = (flags & FLAG_DEBLOCK != 0).then(|| Deblock {
            strength: p[deblock_at],
            radius: p[deblock_at + 1],
        });
        let adaptive = (flags & FLAG_ADAPTIVE != 0).then(|| AdaptiveSteps {
            factors: std::array::from_fn(|i| p[adaptive_at + i]),
            field_log2: p[adaptive_at + CLASSES],
        });
        let lapping = (flags & FLAG_LAPPED != 0).then(|| Lapping {
            weight: p[lapping_at],
        });
        let weights = (flags & FLAG_WEIGHTED != 0).then(|| FrequencyWeights {
            tilts: [p[weights_at], p[weights_at + 1]],
        });
        let basis = if flags & FLAG_LUMA_BASIS != 0 {
            ColourBasis::Luma
        } else {
            ColourBasis::Grey
        };
        if let Some(l) = lapping.filter(|l| !l.is_valid()) {
            return Err(CodecError::range("lapping weight", l.weight, 1.0, 127.0));
        }
        if let Some(a) = adaptive.filter(|a| !a.is_valid()) {
            return Err(CodecError::AdaptiveSteps {
                factors: a.factors,
                field_log2: a.field_log2,
            });
        }
        if let Some(d) = deblock.filter(|d| !d.is_valid()) {
            return Err(CodecError::Deblock {
                strength: d.strength,
                radius: d.radius,
            });
        }
        let tile_side = u16::from_le_bytes([p[36], p[37]]) as u32;
        if tile_side == 0 || !tile_side.is_multiple_of(SIDE_UNIT) || tile_side > MAX_SIDE {
            return Err(CodecError::TileSide {
                side: tile_side,
                unit: SIDE_UNIT,
                max: MAX_SIDE,
            });
        }
        let [detail_luma, detail_chroma] = detail_steps.unwrap_or([1.0; 2]);
        for (name, s) in [
            ("luma quantiser step", step_luma),
            ("chroma quantiser step", step_chroma),
            ("alpha quantiser step", step_alpha),
            ("detail luma quantiser step", detail_luma),
            ("detail chroma quantiser step", detail_chroma),
        ] {
            if !(s.is_finite() && (1e-7..=1e4).contains(&s)) {
                return Err(CodecError::range(name, s, 1e-7, 1e4));
            }
        }
        let header = Header {
            width,
            height,
            layout,
            format,
            block_log2,
            min_log2,
            kernel,
            chroma_pruned: flags & FLAG_PRUNED != 0,
            step_luma,
            step_chroma,
            step_alpha,
            luma_count: u32_at(28),
            chroma_count: u32_at(32),
            tile_side,
            detail_steps,
            deblock,
            adaptive,
            lapping,
            basis,
            level_steps: flags & FLAG_LEVEL_STEPS != 0,
            restoration: None,
            weights,
            display,
        };
        let max = header.shape().max_leaves();
        if header.luma_count == 0 || header.luma_count as u64 > max {
            return Err(CodecError::range(
                "luma key point count",
                header.luma_count,
                1.0,
                max as f64,
            ));
        }
        if header.chroma_count as u64 > max {
            return Err(CodecError::range(
                "chroma key point count",
                header.chroma_count,
                0.0,
                max as f64,
            ));
        }
        if (header.layout.colour_channels() == 3) != (header.chroma_count > 0) {
            return Err(CodecError::ChromaPresence {
                what: "the header",
                chroma: header.chroma_count,
                channels: header.layout.colour_channels(),
            });
        }
        Ok(header)
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

/// Bytes of a tile section's own header: luma and chroma key-point counts, then the
/// lengths of the tree, luma and chroma streams (u32 LE each); the detail stream is
/// the rest of the payload.
const TILE_HEADER_LEN: usize = 5 * 4;

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

impl TileStreams {
    fn to_payload(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(
            TILE_HEADER_LEN
                + self.tree.len()
                + self.luma.len()
                + self.chroma.len()
                + self.detail.len(),
        );
        for v in [
            self.luma_count,
            self.chroma_count,
            self.tree.len() as u32,
            self.luma.len() as u32,
            self.chroma.len() as u32,
        ] {
            b.extend(v.to_le_bytes());
        }
        for s in [&self.tree, &self.luma, &self.chroma, &self.detail] {
            b.extend_from_slice(s);
        }
        b
    }
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

    /// Splits and checks a tile section against the header.
    fn parse(
        p: &'a [u8],
        rect: TileRect,
        header: &Header,
        offset: usize,
    ) -> Result<Self, CodecError> {
        if p.len() < TILE_HEADER_LEN {
            return Err(CodecError::Truncated {
                what: "a tile's counts and stream lengths",
                offset: offset as u64,
                need: TILE_HEADER_LEN as u64,
                available: p.len() as u64,
            });
        }
        let u32_at = |i: usize| u32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
        let (luma_count, chroma_count) = (u32_at(0), u32_at(4));
        let lens = [u32_at(8) as u64, u32_at(12) as u64, u32_at(16) as u64];
        let body = (p.len() - TILE_HEADER_LEN) as u64;
        if lens.iter().sum::<u64>() > body {
            return Err(CodecError::Truncated {
                what: "a tile's streams",
                offset: (offset + TILE_HEADER_LEN) as u64,
                need: lens.iter().sum(),
                available: body,
            });
        }
        let shape = TreeShape {
            width: rect.width,
            height: rect.height,
            block_log2: header.block_log2,
            min_log2: header.min_log2,
        };
        let max = shape.max_leaves();
        if luma_count == 0 || luma_count as u64 > max {
            return Err(CodecError::range(
                "a tile's luma key point count",
                luma_count,
                1.0,
                max as f64,
            ));
        }
        if chroma_count as u64 > max {
            return Err(CodecError::range(
                "a tile's chroma key point count",
                chroma_count,
                0.0,
                max as f64,
            ));
        }
        if (header.layout.colour_channels() == 3) != (chroma_count > 0) {
            return Err(CodecError::ChromaPresence {
                what: "a tile",
                chroma: chroma_count,
                channels: header.layout.colour_channels(),
            });
        }
        let mut rest = &p[TILE_HEADER_LEN..];
        let mut take = |n: u64| {
            let (a, b) = rest.split_at(n as usize);
            rest = b;
            a
        };
        let (tree, luma, chroma) = (take(lens[0]), take(lens[1]), take(lens[2]));
        let detail = rest;
        if header.detail_steps.is_none() && !detail.is_empty() {
            return Err(CodecError::DetailWithoutLayer {
                bytes: detail.len() as u64,
            });
        }
        Ok(TilePayload {
            rect,
            luma_count,
            chroma_count,
            tree,
            luma,
            chroma,
            detail,
        })
    }
}

/// Appends a section: tag, payload length (u32 LE), payload, CRC-32 of all three.
fn push_section(out: &mut Vec<u8>, tag: u8, payload: &[u8]) {
    let start = out.len();
    out.push(tag);
    out.extend((payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out[start..]);
    out.extend(crc.to_le_bytes());
}

/// Bytes of a section besides its payload: tag, length and CRC.
const SECTION_OVERHEAD: usize = 9;

/// Bytes the metadata's sections take in a file.
pub fn metadata_bytes(metadata: &Metadata) -> usize {
    [&metadata.icc, &metadata.exif, &metadata.xmp]
        .iter()
        .map(|m| m.as_ref().map_or(0, |m| m.len() + SECTION_OVERHEAD))
        .sum()
}

/// Assembles a file from the header, the metadata and the tiles' streams (raster
/// order of tiles).
pub fn write(header: &Header, metadata: &Metadata, tiles: &[TileStreams]) -> Vec<u8> {
    let payloads: Vec<Vec<u8>> = tiles.iter().map(TileStreams::to_payload).collect();
    let items = [
        (tag::ICC, &metadata.icc),
        (tag::EXIF, &metadata.exif),
        (tag::XMP, &metadata.xmp),
    ];
    let len = 64
        + payloads
            .iter()
            .map(|p| p.len() + SECTION_OVERHEAD)
            .sum::<usize>()
        + metadata_bytes(metadata);
    let mut out = Vec::with_capacity(len);
    out.extend(MAGIC);
    out.push(VERSION);
    push_section(&mut out, tag::HEADER, &header.to_bytes());
    for (t, item) in items {
        if let Some(item) = item {
            push_section(&mut out, t, item);
        }
    }
    for p in &payloads {
        push_section(&mut out, tag::TILE, p);
    }
    if let Some(r) = &header.restoration {
        push_section(&mut out, tag::RESTORATION, &restoration::syntax::write(r));
    }
    push_section(&mut out, tag::END, &[]);
    out
}

/// One section as found in a file.
#[derive(Debug, Clone, Copy)]
pub struct Section<'a> {
    /// Tag byte.
    pub tag: u8,
    /// Offset of the tag in the file.
    pub offset: usize,
    /// Payload.
    pub payload: &'a [u8],
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

/// Parses and checks the container: magic, version, section order, lengths, CRCs,
/// and the header's limits, before anything is allocated for the image.
pub fn parse(bytes: &[u8], max_pixels: u64) -> Result<Parsed<'_>, CodecError> {
    if bytes.len() < 4 && MAGIC.starts_with(bytes) {
        return Err(CodecError::Truncated {
            what: "the magic bytes",
            offset: 0,
            need: 4,
            available: bytes.len() as u64,
        });
    }
    if bytes.len() < 4 || bytes[..4] != MAGIC {
        return Err(CodecError::WrongMagic {
            found: bytes[..bytes.len().min(4)].to_vec(),
        });
    }
    if bytes.len() < 5 {
        return Err(CodecError::Truncated {
            what: "the version byte",
            offset: 4,
            need: 1,
            available: 0,
        });
    }
    if bytes[4] != VERSION {
        return Err(CodecError::UnsupportedVersion {
            found: bytes[4],
            supported: VERSION,
        });
    }
    let mut sections = Vec::new();
    let mut pos = 5;
    loop {
        if bytes.len() - pos < 9 {
            return Err(CodecError::Truncated {
                what: "a section's tag, length and CRC",
                offset: pos as u64,
                need: 9,
                available: (bytes.len() - pos) as u64,
            });
        }
        let tag = bytes[pos];
        let len = u32::from_le_bytes([
            bytes[pos + 1],
            bytes[pos + 2],
            bytes[pos + 3],
            bytes[pos + 4],
        ]) as usize;
        let end = pos + 5 + len;
        if len > bytes.len() - pos - 9 {
            return Err(CodecError::Truncated {
                what: "a section's payload",
                offset: pos as u64 + 5,
                need: len as u64,
                available: (bytes.len() - pos - 9) as u64,
            });
        }
        let stored =
            u32::from_le_bytes([bytes[end], bytes[end + 1], bytes[end + 2], bytes[end + 3]]);
        let computed = crc32fast::hash(&bytes[pos..end]);
        if computed != stored {
            return Err(CodecError::CrcMismatch {
                tag: Tag(tag),
                offset: pos as u64,
                stored,
                computed,
            });
        }
        if tag == tag::END && len != 0 {
            return Err(CodecError::EndNotEmpty {
                offset: pos as u64,
                len: len as u64,
            });
        }
        sections.push(Section {
            tag,
            offset: pos,
            payload: &bytes[pos + 5..end],
        });
        pos = end + 4;
        if tag == tag::END {
            break;
        }
    }
    if pos != bytes.len() {
        return Err(CodecError::TrailingData {
            bytes: (bytes.len() - pos) as u64,
        });
    }
    let tags: Vec<u8> = sections.iter().map(|s| s.tag).collect();
    let header = match tags.first() {
        Some(&tag::HEADER) => Header::parse(sections[0].payload, max_pixels)?,
        first => {
            return Err(CodecError::HeaderNotFirst {
                first: first.map(|&t| Tag(t)),
            })
        }
    };
    // Header, the metadata items present (each at most once, in this order), one
    // section per tile, end.
    let mut i = 1;
    for t in [tag::ICC, tag::EXIF, tag::XMP] {
        if tags.get(i) == Some(&t) {
            let n = sections[i].payload.len();
            if n > MAX_ITEM_BYTES {
                return Err(CodecError::Limit {
                    what: "metadata item bytes",
                    value: n as u64,
                    limit: MAX_ITEM_BYTES as u64,
                });
            }
            i += 1;
        }
    }
    let tiling = header.tiling();
    let count = tiling.count();
    let tile_tags = tags[i..].iter().take_while(|&&t| t == tag::TILE).count();
    let restored = tags.get(i + count) == Some(&tag::RESTORATION);
    if tile_tags != count || i + count + usize::from(restored) + 1 != tags.len() {
        return Err(CodecError::SectionOrder { tags, tiles: count });
    }
    let mut header = header;
    if restored {
        let planes = header.layout.colour_channels();
        header.restoration = Some(restoration::syntax::parse(
            sections[i + count].payload,
            planes,
        )?);
    }
    let tiles = sections[i..i + count]
        .iter()
        .enumerate()
        .map(|(k, s)| TilePayload::parse(s.payload, tiling.rect(k), &header, s.offset))
        .collect::<Result<Vec<_>, _>>()?;
    let (luma, chroma) = tiles.iter().fold((0u64, 0u64), |(l, c), t| {
        (l + t.luma_count as u64, c + t.chroma_count as u64)
    });
    if (luma, chroma) != (header.luma_count as u64, header.chroma_count as u64) {
        let (what, found, declared) = if luma != header.luma_count as u64 {
            ("the tiles", luma, header.luma_count)
        } else {
            ("the tiles' chroma", chroma, header.chroma_count)
        };
        return Err(CodecError::CountMismatch {
            what,
            unit: "key points",
            found,
            declared: declared as u64,
        });
    }
    Ok(Parsed {
        header,
        sections,
        tiles,
    })
}
