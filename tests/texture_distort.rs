//! `caoen distort` and the warp network: control point placement, identity,
//! Jacobian sign, PNG vs .cae agreement, fold-over warning, CLI errors.

mod common;
use common::{argv, assert_ok, caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

use caoen::codec::{self, decoder, DecodeOptions, EncodeOptions};
use caoen::image_io;
use caoen::metrics;
use caoen::raster::{ChannelLayout, Raster, SampleFormat};
use caoen::texture::warp::{self, Move, Warp};
use caoen::texture::warp3d::{Move3, Warp3};

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("distort-{name}"))
}

const W: u32 = 160;
const H: u32 = 120;

/// A consistent set of moves: four points pushed in different directions.
fn moves() -> Vec<Move> {
    [
        ([40.5, 30.5], [48.25, 36.0]),
        ([120.5, 30.5], [113.0, 26.5]),
        ([80.5, 60.5], [80.5, 70.0]),
        ([50.5, 95.5], [44.0, 92.75]),
    ]
    .map(|(from, to)| Move { from, to })
    .to_vec()
}

/// [`moves`] with every point kept where it is.
fn identity_moves() -> Vec<Move> {
    moves()
        .iter()
        .map(|m| Move {
            from: m.from,
            to: m.from,
        })
        .collect()
}

/// A smooth colourful image with some structure.
fn pattern() -> Raster {
    let n = (W * H) as usize;
    let mut v = vec![0.0f32; 3 * n];
    for y in 0..H as usize {
        for x in 0..W as usize {
            let (fx, fy) = (x as f32 / W as f32, y as f32 / H as f32);
            let i = y * W as usize + x;
            v[i] = 0.5 + 0.4 * (fx * 12.0).sin() * (fy * 9.0).cos();
            v[n + i] = fx;
            v[2 * n + i] = if (x / 16 + y / 16) % 2 == 0 { 0.8 } else { 0.2 };
        }
    }
    Raster::new(W, H, ChannelLayout::Rgb, SampleFormat::U8, v).unwrap()
}

#[test]
fn control_points_land_on_their_targets_exactly() {
    let warp = Warp::new(W, H, &moves()).unwrap();
    let mut worst: f64 = 0.0;
    for m in moves() {
        let p = warp.map(m.from[0], m.from[1]);
        worst = worst.max(((p[0] - m.to[0]).powi(2) + (p[1] - m.to[1]).powi(2)).sqrt());
    }
    println!("warp function placement error: max {worst:.2e} px");
    assert!(worst < 1e-6, "{worst}"); // far inside the 0.5 px requirement
                                      // Far corners stay put.
    for (x, y) in [
        (0.0, 0.0),
        (W as f64, 0.0),
        (0.0, H as f64),
        (W as f64, H as f64),
    ] {
        let d = warp.displacement(x, y);
        assert!(
            d[0].abs() < 1e-6 && d[1].abs() < 1e-6,
            "corner {x},{y}: {d:?}"
        );
    }
}

#[test]
fn dots_at_control_points_move_to_their_targets() {
    // Black image with small Gaussian dots at the control points.
    let n = (W * H) as usize;
    let mut v = vec![0.0f32; n];
    for m in moves() {
        for y in 0..H as usize {
            for x in 0..W as usize {
                let d2 =
                    (x as f64 + 0.5 - m.from[0]).powi(2) + (y as f64 + 0.5 - m.from[1]).powi(2);
                v[y * W as usize + x] += (-d2 / (2.0 * 1.2f64.powi(2))).exp() as f32;
            }
        }
    }
    let img = Raster::new(W, H, ChannelLayout::Grey, SampleFormat::F32, v).unwrap();
    let warp = Warp::new(W, H, &moves()).unwrap();
    let out = warp::warp_raster(&img, &warp, 4).unwrap();
    let p = out.plane(0);
    let mut worst: f64 = 0.0;
    for m in moves() {
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in 0..H as i64 {
            for x in 0..W as i64 {
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                if (cx - m.to[0]).abs() > 7.0 || (cy - m.to[1]).abs() > 7.0 {
                    continue;
                }
                let v = p[(y * W as i64 + x) as usize] as f64;
                sx += v * cx;
                sy += v * cy;
                sw += v;
            }
        }
        let e = ((sx / sw - m.to[0]).powi(2) + (sy / sw - m.to[1]).powi(2)).sqrt();
        worst = worst.max(e);
    }
    println!("dot centroid placement error: max {worst:.3} px");
    assert!(worst < 0.5, "{worst}");
}

