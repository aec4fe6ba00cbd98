//! # caoen-corpus: a procedural, bit-reproducible test-image corpus
//!
//! Every image is a pure function of `(class, width, height, seed)`: the same call
//! produces the same samples on every machine and with any number of threads.
//! See `README.md` in this crate for the class list, the determinism rules and
//! the manifest format.
//!
//! ```
//! use caoen_corpus::{generate, Class};
//! let img = generate(Class::Texture, 64, 48, 0); // a zone plate
//! assert_eq!((img.width(), img.height(), img.channels()), (64, 48, 1));
//! let again = generate(Class::Texture, 64, 48, 0);
//! assert_eq!(img.sha256(), again.sha256());
//! ```

pub mod canvas;
mod classes;
pub mod cli;
pub mod contact;
mod error;
mod image;
pub mod manifest;
pub mod math;
pub mod noise;
pub mod rng;

use std::fmt;
use std::str::FromStr;

pub use crate::error::CorpusError;
pub use crate::image::{CorpusImage, PixelData, SampleFormat};

/// Image classes of the corpus. The seed selects a variant within the class
/// (`seed % class.variant_count()`) and randomises its parameters.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Class {
    /// Linear/radial gradients, smooth blobs, low-frequency fields only.
    Smooth,
    /// Flat regions bounded by hard anti-aliased edges: polygons, discs, curves,
    /// text-like strokes, thin lines.
    #[value(name = "flat-edges", alias = "flat", alias = "flat-and-edges")]
    FlatEdges,
    /// Stripes, checkerboards, zone plate up to Nyquist, periodic patterns.
    Texture,
    /// fBm noise terrain, clouds, marble, wood, with lighting.
    Natural,
    /// Photograph-like composites.
    Scene,
    /// Float scenes with dynamic range above 1000:1 (OpenEXR).
    Hdr,
    /// Degenerate sizes, flat images, pure noise, gray and alpha variants.
    #[value(name = "edge-cases", alias = "edge", alias = "edges")]
    EdgeCases,
}

impl Class {
    /// All classes, in corpus order.
    pub const ALL: [Class; 7] = [
        Class::Smooth,
        Class::FlatEdges,
        Class::Texture,
        Class::Natural,
        Class::Scene,
        Class::Hdr,
        Class::EdgeCases,
    ];

    /// The name used on the command line, in file names and in the manifest.
    pub fn name(self) -> &'static str {
        match self {
            Class::Smooth => "smooth",
            Class::FlatEdges => "flat-edges",
            Class::Texture => "texture",
            Class::Natural => "natural",
            Class::Scene => "scene",
            Class::Hdr => "hdr",
            Class::EdgeCases => "edge-cases",
        }
    }

    /// Number of distinct variants; `seed % variant_count()` picks one.
    pub fn variant_count(self) -> u64 {
        match self {
            Class::Smooth | Class::FlatEdges | Class::Texture | Class::Natural | Class::Scene => 4,
            Class::Hdr => 3,
            Class::EdgeCases => 8,
        }
    }

    /// Short description of the variant a seed selects.
    pub fn variant_name(self, seed: u64) -> &'static str {
        classes::variant_name(self, seed)
    }

    /// Number of seeds of this class in the default corpus.
    pub fn default_seed_count(self) -> u64 {
        match self {
            Class::Smooth | Class::FlatEdges | Class::Texture | Class::Natural => 6,
            Class::Scene | Class::EdgeCases => 8,
            Class::Hdr => 3,
        }
    }

    /// Channel count and sample format that `generate(self, _, _, seed)` produces.
    pub fn format(self, seed: u64) -> (u8, SampleFormat) {
        classes::format(self, seed)
    }

    /// Image size used for `seed` in a corpus of nominal size `size`: `size x size`,
    /// except wide scenes (`seed / 4` odd: `3*size/2 x size`) and edge cases, whose
    /// sizes cycle through 1x1, 1xN, Nx1, 1023x7 and odd sizes.
    pub fn dims(self, seed: u64, size: u32) -> (u32, u32) {
        let s = size.max(1);
        match self {
            Class::Scene if (seed / 4) % 2 == 1 => ((s * 3).div_ceil(2), s),
            Class::EdgeCases => match seed % 8 {
                0 | 1 => (s, s),
                2 => (1023, 7),
                3 => (1, 1),
                4 => (1, s),
                5 => (s, 1),
                6 => (1, 1),
                _ => ((s * 2 / 3) | 1, (s + 5) | 1),
            },
            _ => (s, s),
        }
    }
}

