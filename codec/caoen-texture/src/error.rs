//! Errors of the texture tools, sorted by who is at fault (the input's data, the
//! caller's parameters, the limits, the layers below) and carrying the offending values.

use std::path::PathBuf;

use thiserror::Error;

use caoen_surface::Domain;

/// Why a texture operation failed.
#[derive(Debug, Error)]
pub enum TextureError {
    // Bad input data: a file or model that cannot be used.
    /// A moves file is not a JSON array of moves.
    #[error("{source}")]
    MovesJson {
        /// What the JSON parser said.
        #[source]
        source: serde_json::Error,
    },
    /// A move of a moves file has a NaN or infinite coordinate.
    #[error("move {index} ({from:?} -> {to:?}) is not finite")]
    NonFiniteMove {
        /// The move's position in its list (from 0).
        index: usize,
        /// Its start.
        from: [f64; 2],
        /// Its target.
        to: [f64; 2],
    },
    /// A move on a surface has a NaN or infinite coordinate.
    #[error("move {index} ({from:?} -> {to:?}) is not finite")]
    NonFiniteMove3 {
        /// The move's position in its list (from 0).
        index: usize,
        /// Its start.
        from: [f64; 3],
        /// Its target.
        to: [f64; 3],
    },
    /// A move on a surface reaches past the coordinates a surface model may hold.
    #[error("move {index} ({from:?} -> {to:?}) reaches past {max:e}, the largest coordinate a surface model holds")]
    MoveOutOfRange {
        /// The move's position in its list (from 0).
        index: usize,
        /// Its start.
        from: [f64; 3],
        /// Its target.
        to: [f64; 3],
        /// The largest coordinate magnitude allowed.
        max: f64,
    },
    /// The warp moves a key point's shape past the coordinates a surface model holds.
    #[error("the warp moves key point {index} to {value:e}, past {max:e}, the largest coordinate a surface model holds")]
    WarpedOutOfRange {
        /// The key point (from 0).
        index: usize,
        /// The coordinate it would take.
        value: f64,
        /// The largest coordinate magnitude allowed.
        max: f64,
    },
    /// Two moves on a surface start at the same point, so no warp takes both.
    #[error("two moves start at the same point (move {index}, from {from:?})")]
    CoincidentMoves {
        /// One of the two moves (from 0).
        index: usize,
        /// Where it starts.
        from: [f64; 3],
    },
    /// The control points are too close for the interpolation system to be solved.
    #[error("control points too close to solve: {source}")]
    Unsolvable {
        /// The solve's failure.
        #[source]
        source: caoen_surface::SurfaceError,
    },
    /// A 3-D warp needs models whose shapes start with a position.
    #[error("the model's shapes have {components} components; a 3-D warp needs positions")]
    NotPositions {
        /// Components of the model's shapes.
        components: usize,
    },
    /// A texture-space network must map to 3-D points.
    #[error("the texture-space network must output 3-D points (it outputs {components})")]
    SpaceNotPositions {
        /// Components the network outputs.
        components: usize,
    },
    /// Transfer goes through shared domain points, so the surfaces need one domain.
    #[error(
        "the surfaces do not share a domain ({from:?} vs {to:?}); transfer goes through \
         corresponding domain points"
    )]
    DomainMismatch {
        /// The source surface's domain.
        from: Domain,
        /// The target surface's domain.
        to: Domain,
    },
    /// A texture-space network over another domain than its surface's.
    #[error("the texture-space network's domain {space:?} is not the surface's {surface:?}")]
    SpaceDomainMismatch {
        /// The texture-space network's domain.
        space: Domain,
        /// The surface's domain.
        surface: Domain,
    },
    /// A domain without texture coordinates.
    #[error("domain {domain:?} has no texture coordinates (sphere S^2 and torus do)")]
    NoTextureCoordinates {
        /// The domain.
        domain: Domain,
    },
    /// A surface whose box is a point or not finite.
    #[error(
        "surface `{surface}` has no extent to project a picture onto (its box's largest side is {largest_side})"
    )]
    NoExtent {
        /// The surface's name.
        surface: String,
        /// The largest side of its box: zero, or not finite.
        largest_side: f64,
    },
    /// A volume spec names no slices, or a slice stack is empty.
    #[error("volume: the slice stack is empty (\"slices\": [])")]
    NoSlices,
    /// The slices of a volume differ in size.
    #[error(
        "volume: slice {slice} is {}x{}, slice 0 is {}x{}: all slices must have one size",
        size.0, size.1, first.0, first.1
    )]
    SliceSize {
        /// The slice (from 0).
        slice: usize,
        /// Its width and height.
        size: (u32, u32),
        /// The first slice's width and height.
        first: (u32, u32),
    },
    /// A volume's voxel list does not match its size.
    #[error("volume of {}x{}x{} voxels given {values} values", size[0], size[1], size[2])]
    VoxelCount {
        /// Voxels per axis.
        size: [usize; 3],
        /// Values given.
        values: usize,
    },
    /// A slice of a volume could not be read.
    #[error("slice {slice} ({}): {source}", path.display())]
    SliceRead {
        /// The slice (from 0).
        slice: usize,
        /// Its file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A slice of a volume is not a readable image.
    #[error("slice {slice} ({}): {source}", path.display())]
    SliceDecode {
        /// The slice (from 0).
        slice: usize,
        /// Its file.
        path: PathBuf,
        /// The decoder's failure (boxed: it would double the size of every error).
        #[source]
        source: Box<caoen_render::RenderError>,
    },
    /// A volume spec is not valid JSON of its form.
    #[error("{source}")]
    VolumeJson {
        /// What the JSON parser said.
        #[source]
        source: serde_json::Error,
    },
    /// Something in a volume spec is wrong; `source` says what.
    #[error("{}: {source}", path.display())]
    InVolumeSpec {
        /// The spec file.
        path: PathBuf,
        /// The problem.
        #[source]
        source: Box<TextureError>,
    },
    /// A file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },

    // Bad parameters from the caller.
    /// An image with no pixels.
    #[error("empty image {width}x{height}")]
    EmptyImage {
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
    /// A warp applied to an image of another size than its own.
    #[error(
        "warp of {}x{} and image of {}x{}: sizes differ",
        warp.0, warp.1, image.0, image.1
    )]
    SizeMismatch {
        /// The warp's width and height.
        warp: (u32, u32),
        /// The image's width and height.
        image: (u32, u32),
    },
    /// A warp option outside its range.
    #[error("bad warp options: {name} = {value}, allowed {allowed}")]
    WarpOption {
        /// Which option.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Its valid range.
        allowed: &'static str,
    },
    /// A real parameter outside its range.
    #[error("{what} {value}: {allowed}")]
    Parameter {
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f64,
        /// Its valid range.
        allowed: &'static str,
    },
    /// A count outside its range.
    #[error("{what} {value}: allowed {min}..={max}")]
    Count {
        /// Which count.
        what: &'static str,
        /// Its value.
        value: u64,
        /// Smallest allowed.
        min: u64,
        /// Largest allowed.
        max: u64,
    },
    /// A box with a side that is not finite and positive.
    #[error("{what} {lo:?}..{hi:?}: each side must be finite and > 0")]
    BadBox {
        /// Which box.
        what: &'static str,
        /// Its low corner.
        lo: [f64; 3],
        /// Its high corner.
        hi: [f64; 3],
    },
    /// A volume's box with a side that is not finite and positive.
    #[error("volume box {min:?}..{max:?}: need finite min < max on every axis")]
    VolumeBox {
        /// Its low corner.
        min: [f64; 3],
        /// Its high corner.
        max: [f64; 3],
    },
    /// An unknown solid texture name.
    #[error(
        "unknown solid texture {name:?}: one of {} or a volume spec (.json)",
        super::solid::PROCEDURAL.join(", ")
    )]
    UnknownSolid {
        /// The name given.
        name: String,
    },
    /// Colours not in the form `RRGGBB,RRGGBB`.
    #[error(
        "colours {text:?}: {}expected two sRGB hex colours RRGGBB,RRGGBB",
        match colour { Some(0) => "the first is not a colour; ", Some(_) => "the second is not a colour; ", None => "" }
    )]
    Colours {
        /// The text given.
        text: String,
        /// Which of the two colours is malformed (0: the first); `None` when the text
        /// is not two colours.
        colour: Option<usize>,
    },

    // Limits.
    /// More moves than the dense solve takes.
    #[error("{moves} moves: at most {max}")]
    TooManyMoves {
        /// Moves given.
        moves: usize,
        /// The limit.
        max: usize,
    },
    /// A 3-D warp without moves.
    #[error("no moves: a surface warp needs 1..={max}")]
    NoMoves {
        /// The most moves it takes.
        max: usize,
    },
    /// More key points (controls, rings and anchors) than the dense solve takes.
    #[error("{key_points} key points: at most {max}")]
    TooManyKeyPoints {
        /// Key points needed.
        key_points: usize,
        /// The limit.
        max: usize,
    },
    /// A volume with no voxels or too many.
    #[error(
        "volume of {}x{}x{} voxels: must be non-empty and at most {max}",
        size[0], size[1], size[2]
    )]
    VolumeSize {
        /// Voxels per axis.
        size: [usize; 3],
        /// The most voxels a volume may have.
        max: usize,
    },
    /// A volume spec's slices hold more voxels than a volume may have.
    #[error("more than {max} voxels (by slice {slice})")]
    TooManyVoxels {
        /// The slice that went over (from 0).
        slice: usize,
        /// The most voxels a volume may have.
        max: usize,
    },
    /// A texture grid with no texels or too many.
    #[error("texture size {width}x{height}: must be non-empty and at most {max} texels")]
    TextureSize {
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The most texels it may have.
        max: u64,
    },

    // Failures of the layers below.
    /// A network could not be built or evaluated.
    #[error(transparent)]
    Surface(#[from] caoen_surface::SurfaceError),
    /// A raster could not be built.
    #[error(transparent)]
    Raster(#[from] caoen_base::raster::RasterError),
    /// A surface could not be tessellated.
    #[error(transparent)]
    Render(#[from] caoen_render::RenderError),
}
