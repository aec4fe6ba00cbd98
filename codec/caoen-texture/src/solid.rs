//! Solid (3-D) textures for the texture-space method of [`super::transfer`]: a small
//! set of procedural ones (checker, stripes, wood rings, Perlin-noise marble) and a
//! volume from data (a stack of image slices, sampled trilinearly).
//!
//! Everything here is plain `+ - * /`, `floor` and `sqrt` on `f64` (all correctly
//! rounded by IEEE 754) and integer hashing, with no `sin`, `exp` or `pow` whose last
//! bits differ between math libraries, so a texture is the same on every platform.

use std::path::Path;

use super::TextureError;
use caoen_render::framebuffer::{srgb8_to_linear, RgbImage};

/// Default colours (linear light) of the procedural textures: a light sand and a dark
/// blue, the checker's colours since the first version.
pub const DEFAULT_COLOURS: [[f32; 3]; 2] = [[0.85, 0.8, 0.65], [0.06, 0.12, 0.35]];

/// The procedural kinds, in the order `--help` lists them.
pub const PROCEDURAL: [&str; 4] = ["checker", "stripes", "rings", "marble"];

/// A procedural pattern of two colours.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// Cubes of side `scale` in alternating colours.
    Checker,
    /// Layers perpendicular to x, `scale` thick per colour, blended smoothly.
    Stripes,
    /// Wood: cylinders around the z axis, `scale` apart, rings wobbled by noise (early
    /// wood, late wood).
    Rings,
    /// Marble: layers perpendicular to x, `scale` apart, displaced by fractal Perlin
    /// noise (turbulence) into veins (stone, vein).
    Marble,
}

/// A solid texture: a colour (linear light) at every point of 3-D texture space.
#[derive(Debug, Clone, PartialEq)]
pub enum Solid {
    /// A procedural pattern.
    Procedural {
        /// Which pattern.
        pattern: Pattern,
        /// Its feature size: cube side, stripe period, ring or vein spacing.
        scale: f64,
        /// The two colours.
        colours: [[f32; 3]; 2],
    },
    /// A voxel volume from data.
    Volume(Volume),
}

impl Solid {
    /// A procedural texture by name (one of [`PROCEDURAL`]) with feature size `scale`
    /// (> 0) and two colours.
    pub fn procedural(
        kind: &str,
        scale: f64,
        colours: [[f32; 3]; 2],
    ) -> Result<Solid, TextureError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(TextureError::Parameter {
                what: "solid texture scale",
                value: scale,
                allowed: "must be positive",
            });
        }
        let pattern = match kind {
            "checker" => Pattern::Checker,
            "stripes" => Pattern::Stripes,
            "rings" => Pattern::Rings,
            "marble" => Pattern::Marble,
            _ => {
                return Err(TextureError::UnknownSolid {
                    name: kind.to_string(),
                })
            }
        };
        Ok(Solid::Procedural {
            pattern,
            scale,
            colours,
        })
    }

    /// The colour at `p`.
    pub fn sample(&self, p: [f64; 3]) -> [f32; 3] {
        let (pattern, scale, colours) = match self {
            Solid::Procedural {
                pattern,
                scale,
                colours,
            } => (*pattern, *scale, colours),
            Solid::Volume(v) => return v.sample(p),
        };
        match pattern {
            Pattern::Checker => {
                // Wrapping sum: the parity survives, and huge coordinates cannot overflow.
                let k = p
                    .iter()
                    .fold(0i64, |a, v| a.wrapping_add((v / scale).floor() as i64));
                colours[k.rem_euclid(2) as usize]
            }
            Pattern::Stripes => mix(colours, wave(p[0] / scale)),
            Pattern::Rings => {
                let q = p.map(|v| v / scale);
                let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
                // Rings slightly wobbled, and late wood (the thin dark band) sharpened.
                let t = wave(r + 0.15 * perlin([q[0], q[1], 0.25 * q[2]]));
                mix(colours, t * t * t)
            }
            Pattern::Marble => {
                let q = p.map(|v| v / scale);
                let t = wave(q[0] + 2.0 * turbulence(q, 5));
                // Thin veins: the vein colour only near the wave's crest.
                let v = t * t;
                mix(colours, v * v)
            }
        }
    }
}

