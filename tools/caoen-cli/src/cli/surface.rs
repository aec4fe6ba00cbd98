//! The `caoen surface` subcommands' arguments (clap).

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};

/// `caoen surface ...`.
#[derive(Debug, Subcommand)]
pub enum SurfaceCommand {
    /// Describe a model: domain, dimensions, blending, key points.
    Info(SurfaceInfoArgs),
    /// Evaluate a model at points, domain parameters or a grid.
    Eval(SurfaceEvalArgs),
    /// Tessellate a model and write a mesh (OBJ or PLY by extension).
    Mesh(SurfaceMeshArgs),
    /// Write a model (e.g. a built-in one) as a surface file.
    Export(SurfaceExportArgs),
    /// Render a model or a scene to a PNG (mesh, depth-buffer or ray-traced).
    Render(SurfaceRenderArgs),
}

/// Render method.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum MethodArg {
    /// Tessellate and z-buffer the triangles (solids: marching tetrahedra).
    Mesh,
    /// Sample the domain into a depth buffer (solids: ray traced).
    Depth,
    /// Ray trace implicit solids with CSG (surfaces: depth buffer).
    Ray,
}

/// Camera projection override.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ProjectionArg {
    /// Pinhole camera, 30 degree vertical field of view.
    Perspective,
    /// Parallel projection framing the scene.
    Orthographic,
}

/// Crossing search for implicit solids.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum RayMethodArg {
    /// The paper's: bounding sphere, halving search, bisection.
    Paper,
    /// Polyhedron clipping and convex Newton steps (same crossings, faster).
    Fast,
}

/// `caoen surface render`.
#[derive(Debug, Args)]
pub struct SurfaceRenderArgs {
    /// Surface file, builtin:NAME, or scene file (format "caoen-scene/1", see docs/rendering.md).
    pub model: String,
    /// Output image (.png or .jpg; `-`: PNG on standard output).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = MethodArg::Mesh)]
    pub method: MethodArg,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "512x384")]
    pub size: String,
    /// Supersampling: N x N samples per pixel.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub samples: u32,
    /// Also write the depth map: 16-bit PNG (near bright, background 0) or .exr (raw
    /// depths); `-`: the PNG on standard output (then -o names a file).
    #[arg(long, value_name = "FILE")]
    pub depth_out: Option<PathBuf>,
    /// Mesh tessellation level for --method mesh.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(0..=9))]
    pub detail: u32,
    /// How surface normals are computed.
    #[arg(long, value_enum, default_value_t = NormalsArg::Exact)]
    pub normals: NormalsArg,
    /// Override the camera projection.
    #[arg(long, value_enum)]
    pub projection: Option<ProjectionArg>,
    /// Crossing search for implicit solids.
    #[arg(long, value_enum, default_value_t = RayMethodArg::Fast)]
    pub ray_method: RayMethodArg,
    /// Texture image (PNG/JPEG) on the domain of a model (overrides the model's own).
    #[arg(long, value_name = "FILE")]
    pub texture: Option<PathBuf>,
    /// How mesh vertices reach the screen: the exact camera, or the paper's camera
    /// network (axis generators, exact for orthographic views; shape vectors projected
    /// to the screen, an approximation, for perspective views). The network's distance
    /// from the exact projection is printed.
    #[arg(long, value_parser = ["exact", "network"], default_value = "exact")]
    pub camera: String,
}

/// `caoen surface info`.
#[derive(Debug, Args)]
pub struct SurfaceInfoArgs {
    /// Surface file (JSON, see docs/surface-format.md) or builtin:NAME (six-point, octahedron, blob, ring).
    pub model: String,
    /// Print JSON on stdout instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `caoen surface eval`.
#[derive(Debug, Args)]
pub struct SurfaceEvalArgs {
    /// Surface file (JSON, see docs/surface-format.md) or builtin:NAME (six-point, octahedron, blob, ring).
    pub model: String,
    /// Domain point(s) as comma-separated coordinates (repeatable).
    #[arg(long, value_name = "X,Y,..", allow_hyphen_values = true)]
    pub at: Vec<String>,
    /// Domain parameters (angles in radians; a ball point for the ball), repeatable.
    #[arg(long, value_name = "A,B,..", allow_hyphen_values = true)]
    pub param: Vec<String>,
    /// A parameter grid COLSxROWS over the whole domain.
    #[arg(long, value_name = "COLSxROWS")]
    pub grid: Option<String>,
    /// Also print the Jacobian dy/dx (p x m, row-major).
    #[arg(long)]
    pub jacobian: bool,
    /// Also print the exact unit normal (3-D surfaces on 2-parameter domains).
    #[arg(long)]
    pub normal: bool,
    /// Print JSON instead of whitespace-separated columns.
    #[arg(long)]
    pub json: bool,
}

/// Normal computation for meshes.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum NormalsArg {
    /// Exact, from the Jacobian.
    Exact,
    /// Interpolated by a second network from the key points' exact normals.
    Interpolated,
}

/// `caoen surface mesh`.
#[derive(Debug, Args)]
pub struct SurfaceMeshArgs {
    /// Surface file (JSON, see docs/surface-format.md) or builtin:NAME (six-point, octahedron, blob, ring).
    pub model: String,
    /// Output file: .obj or .ply (`-`: OBJ on standard output, without a material).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Tessellation level (sphere: icosahedron subdivisions, 20*4^N triangles).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(0..=9))]
    pub detail: u32,
    /// How vertex normals are computed.
    #[arg(long, value_enum, default_value_t = NormalsArg::Exact)]
    pub normals: NormalsArg,
    /// Texture image on the domain (overrides the model's own); an OBJ output then also
    /// gets a material library (.mtl) and the texture as STEM-texture.png (STEM: the output name without extension).
    #[arg(long, value_name = "FILE")]
    pub texture: Option<PathBuf>,
}

/// `caoen surface export`.
#[derive(Debug, Args)]
pub struct SurfaceExportArgs {
    /// Surface file (JSON, see docs/surface-format.md) or builtin:NAME (six-point, octahedron, blob, ring).
    pub model: String,
    /// Output surface file (`-` for stdout).
    #[arg(short, long)]
    pub output: PathBuf,
}
