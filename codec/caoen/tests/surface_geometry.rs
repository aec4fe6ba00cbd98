//! Projections, the implicit form for convex solids, domains, morphing, model files.

mod common;
use common::SplitMix as Rng;

use caoen::surface::gallery::{blob, ring, six_point};
use caoen::surface::morph::{morph, pad_to};
use caoen::surface::projection::{axis_generators, perspective_error, PerspectiveCamera};
use caoen::surface::{
    Blend, ConvexSolid, Domain, KeyPoint, Network, Plane, SurfaceError, SurfaceModel,
};

#[test]
fn axis_generators_equal_the_projected_surface_point() {
    let model = blob().unwrap();
    let z1 = [0.3, -0.5, 0.8];
    let z2 = [1.0, 2.0, -0.25];
    let gen = axis_generators(&model.network, &[&z1, &z2]).unwrap();
    let grid = model.domain.grid(40, 21).unwrap();
    for x in grid.points.chunks_exact(3) {
        let y = model.network.eval(x).unwrap();
        let g = gen.eval(x).unwrap();
        for (k, z) in [z1, z2].iter().enumerate() {
            let want: f64 = y.iter().zip(z).map(|(a, b)| a * b).sum();
            assert!(
                (g[k] - want).abs() <= 4.0 * f64::EPSILON * want.abs().max(1.0),
                "{} vs {want}",
                g[k]
            );
        }
    }
}

#[test]
fn perspective_approximation_error_is_small_for_dense_models() {
    let model = blob().unwrap();
    let cam = PerspectiveCamera::look_at([0.5, -4.0, 1.5], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0)
        .unwrap();
    let grid = model.domain.grid(60, 31).unwrap();
    let sparse = perspective_error(&model.network, &cam, &grid.points).unwrap();
    let dense_net = common::resampled(&model, 2000, 400.0);
    let dense = perspective_error(&dense_net, &cam, &grid.points).unwrap();
    eprintln!(
        "perspective approximation error (max, rms), focal 1: sparse {sparse:?}, dense {dense:?}"
    );
    assert!(
        dense.0 < 0.3 * sparse.0,
        "dense {dense:?} sparse {sparse:?}"
    );
    assert!(dense.1 < 2e-3, "dense rms {}", dense.1);
}

fn random_polyhedron(rng: &mut Rng) -> Vec<Plane> {
    // Four tetrahedral directions guarantee a bounded solid; the rest are random.
    let mut planes: Vec<Plane> = [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]]
        .iter()
        .map(|n| Plane {
            normal: *n,
            offset: 3f64.sqrt() * (0.8 + 0.6 * rng.next()),
        })
        .collect();
    for _ in 0..(4 + (rng.next() * 16.0) as usize) {
        planes.push(Plane {
            normal: rng.unit3(),
            offset: 0.6 + 0.8 * rng.next(),
        });
    }
    planes
}

#[test]
fn implicit_form_inside_at_half_outside_at_one_and_a_half() {
    let mut rng = Rng(3);
    for _ in 0..30 {
        let planes = random_polyhedron(&mut rng);
        for blend in [Blend::Power, Blend::Exponential] {
            let solid = ConvexSolid::from_planes(&planes, [0.0; 3], blend, 40.0, 2.0).unwrap();
            for _ in 0..50 {
                let d = rng.unit3();
                let r = solid.polyhedron_extent(d);
                assert!(r.is_finite());
                assert!(solid.contains([0.5 * r * d[0], 0.5 * r * d[1], 0.5 * r * d[2]]));
                assert!(!solid.contains([1.5 * r * d[0], 1.5 * r * d[1], 1.5 * r * d[2]]));
                assert!(r * 1.5 < solid.bounding_radius() * 1.5 + 1.0);
                // The bounding sphere really bounds: beyond it is outside.
                let b = solid.bounding_radius() * 1.0001;
                assert!(!solid.contains([b * d[0], b * d[1], b * d[2]]));
            }
        }
    }
}

