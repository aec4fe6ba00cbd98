//! Secondary rays: reflection and refraction from the network's exact normals against
//! finite differences, shadow transmission from the math, material fields refused with
//! their path, output independent of the thread count, and the mirror-and-glass
//! and image-map examples against POV-Ray.

mod common;
use common::{assert_ok, caoen, povray_dir, s, Stream};

use std::path::Path;

use caoen::render::rays::{fresnel, reflect, refract, RayScene};
use caoen::render::renderer::{render, Method, RenderOptions};
use caoen::render::Scene;
use caoen::surface::normals::point_and_normal;
use caoen::surface::tracer::RayMethod;
use serde_json::json;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

/// At 10,000 random domain points of three Cao En surfaces, the reflected and
/// refracted directions (section 9) from the exact normal (the cross product of the
/// Jacobian's images of the domain tangents) equal those from a normal of central
/// finite differences of the surface map to 1e-6. The step, 1e-5 in the domain,
/// balances the differences' truncation error (h^2 times the third derivative, about
/// 1e-10) against rounding (1e-16 / h, about 1e-11).
#[test]
fn exact_normal_directions_match_finite_differences() {
    let h = 1e-5;
    let mut s = Stream(0x2545_f491_4f6c_dd1d);
    let mut worst: f64 = 0.0;
    for name in ["blob", "ring", "six-point"] {
        let model = caoen::surface::gallery::by_name(name).unwrap().unwrap();
        let (net, domain) = (&model.network, &model.domain);
        let m = domain.ambient_dim();
        let mut checked = 0;
        while checked < 10_000 / 3 + 1 {
            let raw: Vec<f64> = (0..m).map(|_| s.next()).collect();
            let Ok(x) = domain.project(&raw) else {
                continue;
            };
            let (_, n) = point_and_normal(net, domain, &x).unwrap();
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            // Singular points (no tangent plane) have no direction to compare.
            if len.is_nan() || len <= 1e-3 {
                continue;
            }
            let exact = n.map(|v| v / len);
            let (ta, tb) = domain.tangents(&x).unwrap();
            let diff = |t: &[f64; 4]| -> [f64; 3] {
                let at = |sign: f64| {
                    let p: Vec<f64> = (0..m).map(|k| x[k] + sign * h * t[k]).collect();
                    net.eval(&domain.project(&p).unwrap()).unwrap()
                };
                let (a, b) = (at(1.0), at(-1.0));
                [0, 1, 2].map(|k| (a[k] - b[k]) / (2.0 * h))
            };
            let (da, db) = (diff(&ta), diff(&tb));
            let fd = unit([
                da[1] * db[2] - da[2] * db[1],
                da[2] * db[0] - da[0] * db[2],
                da[0] * db[1] - da[1] * db[0],
            ]);
            // An incoming direction from the side the normal faces.
            let d = unit([s.next(), s.next(), s.next()]);
            let d = if d[0] * exact[0] + d[1] * exact[1] + d[2] * exact[2] > 0.0 {
                d.map(|v| -v)
            } else {
                d
            };
            let err =
                |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
            worst = worst.max(err(reflect(d, exact), reflect(d, fd)));
            for eta in [1.0 / 1.5, 1.5] {
                match (refract(d, exact, eta), refract(d, fd, eta)) {
                    (Some(a), Some(b)) => worst = worst.max(err(a, b)),
                    (None, None) => {}
                    // Only at the critical angle itself may the two disagree.
                    _ => {
                        let c = -(d[0] * exact[0] + d[1] * exact[1] + d[2] * exact[2]);
                        assert!((1.0 - eta * eta * (1.0 - c * c)).abs() < 1e-6);
                    }
                }
            }
            checked += 1;
        }
    }
    println!("largest direction difference, exact vs finite-difference normals: {worst:.2e}");
    assert!(worst < 1e-6, "{worst}");
}

fn scene(v: serde_json::Value) -> Scene {
    Scene::from_json(&v.to_string(), Path::new("."), &caoen::Limits::default()).unwrap()
}

