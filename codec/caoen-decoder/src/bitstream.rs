//! The container: magic, version, then CRC-checked sections (see `docs/format.md`).

use super::colour::ColourBasis;
use super::deringing::{Deringing, Strengths};
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
use super::varint;
use super::{CodecError, MAX_SIDE};
use caoen_base::metadata::{Metadata, MAX_ITEM_BYTES};
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

/// Reads a section's fields in order, naming what runs short.
struct Fields<'a> {
    /// The section's payload.
    p: &'a [u8],
    /// Bytes read so far.
    pos: usize,
    /// Where the payload starts in the file, for messages.
    base: usize,
}

impl<'a> Fields<'a> {
    fn new(p: &'a [u8], base: usize) -> Self {
        Fields { p, pos: 0, base }
    }

    fn remaining(&self) -> usize {
        self.p.len() - self.pos
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], CodecError> {
        if self.remaining() < n {
            return Err(CodecError::Truncated {
                what,
                offset: (self.base + self.pos) as u64,
                need: n as u64,
                available: self.remaining() as u64,
            });
        }
        let s = &self.p[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], CodecError> {
        Ok(self.take(N, what)?.try_into().expect("N bytes"))
    }

    fn u8(&mut self, what: &'static str) -> Result<u8, CodecError> {
        Ok(self.array::<1>(what)?[0])
    }

    fn u16(&mut self, what: &'static str) -> Result<u16, CodecError> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    fn step(&mut self, what: &'static str) -> Result<f32, CodecError> {
        Ok(step_from_bits(self.u16(what)?))
    }

    /// A LEB128 number of at most 32 bits, in its shortest form (one form per value).
    fn varint(&mut self, what: &'static str) -> Result<u32, CodecError> {
        let (v, used) = varint::read(&self.p[self.pos..], what, self.base + self.pos)?;
        self.pos += used;
        Ok(v)
    }
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
    /// The deringing after the restoration (the channel byte's bit 6).
    pub deringing: Option<Deringing>,
    /// The image's own size when it was coded at a smaller one (`width x height`),
    /// which the decoder then outputs by default: the last 8 bytes of the header.
    pub display: Option<(u32, u32)>,
}

/// Bytes of a section besides its payload at least: tag, a 1-byte length and CRC.
const SECTION_MIN: usize = 6;
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

    fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(48);
        varint::push(&mut b, self.width);
        varint::push(&mut b, self.height);
        let format = match self.format {
            SampleFormat::U8 => 0,
            SampleFormat::U16 => 1,
            SampleFormat::F32 => 2,
        };
        b.push(
            self.layout.channels() as u8
                | format << 3
                | if self.display.is_some() {
                    KIND_DISPLAY
                } else {
                    0
                }
                | if self.deringing.is_some() {
                    KIND_DERINGING
                } else {
                    0
                },
        );
        b.push(self.block_log2 | self.min_log2 << 4);
        b.extend(((self.kernel.sigma_factor * 1024.0).round() as u16).to_le_bytes());
        b.push((self.kernel.weight_exponent * 16.0).round() as u8);
        let flag = |on: bool, bit: u8| if on { bit } else { 0 };
        b.push(
            flag(self.chroma_pruned, FLAG_PRUNED)
                | flag(self.detail_steps.is_some(), FLAG_DETAIL)
                | flag(self.deblock.is_some(), FLAG_DEBLOCK)
                | flag(self.adaptive.is_some(), FLAG_ADAPTIVE)
                | flag(self.lapping.is_some(), FLAG_LAPPED)
                | flag(self.basis == ColourBasis::Luma, FLAG_LUMA_BASIS)
                | flag(self.level_steps, FLAG_LEVEL_STEPS)
                | flag(self.weights.is_some(), FLAG_WEIGHTED),
        );
        b.extend(step_bits(self.step_luma).to_le_bytes());
        if self.layout.colour_channels() == 3 {
            b.extend(step_bits(self.step_chroma).to_le_bytes());
        }
        if self.layout.has_alpha() {
            b.extend(step_bits(self.step_alpha).to_le_bytes());
        }
        varint::push(&mut b, self.luma_count);
        varint::push(&mut b, self.chroma_count);
        b.push((self.tile_side / SIDE_UNIT) as u8);
        for &s in self.detail_steps.iter().flatten() {
            b.extend(step_bits(s).to_le_bytes());
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
        if let Some(d) = self.deringing {
            b.extend([d.luma.primary, d.luma.secondary, d.luma.cutoff]);
            if self.layout.colour_channels() == 3 {
                b.extend([d.chroma.primary, d.chroma.secondary, d.chroma.cutoff]);
            }
        }
        if let Some((w, h)) = self.display {
            varint::push(&mut b, w);
            varint::push(&mut b, h);
        }
        b
    }

