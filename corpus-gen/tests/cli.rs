//! The command line: outputs, manifest, contact sheet, overwrite protection, errors.

mod common;

use std::path::Path;
use std::process::Command;

use caoen_corpus::cli::{run, CorpusArgs};
use caoen_corpus::manifest::{Manifest, MANIFEST_NAME};
use caoen_corpus::{contact, CorpusError, PixelData, SampleFormat, Spec};
use common::TempDir;

fn args(out: &Path) -> CorpusArgs {
    CorpusArgs {
        out: Some(out.to_path_buf()),
        size: 32,
        classes: vec![
            caoen_corpus::Class::Smooth,
            caoen_corpus::Class::Hdr,
            caoen_corpus::Class::EdgeCases,
        ],
        seeds: Some(3),
        quiet: true,
        ..CorpusArgs::default()
    }
}

fn read_exr(path: &Path) -> Vec<f32> {
    use exr::prelude::*;
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![0f32; res.width() * res.height() * 3]),
        |(w, v): &mut (usize, Vec<f32>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = (pos.y() * *w + pos.x()) * 3;
            v[i] = r;
            v[i + 1] = g;
            v[i + 2] = b;
        },
    )
    .unwrap();
    img.layer_data.channel_data.pixels.1
}

#[test]
fn writes_files_matching_the_manifest_and_a_contact_sheet() {
    let dir = TempDir::new("cli");
    let mut a = args(dir.path());
    let sheet = dir.path().join("sheet.png");
    a.contact_sheet = Some(sheet.clone());
    run(&a).unwrap();
    let m = Manifest::read_from_dir(dir.path())
        .unwrap()
        .expect("our manifest");
    assert_eq!(m.images.len(), 9);
    assert_eq!(m.contact_sheet.as_deref(), Some("sheet.png"));
    for e in &m.images {
        let spec = Spec::new(e.class, e.width, e.height, e.seed);
        assert_eq!(e.file, spec.file_name());
        let img = spec.generate();
        assert_eq!(e.sha256, img.sha256(), "{}", e.file);
        assert_eq!((e.channels, e.bit_depth), (img.channels(), img.bit_depth()));
        let path = dir.path().join(&e.file);
        // The files decode to exactly the generated samples.
        match img.data() {
            PixelData::F32(v) => {
                assert_eq!(e.sample_format, SampleFormat::F32);
                assert!(e.file.ends_with(".exr"));
                assert_eq!(&read_exr(&path), v, "{}", e.file);
            }
            _ => {
                let decoded = image::open(&path).unwrap();
                assert_eq!(decoded, img.to_dynamic_image(), "{}", e.file);
            }
        }
    }
    // Contact sheet: a PNG with the layout's dimensions.
    let s = image::open(&sheet).unwrap();
    let (_, _, w, h) = contact::layout(9);
    assert_eq!((s.width(), s.height()), (w, h));
    assert_eq!(contact::layout(43), (8, 6, 6 + 8 * 166, 6 + 6 * 180));

    // Running again into our own directory is fine and reproduces the manifest.
    run(&a).unwrap();
    assert_eq!(Manifest::read_from_dir(dir.path()).unwrap().unwrap(), m);
}

#[test]
fn output_does_not_depend_on_thread_count() {
    let (d1, d2) = (TempDir::new("t1"), TempDir::new("t2"));
    let mut a1 = args(d1.path());
    a1.threads = Some(1);
    a1.classes = vec![];
    a1.seeds = Some(4);
    let mut a2 = a1.clone();
    a2.out = Some(d2.path().to_path_buf());
    a2.threads = Some(2);
    run(&a1).unwrap();
    run(&a2).unwrap();
    let m = Manifest::read_from_dir(d1.path()).unwrap().unwrap();
    assert_eq!(m.images.len(), 28);
    for name in m
        .images
        .iter()
        .map(|e| e.file.clone())
        .chain([MANIFEST_NAME.to_string()])
    {
        let b1 = std::fs::read(d1.path().join(&name)).unwrap();
        let b2 = std::fs::read(d2.path().join(&name)).unwrap();
        assert!(b1 == b2, "{name} differs between 1 and 2 threads");
    }
}

