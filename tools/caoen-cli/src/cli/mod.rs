//! Argument definitions (clap).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

mod print;
mod surface;
pub use print::*;
pub use surface::*;

/// How every command treats its outputs, shown at the end of `caoen --help`.
const OUTPUT_RULES: &str = "\
Outputs: `-o -` is standard output for every output that is one file (PNG for
pictures, binary STL for meshes, JSON for models; the summary then goes to stderr);
outputs that are folders refuse it (exit 2). An existing file is not replaced without
-f/--force, whether named with -o or chosen by the command, and never when it is an
input of the same command. Files are written whole through a temporary file beside
them, renamed into place when complete. Devices and FIFOs (/dev/null, named pipes) are
written in place; a symbolic link's target is written and the link kept.
`caoen examples`, `caoen demo` and `caoen bench --keep` regenerate their own
directories. Exit codes: 0 success, 1 failure, 2 usage error.";

/// caoen: Cao En surfaces, an image codec built on them, and texture tools.
#[derive(Debug, Parser)]
#[command(name = "caoen", version, about, propagate_version = true, after_help = OUTPUT_RULES)]
pub struct Cli {
    /// Options shared by every command.
    #[command(flatten)]
    pub global: GlobalArgs,
    /// The command to run (none: the demo on built-in data).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Options shared by every command.
#[derive(Debug, Args, Clone)]
pub struct GlobalArgs {
    /// No progress or informational messages on stderr (`-q` is quality, as in cwebp).
    #[arg(long, global = true)]
    pub quiet: bool,
    /// Worker threads (default: all cores). Output never depends on it.
    #[arg(short = 'j', long, global = true, value_parser = clap::value_parser!(u16).range(1..=256))]
    pub threads: Option<u16>,
    /// Memory budget of the command (e.g. 2G, 512M, 1.5GiB): work that would need more
    /// is refused before it starts, with the need and the budget in the message.
    #[arg(long, global = true, value_name = "SIZE", default_value = "2G", value_parser = caoen::budget::parse_size)]
    pub max_memory: u64,
    /// Longest estimated CPU time of a render or of `deviation`'s field sampling (e.g.
    /// 90s, 10m, 2h; a bare number is seconds): a render estimated to need more is
    /// refused before it starts, with the estimate and the limit in the message;
    /// `deviation` measures on a coarser grid that fits [default: 2m for a render, 10s
    /// for deviation].
    #[arg(long, global = true, value_name = "TIME", value_parser = parse_duration)]
    pub max_work: Option<f64>,
    /// Replace existing output files, named with -o or not. Never an input of the same
    /// command; devices and FIFOs (/dev/null, pipes) are written in place without it.
    #[arg(short = 'f', long, global = true)]
    pub force: bool,
    /// The command's memory limit, made from `--max-memory`: every library call of the
    /// command gets it, so what one load keeps counts in every later check.
    #[arg(skip)]
    pub limits: caoen::Limits,
}

/// Top-level commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the main job on built-in data, no input files needed (replaces its own
    /// files in its output directory).
    Demo(DemoArgs),
    /// Encode an image (PNG, JPEG, EXR, ...) into a caoen file.
    Encode(EncodeArgs),
    /// Decode a caoen file to PNG or EXR (without -o: validate only).
    Decode(DecodeArgs),
    /// Describe a caoen file: header, sections, key points.
    Info(InfoArgs),
    /// Serve the zooming web viewer (tools/web/) and a caoen file on localhost.
    View(ViewArgs),
    /// Generate the procedural test corpus (same as the caoen-corpus binary).
    Corpus(caoen_corpus::cli::CorpusArgs),
    /// Cao En surface models: inspect, evaluate, mesh.
    #[command(subcommand)]
    Surface(SurfaceCommand),
    /// Regenerate the example models, scenes and pictures (examples/; replaces its
    /// own files there).
    Examples(ExamplesArgs),
    /// Measure B against the reference A: PSNR, Y-PSNR, SSIM, SSIMULACRA2.
    Compare(CompareArgs),
    /// Rate-distortion benchmark of caoen and peer codecs on a corpus.
    Bench(crate::bench::BenchArgs),
    /// Distort an image or caoen file by moving control points (a Cao En warp).
    Distort(DistortArgs),
    /// Carry a texture from one surface to another through their shared domain.
    Transfer(TransferArgs),
    /// Function-based (F-rep) solids: render, mesh, export to POV-Ray.
    #[command(subcommand)]
    Frep(FrepCommand),
    /// A height map from an image on a plane, ellipsoid or cylinder (an F-rep model).
    Heightfield(HeightfieldArgs),
    /// Morph between two surfaces (key points paired, the shorter padded with empty
    /// ones) and render the frames: a folder of PNGs, an animated GIF or PNG.
    Morph(MorphArgs),
    /// Raise an image's grey levels as relief on an F-rep model (along its normal).
    Relief(PictureArgs),
    /// Carve an F-rep model with an image's pattern swept through it (lattice carving).
    Carve(PictureArgs),
    /// A lithophane of a picture to print: a plate thinnest where the picture is white,
    /// as 3MF (with its unit), STL, OBJ or PLY.
    Lithophane(LithophaneArgs),
    /// Convert a polygon mesh (OBJ, PLY) into an implicit model: a base quadric plus
    /// local cubic perturbations (an F-rep model file).
    Convert(ConvertArgs),
    /// Measure an implicit model (or an RBF baseline) against a mesh: vertex
    /// distances, normal angles, depth buffers from several sides.
    Deviation(DeviationArgs),
}

