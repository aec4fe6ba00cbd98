//! Side by side with ImageMagick's `-distort Shepards` on the same control points:
//! placement error (dot centroids), smoothness (mean |Laplacian| of the
//! displacement field, measured the same way for both through a warped coordinate
//! image) and time. `.ci/run` installs ImageMagick (Debian `imagemagick`); under
//! `CI=true` its absence fails the test, elsewhere it is skipped with a message.

mod common;
use common::{assert_ok, s};

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use caoen::image_io;
use caoen::raster::{ChannelLayout, Raster, SampleFormat};

const W: u32 = 256;
const H: u32 = 192;
/// Dot sizes (Gaussian sigma, px) for the placement measurement.
const DOT_SIGMAS: [f64; 3] = [1.0, 1.5, 2.5];

/// The real ImageMagick (`magick`, or `convert` that says it is ImageMagick).
fn imagemagick() -> Option<Vec<String>> {
    for cmd in [vec!["magick"], vec!["convert"]] {
        if let Ok(o) = Command::new(cmd[0]).arg("-version").output() {
            if o.status.success()
                && String::from_utf8_lossy(&o.stdout).contains("Version: ImageMagick")
            {
                return Some(cmd.iter().map(|s| s.to_string()).collect());
            }
        }
    }
    None
}

fn moves() -> Vec<([f64; 2], [f64; 2])> {
    vec![
        ([64.5, 48.5], [76.0, 57.5]),
        ([192.5, 48.5], [180.25, 42.0]),
        ([128.5, 96.5], [128.5, 111.0]),
        ([80.5, 152.5], [70.0, 148.25]),
        ([200.5, 150.5], [206.0, 141.0]),
    ]
}

fn dots(sigma: f64) -> Raster {
    let n = (W * H) as usize;
    let mut v = vec![0.0f32; n];
    for (from, _) in moves() {
        for y in 0..H as usize {
            for x in 0..W as usize {
                let d2 = (x as f64 + 0.5 - from[0]).powi(2) + (y as f64 + 0.5 - from[1]).powi(2);
                v[y * W as usize + x] += (-d2 / (2.0 * sigma * sigma)).exp() as f32;
            }
        }
    }
    Raster::new(W, H, ChannelLayout::Grey, SampleFormat::U16, v).unwrap()
}

/// R = x / W, G = y / H at pixel centres, 16-bit.
fn coords() -> Raster {
    let n = (W * H) as usize;
    let mut v = vec![0.0f32; 3 * n];
    for y in 0..H as usize {
        for x in 0..W as usize {
            v[y * W as usize + x] = ((x as f64 + 0.5) / W as f64) as f32;
            v[n + y * W as usize + x] = ((y as f64 + 0.5) / H as f64) as f32;
        }
    }
    Raster::new(W, H, ChannelLayout::Rgb, SampleFormat::U16, v).unwrap()
}

fn placement_error(img: &Raster) -> f64 {
    let p = img.plane(0);
    let mut worst: f64 = 0.0;
    for (_, to) in moves() {
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in 0..H as usize {
            for x in 0..W as usize {
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                if (cx - to[0]).abs() > 8.0 || (cy - to[1]).abs() > 8.0 {
                    continue;
                }
                let v = p[y * W as usize + x] as f64;
                sx += v * cx;
                sy += v * cy;
                sw += v;
            }
        }
        worst = worst.max(((sx / sw - to[0]).powi(2) + (sy / sw - to[1]).powi(2)).sqrt());
    }
    worst
}

/// Mean |Laplacian| (5-point) of a displacement field `d(x, y) -> [dx, dy]` sampled at
/// pixel centres, away from a 3-pixel border.
#[allow(clippy::needless_range_loop)]
fn field_roughness(d: impl Fn(f64, f64) -> [f64; 2]) -> f64 {
    let (w, h) = (W as usize, H as usize);
    let f: Vec<[f64; 2]> = (0..w * h)
        .map(|i| d((i % w) as f64 + 0.5, (i / w) as f64 + 0.5))
        .collect();
    let (mut sum, mut n) = (0.0, 0.0);
    for c in 0..2 {
        for y in 3..h - 3 {
            for x in 3..w - 3 {
                let at = |x: usize, y: usize| f[y * w + x][c];
                let l = at(x - 1, y) + at(x + 1, y) + at(x, y - 1) + at(x, y + 1) - 4.0 * at(x, y);
                sum += l.abs();
                n += 1.0;
            }
        }
    }
    sum / n
}

/// Mean |Laplacian| (5-point) of the backward displacement X - source(X), over both
/// components, away from a 3-pixel border.
fn roughness(img: &Raster) -> f64 {
    let (w, h) = (W as usize, H as usize);
    let (r, g) = (img.plane(0), img.plane(1));
    let d = |c: usize, x: usize, y: usize| {
        let i = y * w + x;
        if c == 0 {
            x as f64 + 0.5 - r[i] as f64 * W as f64
        } else {
            y as f64 + 0.5 - g[i] as f64 * H as f64
        }
    };
    let (mut sum, mut n) = (0.0, 0.0);
    for c in 0..2 {
        for y in 3..h - 3 {
            for x in 3..w - 3 {
                let l = d(c, x - 1, y) + d(c, x + 1, y) + d(c, x, y - 1) + d(c, x, y + 1)
                    - 4.0 * d(c, x, y);
                sum += l.abs();
                n += 1.0;
            }
        }
    }
    sum / n
}