#[test]
fn implicit_boundary_converges_to_the_polyhedron_as_q_grows() {
    let mut rng = Rng(5);
    let planes = random_polyhedron(&mut rng);
    let dirs: Vec<[f64; 3]> = (0..200).map(|_| rng.unit3()).collect();
    let mut last = f64::INFINITY;
    for q in [2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0] {
        let solid = ConvexSolid::from_planes(&planes, [0.0; 3], Blend::Power, q, 2.0).unwrap();
        let mut worst: f64 = 0.0;
        for d in &dirs {
            // Bisection for f(r d) = s between the centre and the bounding sphere.
            let (mut lo, mut hi) = (0.0, solid.bounding_radius());
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if solid.contains([mid * d[0], mid * d[1], mid * d[2]]) {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let r = solid.polyhedron_extent(*d);
            worst = worst.max((lo - r).abs() / r);
        }
        assert!(
            worst < last,
            "q={q}: worst relative gap {worst} did not shrink from {last}"
        );
        last = worst;
    }
    assert!(
        last < 0.01,
        "q=128 boundary within 1% of the polyhedron, got {last}"
    );
}

#[test]
fn unbounded_or_invalid_polyhedra_are_rejected() {
    let half_spaces = [
        Plane {
            normal: [1.0, 0.0, 0.0],
            offset: 1.0,
        },
        Plane {
            normal: [0.0, 1.0, 0.0],
            offset: 1.0,
        },
    ];
    assert!(matches!(
        ConvexSolid::from_planes(&half_spaces, [0.0; 3], Blend::Power, 8.0, 2.0),
        Err(SurfaceError::Parameter { reason, .. }) if reason.contains("bounded")
    ));
    let outside = [Plane {
        normal: [1.0, 0.0, 0.0],
        offset: -1.0,
    }];
    assert!(matches!(
        ConvexSolid::from_planes(&outside, [0.0; 3], Blend::Power, 8.0, 2.0),
        Err(SurfaceError::Parameter { value, .. }) if value == -1.0
    ));
    assert!(matches!(
        ConvexSolid::from_face_feet(&[], [0.0; 3], Blend::Power, 8.0, 2.0),
        Err(SurfaceError::Empty)
    ));
}

#[test]
fn sampled_torus_surface_is_closed_with_euler_characteristic_zero() {
    let model = ring().unwrap();
    let grid = model.domain.grid(64, 24).unwrap();
    let tris = grid.wrapped_triangles().unwrap();
    let verts = model.network.eval_batch(&grid.points).unwrap();
    let mut edges = std::collections::HashMap::new();
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            // Consistent winding: each directed edge once, its reverse once.
            *edges.entry((a, b)).or_insert(0) += 1;
        }
        let p = |i: u32| {
            [
                verts[3 * i as usize],
                verts[3 * i as usize + 1],
                verts[3 * i as usize + 2],
            ]
        };
        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        assert!(
            (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() > 1e-8,
            "degenerate triangle"
        );
    }
    assert!(
        edges
            .iter()
            .all(|(&(a, b), &c)| c == 1 && edges.get(&(b, a)) == Some(&1)),
        "not closed/manifold"
    );
    let v = (grid.rows * grid.cols) as i64;
    let e = (edges.len() / 2) as i64;
    let f = tris.len() as i64;
    assert_eq!(v - e + f, 0);
}

#[test]
fn domains_embed_on_the_unit_sphere_and_project_back() {
    let mut rng = Rng(9);
    for domain in [
        Domain::Sphere { dim: 2 },
        Domain::SPHERE,
        Domain::Sphere { dim: 5 },
        Domain::Torus,
        Domain::Ball,
    ] {
        for _ in 0..50 {
            let params: Vec<f64> = (0..domain.param_dim()).map(|_| rng.next() * 0.55).collect();
            let x = domain.point(&params).unwrap();
            let n: f64 = x.iter().map(|a| a * a).sum();
            assert!((n - 1.0).abs() < 1e-12, "{domain:?} {x:?}");
            let back = domain.project(&x).unwrap();
            assert!(x.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-12));
        }
    }
    assert!(matches!(
        Domain::Ball.point(&[1.0, 1.0, 0.0]),
        Err(SurfaceError::Parameter { .. })
    ));
    assert!(matches!(
        Domain::Sphere { dim: 1 }.validate(),
        Err(SurfaceError::Parameter { .. })
    ));
}

#[test]
fn morph_endpoints_reproduce_both_models_and_padding_changes_nothing() {
    let a = six_point(Blend::Exponential, 3.0, true).unwrap().network;
    let b = blob().unwrap().network;
    assert_ne!(a.len(), b.len());
    let grid = Domain::SPHERE.grid(30, 17).unwrap();
    let eval = |n: &Network| n.eval_batch(&grid.points).unwrap();
    let bits = |v: Vec<f64>| v.into_iter().map(f64::to_bits).collect::<Vec<_>>();
    assert_eq!(bits(eval(&pad_to(&a, &b).unwrap())), bits(eval(&a)));
    assert_eq!(bits(eval(&morph(&a, &b, 0.0).unwrap())), bits(eval(&a)));
    assert_eq!(bits(eval(&morph(&a, &b, 1.0).unwrap())), bits(eval(&b)));
    // Halfway lies between: the surface point moves continuously.
    let mid = eval(&morph(&a, &b, 0.5).unwrap());
    let (ea, eb) = (eval(&a), eval(&b));
    let dist = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    assert!(dist(&mid, &ea) < dist(&ea, &eb) && dist(&mid, &eb) < dist(&ea, &eb));
    // Unnormalised models pad the same way.
    let c = six_point(Blend::Power, 2.0, false).unwrap().network;
    let d = pad_to(&c, &b.clone()).unwrap();
    assert_eq!(bits(eval(&d)), bits(eval(&c)));
}