/// A smooth periodic wave with period 1, 0 at integers and 1 at half-integers: the
/// smoothstep of a triangle wave (C1, close to `(1 - cos(2 pi t)) / 2`).
fn wave(t: f64) -> f64 {
    let f = t - t.floor();
    let tri = 1.0 - (2.0 * f - 1.0).abs();
    tri * tri * (3.0 - 2.0 * tri)
}

fn mix(c: &[[f32; 3]; 2], t: f64) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0) as f32;
    [0, 1, 2].map(|k| c[0][k] + t * (c[1][k] - c[0][k]))
}

/// A 32-bit integer hash of a lattice point (deterministic; no table, no seed state).
fn hash(i: i64, j: i64, k: i64) -> u32 {
    let mut h = (i as u32).wrapping_mul(0x8da6_b343)
        ^ (j as u32).wrapping_mul(0xd816_3841)
        ^ (k as u32).wrapping_mul(0xcb1a_b31f);
    // Murmur3's finaliser: every input bit reaches every output bit.
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Perlin's gradient noise (improved version: the 12 cube-edge gradients, quintic
/// fade), roughly in `-1..1`, 0 at lattice points.
pub fn perlin(p: [f64; 3]) -> f64 {
    const GRAD: [[f64; 3]; 16] = [
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
        [1.0, -1.0, 0.0],
        [-1.0, -1.0, 0.0],
        [1.0, 0.0, 1.0],
        [-1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
        [-1.0, 0.0, -1.0],
        [0.0, 1.0, 1.0],
        [0.0, -1.0, 1.0],
        [0.0, 1.0, -1.0],
        [0.0, -1.0, -1.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
        [0.0, -1.0, 1.0],
        [0.0, -1.0, -1.0],
    ];
    let cell = p.map(|v| v.floor());
    let f = [0, 1, 2].map(|k| p[k] - cell[k]);
    let c = cell.map(|v| v as i64);
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let u = f.map(fade);
    let corner = |a: i64, b: i64, d: i64| {
        let h = hash(
            c[0].wrapping_add(a),
            c[1].wrapping_add(b),
            c[2].wrapping_add(d),
        );
        let g = GRAD[(h & 15) as usize];
        g[0] * (f[0] - a as f64) + g[1] * (f[1] - b as f64) + g[2] * (f[2] - d as f64)
    };
    let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), u[0]);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), u[0]);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), u[0]);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), u[0]);
    lerp(lerp(x00, x10, u[1]), lerp(x01, x11, u[1]), u[2])
}

/// Perlin's turbulence: `sum |noise(2^o p)| / 2^o` over `octaves`.
pub fn turbulence(p: [f64; 3], octaves: u32) -> f64 {
    let (mut sum, mut f) = (0.0, 1.0);
    for _ in 0..octaves {
        sum += perlin(p.map(|v| v * f)).abs() / f;
        f *= 2.0;
    }
    sum
}

/// How a volume is continued outside its box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VolumeWrap {
    /// The edge voxels extend outwards.
    Clamp,
    /// The volume tiles space.
    Repeat,
}

/// A voxel volume over an axis-aligned box, sampled trilinearly (voxel centres at
/// `min + (i + 0.5) / n (max - min)` per axis).
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    size: [usize; 3],
    /// Voxels x fastest, then y, then z; linear light.
    voxels: Vec<[f32; 3]>,
    min: [f64; 3],
    max: [f64; 3],
    wrap: VolumeWrap,
}

/// Largest number of voxels a volume may have (2^26: 800 MB of f32 RGB at most).
pub const MAX_VOXELS: usize = 1 << 26;

