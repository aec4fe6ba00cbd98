//! The bodies of the fuzz targets (`docs/fuzzing.md`).
//!
//! Each target takes the fuzzer's bytes, drives one input path of `caoen` and returns
//! the error the input earned, if any. It panics only when something that must hold for
//! every input does not: a panic inside `caoen`, an error message that is not one
//! printable line, a file accepted that the format forbids, a result of the wrong size,
//! a file written by `caoen` that it cannot read back. A hang is caught by the fuzzer's
//! timeout (and by the replay test's time bound).
//!
//! The binaries in `src/bin/` are one call each; `codec/tests/fuzz_replay.rs` compiles this
//! same file into the main workspace to replay seeds and findings without AFL.
#![forbid(unsafe_code)]

use std::cell::RefCell;
use std::path::Path;

use caoen::codec::bitstream::{self, Header, Parsed, TilePayload, TileStreams};
use caoen::codec::decoder;
use caoen::codec::deringing::{Deringing, Strengths};
use caoen::codec::detail::{
    self,
    adaptive::{block_classes, AdaptiveSteps},
    dct::COEFFS,
    deblock::Deblock,
    field::ActivityField,
    lapping::Lapping,
    weights::FrequencyWeights,
    Detail, DetailPlane,
};
use caoen::codec::entropy::AnsSink;
use caoen::codec::keyset::KernelParams;
use caoen::codec::quadtree::{self, TreeShape};
use caoen::codec::restoration::{self, PlaneFilter, Restoration};
use caoen::codec::tiling::SIDE_UNIT;
use caoen::codec::ColourBasis;
use caoen::codec::{self, syntax, DecodeOptions, EncodeOptions};
use caoen::conversion::mesh_file;
use caoen::conversion::polygon_mesh::PolygonMesh;
use caoen::frep::node::MAX_NODES;
use caoen::frep::polygonise;
use caoen::frep::raycast::{CastOptions, Caster};
use caoen::frep::{Aabb, Node};
use caoen::geometry::mesh::Mesh;
use caoen::image_io::{self, LoadLimits};
use caoen::metadata::Metadata;
use caoen::raster::{ChannelLayout, Raster, SampleFormat};
use caoen::render::mesh::{tessellate, NormalMode};
use caoen::render::raytrace::RayMethod;
use caoen::render::{render, Method, RenderOptions, Scene};
use caoen::surface::SurfaceModel;
use caoen::texture::warp::{self, Warp};

#[path = "metadata.rs"]
mod metadata;
#[path = "solids.rs"]
mod solids;

pub use metadata::{exif, icc, image, meta_container, xmp};
pub use solids::{frep, obj, ply};

/// What a target made of its input: nothing to report, or the error the input earned.
pub type Outcome = Result<(), String>;

/// A fuzz target's body.
pub type Target = fn(&[u8]) -> Outcome;

/// Every target by name: the binary in `src/bin/`, the seed directory under `seeds/` and
/// the findings directory under `tests/bad/` share it.
pub const TARGETS: [(&str, Target); 15] = [
    ("decode", decode),
    ("container", container),
    ("image", image),
    ("surface", surface),
    ("scene", scene),
    ("distort", distort),
    ("frep", frep),
    ("obj", obj),
    ("ply", ply),
    ("scene_frep", scene),
    ("jpeg_meta", meta_container),
    ("png_meta", meta_container),
    ("exif", exif),
    ("icc", icc),
    ("xmp", xmp),
];

/// Runs rayon's parallel loops on one worker thread, so that a run's coverage does not
/// depend on thread scheduling (AFL's stability) and parallel fuzzers do not compete
/// for cores with each other's thread pools.
///
/// Call it inside the fuzz loop, not before: AFL's fork server forks when the loop
/// starts, a forked child has none of its parent's threads, and a pool built before the
/// fork would never run a job (every input would hang).
pub fn single_thread() {
    // After the first call this fails at once: the pool exists and serves.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
}

/// Pixel limit of the decode targets: the format's limits are exercised by `inspect`,
/// which has none, and far below the CLI's default so a run takes milliseconds.
const DECODE_MAX_PIXELS: u64 = 1 << 16;