#[test]
fn model_files_round_trip() {
    for model in [
        blob().unwrap(),
        ring().unwrap(),
        six_point(Blend::Compact, 5.0, true).unwrap(),
    ] {
        let text = model.to_json();
        let back = SurfaceModel::from_json(&text).unwrap();
        assert_eq!(back.domain, model.domain);
        assert_eq!(back.network.key_points(), model.network.key_points());
        assert_eq!(back.network.is_normalised(), model.network.is_normalised());
    }
}

#[test]
fn bad_model_files_name_the_field() {
    let good = r#"{"format":"caoen-surface/1","domain":{"kind":"sphere","dim":3},
        "key_points":[{"source":[1,0,0],"shape":[1,0,0]},{"param":[0,1.5],"shape":[0,1,0],"q":2}]}"#;
    assert_eq!(SurfaceModel::from_json(good).unwrap().network.len(), 2);
    let cases = [
        (good.replace("caoen-surface/1", "other/9"), "format"),
        (good.replace(r#""q":2"#, r#""q":"two""#), "key_points[1].q"),
        (good.replace(r#""q":2"#, r#""q":-2"#), "key_points[1].q"),
        (
            good.replace(r#""source":[1,0,0]"#, r#""source":[1,0]"#),
            "key_points[0].source",
        ),
        (
            good.replace(r#""shape":[0,1,0]"#, r#""shape":[0,1]"#),
            "key_points[1].shape",
        ),
        (good.replace(r#""dim":3"#, r#""dim":1"#), "domain.dim"),
        (
            good.replace(r#""kind":"sphere""#, r#""kind":"cube""#),
            "domain",
        ),
        (
            good.replace(r#""param":[0,1.5],"#, ""),
            "key_points[1].source",
        ),
        (
            good.replace(r#","q":2"#, r#","q":2,"colour":1"#),
            "key_points[1]",
        ),
        (
            r#"{"format":"caoen-surface/1","domain":{"kind":"torus"},"key_points":[]}"#.to_string(),
            "key_points",
        ),
        ("{not json".to_string(), "key"),
    ];
    for (text, field) in cases {
        let err = SurfaceModel::from_json(&text).unwrap_err().to_string();
        assert!(err.contains(field), "error for field {field} was: {err}");
    }
}

#[test]
fn nan_inputs_and_empty_models_are_errors() {
    let model = blob().unwrap();
    assert!(matches!(
        model.network.eval(&[f64::NAN, 0.0, 1.0]),
        Err(SurfaceError::NonFinite { .. })
    ));
    assert!(matches!(
        model.network.eval(&[0.0, 1.0]),
        Err(SurfaceError::Dimension {
            expected: 3,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        model
            .network
            .eval_batch(&[0.0, 0.0, 1.0, f64::INFINITY, 0.0, 0.0]),
        Err(SurfaceError::NonFinite { value, .. }) if value == f64::INFINITY
    ));
    assert!(matches!(
        model.network.eval_with_jacobian(&[f64::NAN; 3]),
        Err(SurfaceError::NonFinite { .. })
    ));
    assert!(matches!(
        Network::new(3, 3, &[], false),
        Err(SurfaceError::Empty)
    ));
    let bad_q = KeyPoint::new(vec![1.0, 0.0, 0.0], vec![1.0], Blend::Power, f64::NAN);
    assert!(matches!(
        Network::new(3, 1, &[bad_q], false),
        Err(SurfaceError::Parameter { what, .. }) if what == "key_points[0].q"
    ));
}

#[test]
fn interpolating_networks_hit_their_targets_exactly() {
    let mut rng = Rng(21);
    let n = 40;
    let sources: Vec<f64> = (0..n).flat_map(|_| rng.unit3()).collect();
    let targets: Vec<f64> = (0..n * 2).map(|_| rng.next() - 0.5).collect();
    let net = Network::interpolating(
        3,
        2,
        sources.clone(),
        vec![30.0; n],
        Blend::Exponential,
        &targets,
    )
    .unwrap();
    for j in 0..n {
        let y = net.eval(&sources[3 * j..3 * j + 3]).unwrap();
        assert!((y[0] - targets[2 * j]).abs() < 1e-9 && (y[1] - targets[2 * j + 1]).abs() < 1e-9);
    }
    // Two key points at the same source cannot both be met: a clear error.
    let dup = [sources[..3].to_vec(), sources[..3].to_vec()].concat();
    assert!(matches!(
        Network::interpolating(3, 1, dup, vec![30.0; 2], Blend::Exponential, &[0.0, 1.0]),
        Err(SurfaceError::Parameter { what, .. }) if what == "interpolation system"
    ));
}
