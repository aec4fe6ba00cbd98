//! Development measurements (ignored by default): rate, PSNR, timings.

mod common;

use caoen::codec::{decode, encode_with_progress, DecodeOptions, EncodeOptions};
use caoen::raster::{ChannelLayout, Raster, SampleFormat};

fn corpus_raster(class: &str, seed: u64) -> Raster {
    let img = caoen_corpus::generate(class.parse().unwrap(), 768, 512, seed);
    let (w, h) = (img.width(), img.height());
    let px: Vec<f32> = (0..3)
        .flat_map(|c| (0..h).flat_map(move |y| (0..w).map(move |x| (c, x, y))))
        .map(|(c, x, y)| img.sample(x, y, c))
        .collect();
    Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::U8, px).unwrap()
}

fn psnr(a: &Raster, b: &Raster) -> f64 {
    let mse = common::mse_by(a, b, |v| (v.clamp(0.0, 1.0) * 255.0).round() as f64);
    10.0 * (255.0f64 * 255.0 / mse).log10()
}

/// `QS`, comma-separated qualities, or `default`.
fn qualities(default: &str) -> Vec<f32> {
    std::env::var("QS")
        .unwrap_or(default.into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect()
}

/// The RD scripts' inputs: `FILES` (comma-separated), `QS` and `EFFORT`.
fn rd_inputs() -> (String, Vec<f32>, u8) {
    let files = std::env::var("FILES").unwrap();
    let effort = std::env::var("EFFORT")
        .unwrap_or("5".into())
        .parse()
        .unwrap();
    (files, qualities("20,35,50,60,70,80,90"), effort)
}

#[test]
#[ignore]
fn rate_distortion_sweep() {
    let class = std::env::var("CLASS").unwrap_or("scene".into());
    let img = corpus_raster(&class, 1);
    let qs = qualities("30,50,70,85");
    for q in qs {
        let t = std::time::Instant::now();
        let (bytes, stats) = encode_with_progress(
            &img,
            &EncodeOptions {
                quality: q,
                ..Default::default()
            },
            |_, _| {},
        )
        .unwrap();
        let te = t.elapsed();
        let t = std::time::Instant::now();
        let dec = decode(&bytes, &DecodeOptions::default()).unwrap();
        let td = t.elapsed();
        let bpp = bytes.len() as f64 * 8.0 / (768.0 * 512.0);
        let forward = |supersample| {
            let opts = DecodeOptions {
                supersample: Some(supersample),
                ..Default::default()
            };
            decode(&bytes, &opts).unwrap()
        };
        let (fwd, fwd2) = (forward(1), forward(2));
        println!(
            "Q={q}: {} B, {bpp:.3} bpp, PSNR {:.2} dB, kp {}+{}, enc {te:?} dec {td:?}; fwd S1 vs id {:.1} dB, S2 {:.1} dB",
            bytes.len(), psnr(&img, &dec), stats.luma_keypoints, stats.chroma_keypoints, psnr(&dec, &fwd), psnr(&dec, &fwd2)
        );
    }
}

/// FILES=a.png,b.png QS=... : prints "file quality bpp psnr" lines for the RD scripts.
#[test]
#[ignore]
fn rd_points_for_files() {
    let (files, qs, effort) = rd_inputs();
    for f in files.split(',') {
        let img = caoen::image_io::load(std::path::Path::new(f)).unwrap();
        for &q in &qs {
            let t = std::time::Instant::now();
            let bytes = caoen::codec::encode(
                &img,
                &EncodeOptions {
                    quality: q,
                    effort,
                    ..Default::default()
                },
            )
            .unwrap();
            let te = t.elapsed().as_secs_f64();
            let dec = decode(&bytes, &DecodeOptions::default()).unwrap();
            let bpp = bytes.len() as f64 * 8.0 / img.pixel_count() as f64;
            println!(
                "RD {} {q} {bpp:.4} {:.3} {te:.2}",
                f.rsplit('/').next().unwrap(),
                psnr(&img, &dec)
            );
        }
    }
}

/// Like `rd_points_for_files` but with internal settings overridden from the
/// environment (STEPK, CSTEP, SIGMA, WEXP, RIDGE, MINLOG, ROOTLOG, GROWTH, ROUNDS, DZ, DETAIL_DZ, LAMBDA, DETAIL_CSTEP), and the
/// section sizes printed: "RD file q bpp psnr secs tree luma chroma nluma".
#[test]
#[ignore]
fn rd_settings_for_files() {
    use caoen::codec::{bitstream, encoder, rate_control};
    let env = |k: &str| std::env::var(k).ok().map(|v| v.parse::<f64>().unwrap());
    let (files, qs, effort) = rd_inputs();
    for f in files.split(',') {
        let img = caoen::image_io::load(std::path::Path::new(f)).unwrap();
        for &q in &qs {
            let t = std::time::Instant::now();
            let mut s = rate_control::settings(q, effort, None);
            let cratio = s.step_chroma / s.step_luma;
            if let Some(k) = env("STEPK") {
                // Network steps relative to the detail layer's luma step.
                let base = s.detail_step_luma;
                s.step_luma = k * base;
                s.step_alpha = k * base;
                s.step_chroma = k * base * env("CSTEP").unwrap_or(cratio);
            } else if let Some(c) = env("CSTEP") {
                s.step_chroma = c * s.step_luma;
            }
            if let Some(v) = env("SIGMA") {
                s.model.kernel.sigma_factor = v;
            }
            if let Some(v) = env("WEXP") {
                s.model.kernel.weight_exponent = v;
            }
            if let Some(v) = env("RIDGE") {
                s.model.ridge = v;
            }
            if let Some(v) = env("MINLOG") {
                s.model.min_log2 = v as u8;
            }
            if let Some(v) = env("GROWTH") {
                s.model.growth = v;
            }
            if let Some(v) = env("ROUNDS") {
                s.model.rounds = v as usize;
            }
            if let Some(v) = env("TSCALE") {
                s.model.split_threshold *= v;
            }
            if let Some(v) = env("DZ") {
                s.deadzone = v;
            }
            if let Some(v) = env("DETAIL_DZ") {
                s.detail_deadzone = v;
            }
            if let Some(v) = env("LAMBDA") {
                s.detail_lambda = v;
            }
            if let Some(v) = env("DETAIL_CSTEP") {
                s.detail_step_chroma = v * s.detail_step_luma;
            }
            if let Some(v) = env("ROOTLOG") {
                s.model.block_log2 = v as u8;
            }
            match std::env::var("ABL").unwrap_or_default().as_str() {
                "sampled" => s.model.least_squares = false,
                "grid" => s.model.uniform_grid = true,
                "rgb" => {
                    s.decorrelate = false;
                    s.model.chroma_pruned = false;
                    s.step_chroma = s.step_luma;
                }
                "chroma" => s.model.chroma_pruned = false,
                "noanalysis" => s.model.analysis_start = false,
                "" => {}
                a => panic!("unknown ablation {a}"),
            }
            let (bytes, stats) =
                encoder::encode_with(&img, &s, &Default::default(), 2, |_, _| {}).unwrap();
            let te = t.elapsed().as_secs_f64();
            let quality = if s.decorrelate {
                psnr(&img, &decode(&bytes, &DecodeOptions::default()).unwrap())
            } else {
                // Raw-RGB ablation: the planes are RGB already.
                let d = caoen::codec::decoder::read(&bytes, u64::MAX).unwrap();
                let planes = caoen::codec::decoder::render_identity(&d, img.width(), img.height());
                let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round();
                let mut se = 0.0;
                for c in 0..3 {
                    for (a, b) in img.plane(c).iter().zip(&planes.colour[c]) {
                        se += (q(*a as f64) - q(*b as f64)).powi(2);
                    }
                }
                10.0 * (255.0f64 * 255.0 / (se / (3 * img.pixel_count()) as f64)).log10()
            };
            let bpp = bytes.len() as f64 * 8.0 / img.pixel_count() as f64;
            let p = bitstream::parse(&bytes, u64::MAX).unwrap();
            let sz = |f: fn(&bitstream::TilePayload) -> usize| p.tiles.iter().map(f).sum::<usize>();
            println!(
                "RD {} {q} {bpp:.4} {:.3} {te:.2} {} {} {} {}",
                f.rsplit('/').next().unwrap(),
                quality,
                sz(|t| t.tree.len()),
                sz(|t| t.luma.len()),
                sz(|t| t.chroma.len()),
                stats.luma_keypoints
            );
        }
    }
}