/// Largest coded image also decoded by forward mapping, which costs more per pixel.
const FORWARD_MAX_PIXELS: u64 = 1 << 12;

/// An error message as the command line prints it must be one line of printable text.
fn message(e: impl std::fmt::Display) -> String {
    let m = e.to_string();
    assert!(
        !m.is_empty() && !m.chars().any(char::is_control),
        "error message is not one printable line: {m:?}"
    );
    m
}

/// The input as text; bytes that are not UTF-8 are an error, as for a file.
fn text(data: &[u8]) -> Result<&str, String> {
    std::str::from_utf8(data).map_err(message)
}

/// A JSON file a parser accepted must be exactly one JSON document: nothing after it.
fn assert_one_document(text: &str, what: &str) {
    if let Err(e) = serde_json::from_str::<serde_json::Value>(text) {
        panic!("accepted a {what} that is not one JSON document: {e}");
    }
}

/// Decodes and inspects a caoen file.
///
/// A file `inspect` rejects must not decode, and a file it accepts must be the one way
/// of writing its parts (no payload in the end section, nothing after it). Decoding
/// runs the identity path at the coded size and, for small images, the forward-mapping
/// path at another size.
pub fn decode(data: &[u8]) -> Outcome {
    let opts = DecodeOptions {
        max_pixels: DECODE_MAX_PIXELS,
        ..DecodeOptions::default()
    };
    let decoded = codec::decode(data, &opts);
    let parsed = match codec::inspect(data) {
        Ok(p) => p,
        Err(e) => {
            let e = message(e);
            assert!(
                decoded.is_err(),
                "decode accepts a file inspect rejects: {e}"
            );
            return Err(e);
        }
    };
    assert_canonical(data, &parsed);
    let h = &parsed.header;
    let img = decoded.map_err(message)?;
    assert_decoded(&img, h, h.display_size());
    if u64::from(h.width) * u64::from(h.height) <= FORWARD_MAX_PIXELS {
        // Narrower (a downscaled axis) and taller (an upscaled one).
        let size = ((h.width * 3).div_ceil(4), h.height + h.height / 2);
        let opts = DecodeOptions {
            size: Some(size),
            supersample: Some(2),
            max_pixels: DECODE_MAX_PIXELS,
            ..DecodeOptions::default()
        };
        let img = codec::decode(data, &opts).map_err(message)?;
        assert_decoded(&img, h, size);
    }
    Ok(())
}

/// The container written again from its parsed parts must be the input itself.
fn assert_canonical(data: &[u8], parsed: &Parsed) {
    let tiles: Vec<TileStreams> = parsed.tiles.iter().map(TilePayload::to_streams).collect();
    let again = bitstream::write(&parsed.header, &parsed.metadata(), &tiles);
    if again != data {
        let at = again.iter().zip(data).take_while(|(a, b)| a == b).count();
        let section = parsed
            .sections
            .iter()
            .rev()
            .find(|s| s.offset <= at)
            .map_or('?', |s| s.tag as char);
        panic!(
            "accepted a container that is not the canonical writing of its parts: \
             {} bytes read, {} written, first difference at byte {at} (section {section:?})",
            data.len(),
            again.len()
        );
    }
}

/// A decoded image has the requested size and the header's layout and format.
fn assert_decoded(img: &Raster, h: &Header, (w, ht): (u32, u32)) {
    assert_eq!((img.width(), img.height()), (w, ht), "decoded size");
    assert_eq!(img.layout(), h.layout, "decoded channel layout");
    assert_eq!(img.format(), h.format, "decoded sample format");
}

/// The fuzzer's bytes read as a stream of choices; past the end every choice is 0, so
/// a short input makes a small, simple file.
struct Choices<'a> {
    data: &'a [u8],
    pos: usize,
    /// Bits left over from the last byte read by [`Choices::bit`].
    bits: u8,
    nbits: u32,
}

impl<'a> Choices<'a> {
    fn new(data: &'a [u8]) -> Self {
        Choices {
            data,
            pos: 0,
            bits: 0,
            nbits: 0,
        }
    }

