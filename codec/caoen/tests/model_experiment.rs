//! Development measurement (ignored by default): PSNR against key point count.
use caoen::codec::{colour, keyset::KeySet, model};
use caoen::raster::{ChannelLayout, Raster, SampleFormat};

fn psnr(a: &[f64], b: &[f64]) -> f64 {
    let mse = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64;
    10.0 * (1.0 / mse).log10()
}

#[test]
#[ignore]
fn psnr_against_keypoints() {
    let class: caoen_corpus::Class = std::env::var("CLASS")
        .unwrap_or("scene".into())
        .parse()
        .unwrap();
    let img = caoen_corpus::generate(class, 768, 512, 1);
    let (w, h) = (img.width(), img.height());
    let px: Vec<f32> = (0..3)
        .flat_map(|c| (0..h).flat_map(move |y| (0..w).map(move |x| (c, x, y))))
        .map(|(c, x, y)| img.sample(x, y, c))
        .collect();
    let r = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::U8, px).unwrap();
    let planes = colour::forward(&r, colour::ColourBasis::Grey);
    for t in [1.0, 0.3, 0.1, 0.03] {
        let s = model::ModelSettings {
            split_threshold: t,
            ..Default::default()
        };
        let start = std::time::Instant::now();
        let m = model::build(&planes, w, h, &s, |_, _| {});
        let el = start.elapsed();
        let frame = caoen::codec::geometry::Frame::new(w, h);
        let luma = KeySet::new(frame, &m.luma_cells, m.kernel).render(&m.luma_colours, w, h);
        let chroma = KeySet::new(frame, &m.chroma_cells, m.kernel).render(&m.chroma_colours, w, h);
        let rec = colour::CodingPlanes {
            colour: vec![luma[0].clone(), chroma[0].clone(), chroma[1].clone()],
            alpha: None,
        };
        let out = colour::inverse(&rec, w, h, SampleFormat::U8, colour::ColourBasis::Grey);
        let a: Vec<f64> = r.samples().iter().map(|&v| v as f64).collect();
        let b: Vec<f64> = out
            .iter()
            .map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as f64 / 255.0)
            .collect();
        println!(
            "T={t}: {} luma + {} chroma kp ({:.3} kp/px), PSNR {:.2} dB, {:?}",
            m.luma_cells.len(),
            m.chroma_cells.len(),
            m.luma_cells.len() as f64 / (w * h) as f64,
            psnr(&a, &b),
            el
        );
    }
}