/// `caoen convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The mesh (.obj, .ply or .off).
    pub mesh: PathBuf,
    /// The F-rep model file to write (.json; `-`: the model on standard output, the
    /// summary on stderr).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The most functions: the base quadric and the perturbations [default: 6000, or
    /// 3 per vertex when that is more, up to 9000].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=9000))]
    pub max_functions: Option<u32>,
    /// The mean normal angle to reach (degrees, between the mesh's vertex normals and
    /// the model's gradient): part of the targets the summary checks; the fit stops
    /// adding perturbations at 0.8 of it.
    #[arg(long, value_name = "DEGREES", default_value_t = 3.0, value_parser = angle)]
    pub target_angle: f64,
    /// The depth deviation to reach: the mean depth-buffer difference over all pixels
    /// of the six axis views, a fraction of the bounding box's longest side.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.002, value_parser = positive_fraction)]
    pub target_depth: f64,
    /// Side in pixels of the depth buffers the summary measures the model with.
    #[arg(long, value_name = "PX", default_value_t = 256, value_parser = clap::value_parser!(u32).range(32..=1024))]
    pub check_size: u32,
    /// Refine where a vertex is further than this from the surface (a fraction of the
    /// bounding box's longest side).
    #[arg(long, value_name = "DEVIATION", default_value_t = 0.001, value_parser = positive_fraction)]
    pub target: f64,
    /// Refine where the angle (degrees) between a vertex normal and the surface normal
    /// is larger than this.
    #[arg(long, default_value_t = 10.0, value_parser = angle)]
    pub max_angle: f64,
    /// Convert an open sheet anyway, as the solid its winding number closes. A sheet:
    /// a boundary over 2.5 sqrt(area) long, or inside told from outside at under 80% of
    /// probed vertices; a mesh of 2 to 32 parts, none a sheet alone, converts part by
    /// part and is united; other sheets are refused without this or --thicken.
    #[arg(long, conflicts_with = "thicken")]
    pub fill_open: bool,
    /// Convert the solid within T (the mesh's units) of the mesh's triangles, by their
    /// unsigned distance: a sheet given a thickness. T is from 0.01 to 0.25 of the
    /// box's longest side.
    #[arg(long, value_name = "T", value_parser = thickness)]
    pub thicken: Option<f64>,
    /// A solid with holes (boundary loops, not a sheet): `close` models the closed
    /// solid; `open` a thin shell of it with an opening cut at each loop, so views into
    /// the holes see inside as the mesh does; `auto` measures both and writes the one
    /// with the smaller depth deviation.
    #[arg(long, value_enum, default_value_t = HolesArg::Auto)]
    pub holes: HolesArg,
    /// Sweeps of the local descent on the form factors after the fit (0: none).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=100))]
    pub descent: u32,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// How `caoen convert` models the holes of a solid with holes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum HolesArg {
    /// Measure the closed solid and the shell with openings; keep the closer.
    Auto,
    /// The closed solid: the fit's surface spans each hole.
    Close,
    /// A shell of the fitted solid with an opening at each boundary loop.
    Open,
}