    fn byte(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }

    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.byte(), self.byte()])
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }

    /// One bit; eight per byte, since a tree takes one per node.
    fn bit(&mut self) -> bool {
        if self.nbits == 0 {
            self.bits = self.byte();
            self.nbits = 8;
        }
        let b = self.bits & 1 == 1;
        self.bits >>= 1;
        self.nbits -= 1;
        b
    }

    /// The bytes not read yet.
    fn rest(&self) -> &'a [u8] {
        self.data.get(self.pos..).unwrap_or(&[])
    }
}

/// A header within every limit of the format, its fields chosen by the fuzzer; the key
/// point counts are filled in once the tree is drawn.
fn choose_header(c: &mut Choices) -> Header {
    // Up to two tiles per side.
    let width = 1 + u32::from(c.byte());
    let height = 1 + u32::from(c.byte());
    let layout = ChannelLayout::from_channels(1 + usize::from(c.byte() % 4)).expect("1..=4");
    let format =
        [SampleFormat::U8, SampleFormat::U16, SampleFormat::F32][usize::from(c.byte() % 3)];
    let block_log2 = 1 + c.byte() % 7;
    let min_log2 = c.byte() % (block_log2.min(4) + 1);
    // 308/1024 is the first stored footprint at or above the 0.3 minimum.
    let sigma = 308 + c.u16() % (4096 - 308 + 1);
    let kernel = KernelParams {
        sigma_factor: f64::from(sigma) / 1024.0,
        weight_exponent: f64::from(c.byte()) / 16.0,
    };
    let chroma_pruned = c.bit();
    // Log-uniform over the valid 1e-7..=1e4.
    let mut step = || {
        let t = f64::from(c.u16()) / 65535.0;
        bitstream::stored_step((1e-7 * 1e11f64.powf(t)).clamp(1e-7, 1e4)) as f32
    };
    let (step_luma, step_chroma, step_alpha) = (step(), step(), step());
    let detail = [step(), step()];
    let detail_steps = c.bit().then_some(detail);
    // Valid parameters: the header's own checks are what the byte-level targets probe.
    let deblock = (detail_steps.is_some() && c.bit()).then(|| Deblock {
        strength: c.byte().max(1),
        radius: 1 + c.byte() % Deblock::MAX_RADIUS,
    });
    Header {
        width,
        height,
        layout,
        format,
        block_log2,
        min_log2,
        kernel,
        chroma_pruned,
        step_luma,
        // The header stores no step for a channel the image lacks.
        step_chroma: if layout.colour_channels() == 3 {
            step_chroma
        } else {
            bitstream::ABSENT_STEP
        },
        step_alpha: if layout.has_alpha() {
            step_alpha
        } else {
            bitstream::ABSENT_STEP
        },
        luma_count: 0,
        chroma_count: 0,
        tile_side: SIDE_UNIT * (1 + u32::from(c.bit())),
        detail_steps,
        deblock,
        adaptive: (detail_steps.is_some() && c.bit()).then(|| AdaptiveSteps {
            factors: [c.byte().max(1), c.byte().max(1), c.byte().max(1)],
            field_log2: if c.bit() {
                *detail::field::LOG2_RANGE.start() + c.byte() % 5
            } else {
                0
            },
        }),
        lapping: (detail_steps.is_some() && c.bit()).then(|| Lapping {
            weight: 1 + c.byte() % 127,
        }),
        basis: if layout.colour_channels() == 3 && c.bit() {
            ColourBasis::Luma
        } else {
            ColourBasis::Grey
        },
        level_steps: c.bit(),
        // A larger image coded at this size: each side grows by up to 64, within
        // the pixels the decode target allows.
        display: c
            .bit()
            .then(|| {
                let grow =
                    |side: u32, by: u8| (side + u32::from(by % 65)).min(caoen::codec::MAX_SIDE);
                (grow(width, c.byte()), grow(height, c.byte()))
            })
            .filter(|&(dw, dh)| {
                (dw, dh) != (width, height) && u64::from(dw) * u64::from(dh) <= DECODE_MAX_PIXELS
            }),
        weights: (detail_steps.is_some() && c.bit()).then(|| FrequencyWeights {
            tilts: [c.byte(), c.byte()],
        }),
        restoration: c.bit().then(|| {
            let plane = |c: &mut Choices, p: usize| {
                let n = if c.bit() {
                    1 + usize::from(c.byte()) % restoration::MAX_FILTERS
                } else {
                    1
                };
                let filters = (0..n)
                    .map(|_| {
                        (0..restoration::shape(p).len())
                            .map(|_| (i32::from(c.byte()) - 128) * 7)
                            .collect()
                    })
                    .collect();
                let classes = (n > 1 || c.bit())
                    .then(|| std::array::from_fn(|_| (usize::from(c.byte()) % (n + 1)) as u8));
                PlaneFilter { filters, classes }
            };
            let colours = layout.colour_channels();
            let mut planes: Vec<Option<PlaneFilter>> = Vec::with_capacity(colours);
            for p in 0..colours {
                let filtered = c.bit();
                planes.push(filtered.then(|| plane(c, p)));
            }
            let colour = c.bit().then(|| restoration::colour_map::ColourMap {
                rows: (0..colours)
                    .map(|_| {
                        (0..=colours)
                            .map(|_| (i32::from(c.byte()) - 128) * 15)
                            .collect()
                    })
                    .collect(),
            });
            let last = c.bit().then(|| plane(c, 0));
            if planes.iter().all(Option::is_none) && colour.is_none() && last.is_none() {
                planes[0] = Some(PlaneFilter::single(vec![0; restoration::shape(0).len()]));
            }
            Restoration {
                planes,
                colour,
                last,
            }
        }),
        deringing: c.bit().then(|| {
            let mut strengths = || {
                if c.bit() {
                    Strengths {
                        primary: c.byte(),
                        secondary: c.byte(),
                        cutoff: c.byte().max(1),
                    }
                } else {
                    Strengths::OFF
                }
            };
            let luma = strengths();
            let chroma = if layout.colour_channels() == 3 {
                strengths()
            } else {
                Strengths::OFF
            };
            let on = |s: Strengths| if s.is_on() { s } else { Strengths::OFF };
            let (luma, chroma) = (on(luma), on(chroma));
            let luma = if luma.is_on() || chroma.is_on() {
                luma
            } else {
                Strengths {
                    primary: 1,
                    secondary: 0,
                    cutoff: 1,
                }
            };
            Deringing { luma, chroma }
        }),
    }
}

