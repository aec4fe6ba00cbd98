//! Codec throughput on a 768x512 corpus scene: encode at the default quality and
//! effort, decode by the identity fast path and by forward mapping with S = 1 and
//! S = 2, each in pixels/s, beside a JPEG decode of the same image (the `image` crate's
//! decoder, at a similar file size) measured in the same run as a plain baseline; and
//! the same scene coded at full size, 0.5, 0.7 and 0.8 per side (`-q 20`), each decoded
//! at its image's size, at twice it and stretched 16 times down, beside each other.

use std::hint::black_box;

use caoen::codec::{decode, encode, DecodeOptions, EncodeOptions};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn bench(c: &mut Criterion) {
    let corpus = caoen_corpus::generate(caoen_corpus::Class::Scene, 768, 512, 4);
    let img = caoen::image_io::from_dynamic(corpus.to_dynamic_image()).unwrap();
    let pixels = img.pixel_count() as u64;
    let bytes = encode(&img, &EncodeOptions::default()).unwrap();
    let mut jpeg = Vec::new();
    corpus
        .to_dynamic_image()
        .to_rgb8()
        .write_with_encoder(image::codecs::jpeg::JpegEncoder::new_with_quality(
            &mut jpeg, 80,
        ))
        .unwrap();
    eprintln!(
        "caoen file {} bytes, JPEG q80 {} bytes",
        bytes.len(),
        jpeg.len()
    );
    let mut g = c.benchmark_group("codec_768x512");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pixels));
    g.bench_function("encode_default", |b| {
        b.iter(|| black_box(encode(black_box(&img), &EncodeOptions::default()).unwrap()))
    });
    g.bench_function("decode_identity", |b| {
        b.iter(|| black_box(decode(black_box(&bytes), &DecodeOptions::default()).unwrap()))
    });
    for s in [1, 2] {
        let opts = DecodeOptions {
            supersample: Some(s),
            ..Default::default()
        };
        g.bench_function(format!("decode_forward_s{s}"), |b| {
            b.iter(|| black_box(decode(black_box(&bytes), &opts).unwrap()))
        });
    }
    g.bench_function("baseline_jpeg_decode", |b| {
        b.iter(|| {
            black_box(
                image::load_from_memory_with_format(black_box(&jpeg), image::ImageFormat::Jpeg)
                    .unwrap(),
            )
        })
    });
    g.finish();
}

/// Decodes of files coded at a fraction of their size: the fractions that are not a
/// whole number of output pixels per coded pixel (0.7, 0.8) beside the ones that are.
fn resampled(c: &mut Criterion) {
    let corpus = caoen_corpus::generate(caoen_corpus::Class::Scene, 768, 512, 4);
    let img = caoen::image_io::from_dynamic(corpus.to_dynamic_image()).unwrap();
    let mut g = c.benchmark_group("decode_resampled_768x512");
    g.sample_size(10);
    for (name, tenths) in [("full", 10), ("0.5", 5), ("0.7", 7), ("0.8", 8)] {
        let scale = caoen::codec::Scale::new(tenths).expect("a size in tenths");
        let opts = EncodeOptions {
            quality: 20.0,
            resampling: caoen::codec::Resampling::At(scale),
            ..EncodeOptions::default()
        };
        let bytes = encode(&img, &opts).unwrap();
        for (size, out) in [
            ("own", None),
            ("2x", Some((1536, 1024))),
            ("tall", Some((768, 8192))),
        ] {
            let opts = DecodeOptions {
                size: out,
                ..Default::default()
            };
            g.bench_function(format!("{name}_{size}"), |b| {
                b.iter(|| black_box(decode(black_box(&bytes), &opts).unwrap()))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench, resampled);
criterion_main!(benches);