/// `caoen deviation`.
#[derive(Debug, Args)]
pub struct DeviationArgs {
    /// The mesh (.obj, .ply or .off).
    pub mesh: PathBuf,
    /// The F-rep model file to measure (as written by `caoen convert`).
    #[arg(required_unless_present = "rbf", conflicts_with = "rbf")]
    pub model: Option<PathBuf>,
    /// Instead of a model, fit and measure the RBF baseline with N centres (vertices
    /// and their normal offsets, a dense triharmonic interpolation).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(3..=6000))]
    pub rbf: Option<u32>,
    /// Number of axis views for the depth buffers (front, back, sides, top, bottom).
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=6))]
    pub views: u32,
    /// Side of each depth buffer in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=2048))]
    pub size: u32,
    /// Write a picture: per view the mesh, the function and their depth difference
    /// (`-`: PNG on standard output, the summary on stderr).
    #[arg(long, value_name = "PNG")]
    pub picture: Option<PathBuf>,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Print no summary (with --picture: only the picture).
    #[arg(long, conflicts_with = "json")]
    pub no_summary: bool,
}

fn positive_fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v < 1.0 => Ok(v),
        _ => Err(format!(
            "`{s}`: expected a number between 0 and 1 (exclusive)"
        )),
    }
}

fn thickness(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("`{s}`: expected a thickness above 0")),
    }
}

fn angle(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 180.0 => Ok(v),
        _ => Err(format!(
            "`{s}`: expected an angle in degrees, above 0 and at most 180"
        )),
    }
}

/// `caoen morph`.
#[derive(Debug, Args)]
pub struct MorphArgs {
    /// The first surface (file or builtin:NAME).
    pub a: String,
    /// The last surface (same domain).
    pub b: String,
    /// Number of frames, the first A and the last B.
    #[arg(long, default_value_t = 9, value_parser = clap::value_parser!(u32).range(2..=1000))]
    pub frames: u32,
    /// Output: a folder (frame-000.png, ... and contact.png), anim.gif, or anim.png
    /// (animated PNG); not `-` (standard output takes one file: a usage error).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Frame size WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    pub size: String,
    /// Supersampling: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
    /// Tessellation level of the meshes.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(0..=9))]
    pub detail: u32,
    /// Time per frame of an animation, in milliseconds.
    #[arg(long, default_value_t = 80, value_parser = clap::value_parser!(u32).range(10..=10000))]
    pub delay: u32,
    /// Print the frame count and the camera as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `caoen relief` and `caoen carve`.
#[derive(Debug, Args)]
pub struct PictureArgs {
    /// Image (grey levels 0..1: relief height, or the pattern; bright is kept).
    pub image: PathBuf,
    /// The F-rep model file (format "caoen-frep/1") to work on.
    #[arg(long)]
    pub on: PathBuf,
    /// Output: .json (the new model, naming the image), .png (its render), or a mesh
    /// to print (.stl, .3mf, .obj, .ply); `-`: the render as PNG on standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Mesh output: grid cells along the longest side.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(4..=1024))]
    pub cells: u32,
    /// Mesh output: multiply the model's coordinates by S.
    #[arg(long, value_name = "S", value_parser = scale_factor, allow_hyphen_values = true)]
    pub scale: Option<f64>,
    /// Mesh output: unit and STL form of the file.
    #[command(flatten)]
    pub file: MeshFileArgs,
    /// How the image lies on the model: along z, around the z axis, or around the origin.
    #[arg(long, value_parser = ["planar", "cylindrical", "spherical"], default_value = "spherical")]
    pub projection: String,
    /// Relief: height of white in the model's units (negative engraves).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub depth: f64,
    /// Carve: the grey level between kept (brighter) and cut away.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true)]
    pub level: f64,
    /// Carve: hollow the model first, leaving a wall this thick (lattice carving).
    #[arg(long)]
    pub shell: Option<f64>,
    /// Render size WIDTHxHEIGHT (.png output) [default: 512x384]; for a mesh output,
    /// the model's largest extent (150mm, 15cm, 6in), the model scaled to it.
    #[arg(long, conflicts_with = "scale")]
    pub size: Option<String>,
    /// Supersampling of the render: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
}

/// Base solid of `caoen heightfield`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum HeightBaseArg {
    /// A slab under the plane z = 0; the image covers it with its aspect ratio.
    Plane,
    /// The unit sphere; the image covers all longitudes and latitudes.
    Ellipsoid,
    /// A cylinder of radius 1 and length 2 around z; the image wraps around it.
    Cylinder,
}

