//! Every picture caoen writes from the damaged and unusual metadata of
//! `tests/bad/hostile/third-*` is one that other readers read: Pillow decodes its
//! pixels, and exiftool reads it with no error and no warning about its structure
//! (a profile of the wrong colour space, EXIF that is not TIFF, a bad chunk CRC).

mod common;

use std::path::Path;
use std::process::Command;

use common::{caoen_ok, fresh_dir, hostile as bad, tool_present};

/// The third round's images with metadata, as cameras and editors damage it.
const INPUTS: [&str; 13] = [
    "third-D1-exif-not-tiff.jpg",
    "third-D1b-exif-double-prefix.jpg",
    "third-D1c-icc-chunk-missing.jpg",
    "third-D1d-iccp-bad-zlib.png",
    "third-D1e-png-exif-not-tiff.png",
    "third-D5-exif-junk.cae",
    "third-D6-cmyk-jpeg-cmyk-icc.jpg",
    "third-D7-xmp-extended.jpg",
    "third-M1-exif-and-xmp-orientation-6.jpg",
    "third-M2-grey-jpeg-rgb-icc.jpg",
    "third-M3-xmp-invalid-utf8.jpg",
    "third-M4-iccp-bad-crc.png",
    "third-M6-orientation-6.jpg",
];

fn exiftool_present() -> bool {
    let ok = Command::new("exiftool")
        .arg("-ver")
        .output()
        .is_ok_and(|o| o.status.success());
    tool_present(ok, "exiftool (Debian libimage-exiftool-perl)")
}

fn pillow_present() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import PIL"])
        .output()
        .is_ok_and(|o| o.status.success());
    tool_present(ok, "Python's Pillow")
}

/// exiftool's errors and warnings about `file`, with `-validate` (structure checks
/// of PNG chunks, EXIF directories and profiles); empty when it reads the file cleanly.
fn exiftool_complaints(file: &Path) -> Vec<String> {
    let out = Command::new("exiftool")
        .args(["-validate", "-error", "-warning", "-a", "-s", "-G1"])
        .arg(file)
        .output()
        .expect("exiftool runs");
    assert!(out.status.success(), "exiftool on {}", file.display());
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| {
            // `Validate` is the summary line ("OK", or the count of problems below).
            let tag = l.split(':').next().unwrap_or("");
            (tag.contains("Error") || tag.contains("Warning")) && !tag.contains("Validate")
        })
        .map(str::to_string)
        .collect()
}

/// Pillow opens and decodes each file fully; the error of the first that fails.
fn pillow_reads(files: &[String]) -> Result<(), String> {
    let script = "import sys\nfrom PIL import Image\nfor f in sys.argv[1:]:\n    \
                  im = Image.open(f); im.load(); assert im.size[0] > 0, f\n";
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(files)
        .output()
        .expect("python3 runs");
    if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

#[test]
fn every_picture_written_from_damaged_metadata_reads_in_pillow_and_exiftool() {
    if !exiftool_present() || !pillow_present() {
        return;
    }
    let dir = fresh_dir("hostile-reread");
    let mut written = Vec::new();
    for input in INPUTS {
        let stem = input.trim_end_matches(|c| c != '.').trim_end_matches('.');
        let at = |ext: &str| dir.join(format!("{stem}.{ext}")).display().to_string();
        let cae = if input.ends_with(".cae") {
            bad(input)
        } else {
            caoen_ok(&["encode", &bad(input), "-o", &at("cae"), "-q", "40"]);
            at("cae")
        };
        for ext in ["png", "exr"] {
            caoen_ok(&["decode", &cae, "-o", &at(ext)]);
            // What caoen writes, caoen reads, and keeps reading the same way.
            caoen_ok(&[
                "encode",
                &at(ext),
                "-o",
                &at(&format!("{ext}.cae")),
                "-q",
                "40",
            ]);
            caoen_ok(&[
                "decode",
                &at(&format!("{ext}.cae")),
                "-o",
                &at(&format!("again.{ext}")),
            ]);
        }
        for file in [at("png"), at("exr"), at("again.png"), at("again.exr")] {
            let complaints = exiftool_complaints(Path::new(&file));
            assert!(complaints.is_empty(), "{file}: {complaints:?}");
            written.push(file);
        }
    }
    let pngs: Vec<String> = written
        .iter()
        .filter(|f| f.ends_with(".png"))
        .cloned()
        .collect();
    assert_eq!(pngs.len(), 2 * INPUTS.len());
    if let Err(e) = pillow_reads(&pngs) {
        panic!("Pillow does not read a PNG caoen wrote: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// exiftool's check sees what the test relies on it to see: a PNG whose profile chunk
/// has a bad CRC is reported (so a clean report of caoen's files means something).
#[test]
fn exiftool_reports_a_damaged_profile_chunk() {
    if !exiftool_present() {
        return;
    }
    let complaints = exiftool_complaints(Path::new(&bad("third-M4-iccp-bad-crc.png")));
    assert!(!complaints.is_empty(), "no complaint about a bad CRC");
}