/// Metadata items, each present or not, of the fuzzer's bytes.
fn choose_metadata(c: &mut Choices) -> Metadata {
    let mut item = || {
        c.bit().then(|| {
            let n = usize::from(c.byte());
            (0..n).map(|_| c.byte()).collect()
        })
    };
    Metadata {
        icc: item(),
        exif: item(),
        xmp: item(),
    }
}

/// Detail levels for every colour channel: most blocks empty, the others with a few
/// small, large or extreme levels at chosen positions.
fn choose_detail(c: &mut Choices, header: &Header, (width, height): (u32, u32)) -> Detail {
    let (cols, rows) = detail::blocks(width, height);
    let channels = header.layout.colour_channels();
    let max = detail::syntax::MAX_LEVEL as i32;
    let planes = (0..channels)
        .map(|plane| {
            let blocks = (0..cols * rows)
                .map(|_| {
                    let mut b = [0i32; COEFFS];
                    if c.byte().is_multiple_of(4) {
                        for _ in 0..1 + c.byte() % 8 {
                            let at = usize::from(c.byte()) % COEFFS;
                            b[at] = match c.byte() % 4 {
                                0 | 1 => i32::from(c.byte() as i8),
                                2 => i32::from(c.u16() as i16),
                                _ => max,
                            } * if c.bit() { -1 } else { 1 };
                        }
                    }
                    b
                })
                .collect();
            let levels = DetailPlane::from_blocks(cols, rows, blocks);
            if plane == 0 {
                return levels;
            }
            // Chroma blocks draw luma factors, any in range; the payload codes those
            // of the blocks whose luma block predicts.
            let limit = detail::syntax::FACTOR_LIMIT;
            let factors = (0..cols * rows)
                .map(|_| {
                    if c.bit() {
                        (i32::from(c.byte()) % (2 * limit + 1) - limit) as i8
                    } else {
                        0
                    }
                })
                .collect();
            levels.with_factors(factors)
        })
        .collect();
    // An activity field of any exponents in range, where the header asks for one.
    let field = header.adaptive.and_then(|a| a.field()).map(|log2| {
        let (cols, rows) = ActivityField::regions(width, height, log2);
        let limit = detail::field::LIMIT;
        ActivityField {
            log2,
            cols,
            rows,
            exponents: (0..cols * rows)
                .map(|_| (c.byte() % (2 * limit as u8 + 1)) as i8 - limit)
                .collect(),
        }
    });
    Detail {
        planes,
        // The header's steps: the streams' starting contexts follow the luma step.
        steps: header
            .detail_plane_steps()
            .expect("a header with the layer"),
        deblock: header.deblock,
        lapping: header.lapping,
        // Only the payload is written: the factors and the weights live in the header.
        block_steps: None,
        weights: None,
        field,
    }
}

