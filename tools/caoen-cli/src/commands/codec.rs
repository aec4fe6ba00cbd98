//! `caoen encode`, `caoen decode`, `caoen info`: the image codec on files.

use std::path::{Path, PathBuf};
use std::time::Instant;

use caoen::codec::bitstream::{self, tag};
use caoen::codec::deringing::Strengths;
use caoen::codec::{decoder, keypoint_map, DecodeOptions, EncodeRequest, Limits, PixelSource};
use caoen::image_io::{self, transcode, DecodeToImage, FormatChoice};
use caoen::metadata::Metadata;
use caoen::raster::Raster;
use serde_json::json;

use crate::cli::{DecodeArgs, EncodeArgs, GlobalArgs, InfoArgs};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::{print, Outputs, Target};

/// Reads a `.cae` input (`-`: standard input) within the memory budget
/// ([`transcode::read_cae`]).
pub fn read_input(path: &Path, limits: &Limits) -> CliResult<Vec<u8>> {
    if path.as_os_str() == "-" {
        return transcode::read_cae(std::io::stdin().lock(), None, limits)
            .map_err(|e| CliError::io("<stdin>", e));
    }
    let file = std::fs::File::open(path).map_err(|e| CliError::io(path, e))?;
    // A regular file's size is known: one too large is refused before any read.
    let len = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    transcode::read_cae(file, len, limits).map_err(|e| CliError::io(path, e))
}

/// Loads an image file into a raster, upright by its EXIF orientation, with a clear
/// error naming the file.
pub fn load_image(path: &Path, limits: &Limits) -> CliResult<Raster> {
    load_image_with_metadata(path, limits).map(|(raster, _)| raster)
}

/// [`load_image`] with the file's metadata (its EXIF saying orientation 1).
pub fn load_image_with_metadata(path: &Path, limits: &Limits) -> CliResult<(Raster, Metadata)> {
    // Image errors name their file already.
    Ok(image_io::load_with_metadata(
        path,
        &image_io::LoadLimits::within(limits),
    )?)
}

/// The metadata a `.cae` file carries.
fn stored_metadata(parsed: &bitstream::Parsed<'_>) -> Metadata {
    parsed.metadata()
}

/// Each metadata item's presence and size (and the EXIF orientation), as JSON.
fn metadata_json(meta: &Metadata) -> serde_json::Value {
    let size = |item: &Option<Vec<u8>>| item.as_ref().map(|b| json!({"bytes": b.len()}));
    let mut exif = size(&meta.exif);
    if let (Some(v), Some(bytes)) = (exif.as_mut(), meta.exif.as_deref()) {
        v["orientation"] = caoen::metadata::orientation(bytes).ok().flatten().into();
    }
    json!({"icc": size(&meta.icc), "exif": exif, "xmp": size(&meta.xmp)})
}

/// Each metadata item's presence and size (and the EXIF orientation), as one line.
fn metadata_text(meta: &Metadata) -> String {
    if meta.is_empty() {
        return "none".into();
    }
    let mut parts = Vec::new();
    if let Some(icc) = &meta.icc {
        parts.push(format!("ICC profile {} bytes", icc.len()));
    }
    if let Some(exif) = &meta.exif {
        let orientation = match caoen::metadata::orientation(exif) {
            Ok(Some(o)) => format!("orientation {o}"),
            Ok(None) => "no orientation".into(),
            Err(e) => format!("unreadable: {e}"),
        };
        parts.push(format!("EXIF {} bytes ({orientation})", exif.len()));
    }
    if let Some(xmp) = &meta.xmp {
        parts.push(format!("XMP {} bytes", xmp.len()));
    }
    parts.join(", ")
}

/// An error encoding an image in memory for the output `path`: named after the output
/// rather than the encoder's placeholder.
pub fn encode_error(path: &Path, e: image_io::ImageIoError) -> CliError {
    CliError::Image(e.named(path))
}

fn codec_err(path: &Path, e: caoen::codec::CodecError) -> CliError {
    crate::failure::codec(path, e)
}

fn progress_bar(global: &GlobalArgs, what: &str) -> Option<indicatif::ProgressBar> {
    if global.quiet {
        return None;
    }
    let pb =
        indicatif::ProgressBar::with_draw_target(Some(1), indicatif::ProgressDrawTarget::stderr());
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    Some(pb)
}