/// `caoen heightfield`.
#[derive(Debug, Args)]
pub struct HeightfieldArgs {
    /// Image whose grey levels (0..1) are the heights.
    pub image: PathBuf,
    /// Output: .json (an F-rep model naming the image) or .png (its render); `-`: the
    /// render as PNG on standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Base solid.
    #[arg(long, value_enum, default_value_t = HeightBaseArg::Plane)]
    pub base: HeightBaseArg,
    /// Height of a white pixel (negative engraves).
    #[arg(long, default_value_t = 0.25, allow_hyphen_values = true)]
    pub height: f64,
    /// Keep only heights at or above T (the rest is 0): a non-rectangular outline.
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// Interpolation between samples.
    #[arg(long, value_parser = ["bilinear", "bicubic"], default_value = "bicubic")]
    pub interp: String,
    /// Render size WIDTHxHEIGHT (.png output).
    #[arg(long, default_value = "512x384")]
    pub size: String,
    /// Supersampling of the render: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
}

/// `caoen frep ...`.
#[derive(Debug, Subcommand)]
pub enum FrepCommand {
    /// Render an F-rep model or scene to a PNG (interval ray casting or its mesh).
    Render(FrepRenderArgs),
    /// Polygonise an F-rep model into a mesh to print (.stl, .3mf, .obj or .ply).
    Mesh(FrepMeshArgs),
    /// Write a POV-Ray scene (.pov) that renders as the same model.
    ExportPov(FrepExportArgs),
}

/// F-rep render method.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum FrepMethodArg {
    /// Interval ray casting with exact gradient normals.
    Ray,
    /// The polygonised mesh, rasterised.
    Mesh,
}

/// `caoen frep render`.
#[derive(Debug, Args)]
pub struct FrepRenderArgs {
    /// F-rep model file (format "caoen-frep/1") or scene file with `frep` objects
    /// (docs/frep.md).
    pub model: PathBuf,
    /// Output image (.png or .jpg; `-`: PNG on standard output).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = FrepMethodArg::Ray)]
    pub method: FrepMethodArg,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "512x384")]
    pub size: String,
    /// Supersampling: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
    /// Grid cells along the longest side for --method mesh.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(4..=1024))]
    pub cells: u32,
}