/// Quantised values for one channel: runs of small, medium or extreme values, always
/// within the format's range.
fn choose_values(c: &mut Choices, n: usize) -> Vec<i64> {
    let max = syntax::MAX_VALUE;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let mode = c.byte();
        let run = 1 + usize::from(mode >> 2);
        for _ in 0..run.min(n - out.len()) {
            out.push(match mode & 3 {
                0 => i64::from(c.byte() as i8),
                1 => i64::from(c.u16() as i16),
                2 => i64::from(c.u32() as i32).clamp(-max, max),
                _ => {
                    if c.bit() {
                        max
                    } else {
                        -max
                    }
                }
            });
        }
    }
    out
}

/// A valid caoen file drawn from the fuzzer's choices: header, a tree, and values coded
/// by the encoder's own syntax writers. Returns the file and its header.
fn choose_file(c: &mut Choices) -> (Vec<u8>, Header) {
    let mut header = choose_header(c);
    let metadata = choose_metadata(c);
    let tiling = header.tiling();
    let colour = header.layout.colour_channels() == 3;
    let luma_channels = 1 + usize::from(header.layout.has_alpha());
    let mut tiles = Vec::with_capacity(tiling.count());
    for i in 0..tiling.count() {
        let r = tiling.rect(i);
        let shape = TreeShape {
            width: r.width,
            height: r.height,
            ..header.shape()
        };
        let mut tree = AnsSink::new();
        let choices = RefCell::new(&mut *c);
        let luma_cells = syntax::write_tree(&shape, |_| choices.borrow_mut().bit(), &mut tree);
        let chroma_cells = if colour {
            quadtree::chroma_cells(&shape, &luma_cells, header.chroma_pruned)
        } else {
            Vec::new()
        };
        let (w, h) = (r.width, r.height);
        let mut luma = AnsSink::new();
        let nbs = syntax::neighbours(&luma_cells, w, h);
        for _ in 0..luma_channels {
            let v = choose_values(c, luma_cells.len());
            syntax::write_values(&luma_cells, &nbs, &v, header.level_steps(), &mut luma);
        }
        let chroma = if colour {
            let mut sink = AnsSink::new();
            let nbs = syntax::neighbours(&chroma_cells, w, h);
            for _ in 0..2 {
                let v = choose_values(c, chroma_cells.len());
                syntax::write_values(&chroma_cells, &nbs, &v, header.level_steps(), &mut sink);
            }
            sink.finish()
        } else {
            Vec::new()
        };
        // A tile of the layer may have no coded block: its stream is then empty.
        let detail = match header.detail_steps {
            Some(_) if !c.byte().is_multiple_of(4) => {
                let classes = block_classes(&luma_cells, w, h);
                choose_detail(c, &header, (w, h)).to_payload(&classes)
            }
            _ => Vec::new(),
        };
        tiles.push(TileStreams {
            luma_count: luma_cells.len() as u32,
            chroma_count: chroma_cells.len() as u32,
            tree: tree.finish(),
            luma: luma.finish(),
            chroma,
            detail,
        });
    }
    header.luma_count = tiles.iter().map(|t| t.luma_count).sum();
    header.chroma_count = tiles.iter().map(|t| t.chroma_count).sum();
    let file = bitstream::write(&header, &metadata, &tiles);
    (file, header)
}

