//! The conformance vectors (`tests/conformance/`): small `.cae` files that pin what a
//! file means, and the checksums of their decoded pixels (`vectors.tsv`).
//!
//! Every vector is decoded at its own size and at one other, and the CRC-32 of the
//! interleaved samples is compared with the recorded one (the definition is in
//! `tests/conformance/README.md`). The list and the folder must hold the same files.
//! The test also reads what each file exercises from the file itself (sections,
//! header fields, restoration, detail layer) and compares it with the list, checks that
//! the vectors together cover every part of the format, and that `docs/format.md`
//! names the version this decoder reads.
//!
//! After a deliberate change of the format or of the decoder's output:
//!
//! ```text
//! CAOEN_BLESS=1 cargo test -p caoen-decoder --test conformance
//! ```
//!
//! rewrites `vectors.tsv` and the table of `README.md` from the files (a file missing
//! from the list is added, decoded at 3/2 of its size per side as its other size).
//! The files themselves were made by the encoder: `make_vectors` below, run on demand,
//! writes them again into a folder (they are not rewritten in place: a vector is a
//! fixed file, and a later encoder makes other bytes).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use caoen_base::raster::{quantise, ChannelLayout, Raster, SampleFormat};
use caoen_decoder::bitstream::{self, tag, Parsed};
use caoen_decoder::decoder::{self, Depth, Samples};
use caoen_decoder::{decode, inspect, DecodeOptions};

/// Fewest vectors the folder may hold.
const MIN_VECTORS: usize = 12;
/// The list of vectors, in the folder.
const LIST: &str = "vectors.tsv";
/// The folder's description, whose table is the list's.
const README: &str = "README.md";
/// The list's columns.
const COLUMNS: [&str; 10] = [
    "file",
    "bytes",
    "file_crc32",
    "width",
    "height",
    "crc32",
    "other_width",
    "other_height",
    "other_crc32",
    "exercises",
];
/// The README's table lies between these lines.
const TABLE_BEGIN: &str = "<!-- vectors: begin (CAOEN_BLESS=1 rewrites this table) -->";
const TABLE_END: &str = "<!-- vectors: end -->";

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn folder() -> PathBuf {
    repo().join("tests/conformance")
}

fn blessing() -> bool {
    std::env::var_os("CAOEN_BLESS").is_some_and(|v| v == "1")
}

/// One line of the list.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Vector {
    file: String,
    /// Bytes of the file.
    bytes: usize,
    /// CRC-32 of the file's bytes.
    file_crc: u32,
    /// The image's size: the header's display size, else its coded size.
    size: (u32, u32),
    /// CRC-32 of the samples decoded at `size`.
    crc: u32,
    /// The other size it is decoded at.
    other: (u32, u32),
    /// CRC-32 of the samples decoded at `other`.
    other_crc: u32,
    /// What the file exercises, as [`describe`] reads it from the file.
    exercises: String,
}

impl Vector {
    fn to_line(&self) -> String {
        format!(
            "{}\t{}\t{:08x}\t{}\t{}\t{:08x}\t{}\t{}\t{:08x}\t{}",
            self.file,
            self.bytes,
            self.file_crc,
            self.size.0,
            self.size.1,
            self.crc,
            self.other.0,
            self.other.1,
            self.other_crc,
            self.exercises
        )
    }

    fn parse(line: &str) -> Result<Vector, String> {
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() != COLUMNS.len() {
            return Err(format!(
                "{} columns, expected {}: {line:?}",
                f.len(),
                COLUMNS.len()
            ));
        }
        let int = |i: usize| -> Result<u32, String> {
            f[i].parse()
                .map_err(|e| format!("column {} of {line:?}: {e}", COLUMNS[i]))
        };
        let hex = |i: usize| -> Result<u32, String> {
            u32::from_str_radix(f[i], 16)
                .map_err(|e| format!("column {} of {line:?}: {e}", COLUMNS[i]))
        };
        Ok(Vector {
            file: f[0].to_string(),
            bytes: int(1)? as usize,
            file_crc: hex(2)?,
            size: (int(3)?, int(4)?),
            crc: hex(5)?,
            other: (int(6)?, int(7)?),
            other_crc: hex(8)?,
            exercises: f[9].to_string(),
        })
    }
}

/// The list: its lines in order (`#` lines and the column names skipped).
fn read_list() -> Vec<Vector> {
    let text = std::fs::read_to_string(folder().join(LIST))
        .unwrap_or_else(|e| panic!("tests/conformance/{LIST}: {e}"));
    let mut lines = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty());
    assert_eq!(
        lines.next(),
        Some(COLUMNS.join("\t").as_str()),
        "the first line of {LIST} names its columns"
    );
    lines
        .map(|l| Vector::parse(l).unwrap_or_else(|e| panic!("{LIST}: {e}")))
        .collect()
}

fn write_list(vectors: &[Vector]) {
    let mut text = String::from(
        "# The conformance vectors and the CRC-32 of their decoded samples (README.md).\n\
         # Rewritten by `CAOEN_BLESS=1 cargo test -p caoen-decoder --test conformance`.\n",
    );
    text.push_str(&COLUMNS.join("\t"));
    text.push('\n');
    for v in vectors {
        text.push_str(&v.to_line());
        text.push('\n');
    }
    std::fs::write(folder().join(LIST), text).expect("write the list");
}