#[test]
fn identity_moves_reproduce_the_input() {
    let img = pattern();
    let id = identity_moves();
    let warp = Warp::new(W, H, &id).unwrap();
    let out = warp::warp_raster(&img, &warp, 3).unwrap();
    let psnr = metrics::psnr(&img, &out).unwrap();
    println!("identity PSNR {psnr} dB");
    assert!(psnr > 45.0, "{psnr}");
}

#[test]
fn consistent_moves_have_a_positive_jacobian_and_no_holes() {
    let warp = Warp::new(W, H, &moves()).unwrap();
    let r = warp.check_folds(1.0);
    println!(
        "Jacobian check: {} samples, {} folded, min det {:.3}",
        r.samples, r.folded, r.min_det
    );
    assert!(r.is_consistent() && r.min_det > 0.0, "{r:?}");
    // The exact Jacobian agrees with finite differences.
    let (x, y) = (70.3, 44.1);
    let j = warp.jacobian(x, y);
    let h = 1e-4;
    let (a, b) = (warp.map(x + h, y), warp.map(x - h, y));
    assert!(((a[0] - b[0]) / (2.0 * h) - j[0][0]).abs() < 1e-5);
    assert!(((a[1] - b[1]) / (2.0 * h) - j[1][0]).abs() < 1e-5);
    let out = warp::warp_raster(&pattern(), &warp, 3).unwrap();
    assert!(out.samples().iter().all(|v| v.is_finite()));
}

#[test]
fn crossing_moves_are_detected_and_still_defined() {
    let crossing = vec![
        Move {
            from: [60.5, 60.5],
            to: [100.5, 60.5],
        },
        Move {
            from: [100.5, 60.5],
            to: [60.5, 60.5],
        },
    ];
    let warp = Warp::new(W, H, &crossing).unwrap();
    let r = warp.check_folds(2.0);
    assert!(!r.is_consistent(), "{r:?}");
    let out = warp::warp_raster(&pattern(), &warp, 2).unwrap();
    assert!(out.samples().iter().all(|v| v.is_finite()));
}

#[test]
fn png_and_cae_paths_agree() {
    let img = pattern();
    let bytes = codec::encode(
        &img,
        &EncodeOptions {
            quality: 95.0,
            ..Default::default()
        },
    )
    .unwrap();
    let decoded = codec::decode(&bytes, &DecodeOptions::default()).unwrap();
    let warp = Warp::new(W, H, &moves()).unwrap();
    let via_png = warp::warp_raster(&decoded, &warp, 3).unwrap();
    let d = decoder::read(&bytes, codec::DEFAULT_MAX_PIXELS).unwrap();
    let via_cae = warp::warp_decoded(&d, &warp, 3).unwrap();
    let agree = metrics::psnr(&via_png, &via_cae).unwrap();
    let unwarped = metrics::psnr(&decoded, &via_cae).unwrap();
    println!(
        "PNG vs .cae distortion: PSNR {agree:.2} dB (vs the unwarped image: {unwarped:.2} dB)"
    );
    // The two paths resample differently (the PNG's pixels against the file's functions
    // forward-mapped with supersampling), most where the detail layer holds the
    // pattern's edges: 28.8 dB at q95, against 14.4 dB for the unwarped image.
    assert!(agree > 27.0, "{agree}");
    assert!(agree > unwarped + 10.0, "{agree} against {unwarped}");
    // With identity moves the .cae path is a box-sampled evaluation of the file: close
    // to the decoder's identity path (pixel centres).
    let id = identity_moves();
    let idw = Warp::new(W, H, &id).unwrap();
    let a = warp::warp_decoded(&d, &idw, 2).unwrap();
    let b = codec::decode(&bytes, &DecodeOptions::default()).unwrap();
    let p = metrics::psnr(&a, &b).unwrap();
    println!(".cae path with identity moves (S=2) vs the identity decode: {p:.2} dB");
    assert!(p > 35.0, "{p}");
}

