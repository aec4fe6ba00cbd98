//! The container's parser: the sections split and CRC-checked in their order, the
//! header's fields read against the format's limits, the tiles split into their streams.

use super::{
    step_from_bits, tag, Header, Parsed, Section, TilePayload, ABSENT_STEP, FLAG_ADAPTIVE,
    FLAG_DEBLOCK, FLAG_DETAIL, FLAG_LAPPED, FLAG_LEVEL_STEPS, FLAG_LUMA_BASIS, FLAG_PRUNED,
    FLAG_WEIGHTED, KIND_DERINGING, KIND_DISPLAY, MAGIC, VERSION,
};
use crate::colour::ColourBasis;
use crate::deringing::{Deringing, Strengths};
use crate::detail::adaptive::{AdaptiveSteps, CLASSES};
use crate::detail::deblock::Deblock;
use crate::detail::lapping::Lapping;
use crate::detail::weights::FrequencyWeights;
use crate::error::Tag;
use crate::keyset::KernelParams;
use crate::quadtree::TreeShape;
use crate::restoration;
use crate::tiling::{TileRect, SIDE_UNIT};
use crate::varint;
use crate::{CodecError, MAX_SIDE};
use caoen_base::metadata::MAX_ITEM_BYTES;
use caoen_base::raster::{ChannelLayout, SampleFormat};

/// Bytes of a section besides its payload at least: tag, a 1-byte length and CRC.
const SECTION_MIN: usize = 6;

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

impl Header {
    /// Reads the header section's payload, which starts at byte `offset` of the file.
    pub(super) fn parse(p: &[u8], offset: usize, max_pixels: u64) -> Result<Self, CodecError> {
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
}

impl<'a> TilePayload<'a> {
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
    CodecError::check_count("the tiles", "key points", luma, header.luma_count.into())?;
    let declared = header.chroma_count.into();
    CodecError::check_count("the tiles' chroma", "key points", chroma, declared)?;
    Ok(Parsed {
        header,
        sections,
        tiles,
    })
}