/// Damages a valid file in one way the fuzzer chooses, keeping every CRC right, so the
/// damage reaches the parsers behind the container check.
fn damage(file: &[u8], how: u8, c: &mut Choices) -> Vec<u8> {
    let parsed = codec::inspect(file).expect("a generated file parses");
    let mut sections: Vec<(u8, Vec<u8>)> = parsed
        .sections
        .iter()
        .map(|s| (s.tag, s.payload.to_vec()))
        .collect();
    let n = sections.len();
    let i = usize::from(c.byte()) % n;
    let payload = &mut sections[i].1;
    match how % 8 {
        // Flip bits of one byte.
        1 if !payload.is_empty() => {
            let at = usize::from(c.u16()) % payload.len();
            payload[at] ^= c.byte().max(1);
        }
        // Cut the payload short (to any length, not only whole words).
        2 => {
            let keep = usize::from(c.u16()) % (payload.len() + 1);
            payload.truncate(keep);
        }
        // Append bytes.
        3 => {
            let k = 1 + usize::from(c.byte() % 8);
            for _ in 0..k {
                payload.push(c.byte());
            }
        }
        // Replace the payload by the rest of the input.
        4 => *payload = c.rest().to_vec(),
        // Overwrite one header field byte (the header is section 0).
        5 => {
            let at = usize::from(c.byte()) % sections[0].1.len();
            sections[0].1[at] = c.byte();
        }
        // Drop a section.
        6 => {
            sections.remove(i);
        }
        // Repeat a section, or swap two.
        _ => {
            let j = usize::from(c.byte()) % n;
            if i == j {
                let s = sections[i].clone();
                sections.insert(i, s);
            } else {
                sections.swap(i, j);
            }
        }
    }
    let mut out = Vec::with_capacity(file.len() + 64);
    out.extend(bitstream::MAGIC);
    out.push(bitstream::VERSION);
    for (t, p) in &sections {
        bitstream::push_section(&mut out, *t, p);
    }
    out
}

/// Structure-aware decoding: builds a valid caoen file from the fuzzer's choices, which
/// must decode to the header's size and layout, then (as the input chooses) damages one
/// section with its CRC kept right, and decodes that through [`decode`].
///
/// Byte mutation of real files mostly breaks a CRC and stops at the container check;
/// here the fuzzer's bytes steer the header fields, the tree, the values and the damage.
pub fn container(data: &[u8]) -> Outcome {
    let mut c = Choices::new(data);
    let (file, header) = choose_file(&mut c);
    let parsed = codec::inspect(&file)
        .unwrap_or_else(|e| panic!("inspect rejects a file the syntax writers made: {e}"));
    assert_eq!(parsed.header, header, "the header read back");
    if let Err(e) = decode(&file) {
        panic!("the decoder rejects a file the syntax writers made: {e}");
    }
    match c.byte() {
        0 => Ok(()),
        how => decode(&damage(&file, how, &mut c)),
    }
}

/// Parses a surface model file; an accepted model must be one JSON document, must
/// write out as a model that reads back the same, and is meshed coarsely with exact
/// normals (its network and Jacobian evaluated at every vertex).
pub fn surface(data: &[u8]) -> Outcome {
    let text = text(data)?;
    let model = SurfaceModel::from_json(text).map_err(message)?;
    assert_one_document(text, "surface model");
    let json = model.to_json();
    let again = SurfaceModel::from_json(&json)
        .unwrap_or_else(|e| panic!("a written model does not read back: {e}"));
    assert!(
        again.to_json() == json,
        "a written model reads back as another model"
    );
    // Domains without a mesh (the 3-ball, S^3) say so in an error.
    if let Err(e) = tessellate(&model, 1, NormalMode::Exact, &caoen::Limits::default()) {
        message(e);
    }
    Ok(())
}

