//! F-rep: R-functions against their formulas, exact gradients against finite
//! differences, interval bounds that hold, the ray caster against analytic
//! intersections, closed meshes with the right volume, bad models refused, and the CLI.

mod common;
use common::{assert_ok, caoen, caoen_ok, povray_dir, s, Stream};

use std::path::{Path, PathBuf};

use caoen::frep::interval::Aabb;
use caoen::frep::raycast::{CastOptions, Caster};
use caoen::frep::rfunction::{self, SetOp};
use caoen::frep::Node;
use caoen::geometry::vector::central_difference;
use proptest::prelude::*;
use serde_json::json;

fn node(v: serde_json::Value) -> Node {
    Node::from_json(&v, "model", Path::new("."), &caoen::Limits::default()).unwrap()
}

#[test]
fn r_functions_equal_their_formulas() {
    let mut s = Stream(0x9e37_79b9_7f4a_7c15);
    for i in 0..100_000 {
        let (f1, f2) = (5.0 * s.next(), 5.0 * s.next());
        // a = 1: max and min exactly.
        assert_eq!(rfunction::apply(SetOp::Union, f1, f2, 1.0), f1.max(f2));
        assert_eq!(
            rfunction::apply(SetOp::Intersection, f1, f2, 1.0),
            f1.min(f2)
        );
        assert_eq!(
            rfunction::apply(SetOp::Difference, f1, f2, 1.0),
            f1.min(-f2)
        );
        let a = if i % 4 == 0 {
            0.0
        } else {
            0.5 * (s.next() + 1.0)
        };
        let root = |p: f64, q: f64| (p * p + q * q - 2.0 * a * p * q).sqrt();
        let u = (f1 + f2 + root(f1, f2)) / (1.0 + a);
        let n = (f1 + f2 - root(f1, f2)) / (1.0 + a);
        let d = (f1 - f2 - root(f1, -f2)) / (1.0 + a);
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * (1.0 + y.abs());
        assert!(
            close(rfunction::apply(SetOp::Union, f1, f2, a), u),
            "{f1} {f2} {a}"
        );
        assert!(close(rfunction::apply(SetOp::Intersection, f1, f2, a), n));
        assert!(close(rfunction::apply(SetOp::Difference, f1, f2, a), d));
    }
}

/// Models covering every node kind, for the gradient and interval properties.
fn zoo() -> Vec<Node> {
    let sphere = json!({"sphere": {"centre": [0.1, -0.2, 0.3], "radius": 0.8}});
    let boxy = json!({"box": {"centre": [0.2, 0.0, -0.1], "size": [1.0, 0.6, 0.8]}});
    vec![
        node(sphere.clone()),
        node(boxy.clone()),
        node(json!({"cylinder": {"centre": [0.0, 0.1, 0.0], "radius": 0.4, "length": 1.5}})),
        node(json!({"cone": {"centre": [0.0, 0.0, -0.5], "radius": 0.7, "length": 1.2}})),
        node(json!({"torus": {"centre": [0.0, 0.0, 0.1], "major": 0.7, "minor": 0.2}})),
        node(json!({"half_space": {"point": [0.1, 0.0, 0.0], "normal": [1.0, 2.0, -0.5]}})),
        node(json!({"quadric": [1.0, 2.0, 0.5, 0.3, -0.2, 0.1, 0.2, -0.1, 0.05, -1.0]})),
        node(json!({"superellipsoid": {"radii": [0.9, 0.7, 0.6], "exponents": [0.5, 0.7]}})),
        node(json!({"union": [sphere.clone(), boxy.clone()], "a": 0.3})),
        node(json!({"intersection": [sphere.clone(), boxy.clone()]})),
        node(json!({"difference": [boxy.clone(), sphere.clone()], "a": 0.6})),
        node(
            json!({"blend_union": [sphere.clone(), boxy.clone()], "a0": 0.4, "a1": 0.5, "a2": 0.3}),
        ),
        node(
            json!({"blend_intersection": [sphere.clone(), boxy.clone()], "a0": -0.2, "a1": 0.5, "a2": 0.5}),
        ),
        node(json!({"offset": sphere.clone(), "by": 0.1})),
        node(json!({"shell": sphere.clone(), "thickness": 0.15})),
        node(
            json!({"cao_en_solid": {"polyhedron": "dodecahedron", "radius": 0.8, "q": 12.0, "level": 2.0}}),
        ),
        node(
            json!({"difference": [{"cao_en_solid": {"polyhedron": "cube", "radius": 0.7, "q": 8.0, "blend": "power"}}, sphere.clone()], "a": 1.0}),
        ),
        node(json!({"perturb": sphere.clone(), "patches": [
            {"bump": {"centre": [0.6, 0.0, 0.3], "radius": 0.5, "height": 0.4}},
            {"quadric": [-1.0, -2.0, -1.5, 0.2, 0.0, 0.1, 0.0, 0.3, 0.0, 0.2], "factor": -0.5}
        ]})),
        node(
            json!({"perturb": boxy.clone(), "patches": [{"bump": {"centre": [0.0, 0.3, 0.4], "radius": 0.6, "height": 0.5}}], "power": 3}),
        ),
        node(json!({"perturb": boxy.clone(), "patches": [
            {"polygon": {"vertices": TRIANGLE, "depth": 0.2}, "factor": 20.0},
            {"polygon": {"vertices": [[0.7, -0.3, -0.1], [0.7, 0.3, -0.3], [0.7, 0.2, 0.25], [0.7, -0.25, 0.2]], "depth": 0.1}, "factor": -30.0}
        ]})),
        node(json!({"perturb": sphere.clone(), "patches": [
            {"spherical_polygon": {"centre": [0.1, -0.2, 0.3], "radius": 0.8, "vertices": SPHERICAL_QUAD, "depth": 0.15}, "factor": 50.0},
            {"spherical_polygon": {"centre": [0.1, -0.2, 0.3], "radius": 0.8, "vertices": [[0.0, 0.0, 1.0], [-0.6, 0.1, 0.8], [-0.1, -0.6, 0.8]], "depth": 0.1}, "factor": 40.0}
        ], "power": 3})),
        node(
            json!({"transform": {"union": [sphere.clone(), boxy.clone()]}, "scale": [1.0, 2.0, 0.5], "rotate_deg": [10.0, 20.0, 30.0], "translate": [0.3, 0.0, -0.2]}),
        ),
        node(json!({"negate": sphere.clone()})),
        node(
            json!({"blend_difference": [boxy.clone(), sphere.clone()], "a0": 0.3, "a1": 0.4, "a2": 0.4}),
        ),
        node(json!({"twist": boxy.clone(), "deg_per_unit": 90.0})),
        node(json!({"taper": boxy.clone(), "z": [-0.5, 0.5], "scale": [1.0, 0.4]})),
        node(json!({"bend": boxy.clone(), "radius": 1.5})),
        node(json!({"noise": sphere.clone(), "amplitude": 0.1, "scale": 0.3, "seed": 7})),
        node(
            json!({"bend": {"twist": {"noise": boxy, "amplitude": 0.05, "scale": 0.2}, "deg_per_unit": -45.0}, "radius": 2.0}),
        ),
    ]
}

/// A triangle on the top face (z = 0.3) of the zoo's box.
const TRIANGLE: [[f64; 3]; 3] = [[0.0, -0.2, 0.3], [0.5, -0.1, 0.3], [0.2, 0.25, 0.3]];
/// A spherical quad's corners, projected onto the zoo sphere from its centre.
const SPHERICAL_QUAD: [[f64; 3]; 4] = [
    [1.0, -0.3, -0.3],
    [1.0, 0.3, -0.35],
    [1.0, 0.35, 0.3],
    [1.0, -0.3, 0.3],
];