/// [`pattern`] written as `dir/in.png`.
fn pattern_png(dir: &Path) -> PathBuf {
    let png = dir.join("in.png");
    image_io::save(&pattern(), &png).unwrap();
    png
}

#[test]
fn cli_distorts_png_and_cae() {
    let dir = tmpdir("cli");
    let png = pattern_png(&dir);
    let distort = |input: &Path, output: &Path, more: &[&str]| {
        caoen_ok(&[&["distort", s(input), "-o", s(output)][..], more].concat())
    };
    let out = dir.join("out.png");
    let moves = ["--move", "40.5,30.5:48,36", "--move", "80,60:80,70"];
    distort(&png, &out, &[&moves[..], &["--grid"]].concat());
    assert_eq!(image_io::load(&out).unwrap().width(), W);
    let cae = dir.join("in.cae");
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "--quiet"]);
    let json = dir.join("moves.json");
    std::fs::write(
        &json,
        r#"[{"from": [40.5, 30.5], "to": [48, 36]}, [[80, 60], [80, 70]]]"#,
    )
    .unwrap();
    let out2 = dir.join("out2.png");
    distort(&cae, &out2, &["--moves", s(&json), "--supersample", "2"]);
    // Crossing moves: a warning, still an image.
    let out3 = dir.join("out3.png");
    let crossing = ["--move", "60,60:100,60", "--move", "100,60:60,60"];
    let o = distort(&png, &out3, &crossing);
    assert!(String::from_utf8_lossy(&o.stderr).contains("warning"));
    assert!(out3.exists());
}

#[test]
fn cli_bad_arguments_and_files() {
    let dir = tmpdir("bad");
    let png = pattern_png(&dir);
    let out = dir.join("o.png");
    // The exit code of `caoen distort INPUT -o OUTPUT MORE...`, which never panics.
    let code = |input: &Path, output: &Path, more: &[&str]| {
        let o = caoen(&[&["distort", s(input), "-o", s(output)][..], more].concat());
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(!err.contains("panicked"), "{err}");
        o.status.code()
    };
    let junk = dir.join("junk.cae");
    std::fs::write(&junk, b"not a caoen file").unwrap();
    let junkpng = dir.join("junk.png");
    std::fs::write(&junkpng, b"\x89PNG garbage").unwrap();
    let bad_json = dir.join("bad.json");
    std::fs::write(&bad_json, b"{\"from\": 1}").unwrap();
    let (txt, missing, none) = (
        dir.join("o.txt"),
        dir.join("missing.png"),
        dir.join("none.json"),
    );
    let cases: [(&Path, &Path, &[&str], i32); 11] = [
        // Usage errors: exit 2.
        (&png, &out, &[], 2),
        (&png, &out, &["--move", "1,2"], 2),
        (&png, &out, &["--move", "a,b:c,d"], 2),
        (&png, &out, &["--move", "nan,1:2,3"], 2),
        (&png, &txt, &["--move", "1,2:3,4"], 2),
        (&png, &out, &["--move", "1,2:3,4", "--supersample", "0"], 2),
        // Bad files: exit 1.
        (&missing, &out, &["--move", "1,2:3,4"], 1),
        (&junk, &out, &["--move", "1,2:3,4"], 1),
        (&junkpng, &out, &["--move", "1,2:3,4"], 1),
        (&png, &out, &["--moves", s(&bad_json)], 1),
        (&png, &out, &["--moves", s(&none)], 1),
    ];
    for (input, output, more, want) in cases {
        let c = code(input, output, more);
        assert_eq!(c, Some(want), "{} -o {} {more:?}", s(input), s(output));
    }
    // Huge move coordinates: defined, no panic.
    let c = code(&png, &out, &["--move", "1e300,1:2,3"]);
    assert!(c == Some(0) || c == Some(1), "{c:?}");
}

/// The blob's +x tip (its first key point, of shape (1.3, 0, 0)) pulled out and a pole
/// held.
fn tip_pulled() -> [Move3; 2] {
    [
        ([1.3, 0.0, 0.0], [1.7, 0.3, -0.1]),
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
    ]
    .map(|(from, to)| Move3 { from, to })
}

