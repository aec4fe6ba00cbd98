//! Secondary rays: reflection and refraction from the network's exact normals against
//! finite differences, shadow transmission from the math, material fields refused with
//! their path, output independent of the thread count, and the mirror-and-glass,
//! image-map, textured-surface and checker examples against POV-Ray.

mod common;
use common::{povray_dir, s, Stream};

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
        let inf = f64::INFINITY;
        let below = rays.light_through([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], inf);
        assert!((below - want).abs() < 1e-6, "{transmit}: {below}");
        assert_eq!(
            rays.light_through([2.0, 0.0, 0.0], [0.0, 0.0, 1.0], inf),
            1.0
        );
        // A point light between the point and the ball is not shadowed by it.
        assert_eq!(
            rays.light_through([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.3),
            1.0
        );
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
        (
            json!({"checker": {"colours": [[1, 1, 1], [0, 0, 0]]}, "colour": [1, 0, 0]}),
            json!({}),
            "objects[0].material.checker",
        ),
        (
            json!({"checker": {"colours": [[1, 1, 1], [0, 0, 0]], "scale": 0}}),
            json!({}),
            "objects[0].material.checker",
        ),
        (
            json!({"checker": {"colours": [[1, 1, 1], [0, 0, 2e300]]}}),
            json!({}),
            "objects[0].material.checker.colours[1]",
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

/// Point, spot and jittered area lights render the same on one thread and on three.
#[test]
fn lights_do_not_depend_on_thread_count() {
    let sc = scene(json!({
        "format": "caoen-scene/1",
        "lights": [
            {"position": [0.5, -0.5, 1.0], "fade_distance": 1.0, "fade_power": 2},
            {"position": [-0.5, -0.5, 1.2], "point_at": [0, 0, -0.5], "radius": 15, "falloff": 25, "tightness": 5},
            {"position": [0, -0.8, 1.5], "area_light": {"axis1": [0.5, 0, 0], "axis2": [0, 0.5, 0], "size1": 5, "size2": 5, "jitter": true, "adaptive": 1}}
        ],
        "objects": [
            {"frep": {"box": {"centre": [0, 0, -0.6], "size": [3, 3, 0.1]}}},
            {"frep": {"sphere": {"centre": [-0.3, 0, 0], "radius": 0.4}}},
            {"frep": {"sphere": {"centre": [0.5, 0.2, -0.2], "radius": 0.25}}, "material": {"transmit": 0.8, "ior": 1.5}}
        ]
    }));
    let opts = RenderOptions {
        width: 64,
        height: 48,
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

/// How caoen's render of a scene and POV-Ray's render of its export agree.
struct Agreement {
    /// Silhouette intersection over union.
    iou: f64,
    /// Mean absolute difference in grey levels (8-bit, over the three channels) inside
    /// both silhouettes.
    grey: f64,
    /// RGB PSNR of the whole pictures (8-bit, peak 255).
    psnr: f64,
    /// CPU seconds of caoen's render (every thread).
    ours: f64,
    /// CPU seconds of POV-Ray's.
    theirs: f64,
}

/// Renders `scene` at 512x512 in caoen (`samples` x `samples` a pixel) and, exported,
/// in POV-Ray (`+A0.1`), both written to `dir`; how they agree.
fn against_povray(dir: &Path, scene: &Path, samples: &str) -> Agreement {
    let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
    let (pov, ours, theirs) = (
        dir.join(format!("{stem}.pov")),
        dir.join(format!("{stem}-caoen.png")),
        dir.join(format!("{stem}-povray.png")),
    );
    common::export_pov(scene, &pov, 512);
    let (ok, err, ours_s) = common::run_cpu(
        std::process::Command::new(env!("CARGO_BIN_EXE_caoen")).args([
            "frep",
            "render",
            s(scene),
            "-o",
            s(&ours),
            "--size",
            "512x512",
            "--samples",
            samples,
        ]),
    );
    assert!(ok, "caoen: {err}");
    let theirs_s = common::povray_cpu(&pov, &theirs, 512, "+A0.1");
    let (a, b) = (
        image::open(&ours).unwrap().to_rgb8(),
        image::open(&theirs).unwrap().to_rgb8(),
    );
    let (ma, mb) = (common::silhouette(&a), common::silhouette(&b));
    let (iou, _) = common::iou(&ma, &mb);
    let inter = ma.iter().zip(&mb).filter(|(x, y)| **x && **y).count();
    let mut sum = 0.0;
    for (i, (pa, pb)) in a.pixels().zip(b.pixels()).enumerate() {
        let d = (0..3).map(|k| pa[k] as f64 - pb[k] as f64);
        if ma[i] && mb[i] {
            sum += d.map(f64::abs).sum::<f64>() / 3.0;
        }
    }
    Agreement {
        iou,
        grey: sum / inter.max(1) as f64,
        psnr: common::psnr_rgb8(&a, &b),
        ours: ours_s,
        theirs: theirs_s,
    }
}

/// Prints how `name` agrees with POV-Ray.
fn report(name: &str, g: &Agreement) {
    println!(
        "{name} 512x512: IoU {:.4}, {:.2} dB, mean difference {:.2} grey levels, CPU caoen {:.2} s, POV-Ray {:.2} s, ratio {:.3}",
        g.iou,
        g.psnr,
        g.grey,
        g.ours,
        g.theirs,
        g.ours / g.theirs
    );
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
    let g = against_povray(&dir, &scene, "2");
    report("mirror-glass", &g);
    assert!(g.iou >= 0.98, "IoU {:.4}", g.iou);
    assert!(g.grey <= 8.0, "{:.2} grey levels", g.grey);
}

/// The light examples (a point light fading with distance, a spot light, an area
/// light's soft shadows through glass) agree with POV-Ray's renders of their exports:
/// silhouette IoU >= 0.99 and PSNR >= 35 dB, in no more CPU time than POV-Ray's.
#[test]
fn light_examples_match_povray() {
    let Some(dir) = povray_dir("rays-lights") else {
        return;
    };
    for name in ["point", "spot", "area"] {
        let scene = common::repo_path(&format!("examples/lights-{name}.scene.json"));
        let g = against_povray(&dir, &scene, "2");
        report(&format!("lights-{name}"), &g);
        assert!(g.iou >= 0.99, "{name}: IoU {:.4}", g.iou);
        assert!(g.psnr >= 35.0, "{name}: {:.2} dB", g.psnr);
        assert!(
            g.ours <= g.theirs,
            "{name}: CPU caoen {:.2} s, POV-Ray {:.2} s",
            g.ours,
            g.theirs
        );
    }
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
    let g = against_povray(&dir, &scene, "2");
    report("textured", &g);
    assert!(g.iou >= 0.99, "IoU {:.4}", g.iou);
    assert!(g.psnr >= 35.0, "PSNR {:.2} dB", g.psnr);
    assert!(
        g.ours <= g.theirs,
        "CPU caoen {:.2} s, POV-Ray {:.2} s",
        g.ours,
        g.theirs
    );
}

/// The textured-surface example (two Cao En surfaces, on the sphere and the torus
/// domain, carrying one image on their domains, on a slab) agrees with POV-Ray's render
/// of its export, the surfaces as `mesh2` with exact normals and `uv_mapping`:
/// silhouette IoU >= 0.99, PSNR >= 35 dB, and caoen takes at most POV-Ray's CPU time.
#[test]
fn textured_surface_example_matches_povray() {
    let Some(dir) = povray_dir("rays-textured-surface") else {
        return;
    };
    let scene = common::repo_path("examples/textured-surface.scene.json");
    let g = against_povray(&dir, &scene, "2");
    report("textured-surface", &g);
    assert!(g.iou >= 0.99, "IoU {:.4}", g.iou);
    assert!(g.psnr >= 35.0, "PSNR {:.2} dB", g.psnr);
    assert!(
        g.ours <= g.theirs,
        "CPU caoen {:.2} s, POV-Ray {:.2} s",
        g.ours,
        g.theirs
    );
}

/// The checker example (POV-Ray's `checker` pigment on a slab, a ball and a Cao En
/// solid) agrees with POV-Ray's render of its export: silhouette IoU >= 0.99, PSNR >=
/// 35 dB, and caoen takes at most POV-Ray's CPU time.
#[test]
fn checker_example_matches_povray() {
    let Some(dir) = povray_dir("rays-checker") else {
        return;
    };
    let scene = common::repo_path("examples/checker.scene.json");
    let g = against_povray(&dir, &scene, "2");
    report("checker", &g);
    assert!(g.iou >= 0.99, "IoU {:.4}", g.iou);
    assert!(g.psnr >= 35.0, "PSNR {:.2} dB", g.psnr);
    assert!(
        g.ours <= g.theirs,
        "CPU caoen {:.2} s, POV-Ray {:.2} s",
        g.ours,
        g.theirs
    );
}