/// `caoen frep mesh`.
#[derive(Debug, Args)]
pub struct FrepMeshArgs {
    /// F-rep model file or scene file with one `frep` object.
    pub model: PathBuf,
    /// Output mesh (.stl, .3mf, .obj or .ply), closed and manifold; `-`: binary STL
    /// (ASCII with --ascii) on standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Grid cells along the longest side.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(4..=1024))]
    pub cells: u32,
    /// Scale the model so its largest extent is this long: 150mm, 15cm, 6in (a bare
    /// number is in --units).
    #[arg(long, value_parser = length, conflicts_with = "scale", allow_hyphen_values = true)]
    pub size: Option<Length>,
    /// Multiply the model's coordinates by S [default: 1, one model unit is one --units].
    #[arg(long, value_name = "S", value_parser = scale_factor, allow_hyphen_values = true)]
    pub scale: Option<f64>,
    /// Unit and STL form of the file.
    #[command(flatten)]
    pub file: MeshFileArgs,
}

/// `caoen frep export-pov`.
#[derive(Debug, Args)]
pub struct FrepExportArgs {
    /// F-rep model file or scene file with `frep` objects and Cao En surfaces.
    pub model: PathBuf,
    /// Output POV-Ray scene (.pov; `-`: standard output).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image size WIDTHxHEIGHT the camera is framed for (render POV-Ray at this size,
    /// e.g. `povray +W512 +H384`).
    #[arg(long, default_value = "512x384")]
    pub size: String,
}

/// `caoen transfer`.
#[derive(Debug, Args)]
pub struct TransferArgs {
    /// Picture laid on surface A: image (PNG, JPEG, EXR, ...) or caoen file (.cae).
    #[arg(long, required_unless_present = "texture_space", requires = "from")]
    pub texture: Option<PathBuf>,
    /// Surface A the picture is laid on (file or builtin:NAME).
    #[arg(long)]
    pub from: Option<String>,
    /// How the picture is laid on A: projected in A's own space onto its bounding box
    /// (planar along z, cylindrical around z, spherical around the centre), then pulled
    /// back to the shared domain; or `domain`: the picture is already A's texture in
    /// domain coordinates and carries over unchanged.
    #[arg(long, value_name = "KIND", default_value = "spherical",
          value_parser = ["planar", "cylindrical", "spherical", "domain"])]
    pub project: String,
    /// Texture grid WIDTHxHEIGHT baked for B from the picture (default: the picture's
    /// size, scaled down to at most twice the longer output side and at most 4096 a
    /// side; with --texture-space, --texture-size).
    #[arg(long, value_name = "WxH")]
    pub bake_size: Option<String>,
    /// Points per texel side averaged when baking a projected picture or a solid
    /// texture (antialiased edges).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub bake_samples: u32,
    /// Instead of --texture/--from: a network from the shared domain into a 3-D texture
    /// space (a surface file); the solid texture (--solid) sampled there is carried
    /// onto B.
    #[arg(long, value_name = "NET", conflicts_with_all = ["texture", "from"])]
    pub texture_space: Option<String>,
    /// Solid texture for --texture-space: checker (cubes), stripes (layers across x),
    /// rings (wood: cylinders around z), marble (Perlin-noise veins), or a volume spec
    /// FILE.json listing PNG slices (sampled trilinearly; docs/texture.md).
    #[arg(long, value_name = "KIND|SPEC.json", default_value = "checker")]
    pub solid: String,
    /// Feature size of a procedural solid texture in texture-space units: cube side,
    /// stripe period, ring spacing, vein spacing (with --texture-space).
    #[arg(long, visible_alias = "cell", default_value_t = 0.25)]
    pub scale: f64,
    /// The two colours of a procedural solid texture, sRGB hex `RRGGBB,RRGGBB`
    /// (default: a light sand and a dark blue).
    #[arg(long, value_name = "RRGGBB,RRGGBB", requires = "texture_space")]
    pub colours: Option<String>,
    /// Texture grid size WIDTHxHEIGHT baked for B (with --texture-space).
    #[arg(long, default_value = "512x256")]
    pub texture_size: String,
    /// Surface B to carry it to (same domain).
    #[arg(long)]
    pub to: String,
    /// Output: .png (a shaded render of B) or .obj (+ .mtl and -texture.png); `-`: the
    /// render as PNG on standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Render size WIDTHxHEIGHT (.png output).
    #[arg(long, default_value = "512x384")]
    pub size: String,
    /// Supersampling of the render: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
    /// Tessellation level of B's mesh.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(0..=9))]
    pub detail: u32,
}

