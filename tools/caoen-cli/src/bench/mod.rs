//! `caoen bench`: the rate-distortion benchmark of caoen against real peer codecs.
//! See `docs/benchmarks.md` for how to run it and what it reports.
//!
//! - [`corpus`]: the images (a corpus directory or the generated default corpus);
//! - [`codecs`]: the codec interface, caoen through its facade, the registry;
//! - `peers` (feature `peers`): JPEG (mozjpeg library, `image` crate) and WebP;
//! - [`external`]: AVIF and JPEG XL through their command-line tools;
//! - [`harness`]: the sweep, rate search, timing and measuring;
//! - [`bd_rate`]: PCHIP and the Bjontegaard deltas;
//! - [`summary`]: per-image and per-class statistics;
//! - [`report`]: the JSON report and its Markdown tables;
//! - [`plot`]: RD plots per class.

pub mod bd_rate;
pub mod codecs;
pub mod corpus;
pub mod external;
pub mod harness;
#[cfg(feature = "peers")]
pub mod peers;
pub mod plot;
pub mod report;
pub mod summary;

use std::path::PathBuf;

use clap::Args;

/// `caoen bench`.
#[derive(Debug, Args, Clone)]
pub struct BenchArgs {
    /// Corpus directory (as written by `caoen corpus --out DIR`: classes from its
    /// manifest.json; or any directory of images). Default: the default corpus,
    /// generated in memory.
    pub corpus: Option<PathBuf>,
    /// Codecs, comma-separated: caoen; avif (avifenc/avifdec, aom speed 6, 4:2:0), avif444
    /// and jxl (cjxl/djxl, effort 7) when their tools are installed; with the `peers`
    /// feature also jpeg (libjpeg-turbo settings, optimised Huffman), mozjpeg, jpeg-image
    /// (the image crate), webp.
    /// Default: caoen,jpeg,webp with peers, caoen without.
    #[arg(long, value_delimiter = ',')]
    pub codecs: Option<Vec<String>>,
    /// Rate points: `auto` (each codec's own quality ladder), or a list of
    /// bits-per-pixel targets and quality settings, e.g. `0.1,0.25,0.5,1` or `q30,q75`.
    #[arg(long, default_value = "auto")]
    pub rates: String,
    /// Reference codec of the BD-rate/BD-PSNR columns (default: jpeg if benchmarked,
    /// else the first codec).
    #[arg(long)]
    pub reference: Option<String>,
    /// Write the JSON report (every measurement and the summaries) here.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Write RD plots, one per class: `rd.png` gives `rd-scene.png`, ... (.png or .svg).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Also write the Markdown tables (always printed on stdout) to this file; a file
    /// holding the two `caoen bench` markers keeps its text outside them (an existing
    /// file needs --force, like every output).
    #[arg(long, value_name = "FILE")]
    pub markdown: Option<PathBuf>,
    /// Keep every encoded file and its decoded image in this directory (files of the
    /// same names there are replaced without --force: the directory is the bench's).
    #[arg(long, value_name = "DIR")]
    pub keep: Option<PathBuf>,
    /// Only these classes (comma-separated corpus class names).
    #[arg(long, value_delimiter = ',')]
    pub classes: Vec<String>,
    /// Nominal size of the generated corpus (no CORPUS_DIR).
    #[arg(long, default_value_t = 512, conflicts_with = "corpus",
          value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub size: u32,
    /// Seeds per class of the generated corpus (default: each class's default count).
    #[arg(long, conflicts_with = "corpus", value_parser = clap::value_parser!(u64).range(1..=64))]
    pub seeds: Option<u64>,
    /// Timed runs of each encode and decode; the median is reported.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=50))]
    pub repeat: u32,
    /// caoen encoder effort (1..9; default: the codec's).
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=9))]
    pub effort: Option<u8>,
}
