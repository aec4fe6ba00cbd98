//! The container's writer: the header's fields, the tiles' payloads and the sections in
//! file order.

use super::{
    step_bits, tag, Header, TileStreams, FLAG_ADAPTIVE, FLAG_DEBLOCK, FLAG_DETAIL, FLAG_LAPPED,
    FLAG_LEVEL_STEPS, FLAG_LUMA_BASIS, FLAG_PRUNED, FLAG_WEIGHTED, KIND_DERINGING, KIND_DISPLAY,
    MAGIC, VERSION,
};
use crate::colour::ColourBasis;
use crate::restoration;
use crate::tiling::SIDE_UNIT;
use crate::varint;
use caoen_base::metadata::Metadata;
use caoen_base::raster::SampleFormat;

impl Header {
    /// The header section's payload.
    pub(super) fn to_bytes(&self) -> Vec<u8> {
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
}

/// Bytes of a tile section's own fields at most: luma and chroma key-point counts,
/// then the lengths of the tree, luma and chroma streams (LEB128 each); the detail
/// stream is the rest of the payload.
const TILE_FIELDS_MAX: usize = 5 * 5;

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
