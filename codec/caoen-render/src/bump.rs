//! Bump patterns as POV-Ray's `normal { bumps | dents | wrinkles A }` (3.7,
//! `normal.cpp`): the surface normal displaced by `A` times POV-Ray's `DNoise` at the
//! point in pattern space (`dents` by `A * Noise^3`, `wrinkles` by ten octaves of
//! `|DNoise|`), through the texture transform as POV-Ray warps normals: the normal is
//! taken to pattern space by the transposed linear part, displaced there, brought back
//! by its inverse transpose and normalised. The noise is not symmetric in its axes, so
//! caoen's point `(x, y, z)` is POV-Ray's `<x, z, y>` and the displacement comes back
//! swapped the same way; the transform is written in POV-Ray's axes, as for image maps.

use serde::Deserialize;

use super::error::Result;
use super::noise::{dnoise, noise};
use super::scene_file::{bad, check_number, check_vec};
use caoen_frep::convex_solid::{scale_of, ScaleSpec};
use caoen_geometry::transform::Affine;

/// Which of POV-Ray's noise normal patterns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BumpKind {
    /// `bumps`: the normal plus `A * DNoise`.
    Bumps,
    /// `dents`: the normal plus `A * Noise^3 * DNoise`.
    Dents,
    /// `wrinkles`: the normal plus `A` times ten octaves of `|DNoise|`.
    Wrinkles,
}

impl BumpKind {
    /// POV-Ray's keyword.
    pub fn pov(self) -> &'static str {
        match self {
            BumpKind::Bumps => "bumps",
            BumpKind::Dents => "dents",
            BumpKind::Wrinkles => "wrinkles",
        }
    }
}

/// A bump pattern in world space, with its texture transform.
#[derive(Debug, Clone)]
pub struct Bumps {
    /// The pattern.
    pub kind: BumpKind,
    /// How far the normal is displaced (POV-Ray's amount).
    pub amount: f64,
    /// The texture transform (scale, then rotate, then translate) from pattern space
    /// to the world; must be invertible.
    pub transform: Affine,
    /// World to pattern space.
    to_pattern: Affine,
}

/// `m` times `v`, or its transpose times `v`.
fn mul(m: &[[f64; 3]; 3], v: [f64; 3], transpose: bool) -> [f64; 3] {
    let at = |r: usize, c: usize| if transpose { m[c][r] } else { m[r][c] };
    [0, 1, 2].map(|r| at(r, 0) * v[0] + at(r, 1) * v[1] + at(r, 2) * v[2])
}

fn normalised(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        v.map(|x| x / l)
    } else {
        v
    }
}

impl Bumps {
    /// A bump pattern; None if `transform` is singular.
    pub fn new(kind: BumpKind, amount: f64, transform: Affine) -> Option<Bumps> {
        if !(transform.det().abs() > 1e-300) {
            return None;
        }
        Some(Bumps {
            kind,
            amount,
            to_pattern: transform.inverse()?,
            transform,
        })
    }

    /// The displacement in pattern space at pattern point `q` (caoen's axes).
    fn displacement(&self, q: [f64; 3]) -> [f64; 3] {
        let pov = [q[0], q[2], q[1]];
        let d = match self.kind {
            BumpKind::Bumps => dnoise(pov).map(|v| v * self.amount),
            BumpKind::Dents => {
                let n = noise(pov);
                let k = n * n * n * self.amount;
                dnoise(pov).map(|v| v * k)
            }
            BumpKind::Wrinkles => {
                let mut sum = [0.0; 3];
                let mut scale = 1.0;
                for _ in 0..10 {
                    let v = dnoise(pov.map(|c| c * scale));
                    for k in 0..3 {
                        sum[k] += (v[k] / scale).abs();
                    }
                    scale *= 2.0;
                }
                sum.map(|v| v * self.amount)
            }
        };
        [d[0], d[2], d[1]]
    }