/// The directory scene files resolve their file names against: one that does not
/// exist, so no `..` climbs out of it and a named file is simply not found.
const NO_DIR: &str = "/nonexistent-caoen-fuzz-dir";

/// Whether any string in the JSON text is an absolute path: a scene may name files,
/// and reading `/dev/zero` or a huge file is not what a fuzzer should spend time on.
fn names_absolute_path(text: &str) -> bool {
    fn walk(v: &serde_json::Value) -> bool {
        match v {
            serde_json::Value::String(s) => s.starts_with('/'),
            serde_json::Value::Array(a) => a.iter().any(walk),
            serde_json::Value::Object(o) => o.values().any(walk),
            _ => false,
        }
    }
    serde_json::from_str::<serde_json::Value>(text).is_ok_and(|v| walk(&v))
}

/// Render sizes and settings of the scene target: tiny, one sample, coarse meshes, so
/// each method's numeric code runs in milliseconds.
fn tiny_render(method: Method, ray_method: RayMethod) -> RenderOptions {
    let mut opts = RenderOptions {
        width: 16,
        height: 12,
        samples: 1,
        method,
        mesh_detail: 2,
        ray_method,
        polygonise_cells: 8,
        ..RenderOptions::default()
    };
    opts.depth.max_samples = 1 << 20;
    opts
}

/// Parses a scene file and renders it at 16x12 by the mesh, depth-buffer and ray
/// methods (both crossing searches); an accepted scene must be one JSON document, and
/// each render that succeeds has the requested size.
pub fn scene(data: &[u8]) -> Outcome {
    let text = text(data)?;
    if names_absolute_path(text) {
        return Err("names an absolute path".into());
    }
    let scene =
        Scene::from_json(text, Path::new(NO_DIR), &caoen::Limits::default()).map_err(message)?;
    assert_one_document(text, "scene");
    for (method, ray) in [
        (Method::Mesh, RayMethod::Fast),
        (Method::Depth, RayMethod::Fast),
        (Method::Ray, RayMethod::Fast),
        (Method::Ray, RayMethod::Paper),
    ] {
        let opts = tiny_render(method, ray);
        match render(&scene, &opts, &|_, _| {}) {
            Ok(r) => assert_eq!(
                (r.image.width, r.image.height),
                (opts.width, opts.height),
                "rendered size"
            ),
            Err(e) => {
                message(e);
            }
        }
    }
    Ok(())
}

/// Size of the image the distort target warps.
const WARP_SIZE: (u32, u32) = (32, 24);

/// The picture the distort target warps, as a caoen file of [`WARP_SIZE`]. Read on
/// every run rather than made once: work done only on a process's first run would make
/// its coverage differ from the next run's (AFL's stability).
const WARP_INPUT: &[u8] = include_bytes!("warp-input.cae");

/// Parses a moves file, builds the warp network for a 32x24 image (the interpolation
/// solve), checks it for folds, and applies it to an image, to its grid, and to the key
/// points of a caoen file; each result has the image's size.
pub fn distort(data: &[u8]) -> Outcome {
    let text = text(data)?;
    let moves = warp::parse_moves(text).map_err(message)?;
    let (w, h) = WARP_SIZE;
    let warp = Warp::new(w, h, &moves).map_err(message)?;
    warp.check_folds(1.0);
    let input = codec::decode(WARP_INPUT, &DecodeOptions::default()).expect("the warp input");
    let img = warp::warp_raster(&input, &warp, 2).map_err(message)?;
    assert_eq!((img.width(), img.height()), WARP_SIZE, "warped image size");
    let grid = warp::draw_grid(img, &warp).map_err(message)?;
    assert_eq!((grid.width(), grid.height()), WARP_SIZE, "grid image size");
    let decoded = decoder::read(WARP_INPUT, u64::MAX).expect("the warp input");
    let img = warp::warp_decoded(&decoded, &warp, 1).map_err(message)?;
    assert_eq!((img.width(), img.height()), WARP_SIZE, "warped caoen size");
    Ok(())
}