/// The library's encode request of `caoen encode`'s options, with the metadata kept.
pub fn encode_request(global: &GlobalArgs, a: &EncodeArgs, metadata: Metadata) -> EncodeRequest {
    EncodeRequest {
        quality: a.quality,
        effort: a.effort,
        target_bpp: a.target_bpp,
        target_size: a.target_size,
        keypoints: a.keypoints,
        metadata,
        resampling: a.resampling,
        budget: global.max_memory,
    }
}

/// An image loaded for `caoen encode`, with the metadata it keeps and the encoder's
/// options.
pub struct Loaded {
    /// The pixels, compact where the file's are integers.
    pub img: image_io::EncodeSource,
    /// The metadata kept in the file.
    pub kept: Metadata,
    /// The encoder's options, within what the budget leaves beside the pixels.
    pub opts: caoen::codec::EncodeOptions,
}

/// Loads `input` as `caoen encode` does, within `limits` (the command's budget).
pub fn load_for_encode(
    global: &GlobalArgs,
    a: &EncodeArgs,
    input: &Path,
    limits: &Limits,
) -> CliResult<Loaded> {
    let load = image_io::LoadLimits {
        max_pixels: caoen::codec::DEFAULT_MAX_PIXELS,
        ..image_io::LoadLimits::within(limits)
    };
    let (img, metadata, dropped) = image_io::load_for_encoding_reporting(input, &load)?;
    let policy = a.metadata.policy(a.strip);
    // Only an item that would have been kept is worth a word.
    for d in dropped.iter().filter(|d| policy.keeps(d.item)) {
        eprintln!("warning: {}: {d}", input.display());
    }
    let kept = metadata.filtered(policy);
    // One budget for the command: what the input already holds is spent.
    let opts = encode_request(global, a, kept.clone())
        .options(img.held_bytes())
        .map_err(|e| codec_err(input, e))?;
    Ok(Loaded { img, kept, opts })
}

/// Encodes a loaded image, reporting progress as `(done, total)` steps.
pub fn encode_loaded(
    global: &GlobalArgs,
    loaded: &Loaded,
    input: &Path,
    progress: impl FnMut(usize, usize) + Send,
) -> CliResult<(Vec<u8>, caoen::codec::EncodeStats)> {
    let held = loaded.img.held_bytes();
    caoen::codec::encode_with_progress(&loaded.img, &loaded.opts, progress).map_err(|e| match e {
        // The budget is the command's: count the decoded input back in.
        caoen::codec::CodecError::Memory(mut over) => {
            over.what += " (the decoded input included)";
            over.need = over.need.saturating_add(held);
            over.budget = global.max_memory;
            codec_err(input, caoen::codec::CodecError::Memory(over))
        }
        e => codec_err(input, e),
    })
}

/// Whether `input` is a folder, to be encoded or decoded file by file; `--resume`
/// (`resume`) only means something for a folder.
fn folder_mode(input: &Path, resume: bool) -> CliResult<bool> {
    if input.is_dir() {
        return Ok(true);
    }
    if resume {
        return Err(CliError::Usage(
            "--resume is for folders: the input is a file".into(),
        ));
    }
    Ok(false)
}