/// The fast ray tracer of the single-object scene `sc` of radius `radius`.
fn fast_rays(sc: &Scene, radius: f64) -> RayScene<'_> {
    RayScene::new(
        sc,
        vec![None],
        RayMethod::Fast,
        radius,
        &caoen::Limits::default(),
    )
    .unwrap()
}

/// A shadow ray through a transmitting ball crosses two surfaces, each passing
/// `transmit` of the light; an opaque ball stops it; beside the ball nothing does.
#[test]
fn shadow_rays_pass_transmit_per_surface() {
    for (transmit, want) in [(0.0f32, 0.0f32), (0.5, 0.25), (0.8, 0.64)] {
        let sc = scene(json!({
            "format": "caoen-scene/1",
            "objects": [{"frep": {"sphere": {"centre": [0, 0, 1], "radius": 0.5}},
                         "material": {"transmit": transmit, "ior": 1.5}}]
        }));
        let rays = fast_rays(&sc, 1.5);
        let below = rays.light_through([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        assert!((below - want).abs() < 1e-6, "{transmit}: {below}");
        assert_eq!(rays.light_through([2.0, 0.0, 0.0], [0.0, 0.0, 1.0]), 1.0);
    }
}

/// A black, perfectly reflecting, unlit box face returns the background exactly; a
/// glass plate seen head-on passes `transmit (1 - F)` at each face, F = 0.04.
#[test]
fn mirror_and_glass_golden_values() {
    let bg = [0.2, 0.4, 0.6];
    let mirror = scene(json!({
        "format": "caoen-scene/1", "background": bg, "ambient": [0, 0, 0], "lights": [],
        "objects": [{"frep": {"box": {"centre": [0, 0, -1], "size": [4, 4, 2]}},
                     "material": {"colour": [0, 0, 0], "reflect": 1.0, "specular": 0}}]
    }));
    let rays = fast_rays(&mirror, 3.0);
    let c = rays.trace([0.0, 0.0, 1.0], unit([0.3, 0.1, -1.0]), 1, 1.0, None);
    assert_eq!(c, mirror.background);
    let f = fresnel(1.0, 1.5);
    assert!((f - 0.04).abs() < 1e-12);
    let glass = scene(json!({
        "format": "caoen-scene/1", "background": [1, 1, 1], "ambient": [0, 0, 0], "lights": [],
        "objects": [{"frep": {"box": {"centre": [0, 0, 0], "size": [4, 4, 0.5]}},
                     "material": {"colour": [0, 0, 0], "reflect": 1.0, "transmit": 0.9, "ior": 1.5, "specular": 0}}]
    }));
    let rays = fast_rays(&glass, 3.0);
    // Straight down: the reflected rays go back up to the white background too,
    // so the radiance is the sum of every path's weight (to the depth limit).
    let c = rays.trace([0.0, 0.0, 2.0], [0.0, 0.0, -1.0], 1, 1.0, None);
    let (t, r) = (0.9 * (1.0 - f), f);
    // Paths: reflect at the top (r); through both faces (t t); through, back from the
    // bottom, out of the top (t r t). The next path's ray inside the plate weighs
    // t r r = 0.0014, below the 1/255 bail-out, so it is not traced.
    let want = r + t * t + t * r * t;
    assert!((c[0] as f64 - want).abs() < 1e-5, "{} vs {want}", c[0]);
}

/// The image of the image-map example, from the repository root (the tests' directory).
const GLOBE: &str = "examples/frep/globe.png";

/// Material and scene fields out of range are refused naming the field.
#[test]
fn bad_material_fields_name_the_field() {
    for (material, top, field) in [
        (
            json!({"reflect": 1.5}),
            json!({}),
            "objects[0].material.reflect",
        ),
        (
            json!({"transmit": -0.1}),
            json!({}),
            "objects[0].material.transmit",
        ),
        (json!({"ior": 0.5}), json!({}), "objects[0].material.ior"),
        (json!({}), json!({"max_depth": 0}), "max_depth"),
        (json!({}), json!({"max_depth": 65}), "max_depth"),
        (json!({}), json!({"shadows": "yes"}), "shadows"),
        (
            json!({"image_map": {"image": "no-such.png"}}),
            json!({}),
            "objects[0].material.image_map.image",
        ),
        (
            json!({"image_map": {"image": GLOBE, "map_type": 3}}),
            json!({}),
            "objects[0].material.image_map.map_type",
        ),
        (
            json!({"image_map": {"image": GLOBE, "interpolate": 1}}),
            json!({}),
            "objects[0].material.image_map.interpolate",
        ),
        (
            json!({"image_map": {"image": GLOBE, "scale": 0}}),
            json!({}),
            "objects[0].material.image_map",
        ),
        (
            json!({"image_map": {"image": GLOBE, "translate": [1e300, 0, 0]}}),
            json!({}),
            "objects[0].material.image_map.translate",
        ),
        (
            json!({"image_map": {"image": GLOBE}, "colour": [1, 0, 0]}),
            json!({}),
            "objects[0].material.image_map",
        ),
    ] {
        let mut v = json!({
            "format": "caoen-scene/1",
            "objects": [{"frep": {"sphere": {"radius": 1}}, "material": material}]
        });
        for (k, x) in top.as_object().unwrap() {
            v[k] = x.clone();
        }
        let e = Scene::from_json(&v.to_string(), Path::new("."), &caoen::Limits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

/// The render is the same on one thread and on three.
#[test]
fn secondary_rays_do_not_depend_on_thread_count() {
    let sc = scene(json!({
        "format": "caoen-scene/1",
        "objects": [
            {"frep": {"box": {"centre": [0, 0, -0.6], "size": [3, 3, 0.1]}}},
            {"frep": {"sphere": {"centre": [-0.5, 0, 0], "radius": 0.4}}, "material": {"reflect": 0.8}},
            {"solid": {"polyhedron": "cube", "radius": 0.3, "centre": [0.5, 0, 0]}, "material": {"transmit": 0.8, "ior": 1.5, "reflect": 1,
                "image_map": {"image": GLOBE, "map_type": 1, "translate": [0.5, 0, 0]}}},
            {"csg": {"op": "difference", "operands": [{"solid": {"polyhedron": "cube", "radius": 0.3, "centre": [0, -0.6, 0]}},
                {"solid": {"polyhedron": "octahedron", "radius": 0.35, "centre": [0, -0.8, 0.1]}}]},
             "material": {"image_map": {"image": GLOBE, "map_type": 2, "interpolate": 0}}},
            {"surface": "builtin:blob", "transform": {"scale": 0.3, "translate": [0, 0.8, 0]}, "material": {"reflect": 0.5}}
        ]
    }));
    let opts = RenderOptions {
        width: 96,
        height: 72,
        samples: 1,
        method: Method::Ray,
        ..RenderOptions::default()
    };
    let run = |threads| {
        common::with_threads(threads, || {
            render(&sc, &opts, &|_, _| {}).unwrap().image.pixels
        })
    };
    assert_eq!(run(1), run(3));
}

/// Seconds of CPU time used by this process's finished children (Linux `/proc`; 0
/// elsewhere): the renders run one at a time, so the difference around one is its time.
fn children_cpu() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which may hold spaces): cutime, cstime are 14, 15.
    let rest = stat.rsplit_once(')').map_or("", |r| r.1);
    let f: Vec<f64> = rest
        .split_whitespace()
        .map(|x| x.parse().unwrap_or(0.0))
        .collect();
    (f.get(13).copied().unwrap_or(0.0) + f.get(14).copied().unwrap_or(0.0)) / 100.0
}

/// caoen's render of a scene against POV-Ray's render of its export.
struct Comparison {
    /// Silhouette intersection over union.
    iou: f64,
    /// Mean absolute difference in grey levels inside both silhouettes.
    grey: f64,
    /// PSNR in dB of the whole pictures (8-bit, three channels).
    psnr: f64,
    /// caoen's CPU seconds.
    ours: f64,
    /// POV-Ray's CPU seconds.
    theirs: f64,
}

/// Renders `scene` at 512x512 in caoen and, exported, in POV-Ray, and compares them.
fn against_povray(dir: &Path, scene: &Path, samples: &str) -> Comparison {
    let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
    let (pov, ours, theirs) = (
        dir.join(format!("{stem}.pov")),
        dir.join(format!("{stem}-caoen.png")),
        dir.join(format!("{stem}-povray.png")),
    );
    common::export_pov(scene, &pov, 512);
    let before = children_cpu();
    let o = caoen(&[
        "frep",
        "render",
        s(scene),
        "-o",
        s(&ours),
        "--size",
        "512x512",
        "--samples",
        samples,
    ]);
    let ours_s = children_cpu() - before;
    assert_ok(&o);
    let before = children_cpu();
    common::povray(&pov, &theirs, 512, "+A0.1");
    let theirs_s = children_cpu() - before;
    let (a, b) = (
        image::open(&ours).unwrap().to_rgb8(),
        image::open(&theirs).unwrap().to_rgb8(),
    );
    let (ma, mb) = (common::silhouette(&a), common::silhouette(&b));
    let (iou, _) = common::iou(&ma, &mb);
    let inter = ma.iter().zip(&mb).filter(|(x, y)| **x && **y).count();
    let (mut sum, mut squares) = (0.0, 0.0);
    for (i, (pa, pb)) in a.pixels().zip(b.pixels()).enumerate() {
        let d = (0..3).map(|k| pa[k] as f64 - pb[k] as f64);
        squares += d.clone().map(|x| x * x).sum::<f64>();
        if ma[i] && mb[i] {
            sum += d.map(f64::abs).sum::<f64>() / 3.0;
        }
    }
    let mse = squares / (3 * a.pixels().len()) as f64;
    Comparison {
        iou,
        grey: sum / inter.max(1) as f64,
        psnr: 10.0 * (255.0 * 255.0 / mse.max(1e-12)).log10(),
        ours: ours_s,
        theirs: theirs_s,
    }
}

/// The mirror-and-glass example (shadows, a mirror ball, a glass Cao En solid) agrees
/// with POV-Ray's render of its export: silhouette IoU >= 0.98 and a mean colour
/// difference inside it of at most 8 grey levels. The times are printed, not asserted.
#[test]
fn mirror_glass_example_matches_povray() {
    let Some(dir) = povray_dir("rays-mirror-glass") else {
        return;
    };
    let scene = common::repo_path("examples/frep/mirror-glass.json");
    let c = against_povray(&dir, &scene, "2");
    println!(
        "mirror-glass 512x512: IoU {:.4}, mean difference {:.2} grey levels, PSNR {:.1} dB, CPU caoen {:.2} s, POV-Ray {:.2} s, ratio {:.3}",
        c.iou, c.grey, c.psnr, c.ours, c.theirs, c.ours / c.theirs
    );
    assert!(c.iou >= 0.98, "IoU {:.4}", c.iou);
    assert!(c.grey <= 8.0, "{:.2} grey levels", c.grey);
}

/// The image-map example (a ball, a cylinder and a box carrying one image by spherical,
/// cylindrical and planar projection) agrees with POV-Ray's render of its export:
/// silhouette IoU >= 0.99, PSNR >= 35 dB, and caoen takes at most POV-Ray's CPU time.
#[test]
fn textured_example_matches_povray() {
    let Some(dir) = povray_dir("rays-textured") else {
        return;
    };
    let scene = common::repo_path("examples/frep/textured.json");
    let c = against_povray(&dir, &scene, "2");
    println!(
        "textured 512x512: IoU {:.4}, PSNR {:.1} dB, mean difference {:.2} grey levels, CPU caoen {:.2} s, POV-Ray {:.2} s, ratio {:.3}",
        c.iou, c.psnr, c.grey, c.ours, c.theirs, c.ours / c.theirs
    );
    assert!(c.iou >= 0.99, "IoU {:.4}", c.iou);
    assert!(c.psnr >= 35.0, "PSNR {:.1} dB", c.psnr);
    assert!(
        c.ours <= c.theirs,
        "caoen {:.2} s of CPU, POV-Ray {:.2} s",
        c.ours,
        c.theirs
    );
}