/// The `.cae` files in the folder, sorted.
fn files() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(folder())
        .expect("tests/conformance/")
        .map(|e| e.expect("a folder entry").file_name())
        .filter_map(|n| n.to_str().map(str::to_string))
        .filter(|n| n.ends_with(".cae"))
        .collect();
    names.sort();
    names
}

/// The checksum of a decoded image: CRC-32 (IEEE 802.3, as zlib's `crc32`) of its
/// samples interleaved (rows top to bottom, pixels left to right, each pixel's
/// channels in order), each sample in the bytes of the image's sample format: 8-bit
/// as one byte `round(clamp(v, 0, 1) * 255)`, 16-bit as two bytes little-endian
/// `round(clamp(v, 0, 1) * 65535)` (halves away from zero), float as the four bytes
/// of its IEEE 754 binary32 value, little-endian.
fn sample_bytes(img: &Raster) -> Vec<u8> {
    let n = img.pixel_count();
    let channels = img.layout().channels();
    let s = img.samples();
    let mut out = Vec::with_capacity(n * channels * 4);
    for i in 0..n {
        for c in 0..channels {
            let v = s[c * n + i];
            match img.format() {
                SampleFormat::U8 => out.push(quantise(v, 255.0) as u8),
                SampleFormat::U16 => out.extend((quantise(v, 65535.0) as u16).to_le_bytes()),
                SampleFormat::F32 => out.extend(v.to_le_bytes()),
            }
        }
    }
    out
}

/// Decodes `bytes` at `size` and returns the checksum of the samples; for integer
/// formats, checks that the decoder's own interleaved output has the same bytes.
fn checksum(name: &str, bytes: &[u8], size: (u32, u32)) -> Result<u32, String> {
    let opts = DecodeOptions {
        size: Some(size),
        ..Default::default()
    };
    let img = decode(bytes, &opts).map_err(|e| format!("{name} at {size:?}: {e}"))?;
    if (img.width(), img.height()) != size {
        return Err(format!(
            "{name}: asked for {size:?}, decoded {}x{}",
            img.width(),
            img.height()
        ));
    }
    let samples = sample_bytes(&img);
    let depth = match img.format() {
        SampleFormat::U8 => Some(Depth::Eight),
        SampleFormat::U16 => Some(Depth::Sixteen),
        SampleFormat::F32 => None,
    };
    if let Some(depth) = depth {
        let il = decoder::decode_interleaved(bytes, &opts, depth)
            .map_err(|e| format!("{name} at {size:?}, interleaved: {e}"))?;
        let il: Vec<u8> = match il.samples {
            Samples::U8(s) => s,
            Samples::U16(s) => s.iter().flat_map(|v| v.to_le_bytes()).collect(),
        };
        if il != samples {
            return Err(format!(
                "{name} at {size:?}: the interleaved decode differs from the raster's samples"
            ));
        }
    }
    Ok(crc32fast::hash(&samples))
}