    /// The unit normal at world point `p` of a surface whose outward normal there is
    /// `n` (POV-Ray displaces the object's own normal, before facing it to the viewer).
    pub fn perturb(&self, p: [f64; 3], n: [f64; 3]) -> [f64; 3] {
        let q = self.to_pattern.point(p);
        let np = normalised(mul(&self.transform.m, normalised(n), true));
        let d = self.displacement(q);
        let moved = [np[0] + d[0], np[1] + d[1], np[2] + d[2]];
        normalised(mul(&self.to_pattern.m, moved, true))
    }

    /// POV-Ray's `normal` block: the pattern and its amount, the texture transform as a
    /// matrix in POV-Ray's axes.
    pub fn pov_normal(&self) -> String {
        format!(
            "normal {{ {} {}{} }}",
            self.kind.pov(),
            caoen_frep::pov::num(self.amount),
            super::image_map::pov_matrix(&self.transform)
        )
    }
}

/// Largest bump amount a scene may give (POV-Ray's own scenes stay below about 2).
const MAX_AMOUNT: f64 = 100.0;

/// `material.normal`: one of `bumps`, `dents` or `wrinkles` with its amount, and the
/// pattern's transform.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileNormal {
    #[serde(default)]
    bumps: Option<f64>,
    #[serde(default)]
    dents: Option<f64>,
    #[serde(default)]
    wrinkles: Option<f64>,
    #[serde(default)]
    scale: Option<ScaleSpec>,
    #[serde(default)]
    rotate_deg: Option<[f64; 3]>,
    #[serde(default)]
    translate: Option<[f64; 3]>,
}

impl FileNormal {
    /// The pattern, its fields checked; `path` names it in errors.
    pub(crate) fn resolve(&self, path: &str) -> Result<Bumps> {
        let given = [
            (BumpKind::Bumps, self.bumps),
            (BumpKind::Dents, self.dents),
            (BumpKind::Wrinkles, self.wrinkles),
        ];
        let mut chosen = given.iter().filter_map(|(k, a)| a.map(|a| (*k, a)));
        let (kind, amount) = match (chosen.next(), chosen.next()) {
            (Some(one), None) => one,
            _ => {
                return Err(bad(
                    path,
                    "give exactly one of `bumps`, `dents` or `wrinkles` with its amount",
                ))
            }
        };
        let amount = check_number(
            &format!("{path}.{}", kind.pov()),
            amount,
            -MAX_AMOUNT,
            MAX_AMOUNT,
        )?;
        let transform = Affine::from_parts(
            scale_of(path, &self.scale)?,
            check_vec(
                &format!("{path}.rotate_deg"),
                self.rotate_deg.unwrap_or([0.0; 3]),
            )?,
            check_vec(
                &format!("{path}.translate"),
                self.translate.unwrap_or([0.0; 3]),
            )?,
        );
        Bumps::new(kind, amount, transform)
            .ok_or_else(|| bad(path, "the pattern transform is singular (a zero scale)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bumps_displace_by_pov_rays_noise() {
        let b = Bumps::new(BumpKind::Bumps, 0.5, Affine::IDENTITY).unwrap();
        let p = [0.5, 0.125, 0.25];
        // POV-Ray's point is <x, z, y> (its DNoise there is a golden value in `noise`).
        let d = dnoise([0.5, 0.25, 0.125]);
        let n = b.perturb(p, [0.0, 0.0, 1.0]);
        let want = normalised([0.5 * d[0], 0.5 * d[2], 1.0 + 0.5 * d[1]]);
        assert!((0..3).all(|k| (n[k] - want[k]).abs() < 1e-12), "{n:?}");
        // A uniform scale only stretches the pattern.
        let s = Bumps::new(
            BumpKind::Bumps,
            0.5,
            Affine::from_parts([0.1; 3], [0.0; 3], [0.0; 3]),
        );
        let m = s.unwrap().perturb(p.map(|v| v * 0.1), [0.0, 0.0, 1.0]);
        assert!((0..3).all(|k| (m[k] - want[k]).abs() < 1e-12), "{m:?}");
        assert_eq!(
            b.pov_normal(),
            "normal { bumps 0.5 }",
            "no matrix for the identity"
        );
    }
}