/// Encodes an image, writing `.cae`; a folder, each image in it
/// ([`super::folder::encode`]).
pub fn encode(global: &GlobalArgs, a: &EncodeArgs) -> CliResult {
    if folder_mode(&a.input, a.resume)? {
        return super::folder::encode(global, a);
    }
    let loaded = load_for_encode(global, a, &a.input, &global.limits)?;
    let img = &loaded.img;
    let out = Target::from_arg(a.output.as_deref(), || default_output(&a.input, "cae"));
    json_beside(a.json, &out)?;
    let mut outputs = Outputs::new(global.force).input(&a.input);
    outputs.check(&out)?;
    let map_format = match &a.keypoint_map {
        Some(map) => {
            outputs.check_path(map)?;
            Some(image_format(map, img.format(), "key point map")?)
        }
        None => None,
    };
    let pb = progress_bar(global, "encoding");
    let start = Instant::now();
    let (bytes, stats) = encode_loaded(global, &loaded, &a.input, |done, total| {
        if let Some(pb) = &pb {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
        }
    })?;
    let secs = start.elapsed().as_secs_f64();
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    outputs.write(&out, &bytes)?;
    let (width, height) = (img.width(), img.height());
    let bpp = bytes.len() as f64 * 8.0 / (width as f64 * height as f64);
    if let (Some(map), Some(format)) = (&a.keypoint_map, map_format) {
        let decoded = decoder::read(&bytes, u64::MAX).map_err(|e| codec_err(&a.input, e))?;
        let raster = loaded.img.into_raster()?;
        // The key points are the coded image's: draw them over it.
        let h = &decoded.header;
        let raster = if (h.width, h.height) == (raster.width(), raster.height()) {
            raster
        } else {
            caoen::codec::resample::downscale(&raster, (h.width, h.height))
        };
        let picture = keypoint_map::render(&raster, &decoded);
        let png = image_io::encode(&picture, format).map_err(|e| encode_error(map, e))?;
        outputs.write_path(map, &png)?;
        note(global, format!("wrote key point map {}", map.display()));
    }
    if a.json {
        let v = json!({"input": a.input, "output": out.display(), "bytes": bytes.len(), "bpp": bpp,
            "width": width, "height": height, "coded_width": stats.coded_size.0,
            "coded_height": stats.coded_size.1, "tiles": stats.tiles, "luma_keypoints": stats.luma_keypoints,
            "chroma_keypoints": stats.chroma_keypoints, "seconds": secs,
            "metadata": metadata_json(&loaded.kept)});
        print(serde_json::to_string_pretty(&v).expect("json") + "\n")?;
    }
    let coded = if stats.coded_size == (width, height) {
        String::new()
    } else {
        format!(", coded at {}x{}", stats.coded_size.0, stats.coded_size.1)
    };
    note(
        global,
        format!(
            "{} -> {}: {} bytes, {bpp:.4} bpp, {} + {} key points{coded}, {secs:.2} s",
            a.input.display(),
            out.display(),
            bytes.len(),
            stats.luma_keypoints,
            stats.chroma_keypoints
        ),
    );
    Ok(())
}

/// Refuses `--json` when the output itself goes to standard output: the two would mix.
fn json_beside(json: bool, target: &Target) -> CliResult {
    if json && *target == Target::Stdout {
        return Err(CliError::Usage(
            "-o - and --json: the output takes standard output; the JSON cannot".into(),
        ));
    }
    Ok(())
}

/// The image format written to `path`: by its extension, or the natural format of
/// `samples` for a stream (`/dev/stdout`, a FIFO), whose name says nothing.
pub fn image_format(
    path: &Path,
    samples: caoen::raster::SampleFormat,
    what: &str,
) -> CliResult<image_io::OutputFormat> {
    image_io::OutputFormat::for_path(path, samples)
        .or_else(|| {
            crate::output::is_stream(path).then(|| image_io::OutputFormat::natural(samples))
        })
        .ok_or_else(|| {
            CliError::Usage(format!(
                "{}: {what} must end in .png or .exr",
                path.display()
            ))
        })
}

fn default_output(input: &Path, ext: &str) -> PathBuf {
    let stem = input
        .file_stem()
        .map_or_else(|| "out".into(), |s| s.to_string_lossy().into_owned());
    input.with_file_name(format!("{stem}.{ext}"))
}

fn parse_size(s: &str) -> CliResult<(u32, u32)> {
    crate::cli::parse_wxh(s, caoen::codec::MAX_SIDE).map_err(CliError::Usage)
}

/// `x0,y0,x1,y1` as a region (the decoder checks it against the image).
fn parse_region(s: &str) -> CliResult<caoen::Region> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| CliError::Usage(format!("--region {s}: {e} (expected x0,y0,x1,y1)")))?;
    let [x0, y0, x1, y1] = v[..] else {
        return Err(CliError::Usage(format!(
            "--region {s}: expected four numbers x0,y0,x1,y1"
        )));
    };
    Ok(caoen::Region { x0, y0, x1, y1 })
}