/// `caoen distort`.
#[derive(Debug, Args)]
pub struct DistortArgs {
    /// Input image (PNG, EXR, ...), caoen file (.cae), or surface model (.json or
    /// builtin:NAME; moves are then x,y,z:x2,y2,z2 and the output .json, .obj or .ply).
    pub input: PathBuf,
    /// Output image: .png or .exr (`-`: standard output, PNG, or EXR for a float
    /// image); for a surface model .json, .obj or .ply (`-`: the model's JSON).
    #[arg(short, long)]
    pub output: PathBuf,
    /// A control point move `x,y:x2,y2` in pixels (repeatable); `x,y,z:x2,y2,z2` for a
    /// surface. Values may be negative (`--move -0.5,0,0:0.5,0,0`).
    #[arg(long = "move", value_name = "X,Y:X2,Y2", allow_hyphen_values = true)]
    pub moves: Vec<String>,
    /// A JSON file of moves: `[{"from": [x, y], "to": [x2, y2]}, ...]` or
    /// `[[[x, y], [x2, y2]], ...]`.
    #[arg(long = "moves", value_name = "JSON", conflicts_with = "moves")]
    pub moves_file: Option<PathBuf>,
    /// Samples per pixel side for the forward mapping.
    #[arg(long, value_name = "S", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub supersample: u32,
    /// Overlay the warped grid lines.
    #[arg(long)]
    pub grid: bool,
}

/// `caoen encode`.
#[derive(Debug, Args)]
pub struct EncodeArgs {
    /// Input image (PNG, JPEG, OpenEXR, anything the image crate reads), or a folder:
    /// every image in its tree, in parallel, into the folder -o names.
    pub input: PathBuf,
    /// Output file (`-` for stdout). Default: the input's name with `.cae`. An
    /// existing file is not replaced without -f/--force. For a folder input: the
    /// output folder (required), where each file keeps its place in the tree.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// For a folder input: skip each image whose output is already a whole, valid
    /// `.cae` file.
    #[arg(long)]
    pub resume: bool,
    /// Quality 0..100.
    #[arg(short = 'q', long, default_value_t = 75.0, value_parser = parse_quality)]
    pub quality: f32,
    /// Effort 1..9: encoder time traded for quality at the same size.
    #[arg(short = 'e', long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=9))]
    pub effort: u8,
    /// Target bits per pixel (searches the quality; lands within ~3%).
    #[arg(long, value_name = "BPP")]
    pub target_bpp: Option<f64>,
    /// Target file size in bytes (searches the quality).
    #[arg(long, value_name = "BYTES")]
    pub target_size: Option<u64>,
    /// Number of luma key points to grow the tree to (overrides the quality's choice).
    #[arg(long, value_name = "N")]
    pub keypoints: Option<usize>,
    /// Also write the analysis and the chosen key points over the image as a PNG
    /// (`-`: standard output, then -o names a file).
    #[arg(long, value_name = "PNG")]
    pub keypoint_map: Option<PathBuf>,
    /// Metadata kept in the file: all (ICC profile, EXIF, XMP), icc (the colour
    /// profile alone) or none. Pixels are turned upright by the EXIF orientation
    /// whatever is kept, and kept EXIF says orientation 1.
    #[arg(long, value_enum, default_value_t = MetadataArg::All)]
    pub metadata: MetadataArg,
    /// Keep no metadata (the same as --metadata none).
    #[arg(long, conflicts_with = "metadata")]
    pub strip: bool,
    /// Coding at a smaller size, which the decoder draws at the image's: auto (0.5,
    /// 0.7 and 0.8 per side tried below quality 55-60 from effort 3-5, kept where they
    /// pay by rate and distortion), off, half, or a size per side in tenths (0.1-1.0)
    #[arg(long, value_name = "auto|off|half|FRACTION", default_value = "auto", value_parser = resampling)]
    pub resampling: caoen::Resampling,
    /// Print statistics as JSON on stdout (for a folder: each file and the totals).
    #[arg(long)]
    pub json: bool,
}