#[test]
fn refuses_to_overwrite_foreign_files() {
    // A non-empty directory without our manifest.
    let dir = TempDir::new("foreign");
    std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
    let a = args(dir.path());
    assert!(matches!(run(&a), Err(CorpusError::ForeignDirectory(_))));
    // A foreign manifest.json does not count as ours.
    std::fs::write(dir.path().join(MANIFEST_NAME), "{\"something\": 1}").unwrap();
    assert!(matches!(run(&a), Err(CorpusError::ForeignDirectory(_))));
    assert_eq!(
        std::fs::read_to_string(dir.path().join(MANIFEST_NAME)).unwrap(),
        "{\"something\": 1}"
    );
    // --force writes anyway.
    let forced = CorpusArgs {
        force: true,
        ..a.clone()
    };
    run(&forced).unwrap();
    assert!(Manifest::read_from_dir(dir.path()).unwrap().is_some());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.txt")).unwrap(),
        "mine"
    );

    // Our directory, but a file we would write is not in our manifest.
    let dir = TempDir::new("unowned");
    let small = CorpusArgs {
        seeds: Some(1),
        ..args(dir.path())
    };
    run(&small).unwrap();
    let next = Spec::new(caoen_corpus::Class::Smooth, 32, 32, 1).file_name();
    std::fs::write(dir.path().join(&next), "not a png").unwrap();
    let more = CorpusArgs {
        seeds: Some(2),
        ..args(dir.path())
    };
    match run(&more) {
        Err(CorpusError::WouldOverwrite(p)) => assert!(p.ends_with(&next)),
        other => panic!("expected WouldOverwrite, got {other:?}"),
    }
    assert_eq!(
        std::fs::read_to_string(dir.path().join(&next)).unwrap(),
        "not a png"
    );
    // Existing contact sheet outside the directory.
    let other = TempDir::new("sheet");
    let sheet = other.path().join("s.png");
    std::fs::write(&sheet, "x").unwrap();
    let with_sheet = CorpusArgs {
        contact_sheet: Some(sheet.clone()),
        ..small.clone()
    };
    assert!(matches!(
        run(&with_sheet),
        Err(CorpusError::WouldOverwrite(_))
    ));
}

#[test]
fn bad_arguments_are_errors_not_panics() {
    let dir = TempDir::new("bad");
    for a in [
        CorpusArgs {
            seeds: Some(0),
            ..args(dir.path())
        },
        CorpusArgs {
            size: 0,
            ..args(dir.path())
        },
        CorpusArgs {
            size: 100_000,
            ..args(dir.path())
        },
        CorpusArgs {
            threads: Some(0),
            ..args(dir.path())
        },
        CorpusArgs {
            contact_sheet: Some(dir.path().join("sheet.jpg")),
            ..args(dir.path())
        },
        CorpusArgs {
            out: None,
            ..args(dir.path())
        },
    ] {
        assert!(
            matches!(run(&a), Err(CorpusError::InvalidArgument(_))),
            "{a:?}"
        );
    }
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    assert!(run(&CorpusArgs {
        out: Some(file),
        ..args(dir.path())
    })
    .is_err());
}

#[test]
fn binary_exit_codes() {
    let bin = env!("CARGO_BIN_EXE_caoen-corpus");
    let dir = TempDir::new("bin");
    let out = dir.path().join("c");
    let out_s = out.to_str().unwrap();
    for bad in [
        vec!["--out", out_s, "--seeds", "0"],
        vec!["--out", out_s, "--size", "0"],
        vec!["--out", out_s, "--classes", "bogus"],
        vec!["--out", out_s, "--size", "abc"],
        vec!["--size", "16"],
    ] {
        let o = Command::new(bin).args(&bad).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{bad:?} succeeded");
        assert!(!err.contains("panicked"), "{bad:?} panicked: {err}");
        assert!(!err.is_empty(), "{bad:?}: no message");
    }
    // A good run, quiet: nothing on stderr.
    let o = Command::new(bin)
        .args([
            "--out",
            out_s,
            "--size",
            "16",
            "--classes",
            "flat,edge",
            "--seeds",
            "2",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stderr.is_empty());
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 5);
    // --list prints the default corpus.
    let o = Command::new(bin).arg("--list").output().unwrap();
    assert!(o.status.success());
    let listing = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        listing.lines().count(),
        caoen_corpus::default_corpus().len()
    );
    assert!(
        listing.contains("scene-04-768x512.png") && listing.contains("edge-cases-02-1023x7.png")
    );
}
