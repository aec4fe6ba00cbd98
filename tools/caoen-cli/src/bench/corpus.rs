//! The images a benchmark runs on: a corpus directory (classes from its
//! `manifest.json`, or any image files) or the default procedural corpus, generated
//! in memory.

use std::path::{Path, PathBuf};

use caoen::image_io;
use caoen::raster::Raster;
use caoen_corpus::manifest::Manifest;
use caoen_corpus::Class;

/// Class given to files of a directory without a manifest.
pub const UNCLASSIFIED: &str = "unclassified";

/// One test image.
#[derive(Debug, Clone)]
pub struct BenchImage {
    /// Name in reports: the file name, or the generated image's stem.
    pub name: String,
    /// The file it came from, if any.
    pub file: Option<PathBuf>,
    /// Corpus class (`scene`, `natural`, ...).
    pub class: String,
    /// The pixels.
    pub raster: Raster,
}

/// Where the images come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A directory: the files its `manifest.json` lists, or else every image file.
    Dir(PathBuf),
    /// The procedural corpus at a nominal size (each class's default seeds, or `seeds`).
    Generated {
        /// Nominal side (`caoen corpus --size`).
        size: u32,
        /// Seeds per class, if not the default count.
        seeds: Option<u64>,
    },
}

impl Source {
    /// A one-line description for the report.
    pub fn describe(&self) -> String {
        match self {
            Source::Dir(d) => format!("directory {}", d.display()),
            Source::Generated { size, seeds } => match seeds {
                Some(s) => format!("procedural corpus generated in memory, size {size}, {s} seeds per class"),
                None => format!("procedural default corpus generated in memory, size {size} (same images as `caoen corpus --size {size}`)"),
            },
        }
    }
}

/// The order classes are reported in: the corpus's own, then any others by name.
pub fn class_rank(class: &str) -> (usize, String) {
    let rank = Class::ALL
        .iter()
        .position(|c| c.name() == class)
        .unwrap_or(Class::ALL.len());
    (rank, class.to_string())
}

/// Extensions read from a directory without a manifest.
const IMAGE_EXTENSIONS: [&str; 12] = [
    "png", "jpg", "jpeg", "exr", "bmp", "gif", "tif", "tiff", "webp", "pnm", "ppm", "tga",
];

/// Loads the images, keeping only `classes` if it is not empty.
pub fn load(source: &Source, classes: &[String]) -> Result<Vec<BenchImage>, String> {
    let keep = |class: &str| classes.is_empty() || classes.iter().any(|c| c == class);
    let mut images = match source {
        Source::Dir(dir) => load_dir(dir, &keep)?,
        Source::Generated { size, seeds } => {
            let wanted: Vec<Class> = Class::ALL
                .iter()
                .copied()
                .filter(|c| keep(c.name()))
                .collect();
            caoen_corpus::corpus(*size, &wanted, *seeds)
                .iter()
                .map(|spec| {
                    let raster = image_io::from_dynamic(spec.generate().to_dynamic_image())
                        .map_err(|e| format!("{}: {e}", spec.stem()))?;
                    Ok(BenchImage {
                        name: spec.stem(),
                        file: None,
                        class: spec.class.name().to_string(),
                        raster,
                    })
                })
                .collect::<Result<Vec<_>, String>>()?
        }
    };
    images.sort_by(|a, b| {
        class_rank(&a.class)
            .cmp(&class_rank(&b.class))
            .then(a.name.cmp(&b.name))
    });
    if images.is_empty() {
        return Err(match source {
            Source::Dir(d) => format!("no images to benchmark in {}", d.display()),
            Source::Generated { .. } => "no corpus classes selected".into(),
        });
    }
    Ok(images)
}

fn load_dir(dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<Vec<BenchImage>, String> {
    let manifest = Manifest::read_for_reading(dir).map_err(|e| e.to_string())?;
    let entries: Vec<(String, String)> = match manifest {
        Some(m) => m
            .images
            .iter()
            .map(|e| (e.file.clone(), e.class.name().to_string()))
            .collect(),
        None => {
            let rd = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let mut files = Vec::new();
            for entry in rd {
                let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let ext = Path::new(&name)
                    .extension()
                    .map(|e| e.to_string_lossy().to_ascii_lowercase());
                if ext.is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.as_str())) {
                    files.push((name, UNCLASSIFIED.to_string()));
                }
            }
            files
        }
    };
    entries
        .into_iter()
        .filter(|(_, class)| keep(class))
        .map(|(name, class)| {
            let path = dir.join(&name);
            let raster = image_io::load(&path).map_err(|e| e.to_string())?;
            Ok(BenchImage {
                name,
                file: Some(path),
                class,
                raster,
            })
        })
        .collect()
}