/// `n`'s analytic gradient at `p` against central differences of step `h`. `None` where
/// the analytic gradient changes by more than `crease` (relative) within `crease_steps * h`
/// along an axis: near a crease (min/max, |x| at 0, a bilinear cell edge) central
/// differences are not O(h^2) and stop being a reference. Otherwise `Err` with both
/// gradients when a component differs by more than `tol` times the gradient's scale.
fn check_gradient(
    n: &Node,
    p: [f64; 3],
    h: f64,
    crease_steps: f64,
    crease: f64,
    tol: f64,
) -> Option<Result<(), String>> {
    let (_, g) = n.value_gradient(p);
    let near_crease = (0..3).any(|k| {
        let (mut a, mut b) = (p, p);
        a[k] += crease_steps * h;
        b[k] -= crease_steps * h;
        let (ga, gb) = (n.value_gradient(a).1, n.value_gradient(b).1);
        (0..3).any(|j| (ga[j] - gb[j]).abs() > crease * (1.0 + g[j].abs()))
    });
    if near_crease {
        return None;
    }
    let fd = central_difference(|q| n.value(q), p, h);
    let scale = g.iter().map(|v| v.abs()).fold(1.0, f64::max);
    Some(if (0..3).all(|k| (g[k] - fd[k]).abs() <= tol * scale) {
        Ok(())
    } else {
        Err(format!("analytic {g:?} vs central {fd:?}"))
    })
}

/// The bound over a box holds the function at points of the box: 300 boxes of `s`,
/// centred in `0.9 x 0.9 x z` times [-1, 1)^3, each at 20 points; `what` names the case.
fn check_bounds(n: &Node, s: &mut Stream, z: f64, what: &str) {
    for _ in 0..300 {
        let c = [0.9 * s.next(), 0.9 * s.next(), z * s.next()];
        let r = 0.3 * (s.next() + 1.0);
        let b = Aabb::new(c.map(|v| v - r), c.map(|v| v + r));
        let range = n.interval(&b);
        for _ in 0..20 {
            let p = [0, 1, 2].map(|k| b.lo[k] + 0.5 * (s.next() + 1.0) * (b.hi[k] - b.lo[k]));
            let v = n.value(p);
            assert!(range.contains(v), "{what}: {v} outside {range:?} on {b:?}");
        }
    }
}

#[test]
fn gradients_equal_central_differences() {
    let mut s = Stream(12345);
    let mut checked = 0;
    for (k, n) in zoo().iter().enumerate() {
        for _ in 0..2000 {
            let p = [1.2 * s.next(), 1.2 * s.next(), 1.2 * s.next()];
            assert_eq!(
                n.value_gradient(p).0,
                n.value(p),
                "model {k}: value_gradient's value is value"
            );
            match check_gradient(n, p, 1e-6, 2.0, 1e-3, 1e-6) {
                None => continue,
                Some(r) => r.unwrap_or_else(|e| panic!("model {k} at {p:?}: {e}")),
            }
            checked += 1;
        }
    }
    assert!(checked > 25_000, "only {checked} smooth points checked");
}

proptest! {
    #![proptest_config(common::proptest_config(200))]
    /// The interval over a box holds the function at every point of the box.
    #[test]
    fn intervals_hold_the_values(
        c in prop::array::uniform3(-1.5f64..1.5),
        h in prop::array::uniform3(0.0f64..0.8),
        t in prop::collection::vec(prop::array::uniform3(0.0f64..1.0), 16),
    ) {
        let b = Aabb::new([0, 1, 2].map(|k| c[k] - h[k]), [0, 1, 2].map(|k| c[k] + h[k]));
        for (k, n) in zoo().iter().enumerate() {
            let range = n.interval(&b);
            for u in &t {
                let p = [0, 1, 2].map(|i| b.lo[i] + u[i] * (b.hi[i] - b.lo[i]));
                let v = n.value(p);
                let slack = 1e-9 * (1.0 + v.abs());
                prop_assert!(range.lo - slack <= v && v <= range.hi + slack,
                    "model {} on {:?}: {} outside [{}, {}]", k, b, v, range.lo, range.hi);
            }
        }
    }
}

#[test]
fn caster_finds_analytic_spans() {
    // Two unit spheres 3 apart on the x axis, a ray along x: [-1, 1] and [2, 4].
    let n = node(json!({"union": [
        {"sphere": {"centre": [0.0, 0.0, 0.0], "radius": 1.0}},
        {"sphere": {"centre": [3.0, 0.0, 0.0], "radius": 1.0}}
    ]}));
    let c = Caster::new(&n, n.bounds().unwrap(), CastOptions::default());
    let spans = c.spans([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0, f64::INFINITY);
    assert_eq!(spans.len(), 2, "{spans:?}");
    let want = [(4.0, 6.0), (7.0, 9.0)];
    for (s, w) in spans.iter().zip(want) {
        assert!(
            (s.enter - w.0).abs() < 1e-9 && (s.exit - w.1).abs() < 1e-9,
            "{s:?}"
        );
    }
    // An off-axis ray meets the first sphere where the quadratic says.
    let y: f64 = 0.6;
    let t = c
        .first_hit([-5.0, y, 0.0], [1.0, 0.0, 0.0], 0.0, f64::INFINITY)
        .unwrap();
    assert!((t - (5.0 - (1.0 - y * y).sqrt())).abs() < 1e-9, "{t}");
    // A miss, and a ray starting inside.
    assert!(c
        .first_hit([-5.0, 1.5, 0.0], [1.0, 0.0, 0.0], 0.0, f64::INFINITY)
        .is_none());
    assert_eq!(c.first_hit([0.0; 3], [1.0, 0.0, 0.0], 0.0, 10.0), Some(0.0));
}

/// Volume enclosed by a closed triangle mesh (divergence theorem).
fn volume(m: &caoen::render::mesh::Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))
                / 6.0
        })
        .sum::<f64>()
        .abs()
}