impl fmt::Display for Class {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Class {
    type Err = CorpusError;
    fn from_str(s: &str) -> Result<Class, CorpusError> {
        <Class as clap::ValueEnum>::from_str(s, true).map_err(|_| {
            let names: Vec<&str> = Class::ALL.iter().map(|c| c.name()).collect();
            CorpusError::InvalidArgument(format!(
                "unknown class {s:?} (expected one of {})",
                names.join(", ")
            ))
        })
    }
}

/// One corpus entry: which image to generate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Spec {
    pub class: Class,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
}

impl Spec {
    pub fn new(class: Class, width: u32, height: u32, seed: u64) -> Spec {
        Spec {
            class,
            width,
            height,
            seed,
        }
    }

    /// Generate the image (see [`generate`]).
    pub fn generate(&self) -> CorpusImage {
        generate(self.class, self.width, self.height, self.seed)
    }

    /// Channel count and sample format of the generated image.
    pub fn format(&self) -> (u8, SampleFormat) {
        self.class.format(self.seed)
    }

    /// `"{class}-{seed:02}-{width}x{height}"`.
    pub fn stem(&self) -> String {
        format!(
            "{}-{:02}-{}x{}",
            self.class.name(),
            self.seed,
            self.width,
            self.height
        )
    }

    /// File name: the stem plus `.png` (8/16-bit) or `.exr` (float).
    pub fn file_name(&self) -> String {
        format!("{}.{}", self.stem(), self.format().1.extension())
    }
}

impl fmt::Display for Spec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} seed {} {}x{}",
            self.class, self.seed, self.width, self.height
        )
    }
}

/// Generate one image. Deterministic: the result depends only on the arguments
/// (not on the platform or on the rayon thread count).
///
/// Any size of at least 1x1 works for every class. Panics if a side is zero;
/// use [`try_generate`] for a `Result`.
pub fn generate(class: Class, width: u32, height: u32, seed: u64) -> CorpusImage {
    match try_generate(class, width, height, seed) {
        Ok(img) => img,
        Err(e) => panic!("{e}"),
    }
}

/// Largest accepted side length.
pub const MAX_SIDE: u32 = 16384;

/// Like [`generate`], but rejects zero or oversized (> [`MAX_SIDE`]) sides with an error.
pub fn try_generate(
    class: Class,
    width: u32,
    height: u32,
    seed: u64,
) -> Result<CorpusImage, CorpusError> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(CorpusError::InvalidArgument(format!(
            "image size {width}x{height} out of range (each side must be 1 to {MAX_SIDE})"
        )));
    }
    let img = classes::render(class, width as usize, height as usize, seed);
    debug_assert_eq!((img.channels(), img.sample_format()), class.format(seed));
    Ok(img)
}

/// The specs of a corpus: for each class (in the given order), seeds `0..n`
/// where `n` is `seeds` or the class's default seed count, sized by [`Class::dims`].
pub fn corpus(size: u32, classes: &[Class], seeds: Option<u64>) -> Vec<Spec> {
    let mut out = Vec::new();
    for &class in classes {
        let n = seeds.unwrap_or_else(|| class.default_seed_count());
        for seed in 0..n {
            let (w, h) = class.dims(seed, size);
            out.push(Spec::new(class, w, h, seed));
        }
    }
    out
}

/// The default corpus: all classes at 512 (43 images: mostly 512x512, wide scenes
/// at 768x512, edge cases at their own sizes).
pub fn default_corpus() -> Vec<Spec> {
    corpus(512, &Class::ALL, None)
}

/// A small fixed subset for test suites: every variant of every class at 64x48
/// (edge cases at their own small sizes). Generates in well under a second.
pub fn test_subset() -> Vec<Spec> {
    let mut out = Vec::new();
    for class in Class::ALL {
        for seed in 0..class.variant_count() {
            let (w, h) = match class {
                Class::EdgeCases => class.dims(seed, 48),
                _ => (64, 48),
            };
            out.push(Spec::new(class, w, h, seed));
        }
    }
    out
}