/// `caoen decode`'s options for an output of `format`.
pub fn decode_request(
    global: &GlobalArgs,
    a: &DecodeArgs,
    format: FormatChoice,
) -> CliResult<DecodeToImage> {
    let size = match (&a.size, a.scale) {
        (Some(_), Some(_)) => {
            return Err(CliError::Usage("give --size or --scale, not both".into()))
        }
        (Some(s), None) => Some(parse_size(s)?),
        (None, Some(f)) if !(f.is_finite() && f > 0.0) => {
            return Err(CliError::Usage(format!(
                "--scale {f}: must be a positive number"
            )))
        }
        _ => None,
    };
    let decode = DecodeOptions {
        size,
        supersample: a.supersample,
        max_pixels: a.max_pixels,
        limits: global.limits.clone(),
        region: a.region.as_deref().map(parse_region).transpose()?,
    };
    Ok(DecodeToImage {
        decode,
        scale: a.scale,
        format,
        png: image_io::PngCompression::parse(&a.png_compression).expect("clap checked it"),
        metadata: a.metadata.policy(a.strip),
    })
}

/// Decodes (or, without `-o`, validates) a `.cae` file; a folder, each `.cae` file in
/// it ([`super::folder::decode`]).
pub fn decode(global: &GlobalArgs, a: &DecodeArgs) -> CliResult {
    if folder_mode(&a.input, a.resume)? {
        return super::folder::decode(global, a);
    }
    // Options first: a usage error is reported before the file is read.
    decode_request(global, a, FormatChoice::Natural)?;
    let bytes = read_input(&a.input, &global.limits)?;
    let target = a
        .output
        .as_deref()
        .map(|o| Target::from_arg(Some(o), PathBuf::new));
    if let Some(t) = &target {
        json_beside(a.json, t)?;
    }
    let format = match target.as_ref().and_then(Target::path) {
        None => FormatChoice::Natural,
        // The extension alone decides whether a format is written at all; a stream's
        // name says nothing, so it gets the file's natural format.
        Some(out) => {
            let named = image_io::OutputFormat::for_path(out, caoen::raster::SampleFormat::U8);
            match named {
                Some(_) => FormatChoice::ForPath(out.to_path_buf()),
                None => {
                    image_format(out, caoen::raster::SampleFormat::U8, "output")?;
                    FormatChoice::Natural
                }
            }
        }
    };
    let mut outputs = Outputs::new(global.force).input(&a.input);
    if let Some(t) = &target {
        outputs.check(t)?;
    }
    let opts = decode_request(global, a, format)?;
    let start = Instant::now();
    let Some(target) = target else {
        let (w, h) = transcode::validate(&bytes, &a.input, &opts)?;
        let secs = start.elapsed().as_secs_f64();
        note(
            global,
            format!(
                "{}: valid, {w}x{h} decoded in {secs:.3} s",
                a.input.display()
            ),
        );
        return Ok(());
    };
    let image = image_io::decode_to_image(&bytes, &a.input, &opts)?;
    let secs = start.elapsed().as_secs_f64();
    outputs.write(&target, &image.bytes)?;
    for d in &image.dropped {
        eprintln!("warning: {}: {d}", a.input.display());
    }
    note(
        global,
        format!(
            "{} -> {}: {}x{} in {secs:.3} s",
            a.input.display(),
            target.display(),
            image.width,
            image.height
        ),
    );
    if a.json {
        let v = json!({"input": a.input, "output": target.display(), "width": image.width,
            "height": image.height, "bytes_in": bytes.len(), "bytes_out": image.bytes.len(),
            "seconds": secs});
        print(serde_json::to_string_pretty(&v).expect("json") + "\n")?;
    }
    Ok(())
}

/// Describes a `.cae` file: header, sections, key points.
pub fn info(global: &GlobalArgs, a: &InfoArgs) -> CliResult {
    let bytes = read_input(&a.input, &global.limits)?;
    let parsed = caoen::codec::inspect(&bytes).map_err(|e| codec_err(&a.input, e))?;
    let about = About::of(&parsed, bytes.len());
    if a.json {
        let v = info_json(&a.input, &parsed, &about);
        return print(serde_json::to_string_pretty(&v).expect("json") + "\n");
    }
    let h = &parsed.header;
    let mut text = String::new();
    info_head(&mut text, &a.input, &parsed, &about);
    info_detail(&mut text, h);
    info_restoration(&mut text, h);
    info_deringing(&mut text, h);
    info_tail(&mut text, &parsed, &about);
    print(text)
}