/// What a file exercises, read from the file: space-separated `key=value` items.
///
/// `channels`, `format`; `sections` (the tags in order, `G*n` for `n` tiles);
/// `tiles` (`columns x rows / side`); `size` (the image) and `coded` (the coded size);
/// `tree` (root and smallest cell, log2); `kernel` (footprint and weight exponent);
/// `chroma` (`pruned` or `luma-tree`, colour images only); `basis` (`grey` or `luma`,
/// RGB only); `steps` (`level` or `flat`); `detail` (`none`, or the layer's options
/// among `deblock`, `adaptive`, `field<r>`, `lapped`, `weighted`); `merged` (level-1
/// and level-2 groups coded), `factors` (chroma blocks with a luma factor) and
/// `field` (regions with a nonzero exponent) when the layer is there; `restoration`
/// (`none`, or the planes filtered, each with its number of filters and `c` when
/// classified, then `map` and `last`); `dering` (`none`, or `luma` and `chroma`);
/// `metadata` (the items' sizes).
fn describe(bytes: &[u8]) -> Result<String, String> {
    let parsed: Parsed = inspect(bytes).map_err(|e| e.to_string())?;
    let h = &parsed.header;
    let mut items: Vec<String> = Vec::new();
    let mut put = |k: &str, v: String| items.push(format!("{k}={v}"));
    put(
        "channels",
        match h.layout {
            ChannelLayout::Grey => "grey",
            ChannelLayout::GreyAlpha => "grey+alpha",
            ChannelLayout::Rgb => "rgb",
            ChannelLayout::Rgba => "rgba",
        }
        .into(),
    );
    put(
        "format",
        match h.format {
            SampleFormat::U8 => "8-bit",
            SampleFormat::U16 => "16-bit",
            SampleFormat::F32 => "float",
        }
        .into(),
    );
    let mut tags: Vec<String> = Vec::new();
    let mut i = 0;
    while i < parsed.sections.len() {
        let t = parsed.sections[i].tag;
        let run = parsed.sections[i..]
            .iter()
            .take_while(|s| s.tag == t)
            .count();
        tags.push(if run > 1 {
            format!("{}*{run}", t as char)
        } else {
            (t as char).to_string()
        });
        i += run;
    }
    put("sections", tags.join(","));
    let tiling = h.tiling();
    put(
        "tiles",
        format!("{}x{}/{}", tiling.columns(), tiling.rows(), h.tile_side),
    );
    let (dw, dh) = h.display_size();
    put("size", format!("{dw}x{dh}"));
    put("coded", format!("{}x{}", h.width, h.height));
    put("tree", format!("{}/{}", h.block_log2, h.min_log2));
    put(
        "kernel",
        format!("{}/{}", h.kernel.sigma_factor, h.kernel.weight_exponent),
    );
    if h.layout.colour_channels() == 3 {
        put(
            "chroma",
            if h.chroma_pruned {
                "pruned"
            } else {
                "luma-tree"
            }
            .into(),
        );
        put(
            "basis",
            match h.basis {
                caoen_decoder::ColourBasis::Grey => "grey",
                caoen_decoder::ColourBasis::Luma => "luma",
            }
            .into(),
        );
    }
    put("steps", if h.level_steps { "level" } else { "flat" }.into());
    let mut detail = Vec::new();
    if h.deblock.is_some() {
        detail.push("deblock".to_string());
    }
    if let Some(a) = h.adaptive {
        detail.push("adaptive".into());
        if a.field_log2 > 0 {
            detail.push(format!("field{}", a.field_log2));
        }
    }
    if h.lapping.is_some() {
        detail.push("lapped".into());
    }
    if h.weights.is_some() {
        detail.push("weighted".into());
    }
    if h.detail_steps.is_none() {
        put("detail", "none".into());
    } else {
        put(
            "detail",
            if detail.is_empty() {
                "plain".into()
            } else {
                detail.join(",")
            },
        );
        let d = decoder::read(bytes, u64::MAX).map_err(|e| e.to_string())?;
        let layer = d.detail.as_ref().ok_or("a header with a layer, no layer")?;
        let mut merged = [0usize; 2];
        let mut factors = 0;
        for p in &layer.planes {
            for b in 0..p.merged.len() {
                if p.merged[b] != 0 && p.coded_block_of(b) == b {
                    merged[usize::from(p.merged[b]) - 1] += 1;
                }
            }
            factors += p.factors.iter().filter(|&&a| a != 0).count();
        }
        put("merged", format!("{}/{}", merged[0], merged[1]));
        if h.layout.colour_channels() == 3 {
            put("factors", factors.to_string());
        }
        if let Some(f) = layer.block_steps.as_ref().filter(|b| !b.field.is_empty()) {
            put(
                "field",
                f.field.iter().filter(|&&e| e != 0).count().to_string(),
            );
        }
    }
    match &h.restoration {
        None => put("restoration", "none".into()),
        Some(r) => {
            let plane = |name: &str, p: &caoen_decoder::restoration::PlaneFilter| {
                format!(
                    "{name}:{}{}",
                    p.filters.len(),
                    if p.classes.is_some() { "c" } else { "" }
                )
            };
            let mut parts: Vec<String> = r
                .planes
                .iter()
                .zip(["Y", "C1", "C2"])
                .filter_map(|(p, name)| p.as_ref().map(|p| plane(name, p)))
                .collect();
            if r.colour.is_some() {
                parts.push("map".into());
            }
            if let Some(l) = &r.last {
                parts.push(plane("last", l));
            }
            put("restoration", parts.join(","));
        }
    }
    match h.deringing {
        None => put("dering", "none".into()),
        Some(d) => {
            let mut kinds = Vec::new();
            if d.luma.is_on() {
                kinds.push("luma");
            }
            if d.chroma.is_on() {
                kinds.push("chroma");
            }
            put("dering", kinds.join(","));
        }
    }
    let meta = parsed.metadata();
    let sizes: Vec<String> = [("icc", &meta.icc), ("exif", &meta.exif), ("xmp", &meta.xmp)]
        .iter()
        .filter_map(|(k, m)| m.as_ref().map(|m| format!("{k}:{}", m.len())))
        .collect();
    if !sizes.is_empty() {
        put("metadata", sizes.join(","));
    }
    Ok(items.join(" "))
}

/// The items of a description as a map.
fn items(exercises: &str) -> BTreeMap<&str, &str> {
    exercises
        .split(' ')
        .map(|kv| kv.split_once('=').unwrap_or((kv, "")))
        .collect()
}

/// Everything the test finds for one file, or what went wrong.
fn measure(name: &str, other: Option<(u32, u32)>) -> Result<Vector, String> {
    let bytes = std::fs::read(folder().join(name)).map_err(|e| format!("{name}: {e}"))?;
    let parsed = inspect(&bytes).map_err(|e| format!("{name}: inspect: {e}"))?;
    let size = parsed.header.display_size();
    let other = other.unwrap_or(((size.0 * 3).div_ceil(2), (size.1 * 3).div_ceil(2)));
    Ok(Vector {
        file: name.to_string(),
        bytes: bytes.len(),
        file_crc: crc32fast::hash(&bytes),
        size,
        crc: checksum(name, &bytes, size)?,
        other,
        other_crc: checksum(name, &bytes, other)?,
        exercises: describe(&bytes).map_err(|e| format!("{name}: {e}"))?,
    })
}