/// `--resampling`: `auto`, `off`, `half`, or a size per side in tenths.
fn resampling(s: &str) -> Result<caoen::Resampling, String> {
    match s {
        "auto" => return Ok(caoen::Resampling::Auto),
        "off" => return Ok(caoen::Resampling::Off),
        "half" => return Ok(caoen::Resampling::At(caoen::Scale::HALF)),
        _ => {}
    }
    s.parse::<f64>()
        .ok()
        .filter(|v| (0.1..=1.0).contains(v) && (v * 10.0 - (v * 10.0).round()).abs() < 1e-9)
        .and_then(|v| caoen::Scale::new((v * 10.0).round() as u32))
        .map(caoen::Resampling::At)
        .ok_or_else(|| {
            format!("`{s}`: expected auto, off, half or a size per side in tenths (0.1 to 1.0)")
        })
}

/// Which metadata items a file keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MetadataArg {
    /// None.
    None,
    /// The ICC colour profile alone.
    Icc,
    /// ICC profile, EXIF and XMP.
    All,
}

impl MetadataArg {
    /// The policy, with `--strip` meaning none.
    pub fn policy(self, strip: bool) -> caoen::metadata::MetadataPolicy {
        use caoen::metadata::MetadataPolicy as P;
        match (strip, self) {
            (true, _) | (false, MetadataArg::None) => P::None,
            (false, MetadataArg::Icc) => P::Icc,
            (false, MetadataArg::All) => P::All,
        }
    }
}

/// Parses a duration in seconds: a number with an optional unit `s`, `m` or `h`.
pub fn parse_duration(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let (num, unit) = match t.char_indices().last() {
        Some((i, 's')) => (&t[..i], 1.0),
        Some((i, 'm')) => (&t[..i], 60.0),
        Some((i, 'h')) => (&t[..i], 3600.0),
        _ => (t, 1.0),
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v * unit <= 1e9 => Ok(v * unit),
        _ => Err(format!(
            "`{s}`: expected a time above 0 and at most 1e9 s, like 90s, 10m or 2h"
        )),
    }
}

/// The default `--max-work` of a render: generous enough for every example scene.
pub const RENDER_MAX_WORK: f64 = 120.0;
/// The default `--max-work` of `deviation`'s sampling.
pub const DEVIATION_MAX_WORK: f64 = 10.0;

/// Shows `seconds` the way `--max-work` reads it back.
pub fn show_duration(seconds: f64) -> String {
    if seconds >= 5400.0 {
        format!("{:.1}h", seconds / 3600.0)
    } else if seconds >= 90.0 {
        format!("{:.1}m", seconds / 60.0)
    } else {
        format!("{seconds:.1}s")
    }
}