#[test]
fn surface_3d_warp_moves_control_points_and_key_point_shapes() {
    let model = caoen::surface::gallery::by_name("blob").unwrap().unwrap();
    let moves = tip_pulled();
    let warp = Warp3::new([-1.5; 3], [1.5; 3], &moves).unwrap();
    for m in &moves {
        let p = warp.map(m.from);
        let e: f64 = (0..3).map(|k| (p[k] - m.to[k]).powi(2)).sum::<f64>().sqrt();
        assert!(e < 1e-9, "{e}");
    }
    let out = warp.apply_to_model(&model).unwrap();
    let sh = &out.network.shapes()[..3];
    assert!((sh[0] - 1.7).abs() < 1e-9 && (sh[1] - 0.3).abs() < 1e-9 && (sh[2] + 0.1).abs() < 1e-9);
    // CLI: a surface in, a surface and a mesh out; bad moves are usage errors.
    let dir = tmpdir("surface");
    let (json, obj) = (dir.join("d.json"), dir.join("d.obj"));
    let distort = |input: &str, output: &Path, mv: &str| {
        caoen(&["distort", input, "-o", s(output), "--move", mv])
    };
    assert_ok(&distort("builtin:blob", &json, "1.3,0,0:1.7,0.3,-0.1"));
    assert!(caoen::surface::SurfaceModel::load(&json, &caoen::Limits::default()).is_ok());
    assert_ok(&distort("builtin:blob", &obj, "1.3,0,0:1.7,0.3,-0.1"));
    let none = dir.join("none.json");
    for (input, output, mv, want) in [
        ("builtin:blob", &json, "1,2:3,4", 2),
        ("builtin:blob", &dir.join("x.png"), "1,0,0:1,1,0", 2),
        (s(&none), &json, "1,0,0:1,1,0", 1),
    ] {
        let code = distort(input, output, mv).status.code();
        assert_eq!(code, Some(want), "{input} -o {} {mv}", s(output));
    }
}

#[test]
fn surface_3d_warp_fold_check() {
    // Consistent: no fold anywhere on the 24^3 grid over the box.
    let consistent = tip_pulled();
    let warp = Warp3::new([-1.5; 3], [1.5; 3], &consistent).unwrap();
    let r = warp.check_folds(24);
    println!(
        "3-D consistent: {} samples, {} folded, min det {:.3}",
        r.samples, r.folded, r.min_det
    );
    assert_eq!(r.samples, 24 * 24 * 24);
    assert!(r.is_consistent() && r.min_det > 0.0, "{r:?}");
    // The exact Jacobian agrees with central differences.
    let p = [0.7, -0.2, 0.4];
    let j = warp.jacobian(p);
    let h = 1e-5;
    for c in 0..3 {
        let (mut a, mut b) = (p, p);
        a[c] += h;
        b[c] -= h;
        let (fa, fb) = (warp.map(a), warp.map(b));
        for r in 0..3 {
            let fd = (fa[r] - fb[r]) / (2.0 * h);
            assert!(
                (fd - j[r][c]).abs() < 1e-6,
                "J[{r}][{c}] {} vs {fd}",
                j[r][c]
            );
        }
    }
    // Crossing: two points swap places through each other: space folds over.
    let crossing = [
        ([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]),
        ([0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]),
    ]
    .map(|(from, to)| Move3 { from, to });
    let warp = Warp3::new([-1.5; 3], [1.5; 3], &crossing).unwrap();
    let r = warp.check_folds(24);
    println!(
        "3-D crossing: {} of {} folded, min det {:.3}",
        r.folded, r.samples, r.min_det
    );
    assert!(!r.is_consistent() && r.min_det < 0.0, "{r:?}");
    // CLI: the warning on stderr for the crossing moves only, a model written in both.
    let dir = tmpdir("fold3");
    let out = dir.join("d.json");
    let o = caoen_ok(&argv(
        "distort builtin:blob -o @ --move 1.3,0,0:1.7,0.3,-0.1 --move 0,0,1:0,0,1",
        &[s(&out)],
    ));
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = caoen_ok(&argv(
        "distort builtin:blob -o @ --force --quiet --move -0.5,0,0:0.5,0,0 --move 0.5,0,0:-0.5,0,0",
        &[s(&out)],
    ));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("warning: inconsistent moves"), "{err}");
    assert!(caoen::surface::SurfaceModel::load(&out, &caoen::Limits::default()).is_ok());
}