/// Every vector decodes to its recorded checksums at both of its sizes, the header
/// reports the listed size, and the list and the folder hold the same files.
#[test]
fn vectors_decode_to_their_checksums() {
    let files = files();
    if blessing() {
        let old: BTreeMap<String, (u32, u32)> = if folder().join(LIST).exists() {
            read_list().into_iter().map(|v| (v.file, v.other)).collect()
        } else {
            BTreeMap::new()
        };
        let vectors: Vec<Vector> = files
            .iter()
            .map(|f| measure(f, old.get(f).copied()).unwrap_or_else(|e| panic!("{e}")))
            .collect();
        write_list(&vectors);
        write_readme_table(&vectors);
        eprintln!("blessed {} vectors", vectors.len());
        let gaps = coverage_gaps(&vectors);
        assert!(
            gaps.is_empty(),
            "the vectors do not cover: {}",
            gaps.join(", ")
        );
        return;
    }
    let list = read_list();
    let listed: Vec<String> = list.iter().map(|v| v.file.clone()).collect();
    let mut failures = Vec::new();
    let mut sorted = listed.clone();
    sorted.sort();
    sorted.dedup();
    if sorted.len() != listed.len() {
        failures.push(format!("{LIST} names a file twice"));
    }
    for f in &files {
        if !listed.contains(f) {
            failures.push(format!("{f} is in tests/conformance/ but not in {LIST}"));
        }
    }
    for v in &list {
        if !files.contains(&v.file) {
            failures.push(format!(
                "{} is in {LIST} but not in tests/conformance/",
                v.file
            ));
            continue;
        }
        match measure(&v.file, Some(v.other)) {
            Err(e) => failures.push(e),
            Ok(found) => {
                if found != *v {
                    failures.push(format!(
                        "{}:\n  listed: {}\n  found:  {}",
                        v.file,
                        v.to_line(),
                        found.to_line()
                    ));
                }
            }
        }
    }
    if list.len() < MIN_VECTORS {
        failures.push(format!(
            "{} vectors listed, at least {MIN_VECTORS} required",
            list.len()
        ));
    }
    assert!(
        failures.is_empty(),
        "{} conformance failures (after a deliberate format change: CAOEN_BLESS=1):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The README's table, rendered from the list.
fn readme_table(vectors: &[Vector]) -> String {
    let mut t = String::from(
        "| file | bytes | image size | CRC-32 at image size | other size | CRC-32 at other size | exercises |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for v in vectors {
        writeln!(
            t,
            "| `{}` | {} | {}x{} | `{:08x}` | {}x{} | `{:08x}` | `{}` |",
            v.file,
            v.bytes,
            v.size.0,
            v.size.1,
            v.crc,
            v.other.0,
            v.other.1,
            v.other_crc,
            v.exercises
        )
        .expect("a string");
    }
    t
}

fn read_readme() -> String {
    std::fs::read_to_string(folder().join(README))
        .unwrap_or_else(|e| panic!("tests/conformance/{README}: {e}"))
}

/// The README's text between the table's markers.
fn table_span(readme: &str) -> std::ops::Range<usize> {
    let begin = readme
        .find(TABLE_BEGIN)
        .unwrap_or_else(|| panic!("{README} has no line {TABLE_BEGIN}"))
        + TABLE_BEGIN.len()
        + 1;
    let end = readme
        .find(TABLE_END)
        .unwrap_or_else(|| panic!("{README} has no line {TABLE_END}"));
    begin..end
}

fn write_readme_table(vectors: &[Vector]) {
    let mut readme = read_readme();
    let span = table_span(&readme);
    readme.replace_range(span, &readme_table(vectors));
    std::fs::write(folder().join(README), readme).expect("write the README");
}

/// The README's table is the list's, and the README says how each file was made.
#[test]
fn readme_shows_the_list() {
    if blessing() {
        return;
    }
    let readme = read_readme();
    let list = read_list();
    assert_eq!(
        &readme[table_span(&readme)],
        readme_table(&list),
        "{README}'s table is not {LIST}'s (CAOEN_BLESS=1 rewrites it)"
    );
    let rest = readme.replace(&readme[table_span(&readme)], "");
    for v in &list {
        assert!(
            rest.contains(&format!("`{}`", v.file)),
            "{README} does not say how {} was made",
            v.file
        );
    }
}

/// Together the vectors cover every section, sample format, channel layout and
/// option of the format, each option both on and off.
#[test]
fn vectors_cover_the_format() {
    if blessing() {
        // The blessing checks what it writes.
        return;
    }
    let gaps = coverage_gaps(&read_list());
    assert!(
        gaps.is_empty(),
        "the vectors do not cover: {}",
        gaps.join(", ")
    );
}

/// What of the format `list` leaves out.
fn coverage_gaps(list: &[Vector]) -> Vec<String> {
    let all: Vec<BTreeMap<&str, &str>> = list.iter().map(|v| items(&v.exercises)).collect();
    let mut missing = Vec::new();
    let mut need = |what: &str, found: bool| {
        if !found {
            missing.push(what.to_string());
        }
    };
    let any = |f: &dyn Fn(&BTreeMap<&str, &str>) -> bool| all.iter().any(f);
    let has = |m: &BTreeMap<&str, &str>, k: &str, part: &str| {
        m.get(k)
            .is_some_and(|v| v.split(',').any(|p| p.starts_with(part)))
    };
    for t in ["H", "I", "X", "M", "G", "R", "E"] {
        need(&format!("section {t}"), any(&|m| has(m, "sections", t)));
    }
    need("several tiles", any(&|m| has(m, "sections", "G*")));
    for c in ["grey", "grey+alpha", "rgb", "rgba"] {
        for f in ["8-bit", "16-bit", "float"] {
            need(
                &format!("{c} {f}"),
                any(&|m| m["channels"] == c && m["format"] == f),
            );
        }
    }
    need(
        "a coded size below the image's",
        any(&|m| m["size"] != m["coded"]),
    );
    need(
        "the image's own coded size",
        any(&|m| m["size"] == m["coded"]),
    );
    need(
        "a file without the detail layer",
        any(&|m| m["detail"] == "none"),
    );
    for o in ["deblock", "adaptive", "field", "lapped", "weighted"] {
        need(&format!("detail {o}"), any(&|m| has(m, "detail", o)));
        need(
            &format!("a detail layer without {o}"),
            any(&|m| m["detail"] != "none" && !has(m, "detail", o)),
        );
    }
    need(
        "regions with nonzero activity exponents",
        any(&|m| m.get("field").is_some_and(|&n| n != "0")),
    );
    need(
        "merged level-1 groups",
        any(&|m| m.get("merged").is_some_and(|v| !v.starts_with("0/"))),
    );
    need(
        "merged level-2 groups",
        any(&|m| m.get("merged").is_some_and(|v| !v.ends_with("/0"))),
    );
    need(
        "luma factors",
        any(&|m| m.get("factors").is_some_and(|&n| n != "0")),
    );
    for (k, v) in [
        ("chroma", "pruned"),
        ("chroma", "luma-tree"),
        ("basis", "grey"),
        ("basis", "luma"),
        ("steps", "level"),
        ("steps", "flat"),
    ] {
        need(&format!("{k} {v}"), any(&|m| m.get(k) == Some(&v)));
    }
    need("restoration Y", any(&|m| has(m, "restoration", "Y:")));
    need("restoration C1 or C2", any(&|m| has(m, "restoration", "C")));
    need(
        "classified filters",
        any(&|m| m["restoration"].contains("c")),
    );
    need("the colour map", any(&|m| has(m, "restoration", "map")));
    need("last luma filters", any(&|m| has(m, "restoration", "last")));
    need("no restoration", any(&|m| m["restoration"] == "none"));
    need("luma deringing", any(&|m| has(m, "dering", "luma")));
    need("chroma deringing", any(&|m| has(m, "dering", "chroma")));
    need("no deringing", any(&|m| m["dering"] == "none"));
    need(
        "another root block size",
        any(&|m| !m["tree"].starts_with("5/")),
    );
    need("another kernel", any(&|m| m["kernel"] != "0.5/0"));
    missing
}

/// `docs/format.md` names the version this decoder reads, in its title and in the
/// container's layout.
#[test]
fn format_document_has_the_code_version() {
    let doc = std::fs::read_to_string(repo().join("docs/format.md")).expect("docs/format.md");
    let title = doc.lines().next().expect("a title");
    let version = title
        .strip_prefix("# The caoen file format, version ")
        .unwrap_or_else(|| panic!("the title {title:?} names no version"));
    assert_eq!(
        version.trim().parse::<u8>().ok(),
        Some(bitstream::VERSION),
        "docs/format.md's title {title:?}"
    );
    let lines: Vec<&str> = doc
        .lines()
        .filter(|l| l.trim_start().starts_with("version") && l.contains("u8"))
        .collect();
    assert_eq!(lines.len(), 1, "one container version line: {lines:?}");
    let field: Vec<&str> = lines[0].split_whitespace().collect();
    assert_eq!(
        field,
        ["version", "u8", &bitstream::VERSION.to_string()],
        "docs/format.md's container version line"
    );
    assert_eq!(bitstream::MAGIC, *b"CAOE");
    assert!(doc.contains("magic    4 bytes   \"CAOE\""));
    // The section tags, in the order the code requires them.
    let order = [
        tag::HEADER,
        tag::ICC,
        tag::EXIF,
        tag::XMP,
        tag::TILE,
        tag::RESTORATION,
        tag::END,
    ];
    let rows: Vec<u8> = doc
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once("` |"))
        .filter(|(t, _)| t.len() == 1)
        .map(|(t, _)| t.as_bytes()[0])
        .collect();
    assert_eq!(rows, order, "docs/format.md's table of sections");
}

/// Writes the vectors again with this encoder into `$CAOEN_CONFORMANCE_MAKE` (a folder):
/// how the committed files were made (with the encoder of commit `bc90f4a`; a later
/// encoder may make other bytes, which are no less valid). Run with
/// `CAOEN_CONFORMANCE_MAKE=/tmp/vectors cargo test -p caoen-decoder --test conformance
/// -- --ignored make_vectors`.
#[test]
#[ignore = "makes the vector files on demand"]
fn make_vectors() {
    let Some(out) = std::env::var_os("CAOEN_CONFORMANCE_MAKE") else {
        panic!("set CAOEN_CONFORMANCE_MAKE to the folder to write the vectors into");
    };
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out).expect("the output folder");
    let only: Option<BTreeSet<String>> = std::env::var("CAOEN_CONFORMANCE_ONLY")
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect());
    for r in make::recipes() {
        if only.as_ref().is_some_and(|o| !o.contains(&r.file)) {
            continue;
        }
        let bytes = (r.make)();
        let d = describe(&bytes).expect("the encoder's file");
        eprintln!("{} ({} bytes): {d}", r.file, bytes.len());
        std::fs::write(out.join(&r.file), bytes).expect("write a vector");
    }
}