#[test]
fn against_imagemagick_shepards() {
    let im = imagemagick();
    if !common::tool_present(im.is_some(), "ImageMagick (magick or convert)") {
        return;
    }
    let im = im.unwrap();
    let dir = common::fresh_dir("im");
    let coords_png = dir.join("coords.png");
    image_io::save(&coords(), &coords_png).unwrap();
    let spec: Vec<String> = moves()
        .iter()
        .map(|(a, b)| format!("{},{} {},{}", a[0], a[1], b[0], b[1]))
        .collect();
    let spec = spec.join("  ");
    let run_im = |input: &Path, out: &Path| {
        let t = Instant::now();
        let o = Command::new(&im[0])
            .args(&im[1..])
            .args([
                s(input),
                "-virtual-pixel",
                "Edge",
                "-distort",
                "Shepards",
                &spec,
                "-depth",
                "16",
                s(out),
            ])
            .output()
            .unwrap();
        assert_ok(&o);
        t.elapsed().as_secs_f64()
    };
    let run_ours = |input: &Path, out: &Path| {
        let mut args = vec![
            "distort".to_string(),
            s(input).into(),
            "-o".into(),
            s(out).into(),
            "--quiet".into(),
            "--supersample".into(),
            "4".into(),
        ];
        for (a, b) in moves() {
            args.push("--move".into());
            args.push(format!("{},{}:{},{}", a[0], a[1], b[0], b[1]));
        }
        let t = Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_caoen"))
            .args(&args)
            .output()
            .unwrap();
        assert_ok(&o);
        t.elapsed().as_secs_f64()
    };
    let mut rows = Vec::new();
    for (name, which) in [
        ("caoen distort (S=4)", 0),
        ("ImageMagick -distort Shepards", 1),
    ] {
        let oc = dir.join(format!("c{which}.png"));
        let mut t = if which == 0 {
            run_ours(&coords_png, &oc)
        } else {
            run_im(&coords_png, &oc)
        };
        let rough = roughness(&image_io::load(&oc).unwrap());
        let mut place = Vec::new();
        for (k, sigma) in DOT_SIGMAS.iter().enumerate() {
            let dots_png = dir.join(format!("dots{k}.png"));
            image_io::save(&dots(*sigma), &dots_png).unwrap();
            let od = dir.join(format!("d{which}-{k}.png"));
            t += if which == 0 {
                run_ours(&dots_png, &od)
            } else {
                run_im(&dots_png, &od)
            };
            place.push(placement_error(&image_io::load(&od).unwrap()));
        }
        rows.push((name, place, rough, t / (1 + DOT_SIGMAS.len()) as f64));
    }
    println!(
        "| method | max placement error (px), dots sigma {DOT_SIGMAS:?} | mean abs Laplacian of displacement (px) | time per {W}x{H} image (s) |"
    );
    println!("|---|---|---|---|");
    for (name, p, r, t) in &rows {
        let p: Vec<String> = p.iter().map(|v| format!("{v:.3}")).collect();
        println!("| {name} | {} | {r:.4} | {t:.3} |", p.join(" / "));
    }
    // The fields themselves (the image measurement above also includes each method's
    // resampling and 16-bit rounding).
    let warp = caoen::texture::warp::Warp::new(
        W,
        H,
        &moves()
            .iter()
            .map(|&(from, to)| caoen::texture::warp::Move { from, to })
            .collect::<Vec<_>>(),
    )
    .unwrap();
    let ours_field = field_roughness(|x, y| warp.displacement(x, y));
    // ImageMagick's Shepards (reverse map, inverse-distance weights, power 2).
    let im_field = field_roughness(|x, y| {
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for (s, d) in moves() {
            let wgt = 1.0 / ((x - d[0]).powi(2) + (y - d[1]).powi(2)).max(1e-12);
            sx += wgt * (d[0] - s[0]);
            sy += wgt * (d[1] - s[1]);
            sw += wgt;
        }
        [sx / sw, sy / sw]
    });
    println!(
        "displacement field mean |Laplacian| (px): caoen warp network {ours_field:.4}, Shepards formula (power 2) {im_field:.4}"
    );
    let (ours, theirs) = (&rows[0].1, &rows[1].1);
    assert!(ours.iter().all(|&e| e < 0.5), "{ours:?}");
    // At least as exact as Shepards at every dot size.
    for (a, b) in ours.iter().zip(theirs) {
        assert!(a <= b, "ours {ours:?} vs ImageMagick {theirs:?}");
    }
    // Smoothness: the field stays within 1.5x of Shepard's global inverse-distance
    // average although ours holds the far field still (measured 0.0052 vs 0.0049; it
    // was 0.0234 with rigid rings and a 6-cell anchor grid).
    assert!(ours_field < 1.5 * im_field, "{ours_field} vs {im_field}");
}