#[test]
fn union_of_two_spheres_meshes_closed_with_the_right_volume() {
    // Unit spheres 1.0 apart: volume 2 (4/3) pi minus the lens pi (4r + d)(2r - d)^2 / 12.
    let want = 8.0 * std::f64::consts::PI / 3.0 - 5.0 * std::f64::consts::PI / 12.0;
    for a in [0.0, 1.0] {
        let n = node(json!({"union": [
            {"sphere": {"centre": [-0.5, 0.0, 0.0], "radius": 1.0}},
            {"sphere": {"centre": [0.5, 0.0, 0.0], "radius": 1.0}}
        ], "a": a}));
        let m = caoen::frep::polygonise::mesh(&n, &n.bounds().unwrap(), 96);
        // Closed: every edge in exactly two triangles, once each way.
        let mut edges = std::collections::HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(i, j), &c) in &edges {
            assert_eq!(c, 1, "edge {i}-{j} used {c} times one way");
            assert_eq!(edges.get(&(j, i)), Some(&1), "edge {i}-{j} has no twin");
        }
        assert_eq!(m.euler_characteristic(), 2);
        let v = volume(&m);
        println!(
            "a = {a}: {} triangles, volume {v:.5} vs {want:.5} ({:+.3}%)",
            m.triangles.len(),
            100.0 * (v / want - 1.0)
        );
        assert!((v / want - 1.0).abs() < 0.01);
        // Every vertex sits on the surface (projected along the gradient).
        let worst = m
            .positions
            .iter()
            .map(|p| {
                let (f, g) = n.value_gradient(*p);
                f.abs() / (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt().max(1e-300)
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "a vertex {worst} off the surface");
    }
}

#[test]
fn bad_models_are_refused_with_the_path() {
    let cases = [
        (json!({"sphere": {"radius": -1.0}}), "model.sphere.radius"),
        (json!({"sphere": {"radius": 1e300}}), "model.sphere.radius"),
        (
            json!({"sphere": {"radius": 1.0, "colour": 3}}),
            "unknown field `colour`",
        ),
        (
            json!({"sphere": {"centre": [0, 0], "radius": 1.0}}),
            "model.sphere.centre",
        ),
        (
            json!({"union": [{"sphere": {"radius": 1.0}}]}),
            "1 operands",
        ),
        (
            json!({"union": [{"sphere": {"radius": 1.0}}, {"box": {"size": [1, 1, 1]}}], "a": 2}),
            "model.a",
        ),
        (
            json!({"quadric": [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]}),
            "all coefficients are zero",
        ),
        (
            json!({"transform": {"sphere": {"radius": 1.0}}, "scale": 0.0}),
            "model.scale",
        ),
        (json!({"teapot": {}}), "no node kind"),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"polygon": {"vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1.5]], "depth": 0.1}}]}),
            "off the plane",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"polygon": {"vertices": [[0, 0, 1], [1, 0, 1], [0.2, 0.2, 1], [0, 1, 1]], "depth": 0.1}}]}),
            "not convex",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"polygon": {"vertices": [[0, 0, 1], [1, 0, 1]], "depth": 0.1}}]}),
            "model.patches[0].polygon.vertices: expected 3 or 4",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"spherical_polygon": {"radius": 1.0, "vertices": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "depth": 1.0}}]}),
            "below the radius",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"polygon": {"vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "depth": 0.0}}]}),
            "model.patches[0].polygon.depth",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [{"polygon": {"vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "depth": 0.1}, "bump": {"radius": 1.0, "height": 1.0}}]}),
            "give exactly one of",
        ),
        (json!([1, 2]), "expected a node object"),
        (
            json!({"twist": {"sphere": {"radius": 1.0}}, "deg_per_unit": "a lot"}),
            "model.deg_per_unit",
        ),
        (
            json!({"twist": {"sphere": {"radius": 1.0}}}),
            "missing field `deg_per_unit`",
        ),
        (
            json!({"taper": {"sphere": {"radius": 1.0}}, "z": [1.0, 0.0], "scale": [1.0, 0.5]}),
            "model.z: expected z0 < z1",
        ),
        (
            json!({"taper": {"sphere": {"radius": 1.0}}, "z": [0.0, 1.0], "scale": [1.0, 0.0]}),
            "model.scale[1]",
        ),
        (
            json!({"bend": {"sphere": {"radius": 1.0}}, "radius": 0.0}),
            "model.radius",
        ),
        (
            json!({"noise": {"sphere": {"radius": 1.0}}, "amplitude": 0.1, "scale": 0.2, "seed": -1}),
            "model.seed",
        ),
        (
            json!({"noise": {"sphere": {"radius": 1.0}}, "amplitude": 0.1, "scale": 0.0}),
            "model.scale",
        ),
        (
            json!({"negate": {"sphere": {"radius": 1.0}}, "by": 1.0}),
            "unknown field `by`",
        ),
        (
            json!({"blend_difference": [{"sphere": {"radius": 1.0}}], "a0": 0.1, "a1": 0.1, "a2": 0.1}),
            "1 operands",
        ),
    ];
    for (v, want) in cases {
        let e = Node::from_json(&v, "model", Path::new("."), &caoen::Limits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{v}: `{e}` should mention `{want}`");
    }
    // Nesting deeper than the limit.
    let mut v = json!({"sphere": {"radius": 1.0}});
    for _ in 0..70 {
        v = json!({"offset": v, "by": 0.0});
    }
    let e = Node::from_json(&v, "model", Path::new("."), &caoen::Limits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nested deeper"), "{e}");
}

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("frep-{name}"))
}

/// The blended-union example model, `examples/frep/blend.json`, copied into `dir`.
fn blend_model(dir: &Path) -> PathBuf {
    let path = dir.join("blend.json");
    let example = common::repo_path("examples/frep/blend.json");
    std::fs::copy(example, &path).unwrap();
    path
}

/// PSNR between `caoen frep render` of `model` by ray casting and by its mesh, 192x144.
fn ray_vs_mesh_psnr(dir: &Path, model: &Path) -> f64 {
    let (ray, mesh) = (dir.join("ray.png"), dir.join("mesh.png"));
    for (out, method) in [(&ray, "ray"), (&mesh, "mesh")] {
        caoen_ok(&[
            "frep",
            "render",
            s(model),
            "-o",
            s(out),
            "--method",
            method,
            "--size",
            "192x144",
        ]);
    }
    let load = |p: &Path| {
        caoen::render::framebuffer::RgbImage::load(p, &caoen::Limits::default()).unwrap()
    };
    common::psnr_render(&load(&ray), &load(&mesh))
}

#[test]
fn cli_render_mesh_and_errors() {
    let dir = tmpdir("cli");
    let model = blend_model(&dir);
    let obj = dir.join("m.obj");
    let psnr = ray_vs_mesh_psnr(&dir, &model);
    println!("ray vs mesh render: {psnr:.1} dB");
    assert!(psnr > 35.0, "{psnr:.1} dB");
    let o = caoen_ok(&["frep", "mesh", s(&model), "-o", s(&obj), "--cells", "48"]);
    // The box's bore makes the solid a handlebody of genus 1: V - E + F = 0.
    assert!(String::from_utf8_lossy(&o.stderr).contains("Euler characteristic 0"));
    // Bad files: exit 1, one line naming the problem, no panic.
    let bad = dir.join("bad.json");
    for (text, want) in [
        (
            "{\"format\": \"caoen-frep/1\", \"model\": {\"sphere\": {\"radius\": NaN}}}",
            "not JSON",
        ),
        (
            "{\"format\": \"caoen-frep/1\", \"model\": {\"sphere\": {\"radius\": 1e999}}}",
            "not JSON",
        ),
        (
            "{\"format\": \"caoen-frep/1\", \"model\": {\"sphere\": {\"radius\": 1e30}}}",
            "radius",
        ),
        (
            "{\"format\": \"caoen-frep/1\", \"model\": {\"half_space\": {\"normal\": [0, 0, 1]}}}",
            "bounds",
        ),
        ("{\"format\": \"caoen-frep/2\", \"model\": {}}", "format"),
        ("{\"format\": \"caoen-frep/1\"}", "missing field `model`"),
    ] {
        std::fs::write(&bad, text).unwrap();
        let o = caoen(&["frep", "render", s(&bad), "-o", s(&dir.join("x.png"))]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{text}: {err}");
        assert!(
            err.contains(want) && !err.contains("panicked") && err.trim().lines().count() == 1,
            "{text}: {err}"
        );
    }
}

/// The POV-Ray render of the exported model has caoen's silhouette: the analytic
/// models at 512x512 with antialiasing, the picture examples (POV-Ray reads the image
/// through its function VM, dozens of times slower) at 128x128 with one ray per pixel in
/// both renderers, so the silhouettes are sampled at the same points.
#[test]
fn pov_ray_renders_the_exported_model() {
    let Some(dir) = povray_dir("frep-pov") else {
        return;
    };
    let bumps = dir.join("bumps.json");
    std::fs::write(
        &bumps,
        json!({
            "format": "caoen-frep/1", "name": "sphere with quadric patches",
            "model": {"perturb": {"sphere": {"radius": 0.8}}, "patches": [
                {"bump": {"centre": [0.7, 0.0, 0.3], "radius": 0.45, "height": 0.5}},
                {"bump": {"centre": [-0.3, -0.6, 0.4], "radius": 0.4, "height": 0.4}},
                {"bump": {"centre": [0.0, 0.5, -0.6], "radius": 0.5, "height": 0.3}, "factor": -1.0}
            ]},
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.8]}
        })
        .to_string(),
    )
    .unwrap();
    let solid = dir.join("cao-en.json");
    std::fs::write(
        &solid,
        json!({
            "format": "caoen-frep/1", "name": "Cao En solid blended with a torus",
            "model": {"blend_union": [
                {"cao_en_solid": {"polyhedron": "dodecahedron", "radius": 0.8, "q": 12.0, "level": 2.0}},
                {"torus": {"major": 0.9, "minor": 0.15}}], "a0": 0.5, "a1": 0.5, "a2": 0.3},
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.7, 1.0]}
        })
        .to_string(),
    )
    .unwrap();
    let examples = common::repo_path("examples/frep");
    let pictures = [
        "lattice",
        "relief",
        "heightfield-ellipsoid",
        "heightfield-cylinder",
    ]
    .map(|m| examples.join(format!("{m}.json")));
    let analytic = [blend_model(&dir), bumps, solid];
    for (model, picture) in analytic
        .into_iter()
        .map(|m| (m, false))
        .chain(pictures.into_iter().map(|m| (m, true)))
    {
        let stem = model.file_stem().unwrap().to_string_lossy().to_string();
        let (side, aa, samples) = if picture {
            (128, "-A", "1")
        } else {
            (512, "+A0.1", "2")
        };
        let (iou, union, pov_s) = pov_silhouettes(&dir, &model, side, aa, samples);
        println!(
            "{stem}: silhouette IoU caoen vs POV-Ray {iou:.4} ({union} pixels, {side}x{side}, POV-Ray {pov_s:.1} s)"
        );
        assert!(
            union > (side * side / 20) as usize && iou >= 0.98,
            "{stem}: IoU {iou:.4}"
        );
    }
}

