//! Built-in example models: the paper's reference figures and a few freeform shapes,
//! so every command has something to work on without input files.

use super::blend::Blend;
use super::domain::Domain;
use super::error::Result;
use super::model_file::SurfaceModel;
use super::network::{KeyPoint, Network};

/// The six axis points of the unit sphere, `(+x, -x, +y, -y, +z, -z)`.
pub fn axis_points() -> [[f64; 3]; 6] {
    [
        [1., 0., 0.],
        [-1., 0., 0.],
        [0., 1., 0.],
        [0., -1., 0.],
        [0., 0., 1.],
        [0., 0., -1.],
    ]
}

/// Figures 2 and 3: six axis key points with `W = V`, one blend and sharpness for all.
pub fn six_point(blend: Blend, q: f64, normalised: bool) -> Result<SurfaceModel> {
    let kps: Vec<KeyPoint> = axis_points()
        .iter()
        .map(|a| KeyPoint::new(a.to_vec(), a.to_vec(), blend, q))
        .collect();
    let name = format!(
        "six-point {} q={q}{}",
        blend.name(),
        if normalised { " normalised" } else { "" }
    );
    SurfaceModel::new(name, Domain::SPHERE, Network::new(3, 3, &kps, normalised)?)
}

/// A freeform blob: the six axis points pulled to different lengths plus four diagonal
/// bumps, normalised exponential blend.
pub fn blob() -> Result<SurfaceModel> {
    let mut kps: Vec<KeyPoint> = axis_points()
        .iter()
        .zip([1.3, 0.9, 1.0, 1.1, 1.6, 0.8])
        .map(|(a, s)| {
            KeyPoint::new(
                a.to_vec(),
                a.iter().map(|v| v * s).collect(),
                Blend::Exponential,
                6.0,
            )
        })
        .collect();
    let r = 1.0 / 3f64.sqrt();
    for d in [[r, r, r], [-r, r, -r], [r, -r, -r], [-r, -r, r]] {
        kps.push(KeyPoint::new(
            d.to_vec(),
            d.iter().map(|v| v * 1.4).collect(),
            Blend::Exponential,
            10.0,
        ));
    }
    SurfaceModel::new("blob", Domain::SPHERE, Network::new(3, 3, &kps, true)?)
}

/// A freeform surface of genus 1 on the torus domain (18): a ring with a few bulges.
pub fn ring() -> Result<SurfaceModel> {
    use std::f64::consts::TAU;
    let (big, small) = (1.0, 0.35);
    let mut kps = Vec::new();
    for i in 0..8 {
        for j in 0..6 {
            let (t, f) = (TAU * i as f64 / 8.0, TAU * j as f64 / 6.0);
            let bulge = if i % 4 == 1 && j == 0 { 1.8 } else { 1.0 };
            let r = big + small * bulge * f.cos();
            let shape = vec![r * t.cos(), r * t.sin(), small * bulge * f.sin()];
            kps.push(KeyPoint::new(
                Domain::Torus.point(&[t, f])?,
                shape,
                Blend::Exponential,
                12.0,
            ));
        }
    }
    SurfaceModel::new("ring", Domain::Torus, Network::new(4, 3, &kps, true)?)
}

/// The built-in models by name.
pub fn by_name(name: &str) -> Option<Result<SurfaceModel>> {
    Some(match name {
        "six-point" => six_point(Blend::Exponential, 3.0, false),
        "octahedron" => six_point(Blend::Exponential, 6.0, true),
        "blob" => blob(),
        "ring" => ring(),
        _ => return None,
    })
}

/// Names accepted by [`by_name`].
pub const NAMES: [&str; 4] = ["six-point", "octahedron", "blob", "ring"];