impl Volume {
    /// A volume of `size[0] x size[1] x size[2]` voxels (x fastest) over `min..max`.
    pub fn new(
        size: [usize; 3],
        voxels: Vec<[f32; 3]>,
        min: [f64; 3],
        max: [f64; 3],
        wrap: VolumeWrap,
    ) -> Result<Self, TextureError> {
        let n = size.iter().try_fold(1usize, |a, &b| a.checked_mul(b));
        match n {
            Some(n) if n > 0 && n <= MAX_VOXELS => {}
            _ => {
                return Err(TextureError::VolumeSize {
                    size,
                    max: MAX_VOXELS,
                })
            }
        }
        if voxels.len() != n.unwrap_or(0) {
            return Err(TextureError::VoxelCount {
                size,
                values: voxels.len(),
            });
        }
        if !(0..3).all(|k| min[k].is_finite() && max[k].is_finite() && min[k] < max[k]) {
            return Err(TextureError::VolumeBox { min, max });
        }
        Ok(Volume {
            size,
            voxels,
            min,
            max,
            wrap,
        })
    }

    /// A volume from a stack of slices (slice `k` is the layer `z = k`, its pixel
    /// `(i, j)` the voxel `(i, j, k)`); all slices must have the same size.
    pub fn from_slices(
        slices: &[RgbImage],
        min: [f64; 3],
        max: [f64; 3],
        wrap: VolumeWrap,
    ) -> Result<Self, TextureError> {
        let first = slices.first().ok_or(TextureError::NoSlices)?;
        for (k, s) in slices.iter().enumerate() {
            if (s.width, s.height) != (first.width, first.height) {
                return Err(TextureError::SliceSize {
                    slice: k,
                    size: (s.width, s.height),
                    first: (first.width, first.height),
                });
            }
        }
        let voxels = slices
            .iter()
            .flat_map(|s| s.pixels.iter().copied())
            .collect();
        Volume::new(
            [first.width as usize, first.height as usize, slices.len()],
            voxels,
            min,
            max,
            wrap,
        )
    }

    /// Reads a volume spec (JSON, see `docs/texture.md`):
    /// `{"slices": ["z0.png", ...], "min": [x, y, z], "max": [x, y, z], "wrap": "clamp"}`,
    /// slice paths relative to the spec's folder; `min`, `max` default to `-1`, `1`,
    /// `wrap` to `clamp`.
    pub fn load(spec: &Path, limits: &caoen_base::budget::Limits) -> Result<Self, TextureError> {
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Spec {
            slices: Vec<String>,
            #[serde(default = "neg_one")]
            min: [f64; 3],
            #[serde(default = "one")]
            max: [f64; 3],
            #[serde(default = "clamp")]
            wrap: VolumeWrap,
        }
        fn neg_one() -> [f64; 3] {
            [-1.0; 3]
        }
        fn one() -> [f64; 3] {
            [1.0; 3]
        }
        fn clamp() -> VolumeWrap {
            VolumeWrap::Clamp
        }
        let at = |e: TextureError| TextureError::InVolumeSpec {
            path: spec.to_path_buf(),
            source: Box::new(e),
        };
        let text = limits
            .read_to_string(spec)
            .map_err(|source| TextureError::Io {
                path: spec.to_path_buf(),
                source,
            })?;
        let s: Spec = serde_json::from_str(&text)
            .map_err(|source| at(TextureError::VolumeJson { source }))?;
        if s.slices.is_empty() {
            return Err(at(TextureError::NoSlices));
        }
        let dir = spec.parent().unwrap_or(Path::new(""));
        let mut images = Vec::with_capacity(s.slices.len());
        let mut voxels = 0usize;
        for (k, name) in s.slices.iter().enumerate() {
            let path = dir.join(name);
            let bytes = limits.read(&path).map_err(|source| {
                at(TextureError::SliceRead {
                    slice: k,
                    path: path.clone(),
                    source,
                })
            })?;
            let img = RgbImage::decode(&bytes, limits).map_err(|source| {
                at(TextureError::SliceDecode {
                    slice: k,
                    path: path.clone(),
                    source: Box::new(source),
                })
            })?;
            voxels = voxels.saturating_add(img.pixels.len());
            if voxels > MAX_VOXELS {
                return Err(at(TextureError::TooManyVoxels {
                    slice: k,
                    max: MAX_VOXELS,
                }));
            }
            images.push(img);
        }
        Volume::from_slices(&images, s.min, s.max, s.wrap).map_err(at)
    }

    /// Voxels per axis.
    pub fn size(&self) -> [usize; 3] {
        self.size
    }