/// Silhouette IoU of POV-Ray's render of the exported model against caoen's, both at
/// `side` x `side` with antialiasing.
fn pov_silhouette_iou(dir: &Path, model: &Path, side: u32) -> f64 {
    let stem = model.file_stem().unwrap().to_string_lossy().to_string();
    let (iou, union, _) = pov_silhouettes(dir, model, side, "+A0.1", "2");
    assert!(
        union > (side * side / 20) as usize,
        "{stem}: {union} pixels"
    );
    iou
}

/// Renders `model` `side` pixels square in caoen with `samples` rays a pixel and, exported,
/// in POV-Ray with the antialiasing switch `aa`: the silhouettes' IoU, their union's
/// pixel count and the seconds POV-Ray took.
fn pov_silhouettes(
    dir: &Path,
    model: &Path,
    side: u32,
    aa: &str,
    samples: &str,
) -> (f64, usize, f64) {
    let stem = model.file_stem().unwrap().to_string_lossy().to_string();
    let (pov, ours, theirs) = (
        dir.join(format!("{stem}.pov")),
        dir.join(format!("{stem}-ours.png")),
        dir.join(format!("{stem}-pov.png")),
    );
    common::export_pov(model, &pov, side);
    caoen_ok(&[
        "frep",
        "render",
        s(model),
        "-o",
        s(&ours),
        "--size",
        &format!("{side}x{side}"),
        "--samples",
        samples,
    ]);
    let pov_s = common::povray(&pov, &theirs, side, aa);
    let open = |p: &Path| image::open(p).unwrap().to_rgb8();
    let (iou, union) = common::iou(
        &common::silhouette(&open(&ours)),
        &common::silhouette(&open(&theirs)),
    );
    (iou, union, pov_s)
}

