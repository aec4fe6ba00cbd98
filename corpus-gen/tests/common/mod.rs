//! Shared measurement helpers for the corpus tests.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh empty directory under the system temp dir, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> TempDir {
        static N: AtomicUsize = AtomicUsize::new(0);
        let p = std::env::temp_dir().join(format!(
            "caoen-corpus-test-{}-{}-{}",
            tag,
            std::process::id(),
            N.fetch_add(1, Ordering::SeqCst)
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
    pub fn path(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Power spectrum (bins 0..=n/2) of a Hann-windowed, mean-removed sequence.
pub fn power_spectrum(x: &[f64]) -> Vec<f64> {
    spectrum(x, true)
}

/// Power spectrum (bins 0..=n/2) of a mean-removed sequence, optionally Hann-windowed.
pub fn spectrum(x: &[f64], hann: bool) -> Vec<f64> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let tau = std::f64::consts::TAU;
    let xw: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            (v - mean)
                * if hann {
                    0.5 - 0.5 * (tau * i as f64 / n as f64).cos()
                } else {
                    1.0
                }
        })
        .collect();
    (0..=n / 2)
        .map(|k| {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in xw.iter().enumerate() {
                let a = tau * (k * i % n) as f64 / n as f64;
                re += v * a.cos();
                im -= v * a.sin();
            }
            re * re + im * im
        })
        .collect()
}

/// Fraction of (windowed) AC energy above `cutoff` cycles/pixel, summed over all
/// rows and columns of a `w x h` plane.
pub fn highfreq_fraction(plane: &[f64], w: usize, h: usize, cutoff: f64) -> f64 {
    let (hi, total) = highfreq_energy(plane, w, h, cutoff);
    if total == 0.0 {
        0.0
    } else {
        hi / total
    }
}

/// `(energy above cutoff, total AC energy)` over all rows and columns.
pub fn highfreq_energy(plane: &[f64], w: usize, h: usize, cutoff: f64) -> (f64, f64) {
    let mut hi = 0.0;
    let mut total = 0.0;
    let mut add = |seq: Vec<f64>| {
        let n = seq.len();
        let p = power_spectrum(&seq);
        for (k, e) in p.iter().enumerate().skip(1) {
            total += e;
            if k as f64 / n as f64 > cutoff {
                hi += e;
            }
        }
    };
    for y in 0..h {
        add(plane[y * w..(y + 1) * w].to_vec());
    }
    for x in 0..w {
        add((0..h).map(|y| plane[y * w + x]).collect());
    }
    (hi, total)
}

/// Least-squares local frequency (cycles/sample) of a sinusoid-like sequence,
/// from s[n-1] + s[n+1] = 2 cos(w) s[n].
pub fn local_frequency(s: &[f64]) -> f64 {
    let mean = 0.5;
    let v: Vec<f64> = s.iter().map(|x| x - mean).collect();
    let (mut num, mut den) = (0.0, 0.0);
    for n in 1..v.len() - 1 {
        num += v[n] * (v[n - 1] + v[n + 1]);
        den += 2.0 * v[n] * v[n];
    }
    (num / den).clamp(-1.0, 1.0).acos() / std::f64::consts::TAU
}

/// Share of pixels whose samples all equal those of their 4 neighbours
/// (interior pixels only).
pub fn flat_share(img: &caoen_corpus::CorpusImage) -> f64 {
    let (w, h, ch) = (img.width(), img.height(), img.channels());
    let same = |x: u32, y: u32, x2: u32, y2: u32| {
        (0..ch).all(|c| img.sample(x, y, c) == img.sample(x2, y2, c))
    };
    let mut flat = 0usize;
    let mut n = 0usize;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            n += 1;
            if same(x, y, x - 1, y)
                && same(x, y, x + 1, y)
                && same(x, y, x, y - 1)
                && same(x, y, x, y + 1)
            {
                flat += 1;
            }
        }
    }
    flat as f64 / n as f64
}

/// Pearson correlation of two equally long sequences.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Value at quantile `q` (0..1) of a list.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

/// Energy of the (Hann-windowed) row and column spectra in frequency bands
/// `[edges[i], edges[i+1])` cycles/pixel.
pub fn band_energies(plane: &[f64], w: usize, h: usize, edges: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; edges.len() - 1];
    let mut add = |seq: Vec<f64>| {
        let n = seq.len();
        for (k, e) in power_spectrum(&seq).iter().enumerate().skip(1) {
            let f = k as f64 / n as f64;
            for b in 0..out.len() {
                if f >= edges[b] && f < edges[b + 1] {
                    out[b] += e;
                }
            }
        }
    };
    for y in 0..h {
        add(plane[y * w..(y + 1) * w].to_vec());
    }
    for x in 0..w {
        add((0..h).map(|y| plane[y * w + x]).collect());
    }
    out
}
