//! How much work a render asks for, estimated before it starts so that a scene of a
//! thousand lights or mirrors is refused (or shown with its time) rather than run for
//! hours unannounced.
//!
//! The unit is one ray-object test: every ray (primary, reflected, refracted) is tested
//! against every object, since the scene keeps no hierarchy over its objects, and every
//! surface a ray meets sends a shadow ray per light (an area light one per sample of
//! its grid), which again meets every object
//! (and, through transmitting ones, does so once per crossing). Reflection and
//! refraction branch: a ray tree has at most `b^k` rays at depth `k` (`b` the most
//! rays a material spawns) and, since a traced ray weighs at least 1/255 and a
//! surface passes on at most `s` of its weight, at most `255 s^k` of them. The
//! estimate assumes every ray hits, so it bounds the work from above; scenes whose
//! rays mostly miss finish sooner.

use super::renderer::{Method, RenderOptions};
use super::scene::{Scene, Shape};

/// Nanoseconds of one core per ray-object test: 7.7 measured on a thousand facing
/// mirrors (F-rep boxes, every ray reaching `max_depth`, where the bound is tight),
/// release build; scenes whose rays escape take less.
pub const NANOS_PER_TEST: f64 = 8.0;

/// The most surfaces a shadow ray passes through (the tracer's own cap).
const MAX_SHADOW_CROSSINGS: f64 = 32.0;

/// The estimated work of a render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkEstimate {
    /// Ray-object tests, an upper bound.
    pub tests: f64,
    /// Rays traced per sample at most (1 without mirrors or glass).
    pub rays_per_sample: f64,
    /// Objects weighed by their test cost.
    pub object_cost: f64,
    /// Tests per traced ray: the ray itself and its shadow rays.
    pub per_ray: f64,
}

impl WorkEstimate {
    /// Seconds of one core the estimate stands for.
    pub fn cpu_seconds(&self) -> f64 {
        self.tests * NANOS_PER_TEST * 1e-9
    }

    /// The tests of shading (secondary and shadow rays) per test of drawing (primary
    /// rays).
    pub fn shading_ratio(&self) -> f64 {
        (self.rays_per_sample * self.per_ray / self.object_cost.max(1e-9) - 1.0).max(0.0)
    }
}

/// The cost of testing one ray against `shape`, in units of an F-rep sphere.
fn shape_cost(shape: &Shape, method: Method) -> f64 {
    match (shape, method) {
        (_, Method::Mesh) => 2.0,
        // A hierarchy walk and Newton steps on the network: the teapot's patches measure
        // about 20 spheres a test.
        (Shape::Surface { .. }, _) => 20.0,
        (Shape::Solid { csg, .. }, _) => 2.0 * csg.solids().len().max(1) as f64,
        (Shape::Field { node, .. }, _) => node.count() as f64,
    }
}

/// Estimates the work of rendering `scene` with `opts`.
pub fn estimate(scene: &Scene, opts: &RenderOptions) -> WorkEstimate {
    let samples = f64::from(opts.width) * f64::from(opts.height) * f64::from(opts.samples).powi(2);
    let object_cost: f64 = scene
        .objects
        .iter()
        .map(|o| shape_cost(&o.shape, opts.method))
        .sum();
    let (mut branch, mut share, mut transmitting) = (0u32, 0.0f64, 0.0f64);
    for o in &scene.objects {
        let m = &o.material;
        let b = u32::from(m.reflect > 0.0) + u32::from(m.transmit > 0.0);
        branch = branch.max(b);
        if m.transmit > 0.0 {
            transmitting += 1.0;
            // Total internal reflection passes the whole weight on.
            share = 1.0;
        } else {
            share = share.max(f64::from(m.reflect).min(1.0));
        }
    }
    let mut rays_per_sample = 0.0;
    let (mut tree, mut weight) = (1.0f64, 255.0f64);
    for _ in 0..scene.max_depth.max(1) {
        if weight < 1.0 || tree < 1.0 {
            break;
        }
        rays_per_sample += tree.min(weight);
        tree *= f64::from(branch);
        weight *= share;
    }
    // An area light's every sample may be tested (adaptive sampling often needs
    // fewer, never more).
    let lights = if scene.shadows {
        scene.lighting.shadow_samples() as f64
    } else {
        0.0
    };
    let passes = 1.0 + transmitting.min(MAX_SHADOW_CROSSINGS);
    let per_ray = object_cost * (1.0 + lights * passes);
    WorkEstimate {
        tests: samples * rays_per_sample * per_ray,
        rays_per_sample,
        object_cost,
        per_ray,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An area light counts one shadow ray per sample of its grid.
    #[test]
    fn area_lights_count_their_samples() {
        let per_ray = |light: &str| {
            let text = format!(
                r#"{{"format": "caoen-scene/1", "lights": [{light}], "objects": [{{"frep": {{"sphere": {{"radius": 1}}}}}}]}}"#
            );
            let scene = Scene::from_json(
                &text,
                std::path::Path::new("."),
                &caoen_base::budget::Limits::default(),
            )
            .unwrap();
            estimate(&scene, &RenderOptions::default()).per_ray
        };
        let point = per_ray(r#"{"position": [0, 0, 3]}"#);
        let area = per_ray(
            r#"{"position": [0, 0, 3], "area_light": {"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 9, "size2": 5, "adaptive": 0}}"#,
        );
        assert_eq!(area / point, (1.0 + 45.0) / 2.0);
    }
}