/// The negation, blended difference, twist, taper, bend and noise nodes: POV-Ray's
/// render of the export has the silhouette of caoen's (IoU at least 0.98 at 512x512).
#[test]
fn pov_ray_renders_the_new_nodes() {
    let Some(dir) = povray_dir("frep-pov-new-nodes") else {
        return;
    };
    let camera =
        json!({"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.8]});
    let models = [
        (
            "twist",
            json!({"twist": {"box": {"size": [0.7, 0.4, 1.4]}}, "deg_per_unit": 80.0}),
        ),
        (
            "taper-bend",
            json!({"bend": {"taper": {"box": {"size": [1.6, 0.5, 0.3]}}, "z": [-0.15, 0.15], "scale": [1.0, 0.6]}, "radius": 1.0}),
        ),
        (
            "negate-blend-difference",
            json!({"blend_difference": [
            {"intersection": [{"sphere": {"radius": 0.8}}, {"negate": {"cylinder": {"radius": 0.25, "length": 3.0}}}], "a": 1.0},
            {"box": {"centre": [0.5, -0.5, 0.5], "size": [0.8, 0.8, 0.8]}}], "a0": 0.1, "a1": 0.3, "a2": 0.3}),
        ),
        (
            "noise",
            json!({"noise": {"sphere": {"radius": 0.7}}, "amplitude": 0.08, "scale": 0.25, "seed": 3}),
        ),
    ];
    for (name, model) in models {
        let path = dir.join(format!("{name}.json"));
        std::fs::write(
            &path,
            json!({"format": "caoen-frep/1", "name": name, "model": model, "camera": camera})
                .to_string(),
        )
        .unwrap();
        let started = std::time::Instant::now();
        let iou = pov_silhouette_iou(&dir, &path, 512);
        println!(
            "{name}: silhouette IoU caoen vs POV-Ray {iou:.4} (512x512, {:.1} s)",
            started.elapsed().as_secs_f64()
        );
        assert!(iou >= 0.98, "{name}: IoU {iou:.4}");
    }
}

/// The blob surface (`builtin:blob`) written to `dir/blob.json`.
fn blob_surface(dir: &Path) -> PathBuf {
    let path = dir.join("blob.json");
    caoen_ok(&["surface", "export", "builtin:blob", "-o", s(&path)]);
    path
}

/// The inside of a closed Cao En surface as a field: the signed distance to its
/// tessellation. Its magnitude equals the distance to the nearest of all triangles
/// (found by brute force), its sign the generalised winding number's (the sum of the
/// triangles' solid angles: 1 inside, 0 outside); gradients equal central differences
/// away from the medial axis; the Lipschitz bound holds the values of random boxes;
/// bad nodes are refused with the path.
#[test]
fn caoen_surface_inside_is_a_signed_distance() {
    let dir = tmpdir("surface-field");
    blob_surface(&dir);
    let v = json!({"caoen_surface": {"file": "blob.json", "detail": 3}});
    let n = Node::from_json(&v, "model", &dir, &caoen::Limits::default()).unwrap();
    let model = caoen::surface::model_file::SurfaceModel::load(
        &dir.join("blob.json"),
        &caoen::Limits::default(),
    )
    .unwrap();
    let mesh = caoen::render::mesh::tessellate(
        &model,
        3,
        caoen::render::mesh::NormalMode::Exact,
        &caoen::Limits::default(),
    )
    .unwrap();
    let tri: Vec<[[f64; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.positions[i as usize]))
        .collect();
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    // Distance from p to a triangle by minimising over a fine barycentric grid and
    // the edges: an independent (slow, approximate from above) nearest point.
    let seg = |p: [f64; 3], a: [f64; 3], b: [f64; 3]| {
        let ab = sub(b, a);
        let t = (dot(sub(p, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
        let q = [0, 1, 2].map(|k| a[k] + t * ab[k]);
        dot(sub(p, q), sub(p, q)).sqrt()
    };
    let to_triangle = |p: [f64; 3], t: &[[f64; 3]; 3]| {
        let nrm = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        let len = dot(nrm, nrm).sqrt();
        let nrm = nrm.map(|v| v / len);
        let h = dot(sub(p, t[0]), nrm);
        let q = [0, 1, 2].map(|k| p[k] - h * nrm[k]);
        // q inside the triangle: the plane distance; else the nearest edge.
        let inside =
            (0..3).all(|i| dot(cross(sub(t[(i + 1) % 3], t[i]), sub(q, t[i])), nrm) >= 0.0);
        if inside {
            h.abs()
        } else {
            (0..3)
                .map(|i| seg(p, t[i], t[(i + 1) % 3]))
                .fold(f64::INFINITY, f64::min)
        }
    };
    let winding = |p: [f64; 3]| {
        let mut sum = 0.0;
        for t in &tri {
            let [a, b, c] = t.map(|v| sub(v, p));
            let (la, lb, lc) = (dot(a, a).sqrt(), dot(b, b).sqrt(), dot(c, c).sqrt());
            let num = dot(a, cross(b, c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            sum += 2.0 * num.atan2(den);
        }
        sum / (4.0 * std::f64::consts::PI)
    };
    let mut st = Stream(0x00c0_ffee_0000_0004);
    let (mut ins, mut outs) = (0, 0);
    for _ in 0..400 {
        let p = [1.2 * st.next(), st.next(), st.next()];
        let (f, _) = n.value_gradient(p);
        let d = tri
            .iter()
            .map(|t| to_triangle(p, t))
            .fold(f64::INFINITY, f64::min);
        assert!(
            (f.abs() - d).abs() < 1e-9,
            "at {p:?}: |f| = {} vs {d}",
            f.abs()
        );
        let w = winding(p);
        assert!(
            (w - 1.0).abs() < 1e-6 || w.abs() < 1e-6,
            "winding {w} at {p:?}"
        );
        assert_eq!(f > 0.0, w > 0.5, "at {p:?}: f = {f}, winding {w}");
        if f > 0.0 {
            ins += 1;
        } else {
            outs += 1;
        }
    }
    assert!(ins > 50 && outs > 50, "{ins} inside, {outs} outside");
    assert!(n.value([0.0; 3]) > 0.3 && n.value([3.0, 0.0, 0.0]) < -1.0);
    // Gradients (unit length, the direction away from the nearest point).
    let mut checked = 0;
    for _ in 0..2000 {
        let p = [1.6 * st.next(), 1.4 * st.next(), 1.4 * st.next()];
        let (_, g) = n.value_gradient(p);
        let h = 1e-6;
        let smooth = (0..3).all(|i| {
            let (mut a, mut b) = (p, p);
            a[i] += 2.0 * h;
            b[i] -= 2.0 * h;
            let (ga, gb) = (n.value_gradient(a).1, n.value_gradient(b).1);
            (0..3).all(|j| (ga[j] - gb[j]).abs() < 1e-3)
        });
        if !smooth {
            continue;
        }
        assert!((dot(g, g).sqrt() - 1.0).abs() < 1e-9);
        let fd = central_difference(|q| n.value(q), p, h);
        for i in 0..3 {
            assert!(
                (g[i] - fd[i]).abs() < 1e-6,
                "at {p:?}: {} vs {}",
                g[i],
                fd[i]
            );
        }
        checked += 1;
    }
    assert!(checked > 1500, "{checked}");
    // Bounds over random boxes hold the values inside them.
    for _ in 0..300 {
        let c = [1.5 * st.next(), 1.5 * st.next(), 1.5 * st.next()];
        let h = [
            0.4 * st.next().abs(),
            0.4 * st.next().abs(),
            0.4 * st.next().abs(),
        ];
        let b = Aabb::new(
            [0, 1, 2].map(|k| c[k] - h[k]),
            [0, 1, 2].map(|k| c[k] + h[k]),
        );
        let range = n.interval(&b);
        for _ in 0..8 {
            let p = [0, 1, 2].map(|k| c[k] + h[k] * st.next());
            let v = n.value(p);
            assert!(range.lo <= v && v <= range.hi, "{v} outside {range:?}");
        }
    }
    for (v, want) in [
        (
            json!({"caoen_surface": {"file": "missing.json"}}),
            "model.caoen_surface.file",
        ),
        (
            json!({"caoen_surface": {"file": "blob.json", "detail": 8}}),
            "model.caoen_surface.detail",
        ),
        (
            json!({"caoen_surface": {"file": "blob.json", "detail": 2.5}}),
            "whole number",
        ),
        (
            json!({"caoen_surface": {"file": "blob.json", "level": 1}}),
            "unknown field `level`",
        ),
    ] {
        let e = Node::from_json(&v, "model", &dir, &caoen::Limits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{v}: `{e}` should mention `{want}`");
    }
}

/// The ray-cast silhouette of a surface's inside matches the surface's own render.
#[test]
fn caoen_surface_field_renders_like_the_surface() {
    let dir = tmpdir("surface-render");
    blob_surface(&dir);
    let camera = json!({"projection": "perspective", "fov_deg": 30.0,
        "eye": [2.0, -3.2, 1.4], "target": [0.0, 0.0, 0.0]});
    let scenes = [
        json!({"format": "caoen-scene/1", "camera": camera, "objects": [{"surface": "blob.json"}]}),
        json!({"format": "caoen-scene/1", "camera": camera,
            "objects": [{"frep": {"caoen_surface": {"file": "blob.json", "detail": 5}}}]}),
    ];
    let mut masks = Vec::new();
    for (k, (scene, method)) in scenes.iter().zip(["mesh", "ray"]).enumerate() {
        let (path, out) = (
            dir.join(format!("s{k}.json")),
            dir.join(format!("s{k}.png")),
        );
        std::fs::write(&path, scene.to_string()).unwrap();
        caoen_ok(&[
            "surface",
            "render",
            s(&path),
            "-o",
            s(&out),
            "--size",
            "160x160",
            "--samples",
            "1",
            "--method",
            method,
        ]);
        masks.push(common::silhouette(&image::open(&out).unwrap().to_rgb8()));
    }
    let (iou, union) = common::iou(&masks[0], &masks[1]);
    println!("surface mesh render vs its inside ray-cast: IoU {iou:.4} ({union} pixels)");
    assert!(union > 160 * 160 / 20 && iou >= 0.99, "IoU {iou:.4}");
}

/// A box minus a ball at its corner: sharp set operations meeting along curves.
fn box_minus_ball(dir: &Path) -> PathBuf {
    let path = dir.join("box-minus-ball.json");
    let model = json!({
        "format": "caoen-frep/1", "name": "box minus ball",
        "model": {"difference": [
            {"box": {"size": [1.2, 1.2, 1.2]}},
            {"sphere": {"centre": [0.6, -0.6, 0.6], "radius": 0.75}}], "a": 1.0},
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.8]}
    });
    std::fs::write(&path, model.to_string()).unwrap();
    path
}

/// Meshes of sharp set operations have sharp creases: the mesh render matches the ray
/// render to 35 dB, and the triangles lie closer to the surface than without moving
/// the crease vertices onto the creases (zigzag rims cut corners).
#[test]
fn sharp_set_operations_mesh_with_sharp_creases() {
    let dir = tmpdir("crease");
    let model = box_minus_ball(&dir);
    let psnr = ray_vs_mesh_psnr(&dir, &model);
    println!("box minus ball, ray vs mesh render: {psnr:.1} dB");
    assert!(psnr >= 35.0, "{psnr:.1} dB");

    // Distance of triangle centres from the surface (|f| / |grad f|, with f the piece
    // active there: max and min are exact, so this is the first-order distance).
    let n = node(json!({"difference": [
        {"box": {"size": [1.2, 1.2, 1.2]}},
        {"sphere": {"centre": [0.6, -0.6, 0.6], "radius": 0.75}}], "a": 1.0}));
    let b = n.bounds().unwrap();
    let off = |m: &caoen::render::mesh::Mesh| {
        let mut worst: f64 = 0.0;
        let mut sum = 0.0;
        for t in &m.triangles {
            let c =
                [0, 1, 2].map(|k| t.iter().map(|&v| m.positions[v as usize][k]).sum::<f64>() / 3.0);
            let (f, g) = n.value_gradient(c);
            let d = f.abs() / (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            worst = worst.max(d);
            sum += d;
        }
        (sum / m.triangles.len() as f64, worst)
    };
    let closed = caoen::frep::polygonise::mesh(&n, &b, 48);
    // The file mesh keeps one vertex per crease point: still closed, a sphere's topology.
    assert_eq!(closed.euler_characteristic(), 2);
    let sharp = off(&closed);
    let smooth = off(&caoen::frep::polygonise::smooth_mesh(&n, &b, 48));
    println!(
        "triangle centres off the surface, mean and worst: sharp {sharp:?}, smooth {smooth:?}"
    );
    assert!(
        sharp.0 < 0.5 * smooth.0 && sharp.1 < 0.5 * smooth.1,
        "{sharp:?} vs {smooth:?}"
    );
}

/// Polygon patches: `Q > 0` exactly over the triangle or quad within the band (checked
/// against an independent point-in-polygon test of the point projected onto the plane
/// or, along its ray from the centre, onto the sphere), so the perturbation is 0
/// outside; and `Q` reaches the depth's half at the polygon's inside, on its surface.
#[test]
fn polygon_patches_are_zero_outside_their_polygon() {
    use caoen::frep::polygon_patch::PolygonSupport;
    let planar = PolygonSupport::planar(&TRIANGLE, 0.2).unwrap();
    let centre = [0.1, -0.2, 0.3];
    let spherical = PolygonSupport::spherical(centre, 0.8, &SPHERICAL_QUAD, 0.15).unwrap();
    // Is q inside the polygon `poly` (points on the plane z = 0.3, or directions),
    // by the sign of the 2-D or 3-D triple products, independent of the support's edges?
    let inside_planar = |p: [f64; 3]| {
        let v = TRIANGLE;
        (0..3).all(|i| {
            let (a, b) = (v[i], v[(i + 1) % 3]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) > 0.0
        }) && (p[2] - 0.3).abs() < 0.2
    };
    let inside_spherical = |p: [f64; 3]| {
        let d = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let v = SPHERICAL_QUAD.map(|q| [0, 1, 2].map(|k| q[k] - centre[k]));
        let det = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        };
        // The quad runs anticlockwise seen from outside.
        (0..4).all(|i| det(v[i], v[(i + 1) % 4], d) > 0.0) && (r - 0.8).abs() < 0.15
    };
    let mut s = Stream(0xfeed_f00d_0000_0003);
    let (mut ins, mut outs) = (0, 0);
    for _ in 0..200_000 {
        let p = [0.25 + 0.6 * s.next(), 0.6 * s.next(), 0.3 + 0.3 * s.next()];
        let q = planar.value_gradient(p).0;
        assert_eq!(q > 0.0, inside_planar(p), "planar at {p:?}: Q = {q}");
        let p = [
            centre[0] + 0.75 + 0.3 * s.next(),
            centre[1] + 0.5 * s.next(),
            centre[2] + 0.5 * s.next(),
        ];
        let q = spherical.value_gradient(p).0;
        assert_eq!(q > 0.0, inside_spherical(p), "spherical at {p:?}: Q = {q}");
        if q > 0.0 {
            ins += 1;
        } else {
            outs += 1;
        }
    }
    assert!(
        ins > 10_000 && outs > 10_000,
        "{ins} inside, {outs} outside"
    );
    // The perturbed model equals its base wherever Q <= 0.
    let base = node(json!({"sphere": {"centre": centre, "radius": 0.8}}));
    let perturbed = node(
        json!({"perturb": {"sphere": {"centre": centre, "radius": 0.8}},
        "patches": [{"spherical_polygon": {"centre": centre, "radius": 0.8,
            "vertices": SPHERICAL_QUAD, "depth": 0.15}, "factor": 50.0}]}),
    );
    for _ in 0..20_000 {
        let p = [1.2 * s.next(), 1.2 * s.next(), 1.2 * s.next()];
        if spherical.value_gradient(p).0 <= 0.0 {
            assert_eq!(perturbed.value(p), base.value(p), "at {p:?}");
        } else {
            assert!(perturbed.value(p) > base.value(p), "at {p:?}");
        }
    }
    // Exact gradients inside the patches (where the zoo's random points seldom fall).
    let planar_model = node(
        json!({"perturb": {"half_space": {"point": [0.0, 0.0, 0.3], "normal": [0.0, 0.0, 1.0]}},
        "patches": [{"polygon": {"vertices": TRIANGLE, "depth": 0.2}, "factor": 20.0}]}),
    );
    let mut checked = 0;
    for _ in 0..20_000 {
        let p = [0.25 + 0.3 * s.next(), 0.25 * s.next(), 0.3 + 0.2 * s.next()];
        let p2 = [
            centre[0] + 0.8 + 0.15 * s.next(),
            centre[1] + 0.3 * s.next(),
            centre[2] + 0.3 * s.next(),
        ];
        for (m, p, support) in [(&planar_model, p, &planar), (&perturbed, p2, &spherical)] {
            if support.value_gradient(p).0 <= 1e-4 {
                continue;
            }
            let (_, g) = m.value_gradient(p);
            let fd = central_difference(|q| m.value(q), p, 1e-6);
            let scale = g.iter().map(|v| v.abs()).fold(1.0, f64::max);
            for i in 0..3 {
                assert!(
                    (g[i] - fd[i]).abs() <= 1e-6 * scale,
                    "at {p:?}: {} vs {}",
                    g[i],
                    fd[i]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 5_000, "{checked}");
    // Golden value: at the centroid, on the plane, the band is depth / 2 and each edge
    // contributes its distance, folded by the a = 0 intersection.
    let v = TRIANGLE;
    let mid = [0, 1, 2].map(|k| (v[0][k] + v[1][k] + v[2][k]) / 3.0);
    let mut want = 0.1;
    for i in 0..3 {
        let (a, b) = (v[i], v[(i + 1) % 3]);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let e = ((b[0] - a[0]) * (mid[1] - a[1]) - (b[1] - a[1]) * (mid[0] - a[0])) / len;
        want = want + e - (want * want + e * e).sqrt();
    }
    let q = planar.value_gradient(mid).0;
    assert!((q - want).abs() < 1e-12, "{q} vs {want}");
}

/// POV-Ray evaluates an exported picture model to the same numbers as caoen: grey and
/// colour images, bilinear and bicubic, planar, cylindrical and ellipsoid parameters.
/// Colour images agree to single precision; POV-Ray's reader of grey PNGs turns some
/// levels into the level below (170 is read as 169/255), so a grey image agrees to 1.3
/// levels (the bicubic weights' sum of magnitudes is at most 1.25). A bicubic map read
/// bilinearly, or a sample grid off by half a pixel, is off by more than 10^-2. Polygon
/// patches (no image) agree to rounding.
#[test]
fn pov_ray_reads_pictures_as_caoen_does() {
    let Some(dir) = povray_dir("frep-pov-values") else {
        return;
    };
    let root = common::repo_path("examples");
    let (grey, colour) = (
        root.join("frep/lattice.png"),
        root.join("distort/input.png"),
    );
    let cases = [
        json!({"pattern": {"image": s(&grey), "projection": "planar",
            "rect": [-0.9, -0.7, 0.8, 0.6], "interp": "bicubic"}}),
        json!({"pattern": {"image": s(&colour), "projection": "planar",
            "rect": [-0.9, -0.7, 0.8, 0.6], "interp": "bilinear", "level": 0.3}}),
        json!({"pattern": {"image": s(&colour), "projection": "cylindrical",
            "rect": [-3.0, -0.8, 3.1, 0.9], "interp": "bicubic"}}),
        json!({"height_map": {"image": s(&colour), "base": {"ellipsoid": [0.9, 0.8, 0.7]},
            "rect": [-3.1, -1.5, 3.1, 1.5], "interp": "bicubic", "height": 0.3, "threshold": 0.05}}),
        json!({"perturb": {"sphere": {"radius": 0.8}}, "patches": [
            {"polygon": {"vertices": [[-0.5, -0.5, 0.2], [0.6, -0.4, 0.3], [0.1, 0.7, 0.1]], "depth": 0.3}, "factor": 20.0},
            {"spherical_polygon": {"radius": 0.8, "vertices": SPHERICAL_QUAD, "depth": 0.3}, "factor": -30.0}
        ], "power": 3}),
    ];
    let mut stream = Stream(0x5eed_1234_abcd_0001);
    // The grey image's tolerance; the colour images' is single precision.
    let tolerance = [1.3 / 255.0, 1e-6, 1e-6, 1e-6, 1e-8];
    for (n, case) in cases.iter().enumerate() {
        let model = json!({"intersection": [case, {"sphere": {"radius": 5.0}}], "a": 1.0});
        let path = dir.join(format!("m{n}.json"));
        std::fs::write(
            &path,
            json!({"format": "caoen-frep/1", "model": model,
                   "bounds": {"min": [-1.5, -1.5, -1.5], "max": [1.5, 1.5, 1.5]}})
            .to_string(),
        )
        .unwrap();
        let pov = dir.join(format!("m{n}.pov"));
        common::export_pov(&path, &pov, 8);
        let mut text = std::fs::read_to_string(&pov).unwrap();
        let top = text
            .split("function { -")
            .nth(1)
            .and_then(|t| t.split('(').next())
            .unwrap()
            .to_string();
        let points: Vec<[f64; 3]> = (0..200)
            .map(|_| [stream.next(), stream.next(), stream.next()])
            .collect();
        let out = dir.join(format!("m{n}.txt"));
        text.push_str(&format!("#fopen O \"{}\" write\n", s(&out)));
        for p in &points {
            text.push_str(&format!(
                "#write (O, str({top}({:?}, {:?}, {:?}), 0, 12), \"\\n\")\n",
                p[0], p[1], p[2]
            ));
        }
        text.push_str("#fclose O\n");
        std::fs::write(&pov, text).unwrap();
        let o = std::process::Command::new("povray")
            .args([&format!("+I{}", s(&pov)), "+W8", "+H8", "-D", "-F"])
            .output()
            .unwrap();
        assert_ok(&o);
        let theirs: Vec<f64> = std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .map(|l| l.trim().parse().unwrap())
            .collect();
        assert_eq!(theirs.len(), points.len());
        let m = node(model);
        let mut worst: f64 = 0.0;
        for (p, t) in points.iter().zip(&theirs) {
            worst = worst.max((m.value(*p) - t).abs());
        }
        println!("case {n}: largest difference caoen vs POV-Ray {worst:.2e}");
        assert!(worst < tolerance[n], "case {n}: {worst}");
    }
}

/// Whether `povray` runs (`.ci/run` installs it); the POV-Ray tests skip without it.
/// A smooth grey image (8-bit) of `w x h`, written to `dir/name`.
fn grey_png(dir: &Path, name: &str, w: u32, h: u32) -> PathBuf {
    let img = image::GrayImage::from_fn(w, h, |i, j| {
        let (x, y) = (i as f64 / (w - 1) as f64, j as f64 / (h - 1) as f64);
        let v = 0.5 + 0.45 * (5.0 * x).sin() * (3.0 * y + 0.5).cos();
        image::Luma([(255.0 * v).round() as u8])
    });
    let p = dir.join(name);
    img.save(&p).unwrap();
    p
}

fn height_map(dir: &Path, base: serde_json::Value, interp: &str, threshold: Option<f64>) -> Node {
    let mut hm = json!({"image": "hm.png", "base": base, "rect": [-1.0, -0.5, 1.0, 0.5], "height": 0.3, "interp": interp});
    if let Some(t) = threshold {
        hm["threshold"] = json!(t);
    }
    Node::from_json(
        &json!({"height_map": hm}),
        "model",
        dir,
        &caoen::Limits::default(),
    )
    .unwrap()
}

#[test]
fn height_map_reproduces_the_samples_and_its_gradient() {
    use caoen::frep::height_map::HeightMap;
    let dir = tmpdir("hm-nodes");
    grey_png(&dir, "hm.png", 33, 17);
    for interp in ["bilinear", "bicubic"] {
        let n = height_map(&dir, json!("plane"), interp, None);
        let Node::HeightMap(h) = &n else {
            panic!("a height map node")
        };
        let h: &HeightMap = h;
        let (w, hh) = h.size();
        for j in 0..hh {
            for i in 0..w {
                let uv = h.sample_uv(i, j);
                // On the plane base at z = 0, F = h exactly at every sample.
                assert_eq!(
                    n.value([uv[0], uv[1], 0.0]),
                    h.sample(i, j),
                    "{interp} sample {i},{j}"
                );
            }
        }
        // Outside the rectangle the base alone.
        assert_eq!(n.value([1.2, 0.0, -0.25]), 0.25);
    }
    // The gradient against central differences on every base (away from cell edges,
    // where bilinear interpolation has a crease).
    let mut s = Stream(7);
    for base in [
        json!("plane"),
        json!({"ellipsoid": [1.0, 0.8, 0.6]}),
        json!({"cylinder": 0.7}),
    ] {
        for interp in ["bilinear", "bicubic"] {
            let n = height_map(&dir, base.clone(), interp, None);
            let mut checked = 0;
            for _ in 0..3000 {
                let p = [0.9 * s.next(), 0.9 * s.next(), 0.6 * s.next()];
                match check_gradient(&n, p, 1e-7, 4.0, 1e-4, 1e-5) {
                    None => continue,
                    Some(r) => r.unwrap_or_else(|e| panic!("{base} {interp} at {p:?}: {e}")),
                }
                checked += 1;
            }
            assert!(checked > 1000, "{base} {interp}: only {checked} points");
            check_bounds(&n, &mut s, 0.6, &format!("{base} {interp}"));
        }
    }
}

#[test]
fn height_map_ray_hits_match_a_fine_mesh() {
    // Vertical rays onto a bilinear map against a mesh of its patches subdivided 16x16
    // per cell (vertices on the surface): depths agree to 1e-4 of the extent.
    let dir = tmpdir("hm-mesh");
    grey_png(&dir, "hm.png", 9, 5);
    let n = height_map(&dir, json!("plane"), "bilinear", None);
    let Node::HeightMap(h) = &n else { panic!() };
    let bounds = Aabb::new([-1.0, -0.5, -0.1], [1.0, 0.5, 0.4]);
    let c = Caster::new(
        &n,
        bounds,
        CastOptions {
            resolution: 1e-4,
            refine_steps: 60,
        },
    );
    let (w, hh) = h.size();
    let sub = 16;
    let mut s = Stream(99);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let (x, y) = (0.999 * s.next(), 0.499 * s.next());
        let t = c
            .first_hit([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
            .unwrap();
        let ray_z = 1.0 - t;
        // The mesh: the bilinear patch sampled at the sub-grid corners, two triangles
        // per sub-cell, interpolated linearly in the triangle holding (x, y).
        let gx = (x + 1.0) / 2.0 * (w - 1) as f64 * sub as f64;
        let gy = (0.5 - y) / 1.0 * (hh - 1) as f64 * sub as f64;
        let (i, j) = (gx.floor(), gy.floor());
        let (fx, fy) = (gx - i, gy - j);
        let z_at = |a: f64, b: f64| {
            let u = -1.0 + 2.0 * a / ((w - 1) * sub) as f64;
            let v = 0.5 - b / ((hh - 1) * sub) as f64;
            h.height([u, v]).0
        };
        let (z00, z10, z01, z11) = (
            z_at(i, j),
            z_at(i + 1.0, j),
            z_at(i, j + 1.0),
            z_at(i + 1.0, j + 1.0),
        );
        let mesh_z = if fx >= fy {
            z00 + fx * (z10 - z00) + fy * (z11 - z10)
        } else {
            z00 + fy * (z01 - z00) + fx * (z11 - z01)
        };
        worst = worst.max((ray_z - mesh_z).abs());
    }
    let extent = bounds.longest();
    println!(
        "height map: worst ray vs 16x mesh depth {worst:.2e} ({:.2e} of the extent)",
        worst / extent
    );
    assert!(worst <= 1e-4 * extent);
}

#[test]
fn thresholded_outline_has_the_counted_area() {
    // With a threshold, the raised part's outline is where h >= T; seen from above, its
    // area matches the count of grid cells whose bilinear heights pass, within 1%.
    let dir = tmpdir("hm-outline");
    grey_png(&dir, "hm.png", 129, 65);
    let t = 0.15;
    let n = height_map(&dir, json!("plane"), "bilinear", Some(t));
    let Node::HeightMap(h) = &n else { panic!() };
    // Counted: the image's samples that pass, each standing for its share of the
    // rectangle (half at an edge, a quarter at a corner).
    let (w, hh) = h.size();
    let sample_area = (2.0 / (w - 1) as f64) * (1.0 / (hh - 1) as f64);
    let mut counted = 0.0;
    let mut passing = 0usize;
    for j in 0..hh {
        for i in 0..w {
            if h.sample(i, j) >= t {
                let edge = |k: usize, n: usize| if k == 0 || k == n - 1 { 0.5 } else { 1.0 };
                counted += edge(i, w) * edge(j, hh) * sample_area;
                passing += 1;
            }
        }
    }
    // Seen: vertical rays on a grid 8 times finer land above the base plane.
    let sub = 8;
    let (cols, rows) = ((w - 1) * sub, (hh - 1) * sub);
    let cell_area = (2.0 / cols as f64) * (1.0 / rows as f64);
    let mut seen = 0usize;
    let c = Caster::new(
        &n,
        Aabb::new([-1.0, -0.5, -0.1], [1.0, 0.5, 0.4]),
        CastOptions::default(),
    );
    for j in 0..rows {
        for i in 0..cols {
            let (x, y) = (
                -1.0 + (i as f64 + 0.5) * 2.0 / cols as f64,
                0.5 - (j as f64 + 0.5) / rows as f64,
            );
            let z = 1.0
                - c.first_hit([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, 10.0)
                    .unwrap();
            seen += usize::from(z > 0.5 * t);
        }
    }
    let (a, b) = (counted, seen as f64 * cell_area);
    println!(
        "thresholded outline: counted {a:.4}, ray cast {b:.4} ({:+.3}%)",
        100.0 * (b / a - 1.0)
    );
    assert!(
        passing > 500 && passing < w * hh - 500,
        "the threshold should cut: {passing}"
    );
    assert!((b / a - 1.0).abs() < 0.01);
}

#[test]
fn cli_heightfield_writes_models_and_renders() {
    let dir = tmpdir("heightfield");
    let img = grey_png(&dir, "relief.png", 48, 32);
    for base in ["plane", "ellipsoid", "cylinder"] {
        let json = dir.join(format!("{base}.json"));
        caoen_ok(&[
            "heightfield",
            s(&img),
            "--base",
            base,
            "--threshold",
            "0.2",
            "-o",
            s(&json),
        ]);
        // The model renders through `caoen frep render` from another directory.
        let png = dir.join(format!("{base}.png"));
        caoen_ok(&[
            "frep",
            "render",
            s(&json),
            "-o",
            s(&png),
            "--size",
            "96x72",
            "--samples",
            "1",
        ]);
        let r =
            caoen::render::framebuffer::RgbImage::load(&png, &caoen::Limits::default()).unwrap();
        let bg = r.pixels[0];
        let covered = r.pixels.iter().filter(|p| **p != bg).count();
        assert!(covered > 500, "{base}: {covered} pixels of the solid");
    }
    let o = caoen(&["heightfield", s(&img), "-o", s(&dir.join("x.obj"))]);
    assert_eq!(o.status.code(), Some(2));
    let o = caoen(&[
        "heightfield",
        s(&dir.join("missing.png")),
        "-o",
        s(&dir.join("x.png")),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
}

#[test]
fn patch_gradient_is_continuous_where_the_patch_ends() {
    // R = Q^2 (and Q^3) where Q > 0: the gradient of F + R is continuous across Q = 0.
    for power in [2, 3] {
        let n = node(json!({"perturb": {"sphere": {"radius": 1.0}}, "patches": [
            {"bump": {"centre": [0.8, 0.2, 0.4], "radius": 0.7, "height": 0.6}}
        ], "power": power}));
        let mut s = Stream(3);
        let mut worst: f64 = 0.0;
        for _ in 0..1000 {
            let d = [s.next(), s.next(), s.next()];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let at = |r: f64| [0, 1, 2].map(|k| [0.8, 0.2, 0.4][k] + r * d[k] / len);
            let eps = 1e-12;
            let (_, gi) = n.value_gradient(at(0.7 - eps));
            let (_, go) = n.value_gradient(at(0.7 + eps));
            let jump = (0..3).map(|k| (gi[k] - go[k]).abs()).fold(0.0, f64::max);
            worst = worst.max(jump);
        }
        println!("power {power}: largest gradient jump across Q = 0: {worst:.2e}");
        assert!(worst < 1e-9, "{worst}");
    }
}

#[test]
fn relief_and_pattern_gradients_and_bounds() {
    let dir = tmpdir("picture-nodes");
    grey_png(&dir, "hm.png", 40, 24);
    let models = [
        json!({"relief": {"sphere": {"radius": 1.0}}, "image": "hm.png", "projection": "spherical", "depth": 0.1, "interp": "bicubic"}),
        json!({"relief": {"box": {"size": [1.6, 1.6, 1.0]}}, "image": "hm.png", "projection": "planar", "depth": -0.05}),
        json!({"pattern": {"image": "hm.png", "projection": "cylindrical", "rect": [-3.0, -1.0, 3.0, 1.0], "level": 0.4, "interp": "bicubic"}}),
    ];
    let mut s = Stream(5);
    for m in models {
        let n = Node::from_json(&m, "model", &dir, &caoen::Limits::default()).unwrap();
        let mut checked = 0;
        for _ in 0..3000 {
            let p = [0.9 * s.next(), 0.9 * s.next(), 0.9 * s.next()];
            assert_eq!(n.value_gradient(p).0, n.value(p));
            match check_gradient(&n, p, 1e-7, 4.0, 1e-4, 1e-5) {
                None => continue,
                Some(r) => r.unwrap_or_else(|e| panic!("{m} at {p:?}: {e}")),
            }
            checked += 1;
        }
        assert!(checked > 1000, "{m}: {checked}");
        check_bounds(&n, &mut s, 0.9, &m.to_string());
    }
}

#[test]
fn cli_relief_and_carve() {
    let dir = tmpdir("carve");
    let img = grey_png(&dir, "pattern.png", 64, 32);
    let ball = dir.join("ball.json");
    std::fs::write(
        &ball,
        // A fixed camera, so the pictures compare pixel for pixel.
        json!({"format": "caoen-frep/1", "name": "ball", "model": {"sphere": {"radius": 1.0}},
               "camera": {"projection": "perspective", "fov_deg": 30.0, "eye": [0.0, -6.0, 0.0], "target": [0.0, 0.0, 0.0]}})
            .to_string(),
    )
    .unwrap();
    let plain = dir.join("plain.png");
    caoen_ok(&[
        "frep",
        "render",
        s(&ball),
        "-o",
        s(&plain),
        "--size",
        "96x72",
        "--samples",
        "1",
    ]);
    let covered = |p: &Path| {
        let r = caoen::render::framebuffer::RgbImage::load(p, &caoen::Limits::default()).unwrap();
        let bg = r.pixels[0];
        r.pixels.iter().filter(|q| **q != bg).count()
    };
    let base = covered(&plain);
    for (cmd, extra) in [
        ("relief", vec!["--depth", "0.2"]),
        ("carve", vec!["--shell", "0.1", "--level", "0.5"]),
    ] {
        let (json_out, png_out) = (
            dir.join(format!("{cmd}.json")),
            dir.join(format!("{cmd}.png")),
        );
        let mut args = vec![cmd, s(&img), "--on", s(&ball), "-o", s(&json_out)];
        args.extend(&extra);
        caoen_ok(&args);
        caoen_ok(&[
            "frep",
            "render",
            s(&json_out),
            "-o",
            s(&png_out),
            "--size",
            "96x72",
            "--samples",
            "1",
        ]);
        let c = covered(&png_out);
        println!("{cmd}: {c} pixels covered, the plain ball {base}");
        if cmd == "relief" {
            // Raised everywhere the picture is not black: the silhouette grows.
            assert!(c > base, "relief {c} vs {base}");
        } else {
            // Cut where the picture is dark: holes show the background.
            assert!(c < base, "carve {c} vs {base}");
        }
    }
    // A picture is no model to carve (1); a text file is no output (2).
    for (cmd, on, out, code) in [("relief", &img, "x.json", 1), ("carve", &ball, "x.txt", 2)] {
        let o = caoen(&[cmd, s(&img), "--on", s(on), "-o", s(&dir.join(out))]);
        assert_eq!(o.status.code(), Some(code), "{cmd}");
    }
    // A model without its optional name renders straight to a picture too.
    let unnamed = dir.join("unnamed.json");
    common::write_frep(&unnamed, json!({"sphere": {"radius": 1.0}}));
    for cmd in ["relief", "carve"] {
        let png = dir.join(format!("unnamed-{cmd}.png"));
        caoen_ok(&[
            cmd,
            s(&img),
            "--on",
            s(&unnamed),
            "-o",
            s(&png),
            "--size",
            "48x36",
            "--samples",
            "1",
        ]);
        assert!(
            caoen::render::framebuffer::RgbImage::load(&png, &caoen::Limits::default()).is_ok(),
            "{cmd}"
        );
    }
}

#[test]
fn a_render_keeps_to_the_commands_memory_budget() {
    let d = common::fresh_dir("frep-render-budget");
    let model = d.join("s.frep.json");
    common::write_frep(
        &model,
        json!({"sphere": {"centre": [0, 0, 0], "radius": 1}}),
    );
    let out = d.join("r.png");
    // 3072x2304 samples need hundreds of MiB: refused under 16 MiB before any work.
    let args = [
        "frep",
        "render",
        s(&model),
        "-o",
        s(&out),
        "--size",
        "1024x768",
    ];
    let mut tight = args.to_vec();
    tight.extend(["--samples", "3", "--max-memory", "16M"]);
    let r = caoen(&tight);
    let err = common::stderr(&r);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("over the memory budget of 16.0 MiB"), "{err}");
    assert!(!out.exists(), "nothing written when refused");
    // The same render within the budget it asks for runs.
    let mut small = args.to_vec();
    small[6] = "64x48";
    small.extend(["--max-memory", "64M"]);
    assert_ok(&caoen(&small));
    assert!(out.exists());
}