/// Parses `WxH` (or `WXH`) into two sides in `1..=max_side`.
pub fn parse_wxh(s: &str, max_side: u32) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}`: expected WIDTHxHEIGHT like 512x384");
    let (a, b) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let side = |t: &str| -> Result<u32, String> {
        let v: u64 = t.trim().parse().map_err(|_| bad())?;
        if v == 0 || v > u64::from(max_side) {
            return Err(format!("`{s}`: each side must be in 1..={max_side}"));
        }
        Ok(v as u32)
    };
    Ok((side(a)?, side(b)?))
}

fn parse_quality(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(q) if (0.0..=100.0).contains(&q) => Ok(q),
        _ => Err(format!("`{s}` is not a quality in 0..100")),
    }
}

/// `caoen decode`.
#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// The caoen file (`-` for stdin), or a folder: every `.cae` file in its tree, in
    /// parallel, into the folder -o names.
    pub input: PathBuf,
    /// Output image: .png (8- or 16-bit as coded) or .exr (float); `-` for PNG on
    /// stdout. For a folder input: the output folder (required), where each file keeps
    /// its place in the tree as `.png` or, for float files, `.exr`.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// For a folder input: skip each file whose output is already a whole image file
    /// that reads back.
    #[arg(long)]
    pub resume: bool,
    /// Print what was done as JSON on stdout (for a folder: each file and the totals).
    #[arg(long)]
    pub json: bool,
    /// S x S samples per output pixel for a resized decode (--size, --scale): they
    /// anti-alias a downscale (at --scale 0.25, S = 2 is 3.7 dB closer to a
    /// box-filtered full-size decode than one sample per pixel). At the coded size it
    /// changes nothing and is skipped.
    #[arg(long, value_name = "S", value_parser = clap::value_parser!(u32).range(1..=4))]
    pub supersample: Option<u32>,
    /// Decode at this size (the continuous network is evaluated at any size).
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Decode scaled by this factor.
    #[arg(long, value_name = "F")]
    pub scale: Option<f64>,
    /// Decode only the rectangle [x0, x1) x [y0, y1) of the image (its own pixel
    /// coordinates, fractions allowed), at --size or --scale times its own size.
    #[arg(long, value_name = "x0,y0,x1,y1", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// Refuse files or outputs with more pixels than this.
    #[arg(long, default_value_t = caoen::codec::DEFAULT_MAX_PIXELS)]
    pub max_pixels: u64,
    /// PNG compression: fast (about the decode's own time), default, or best (the
    /// smallest files, several times slower).
    #[arg(long, value_parser = ["fast", "default", "best"], default_value = "fast")]
    pub png_compression: String,
    /// Metadata the file carries written into the output: all (ICC profile, EXIF,
    /// XMP as PNG iCCP, eXIf and iTXt chunks or EXR attributes), icc, or none.
    #[arg(long, value_enum, default_value_t = MetadataArg::All)]
    pub metadata: MetadataArg,
    /// Write no metadata (the same as --metadata none).
    #[arg(long, conflicts_with = "metadata")]
    pub strip: bool,
}

/// `caoen view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The caoen file to show.
    pub input: PathBuf,
    /// Port on 127.0.0.1 (0: any free one); the URL is printed.
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// The viewer's folder, with its built pkg/ (default: $CAOEN_WEB_DIR, else the
    /// source tree's tools/web/).
    #[arg(long, value_name = "DIR")]
    pub web: Option<PathBuf>,
}

/// `caoen info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The caoen file (`-` for stdin).
    pub input: PathBuf,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `caoen compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Reference image (PNG, JPEG, EXR, ...) or caoen file (.cae).
    pub reference: PathBuf,
    /// Image or caoen file to measure against the reference.
    pub test: PathBuf,
    /// Print JSON on stdout (an infinite PSNR, for identical images, is null).
    #[arg(long)]
    pub json: bool,
}

/// `caoen examples`.
#[derive(Debug, Args)]
pub struct ExamplesArgs {
    /// Directory to write into; the files `caoen examples` writes there are replaced
    /// without --force (regenerating them is its job).
    #[arg(short, long, default_value = "examples")]
    pub out: PathBuf,
    /// Supersampling per pixel side for the pictures.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
}

/// `caoen demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Directory to write into; the demo's files there are replaced without --force
    /// (regenerating them is its job).
    #[arg(short, long, default_value = "caoen-demo")]
    pub out_dir: PathBuf,
}

impl Default for DemoArgs {
    fn default() -> Self {
        DemoArgs {
            out_dir: PathBuf::from("caoen-demo"),
        }
    }
}