    /// Trilinear sample at `p`.
    pub fn sample(&self, p: [f64; 3]) -> [f32; 3] {
        // Per axis: the two voxel indices and the weight of the second.
        let axis = |k: usize| -> (usize, usize, f64) {
            let n = self.size[k];
            let t = (p[k] - self.min[k]) / (self.max[k] - self.min[k]) * n as f64 - 0.5;
            match self.wrap {
                VolumeWrap::Clamp => {
                    let t = t.clamp(0.0, (n - 1) as f64);
                    let i = (t.floor() as usize).min(n - 1);
                    (i, (i + 1).min(n - 1), t - i as f64)
                }
                VolumeWrap::Repeat => {
                    let f = t.floor();
                    let i = (f.rem_euclid(n as f64) as usize).min(n - 1);
                    (i, (i + 1) % n, t - f)
                }
            }
        };
        if !p.iter().all(|v| v.is_finite()) {
            return self.voxels[0];
        }
        let (x, y, z) = (axis(0), axis(1), axis(2));
        let (nx, nxy) = (self.size[0], self.size[0] * self.size[1]);
        let v = |i: usize, j: usize, k: usize| self.voxels[k * nxy + j * nx + i];
        let mut out = [0.0f32; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let lx = |j: usize, k: usize| {
                let a = v(x.0, j, k)[c] as f64;
                a + x.2 * (v(x.1, j, k)[c] as f64 - a)
            };
            let ly = |k: usize| {
                let a = lx(y.0, k);
                a + y.2 * (lx(y.1, k) - a)
            };
            let a = ly(z.0);
            *o = (a + z.2 * (ly(z.1) - a)) as f32;
        }
        out
    }
}

/// Parses two colours `RRGGBB,RRGGBB` (gamma-encoded sRGB hex, an optional `#` each)
/// into linear light.
pub fn parse_colours(s: &str) -> Result<[[f32; 3]; 2], TextureError> {
    let bad = |colour: Option<usize>| TextureError::Colours {
        text: s.to_string(),
        colour,
    };
    let (a, b) = s.split_once(',').ok_or_else(|| bad(None))?;
    let one = |k: usize, c: &str| -> Result<[f32; 3], TextureError> {
        let c = c.trim().trim_start_matches('#');
        if c.len() != 6 || !c.is_ascii() {
            return Err(bad(Some(k)));
        }
        let byte = |i: usize| u8::from_str_radix(&c[i..i + 2], 16).map_err(|_| bad(Some(k)));
        Ok(srgb8_to_linear([byte(0)?, byte(2)?, byte(4)?]))
    };
    Ok([one(0, a)?, one(1, b)?])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_wave_is_periodic_and_spans_zero_to_one() {
        assert_eq!(wave(0.0), 0.0);
        assert_eq!(wave(0.5), 1.0);
        assert_eq!(wave(3.0), 0.0);
        assert_eq!(wave(0.25), 0.5);
        for k in 0..100 {
            let t = k as f64 * 0.0731 - 3.0;
            assert!((wave(t) - wave(t + 1.0)).abs() < 1e-12);
            assert!((0.0..=1.0).contains(&wave(t)));
        }
    }

    #[test]
    fn texture_noise_is_balanced() {
        // Gradient noise averages to about zero: the hash does not favour a gradient.
        let (mut sum, mut n) = (0.0, 0.0);
        for i in 0..40 {
            for j in 0..40 {
                sum += perlin([i as f64 * 0.37 + 0.1, j as f64 * 0.53 + 0.2, 0.77]);
                n += 1.0;
            }
        }
        assert!((sum / n).abs() < 0.05, "{}", sum / n);
        assert!(turbulence([0.3, 0.2, 0.1], 5) >= 0.0);
    }

    #[test]
    fn texture_colours_parse() {
        let c = parse_colours("#ffffff,000000").unwrap();
        assert_eq!(c, [[1.0; 3], [0.0; 3]]);
        for bad in [
            "",
            "ffffff",
            "fffff,000000",
            "gggggg,000000",
            "ffffff,00000é",
        ] {
            assert!(parse_colours(bad).is_err(), "{bad}");
        }
    }
}