/// What `caoen info` adds up from a parsed file.
struct About {
    /// Each section's tag, name, offset and bytes in the file.
    sections: Vec<(char, &'static str, usize, usize)>,
    /// The tiles' stream bytes: tree, luma, chroma, detail.
    streams: [usize; 4],
    /// The file's size in bytes.
    bytes: usize,
    /// Bits per pixel of the image's own size.
    bpp: f64,
}

impl About {
    fn of(parsed: &bitstream::Parsed<'_>, bytes: usize) -> About {
        let sections: Vec<_> = parsed
            .sections
            .iter()
            .map(|s| {
                let name = match s.tag {
                    tag::HEADER => "header",
                    tag::ICC => "ICC profile",
                    tag::EXIF => "EXIF",
                    tag::XMP => "XMP",
                    tag::TILE => "tile",
                    tag::RESTORATION => "restoration",
                    tag::END => "end",
                    _ => "unknown",
                };
                (s.tag as char, name, s.offset, s.file_bytes())
            })
            .collect();
        // What the tiles' streams add up to, per kind.
        let streams = parsed.tiles.iter().fold([0usize; 4], |acc, t| {
            [
                acc[0] + t.tree.len(),
                acc[1] + t.luma.len(),
                acc[2] + t.chroma.len(),
                acc[3] + t.detail.len(),
            ]
        });
        let (dw, dh) = parsed.header.display_size();
        About {
            sections,
            streams,
            bytes,
            bpp: bytes as f64 * 8.0 / (dw as f64 * dh as f64),
        }
    }
}

/// `caoen info --json`.
fn info_json(input: &Path, parsed: &bitstream::Parsed<'_>, about: &About) -> serde_json::Value {
    let h = &parsed.header;
    let (dw, dh) = h.display_size();
    let tiling = h.tiling();
    let (sections, streams) = (&about.sections, about.streams);
    let meta = stored_metadata(parsed);
    json!({
        "file": input, "bytes": about.bytes, "bpp": about.bpp,
        "version": bitstream::VERSION, "width": dw, "height": dh,
        "coded_width": h.width, "coded_height": h.height,
        "channels": h.layout.channels(), "alpha": h.layout.has_alpha(),
        "sample_format": format!("{:?}", h.format), "block_log2": h.block_log2, "min_log2": h.min_log2,
        "sigma_factor": h.kernel.sigma_factor, "weight_exponent": h.kernel.weight_exponent,
        "chroma_pruned": h.chroma_pruned, "step_luma": h.step_luma, "step_chroma": h.step_chroma,
        "step_alpha": h.step_alpha, "level_steps": h.level_steps, "detail_steps": h.detail_steps,
        "deblock": h.deblock.map(|d| json!({"strength_percent": d.strength, "radius_px": d.radius as f64 / 4.0})),
        "lapping": h.lapping.map(|l| json!({"weight": l.weight as f64 / 256.0})),
        "colour_basis": colour_basis_name(h),
        "adaptive_steps": h.adaptive.map(|a| json!({"cells_8px": a.factor(0), "cells_16px": a.factor(1), "cells_32px": a.factor(2), "activity_field_region_px": a.field().map(|l| 1u32 << l)})),
        "frequency_tilts": h.weights.map(|w| json!({"luma": w.tilt(0), "chroma": w.tilt(1)})),
        "restoration": h.restoration.as_ref().map(|r| r.planes.iter().map(|p| p.as_ref().map(|f| json!({
            "filters": f.filters.iter().map(|t| t.iter().map(|&v| v as f64 / 256.0).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "classes": f.classes.map(|m| m.to_vec()),
        }))).collect::<Vec<_>>()),
        "colour_map": h.restoration.as_ref().and_then(|r| r.colour.as_ref()).map(|m| json!({
            "matrix": m.real().iter().map(|r| r[..r.len() - 1].to_vec()).collect::<Vec<_>>(),
            "offsets": m.real().iter().map(|r| r[r.len() - 1]).collect::<Vec<_>>(),
        })),
        "last_luma_filters": h.restoration.as_ref().and_then(|r| r.last.as_ref()).map(|f| json!({
            "filters": f.filters.iter().map(|t| t.iter().map(|&v| v as f64 / 256.0).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "classes": f.classes.map(|m| m.to_vec()),
        })),
        "deringing": h.deringing.map(|d| json!({"luma": strengths_json(d.luma), "chroma": strengths_json(d.chroma)})),
        "luma_keypoints": h.luma_count, "chroma_keypoints": h.chroma_count,
        "tiles": {"count": tiling.count(), "side": tiling.side, "columns": tiling.columns(), "rows": tiling.rows()},
        "streams": {"tree": streams[0], "luma": streams[1], "chroma": streams[2], "detail": streams[3]},
        "metadata": metadata_json(&meta),
        "sections": sections.iter().map(|(t, n, o, b)| json!({"tag": t.to_string(), "name": n, "offset": o, "bytes": b})).collect::<Vec<_>>(),
    })
}

/// The file, format, image, tree, kernel, key point, colour and quantiser lines.
fn info_head(text: &mut String, input: &Path, parsed: &bitstream::Parsed<'_>, about: &About) {
    let h = &parsed.header;
    let (dw, dh) = h.display_size();
    outln!(
        *text,
        "file:        {} ({} bytes, {:.4} bpp)",
        input.display(),
        about.bytes,
        about.bpp
    );
    outln!(*text, "format:      caoen version {}", bitstream::VERSION);
    let coded = if (dw, dh) == (h.width, h.height) {
        String::new()
    } else {
        format!(" (coded at {}x{})", h.width, h.height)
    };
    outln!(
        *text,
        "image:       {dw}x{dh}{coded}, {:?}, {:?} samples",
        h.layout,
        h.format
    );
    outln!(
        *text,
        "tree:        blocks of {} px, cells down to {} px",
        1 << h.block_log2,
        1 << h.min_log2
    );
    let weight = if h.kernel.weight_exponent == 0.0 {
        "1 (equal)".to_string()
    } else {
        format!("cell^-{}", h.kernel.weight_exponent)
    };
    outln!(
        *text,
        "kernel:      compact, sigma = {} x cell, weight = {weight}",
        h.kernel.sigma_factor
    );
    outln!(
        *text,
        "key points:  {} luma, {} chroma{}",
        h.luma_count,
        h.chroma_count,
        if h.chroma_pruned {
            " (pruned tree)"
        } else {
            ""
        }
    );
    if let Some(basis) = colour_basis_name(h) {
        outln!(*text, "colour:      {basis} basis");
    }
    outln!(
        *text,
        "quantiser:   luma {}, chroma {}, alpha {}{}",
        h.step_luma,
        h.step_chroma,
        h.step_alpha,
        if h.level_steps {
            " under root blocks, doubling per level below"
        } else {
            ""
        }
    );
}

/// The detail layer's line.
fn info_detail(text: &mut String, h: &bitstream::Header) {
    match h.detail_steps {
        Some([l, c]) => outln!(
            *text,
            "detail:      8x8 DCT blocks (merged into 16x16 or 32x32 under cells that large, chroma into 16x16 anywhere, where that pays), step luma {l}, chroma {c}, {}, {}, {}, {}",
            match h.deblock {
                Some(d) => format!(
                    "deblocked (steps up to {}% of the step, {} px ramps)",
                    d.strength,
                    d.radius as f64 / 4.0
                ),
                None => "not deblocked".to_string(),
            },
            match h.lapping {
                Some(l) => format!("lapped (weight {}/256 next to an edge)", l.weight),
                None => "not lapped".to_string(),
            },
            match h.adaptive {
                Some(a) => format!(
                    "steps x{} / x{} / x{} under 8 / 16 / 32-pixel cells{}",
                    a.factor(0),
                    a.factor(1),
                    a.factor(2),
                    match a.field() {
                        Some(l) => format!(", times x0.5..x2 by an activity field of {}-pixel regions", 1u32 << l),
                        None => String::new(),
                    }
                ),
                None => "one step per plane".to_string(),
            },
            match h.weights {
                Some(w) => format!(
                    "steps rising with frequency to x{} (luma) / x{} (chroma) at an 8x8 block's highest",
                    1.0 + w.tilt(0),
                    1.0 + w.tilt(1)
                ),
                None => "flat in frequency".to_string(),
            }
        ),
        None => outln!(*text, "detail:      none"),
    }
}

/// The restoration filters' line.
fn info_restoration(text: &mut String, h: &bitstream::Header) {
    match &h.restoration {
        Some(r) => {
            let names = ["Y", "C1", "C2"];
            let planes: Vec<String> = r
                .planes
                .iter()
                .enumerate()
                .filter_map(|(c, p)| {
                    p.as_ref().map(|f| {
                        let name = names.get(c).unwrap_or(&"?");
                        let taps = f.filters[0].len();
                        match f.classes {
                            Some(_) => format!(
                                "{name} ({} filters of {taps} taps by pixel class)",
                                f.filters.len()
                            ),
                            None => format!("{name} ({taps} taps)"),
                        }
                    })
                })
                .collect();
            let planes = if planes.is_empty() {
                "no filters".to_string()
            } else {
                planes.join(", ")
            };
            let map = match &r.colour {
                Some(m) => format!(
                    "; colour map (largest change {:.4})",
                    m.real()
                        .iter()
                        .flatten()
                        .fold(0.0f64, |a, v| a.max(v.abs()))
                ),
                None => String::new(),
            };
            let last = match &r.last {
                Some(f) if f.classes.is_some() => {
                    format!("; last luma filters ({} by pixel class)", f.filters.len())
                }
                Some(_) => "; last luma filter".to_string(),
                None => String::new(),
            };
            outln!(*text, "restoration: {planes}{map}{last}");
        }
        None => outln!(*text, "restoration: none"),
    }
}

/// The deringing's line.
fn info_deringing(text: &mut String, h: &bitstream::Header) {
    match &h.deringing {
        Some(d) => {
            let kind = |name: &str, s: Strengths| {
                if s.is_on() {
                    let (p, sec, cut) = s.in_plane_units(1.0);
                    format!("{name} (primary {p}, secondary {sec}, cutoff {cut} steps)")
                } else {
                    format!("{name} off")
                }
            };
            let mut kinds = vec![kind("Y", d.luma)];
            if h.layout.colour_channels() == 3 {
                kinds.push(kind("C1 and C2", d.chroma));
            }
            outln!(*text, "deringing:   {}", kinds.join(", "));
        }
        None => outln!(*text, "deringing:   none"),
    }
}

/// The tiles, streams, metadata and sections lines.
fn info_tail(text: &mut String, parsed: &bitstream::Parsed<'_>, about: &About) {
    let tiling = parsed.header.tiling();
    let (sections, streams) = (&about.sections, about.streams);
    let meta = stored_metadata(parsed);
    outln!(
        *text,
        "tiles:       {} ({} x {}) of {} px",
        tiling.count(),
        tiling.columns(),
        tiling.rows(),
        tiling.side
    );
    outln!(
        *text,
        "streams:     tree {} bytes, luma {}, chroma {}, detail {}",
        streams[0],
        streams[1],
        streams[2],
        streams[3]
    );
    outln!(*text, "metadata:    {}", metadata_text(&meta));
    outln!(*text, "sections:");
    for (t, n, o, b) in sections.iter().filter(|s| s.0 != tag::TILE as char) {
        outln!(*text, "  '{t}' {n:<14} at {o:>8}: {b:>8} bytes");
    }
    let (count, bytes) = sections
        .iter()
        .filter(|s| s.0 == tag::TILE as char)
        .fold((0, 0), |(n, b), s| (n + 1, b + s.3));
    outln!(*text, "  'G' tiles          x{count:>7}: {bytes:>8} bytes");
}

/// One plane kind's deringing strengths in its steps, for `--json`.
fn strengths_json(s: Strengths) -> serde_json::Value {
    s.is_on()
        .then(|| {
            let (primary, secondary, cutoff) = s.in_plane_units(1.0);
            json!({"primary_steps": primary, "secondary_steps": secondary, "cutoff_steps": cutoff})
        })
        .into()
}

/// The colour basis as `info` names it (`null` in JSON for grey images).
fn colour_basis_name(h: &bitstream::Header) -> Option<&'static str> {
    (h.layout.colour_channels() == 3).then_some(match h.basis {
        caoen::codec::ColourBasis::Grey => "grey-axis opponent",
        caoen::codec::ColourBasis::Luma => "luma opponent",
    })
}