/// The sources and encoder settings of the vectors.
mod make {
    use caoen_base::metadata::Metadata;
    use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};
    use caoen_encoder::{encoder, rate_control, EncodeOptions, Resampling, Scale};

    /// One vector: its file and how it is made.
    pub struct Recipe {
        pub file: String,
        pub make: Box<dyn Fn() -> Vec<u8>>,
    }

    /// A hash of `(x, y, k)` in [-0.5, 0.5).
    fn noise(x: u32, y: u32, k: u32) -> f64 {
        let mut h =
            x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ k.wrapping_mul(0xC2B2_AE3D);
        h ^= h >> 15;
        h = h.wrapping_mul(0x2C1B_3C6D);
        h ^= h >> 12;
        h = h.wrapping_mul(0x297A_2D39);
        h ^= h >> 15;
        f64::from(h) / 4_294_967_296.0 - 0.5
    }

    fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
        std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
    }

    /// A picture with something of everything a photograph has, at pixel `(x, y)` of a
    /// `w x h` image: a smooth sky-to-ground gradient, a shaded sphere, a hard-edged
    /// tilted rectangle, stripes, a thin line and a little noise; and an alpha: opaque
    /// inside a rounded rectangle, a soft edge, a transparent margin and a ramp.
    fn scene(x: u32, y: u32, w: u32, h: u32) -> ([f64; 3], f64) {
        let (px, py) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
        let (fw, fh) = (f64::from(w), f64::from(h));
        let (u, v) = (px / fw, py / fh);
        let s = fw.min(fh);
        let mut c = mix([0.45, 0.62, 0.92], [0.55, 0.48, 0.30], v);
        // Stripes along the bottom.
        if v > 0.72 {
            let t = 0.5 + 0.5 * (px * 1.1 + py * 0.35).sin();
            c = mix(c, [0.30, 0.22, 0.12], 0.6 * t);
        }
        // A shaded sphere.
        let (dx, dy) = (px - 0.32 * fw, py - 0.45 * fh);
        let r = 0.28 * s;
        let d = (dx * dx + dy * dy).sqrt();
        let cover = (r - d + 0.5).clamp(0.0, 1.0);
        if cover > 0.0 {
            let z = (1.0 - (d / r).min(1.0).powi(2)).sqrt();
            let light = 0.25 + 0.75 * (z * 0.8 - dx / r * 0.3 - dy / r * 0.4).max(0.0);
            c = mix(c, [0.85 * light, 0.25 * light, 0.18 * light], cover);
        }
        // A tilted rectangle with hard edges.
        let (rx, ry) = (px - 0.70 * fw, py - 0.40 * fh);
        let (a, b) = (0.94 * rx + 0.34 * ry, -0.34 * rx + 0.94 * ry);
        if a.abs() < 0.16 * fw && b.abs() < 0.22 * fh {
            c = [0.12, 0.55, 0.35];
        }
        // A thin dark line.
        let line = (py - (0.15 * fh + 0.3 * px)).abs();
        if line < 0.8 && u > 0.05 {
            c = mix(c, [0.05, 0.05, 0.08], 0.8);
        }
        let c = std::array::from_fn(|i| (c[i] + 0.03 * noise(x, y, i as u32)).clamp(0.0, 1.0));
        // Alpha: a rounded rectangle with soft edges, fading to the right.
        let (ax, ay) = ((u - 0.5).abs() - 0.38, (v - 0.5).abs() - 0.36);
        let out = (ax.max(0.0).hypot(ay.max(0.0)) + ax.max(ay).min(0.0)) * s;
        let alpha = ((0.5 - out / 2.0).clamp(0.0, 1.0) * (1.2 - 0.6 * u).min(1.0)).clamp(0.0, 1.0);
        (c, alpha)
    }

    /// Only the smooth gradient: nothing the network cannot carry alone.
    fn smooth(x: u32, y: u32, w: u32, h: u32) -> ([f64; 3], f64) {
        let (u, v) = (
            (f64::from(x) + 0.5) / f64::from(w),
            (f64::from(y) + 0.5) / f64::from(h),
        );
        let c = mix([0.2, 0.3, 0.5], [0.7, 0.6, 0.4], 0.6 * u + 0.4 * v);
        (c, 1.0)
    }

    type Picture = fn(u32, u32, u32, u32) -> ([f64; 3], f64);

    /// A source raster of `picture` in `layout` and `format`: integer formats as their
    /// files store them (rounded to 8 or 16 bits), float ones as linear light over a
    /// range of more than 1000:1 (the sphere's highlight far above 1).
    pub fn source(
        picture: Picture,
        (w, h): (u32, u32),
        layout: ChannelLayout,
        format: SampleFormat,
    ) -> Raster {
        let n = (w * h) as usize;
        let channels = layout.channels();
        let mut samples = vec![0f32; n * channels];
        for y in 0..h {
            for x in 0..w {
                let (c, a) = picture(x, y, w, h);
                let grey = 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2];
                let colour: Vec<f64> = match layout.colour_channels() {
                    1 => vec![grey],
                    _ => c.to_vec(),
                };
                let i = (y * w + x) as usize;
                for (k, &v) in colour.iter().enumerate() {
                    let v = match format {
                        SampleFormat::U8 => (v * 255.0).round() / 255.0,
                        SampleFormat::U16 => (v * 65535.0).round() / 65535.0,
                        // Display values to linear light, and a highlight.
                        SampleFormat::F32 => {
                            let lin = v.powf(2.2) * 4.0;
                            let hx = f64::from(x) - 0.26 * f64::from(w);
                            let hy = f64::from(y) - 0.36 * f64::from(h);
                            let spot = (-(hx * hx + hy * hy) / 6.0).exp();
                            lin + 400.0 * spot
                        }
                    };
                    samples[k * n + i] = v as f32;
                }
                if layout.has_alpha() {
                    let a = match format {
                        SampleFormat::U8 => (a * 255.0).round() / 255.0,
                        SampleFormat::U16 => (a * 65535.0).round() / 65535.0,
                        SampleFormat::F32 => a,
                    };
                    samples[(channels - 1) * n + i] = a as f32;
                }
            }
        }
        Raster::new(w, h, layout, format, samples).expect("a valid source")
    }

    /// `caoen_encoder::encode` at quality `q`, effort 5, with `resampling` and
    /// `metadata` (what `caoen encode -q Q --resampling R` does with an image file).
    fn encode(src: &Raster, q: f32, resampling: Resampling, metadata: Metadata) -> Vec<u8> {
        let opts = EncodeOptions {
            quality: q,
            effort: 5,
            resampling,
            metadata,
            ..EncodeOptions::default()
        };
        caoen_encoder::encode(src, &opts).expect("encode")
    }

    /// A minimal ICC v2 profile structure (header and tag table, a white point and a
    /// description): the decoder passes it on unread.
    fn icc() -> Vec<u8> {
        let mut p = vec![0u8; 128];
        p[8..12].copy_from_slice(&0x0210_0000u32.to_be_bytes());
        p[12..16].copy_from_slice(b"mntr");
        p[16..20].copy_from_slice(b"RGB ");
        p[20..24].copy_from_slice(b"XYZ ");
        p[36..40].copy_from_slice(b"acsp");
        // Rendering intent 0; the PCS illuminant D50.
        for (i, v) in [0x0000_F6D6u32, 0x0001_0000, 0x0000_D32D]
            .iter()
            .enumerate()
        {
            p[68 + 4 * i..72 + 4 * i].copy_from_slice(&v.to_be_bytes());
        }
        let desc: &[u8] = b"caoen conformance";
        let mut desc_tag = b"desc\0\0\0\0".to_vec();
        desc_tag.extend((desc.len() as u32 + 1).to_be_bytes());
        desc_tag.extend(desc);
        desc_tag.push(0);
        desc_tag.extend([0u8; 4 + 4 + 2 + 1 + 67]);
        let mut wtpt = b"XYZ \0\0\0\0".to_vec();
        for v in [0x0000_F6D6u32, 0x0001_0000, 0x0000_D32D] {
            wtpt.extend(v.to_be_bytes());
        }
        let table = 4 + 2 * 12;
        let desc_at = 128 + table;
        let wtpt_at = (desc_at + desc_tag.len()).next_multiple_of(4);
        p.extend(2u32.to_be_bytes());
        for (sig, at, len) in [
            (b"desc", desc_at, desc_tag.len()),
            (b"wtpt", wtpt_at, wtpt.len()),
        ] {
            p.extend(sig);
            p.extend((at as u32).to_be_bytes());
            p.extend((len as u32).to_be_bytes());
        }
        p.extend(&desc_tag);
        p.resize(wtpt_at, 0);
        p.extend(&wtpt);
        let len = p.len() as u32;
        p[..4].copy_from_slice(&len.to_be_bytes());
        p
    }

    /// EXIF as a TIFF structure: little-endian, one IFD with the orientation (1).
    fn exif() -> Vec<u8> {
        let mut e = b"II*\0".to_vec();
        e.extend(8u32.to_le_bytes());
        e.extend(1u16.to_le_bytes());
        e.extend(0x0112u16.to_le_bytes());
        e.extend(3u16.to_le_bytes());
        e.extend(1u32.to_le_bytes());
        e.extend([1, 0, 0, 0]);
        e.extend(0u32.to_le_bytes());
        e
    }

    fn xmp() -> Vec<u8> {
        concat!(
            "<?xpacket begin=\"\u{feff}\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>",
            "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF ",
            "xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">",
            "<rdf:Description rdf:about=\"\" xmlns:dc=\"http://purl.org/dc/elements/1.1/\">",
            "<dc:title><rdf:Alt><rdf:li xml:lang=\"x-default\">caoen conformance</rdf:li>",
            "</rdf:Alt></dc:title></rdf:Description></rdf:RDF></x:xmpmeta>",
            "<?xpacket end=\"w\"?>"
        )
        .as_bytes()
        .to_vec()
    }

    pub fn recipes() -> Vec<Recipe> {
        use ChannelLayout::*;
        use SampleFormat::*;
        let plain = |file: &str,
                     picture: Picture,
                     size: (u32, u32),
                     layout: ChannelLayout,
                     format: SampleFormat,
                     q: f32| Recipe {
            file: file.to_string(),
            make: Box::new(move || {
                encode(
                    &source(picture, size, layout, format),
                    q,
                    Resampling::Off,
                    Metadata::default(),
                )
            }),
        };
        // Every channel layout in every sample format, named after both and the size:
        // per format, the width, height and quality of grey, grey+alpha, RGB and RGBA.
        let every = [
            (
                U8,
                [
                    (64, 48, 75.0),
                    (61, 45, 70.0),
                    (128, 96, 75.0),
                    (77, 53, 65.0),
                ],
            ),
            (
                U16,
                [
                    (64, 48, 85.0),
                    (48, 40, 60.0),
                    (96, 64, 60.0),
                    (64, 48, 80.0),
                ],
            ),
            (
                F32,
                [
                    (48, 32, 75.0),
                    (40, 32, 70.0),
                    (64, 48, 75.0),
                    (48, 36, 60.0),
                ],
            ),
        ];
        let layouts = [
            (Grey, "grey"),
            (GreyAlpha, "greyalpha"),
            (Rgb, "rgb"),
            (Rgba, "rgba"),
        ];
        let mut recipes = Vec::new();
        for (format, sizes) in every {
            let format_name = match format {
                U8 => "8",
                U16 => "16",
                F32 => "float",
            };
            for ((layout, layout_name), (w, h, q)) in layouts.into_iter().zip(sizes) {
                let file = format!("{layout_name}{format_name}-{w}x{h}.cae");
                recipes.push(plain(&file, scene, (w, h), layout, format, q));
            }
        }
        recipes.extend([
            // A smooth picture at a low quality: merged groups of 32x32 pixels.
            plain("rgb8-smooth-q10-48x32.cae", smooth, (48, 32), Rgb, U8, 10.0),
            // Detail steps adapted to the cells but no activity field (quality 40).
            plain("grey8-q40-64x64.cae", scene, (64, 64), Grey, U8, 40.0),
            // Three tiles of 512 pixels (the encoder tiles images wider than 1024).
            plain("rgb8-tiles-1060x24.cae", scene, (1060, 24), Rgb, U8, 50.0),
            Recipe {
                file: "rgb8-metadata-64x48.cae".to_string(),
                make: Box::new(|| {
                    let md = Metadata {
                        icc: Some(icc()),
                        exif: Some(exif()),
                        xmp: Some(xmp()),
                    };
                    encode(&source(scene, (64, 48), Rgb, U8), 50.0, Resampling::Off, md)
                }),
            },
            Recipe {
                file: "rgb8-half-128x96.cae".to_string(),
                make: Box::new(|| {
                    let src = source(scene, (128, 96), Rgb, U8);
                    encode(&src, 45.0, Resampling::At(Scale::HALF), Metadata::default())
                }),
            },
            Recipe {
                file: "rgba8-tenths7-100x70.cae".to_string(),
                make: Box::new(|| {
                    let src = source(scene, (100, 70), Rgba, U8);
                    let at = Resampling::At(Scale::new(7).expect("0.7"));
                    encode(&src, 55.0, at, Metadata::default())
                }),
            },
            Recipe {
                // Quality 60's network steps on a finer tree (a fiftieth of the split
                // threshold, cells down to 4 pixels), and detail steps so coarse that
                // no block is coded: the encoder leaves the layer out.
                file: "rgb8-nodetail-64x48.cae".to_string(),
                make: Box::new(|| {
                    let src = source(scene, (64, 48), Rgb, U8);
                    let mut s = rate_control::settings(60.0, 5, None).adapted_to(U8, false);
                    s.detail_step_luma = 1000.0;
                    s.detail_step_chroma = 1000.0;
                    // A finer tree, which carries the picture alone.
                    s.model.split_threshold /= 50.0;
                    s.model.min_log2 = 2;
                    encoder::encode_with(&src, &s, &Metadata::default(), 1, |_, _| {})
                        .expect("encode")
                        .0
                }),
            },
            Recipe {
                // The encoder's settings with every choice it leaves on turned off or
                // changed: grey basis, one step for every cell, chroma on the luma
                // tree, 16-pixel roots down to 2-pixel cells, a wider footprint with
                // weights falling with the cell, a plain detail layer.
                file: "rgb8-options-80x60.cae".to_string(),
                make: Box::new(|| {
                    let src = source(scene, (80, 60), Rgb, U8);
                    let mut s = rate_control::settings(70.0, 5, None).adapted_to(U8, false);
                    s.colour_basis = caoen_decoder::ColourBasis::Grey;
                    s.level_steps = false;
                    s.model.chroma_pruned = false;
                    s.model.block_log2 = 4;
                    s.model.min_log2 = 1;
                    s.model.kernel.sigma_factor = 0.75;
                    s.model.kernel.weight_exponent = 1.0;
                    s.deblock = None;
                    s.lapping = None;
                    s.detail_adaptive = None;
                    s.detail_weights = None;
                    s.detail_field = None;
                    encoder::encode_with(&src, &s, &Metadata::default(), 1, |_, _| {})
                        .expect("encode")
                        .0
                }),
            },
        ]);
        recipes
    }
}