    /// Reads the header section's payload, which starts at byte `offset` of the file.
    fn parse(p: &[u8], offset: usize, max_pixels: u64) -> Result<Self, CodecError> {
        let mut f = Fields::new(p, offset);
        let width = f.varint("the width")?;
        let height = f.varint("the height")?;
        for (what, side) in [("width", width), ("height", height)] {
            if side == 0 || side > MAX_SIDE {
                return Err(CodecError::range(what, side, 1.0, MAX_SIDE.into()));
            }
        }
        let kind = f.u8("the channels and sample format")?;
        let layout = ChannelLayout::from_channels((kind & 7) as usize)
            .ok_or_else(|| CodecError::range("channel count", kind & 7, 1.0, 4.0))?;
        if kind >> 7 != 0 {
            return Err(CodecError::range(
                "reserved bit of the channel byte",
                kind >> 7,
                0.0,
                0.0,
            ));
        }
        let format = match (kind >> 3) & 3 {
            0 => SampleFormat::U8,
            1 => SampleFormat::U16,
            2 => SampleFormat::F32,
            v => return Err(CodecError::range("sample format", v, 0.0, 2.0)),
        };
        let levels = f.u8("the tree's levels")?;
        let (block_log2, min_log2) = (levels & 15, levels >> 4);
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
            sigma_factor: f.u16("the kernel footprint")? as f64 / 1024.0,
            weight_exponent: f.u8("the weight exponent")? as f64 / 16.0,
        };
        if !(0.3..=4.0).contains(&kernel.sigma_factor) {
            return Err(CodecError::range(
                "kernel footprint",
                kernel.sigma_factor,
                0.3,
                4.0,
            ));
        }
        let flags = f.u8("the flags")?;
        // Every bit of the flags byte has a meaning: only combinations are invalid.
        if (flags & (FLAG_DEBLOCK | FLAG_ADAPTIVE | FLAG_LAPPED | FLAG_WEIGHTED) != 0
            && flags & FLAG_DETAIL == 0)
            || (flags & FLAG_LUMA_BASIS != 0 && layout.colour_channels() != 3)
        {
            return Err(CodecError::Flags { flags });
        }
        let step_luma = f.step("luma quantiser step")?;
        let step_chroma = if layout.colour_channels() == 3 {
            f.step("chroma quantiser step")?
        } else {
            ABSENT_STEP
        };
        let step_alpha = if layout.has_alpha() {
            f.step("alpha quantiser step")?
        } else {
            ABSENT_STEP
        };
        let luma_count = f.varint("the luma key point count")?;
        let chroma_count = f.varint("the chroma key point count")?;
        let tile_units = u32::from(f.u8("the tile side")?);
        let tile_side = tile_units * SIDE_UNIT;
        if tile_units == 0 || tile_side > MAX_SIDE {
            return Err(CodecError::TileSide {
                side: tile_side,
                unit: SIDE_UNIT,
                max: MAX_SIDE,
            });
        }
        let detail_steps = if flags & FLAG_DETAIL != 0 {
            Some([
                f.step("detail luma quantiser step")?,
                f.step("detail chroma quantiser step")?,
            ])
        } else {
            None
        };
        let deblock = if flags & FLAG_DEBLOCK != 0 {
            let [strength, radius] = f.array("the deblocking parameters")?;
            Some(Deblock { strength, radius })
        } else {
            None
        };
        let adaptive = if flags & FLAG_ADAPTIVE != 0 {
            let a: [u8; CLASSES + 1] = f.array("the adaptive step factors")?;
            Some(AdaptiveSteps {
                factors: std::array::from_fn(|i| a[i]),
                field_log2: a[CLASSES],
            })
        } else {
            None
        };
        let lapping = if flags & FLAG_LAPPED != 0 {
            Some(Lapping {
                weight: f.u8("the lapping weight")?,
            })
        } else {
            None
        };
        let weights = if flags & FLAG_WEIGHTED != 0 {
            Some(FrequencyWeights {
                tilts: f.array("the frequency tilts")?,
            })
        } else {
            None
        };
        let deringing = if kind & KIND_DERINGING != 0 {
            let strengths = |a: [u8; 3]| Strengths {
                primary: a[0],
                secondary: a[1],
                cutoff: a[2],
            };
            let luma = strengths(f.array("the luma deringing strengths")?);
            let chroma = if layout.colour_channels() == 3 {
                strengths(f.array("the chroma deringing strengths")?)
            } else {
                Strengths::OFF
            };
            for (what, s) in [("luma deringing", luma), ("chroma deringing", chroma)] {
                if !s.is_valid() {
                    return Err(CodecError::Deringing {
                        what,
                        primary: s.primary,
                        secondary: s.secondary,
                        cutoff: s.cutoff,
                    });
                }
            }
            let d = Deringing { luma, chroma };
            if !d.any() {
                return Err(CodecError::Deringing {
                    what: "every plane's deringing",
                    primary: 0,
                    secondary: 0,
                    cutoff: 0,
                });
            }
            Some(d)
        } else {
            None
        };
        let display = if kind & KIND_DISPLAY != 0 {
            Some((
                f.varint("the display width")?,
                f.varint("the display height")?,
            ))
        } else {
            None
        };
        if f.remaining() > 0 {
            return Err(CodecError::HeaderLength {
                found: p.len() as u64,
                expected: f.pos as u64,
            });
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
            luma_count,
            chroma_count,
            tile_side,
            detail_steps,
            deblock,
            adaptive,
            lapping,
            basis,
            level_steps: flags & FLAG_LEVEL_STEPS != 0,
            restoration: None,
            deringing,
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

/// Bytes of a tile section's own fields at most: luma and chroma key-point counts,
/// then the lengths of the tree, luma and chroma streams (LEB128 each); the detail
/// stream is the rest of the payload.
const TILE_FIELDS_MAX: usize = 5 * 5;

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
            TILE_FIELDS_MAX
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
            varint::push(&mut b, v);
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

    /// Splits and checks a tile section (its payload at byte `offset` of the file)
    /// against the header.
    fn parse(
        p: &'a [u8],
        rect: TileRect,
        header: &Header,
        offset: usize,
    ) -> Result<Self, CodecError> {
        let mut f = Fields::new(p, offset);
        let luma_count = f.varint("a tile's luma key point count")?;
        let chroma_count = f.varint("a tile's chroma key point count")?;
        let lens = [
            f.varint("a tile's tree stream length")? as u64,
            f.varint("a tile's luma stream length")? as u64,
            f.varint("a tile's chroma stream length")? as u64,
        ];
        let body = f.remaining() as u64;
        if lens.iter().sum::<u64>() > body {
            return Err(CodecError::Truncated {
                what: "a tile's streams",
                offset: (offset + f.pos) as u64,
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
        let mut rest = &p[f.pos..];
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

/// Appends a section: tag, payload length (LEB128), payload, CRC-32 of all three.
pub fn push_section(out: &mut Vec<u8>, tag: u8, payload: &[u8]) {
    let start = out.len();
    out.push(tag);
    varint::push(out, payload.len() as u32);
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out[start..]);
    out.extend(crc.to_le_bytes());
}

/// Bytes a section with a payload of `len` bytes takes.
fn section_bytes(len: usize) -> usize {
    1 + varint::len(len as u32) + len + 4
}

/// Bytes the metadata's sections take in a file.
pub fn metadata_bytes(metadata: &Metadata) -> usize {
    [&metadata.icc, &metadata.exif, &metadata.xmp]
        .iter()
        .map(|m| m.as_ref().map_or(0, |m| section_bytes(m.len())))
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
            .map(|p| section_bytes(p.len()))
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
        if bytes.len() - pos < SECTION_MIN {
            return Err(CodecError::Truncated {
                what: "a section's tag, length and CRC",
                offset: pos as u64,
                need: SECTION_MIN as u64,
                available: (bytes.len() - pos) as u64,
            });
        }
        let tag = bytes[pos];
        let length_bytes = &bytes[pos + 1..(pos + 1 + 5).min(bytes.len())];
        let (len, used) = varint::read(length_bytes, "a section's length", pos + 1)?;
        let len = len as usize;
        let start = pos + 1 + used;
        let available = bytes.len().saturating_sub(start + 4);
        if start + 4 > bytes.len() || len > available {
            return Err(CodecError::Truncated {
                what: "a section's payload",
                offset: start as u64,
                need: len as u64,
                available: available as u64,
            });
        }
        let end = start + len;
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
            payload_offset: start,
            payload: &bytes[start..end],
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
        Some(&tag::HEADER) => {
            Header::parse(sections[0].payload, sections[0].payload_offset, max_pixels)?
        }
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
        .map(|(k, s)| TilePayload::parse(s.payload, tiling.rect(k), &header, s.payload_offset))
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
