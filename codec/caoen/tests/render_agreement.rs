//! The three methods agree: depth-buffer and mesh-rasterised depth maps of the same
//! model and camera, and ray-traced silhouettes of implicit solids against their
//! marching-tetrahedra meshes. Also: the depth buffer leaves no holes, and renders do
//! not depend on the number of threads.

mod common;

use caoen::render::camera::{Camera, Projection};
use caoen::render::csg::CsgNode;
use caoen::render::framebuffer::GBuffer;
use caoen::render::mesh::NormalMode;
use caoen::render::raster::rasterise;
use caoen::render::raytrace::RayMethod;
use caoen::render::renderer::{
    polygonise_solids, render, render_gbuffer, trace_solids, tracers, Method, RenderOptions,
};
use caoen::render::scene::{polyhedron_solid, Scene, Shape};
use caoen::surface::gallery::{blob, ring};
use caoen::surface::{Blend, ConvexSolid};

const W: u32 = 160;
const H: u32 = 120;

fn opts(method: Method) -> RenderOptions {
    RenderOptions {
        width: W,
        height: H,
        samples: 1,
        method,
        mesh_detail: 6,
        normals: NormalMode::Exact,
        ..RenderOptions::default()
    }
}

fn covered(b: &GBuffer, x: i64, y: i64) -> bool {
    x >= 0
        && y >= 0
        && x < b.width as i64
        && y < b.height as i64
        && b.hits[(y * b.width as i64 + x) as usize].is_some()
}

/// Whether pixel `(x, y)` lies on the silhouette of `b`: covered with an uncovered
/// 8-neighbour, or uncovered with a covered one.
fn near_edge(b: &GBuffer, x: i64, y: i64) -> bool {
    let c = covered(b, x, y);
    (-1..=1).any(|dy| (-1..=1).any(|dx| covered(b, x + dx, y + dy) != c))
}

fn compare_depths(scene: &Scene, camera: &Camera, what: &str, min_agree: f64) {
    let (mesh, _) = render_gbuffer(scene, camera, &opts(Method::Mesh)).unwrap();
    let (depth, stats) = render_gbuffer(scene, camera, &opts(Method::Depth)).unwrap();
    assert_eq!(stats.unresolved, 0, "{what}");
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for h in mesh.hits.iter().flatten() {
        lo = lo.min(h.depth);
        hi = hi.max(h.depth);
    }
    let range = hi - lo;
    let (mut both, mut close) = (0, 0);
    for y in 0..H as i64 {
        for x in 0..W as i64 {
            let i = (y * W as i64 + x) as usize;
            match (&mesh.hits[i], &depth.hits[i]) {
                (Some(a), Some(b)) => {
                    both += 1;
                    if (a.depth - b.depth).abs() < 0.01 * range {
                        close += 1;
                    }
                }
                // Coverage may differ only along the silhouette: a hole inside the
                // depth-buffer image, or a stray sample outside the mesh, fails here.
                (Some(_), None) | (None, Some(_)) => {
                    assert!(
                        near_edge(&mesh, x, y),
                        "{what}: coverage differs inside the silhouette at ({x}, {y})"
                    )
                }
                (None, None) => {}
            }
        }
    }
    assert!(both > 2000, "{what}: only {both} pixels covered");
    let frac = close as f64 / both as f64;
    assert!(
        frac > min_agree,
        "{what}: only {:.2}% of covered pixels agree within 1% of the depth range",
        100.0 * frac
    );
}

#[test]
fn depth_buffer_and_mesh_depth_maps_agree() {
    for model in [blob().unwrap(), ring().unwrap()] {
        let name = model.name.clone();
        let scene = Scene::from_model(model, None, &caoen::Limits::default()).unwrap();
        for projection in [
            Projection::Perspective { fov_y_deg: 30.0 },
            Projection::Orthographic { height: 0.0 },
        ] {
            let mut s = scene.clone();
            s.camera.projection = projection;
            let cam = s.camera(W, H).unwrap();
            compare_depths(&s, &cam, &format!("{name} {projection:?}"), 0.99);
        }
    }
    // A compound, transformed scene (the teapot-like example). Where one object's edge
    // passes in front of another inside a pixel, the depth buffer keeps the nearer
    // object's sample while the centre ray of the rasteriser sees the farther one, so
    // the many inner silhouettes of a compound scene cost about one percent here.
    let scene = common::example_scene("teapot/teapot.scene.json");
    compare_depths(&scene, &scene.camera(W, H).unwrap(), "teapot", 0.98);
}

#[test]
fn the_depth_buffer_leaves_no_hole_inside_the_silhouette() {
    // Close up, so the starting triangulation is far coarser than a pixel and most
    // samples come from subdivision.
    let scene = Scene::from_model(blob().unwrap(), None, &caoen::Limits::default()).unwrap();
    let cam = Camera::look_at(
        [0.0, -2.6, 0.8],
        [0.0, 0.0, 0.1],
        [0.0, 0.0, 1.0],
        Projection::Perspective { fov_y_deg: 40.0 },
        W,
        H,
    )
    .unwrap();
    let (depth, _) = render_gbuffer(&scene, &cam, &opts(Method::Depth)).unwrap();
    let mut holes = Vec::new();
    for y in 1..H as i64 - 1 {
        for x in 1..W as i64 - 1 {
            let around = [(-1, 0), (1, 0), (0, -1), (0, 1)]
                .iter()
                .all(|(dx, dy)| covered(&depth, x + dx, y + dy));
            if !covered(&depth, x, y) && around {
                holes.push((x, y));
            }
        }
    }
    assert!(holes.is_empty(), "holes at {holes:?}");
    // With a deliberately coarse threshold the same check does find holes, so it can fail.
    let mut coarse = opts(Method::Depth);
    coarse.depth.max_edge_px = 6.0;
    let (sparse, _) = render_gbuffer(&scene, &cam, &coarse).unwrap();
    let empty_inside = (1..H as i64 - 1)
        .flat_map(|y| (1..W as i64 - 1).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            !covered(&sparse, x, y)
                && [(-1, 0), (1, 0), (0, -1), (0, 1)]
                    .iter()
                    .all(|(dx, dy)| covered(&sparse, x + dx, y + dy))
        })
        .count();
    assert!(empty_inside > 0);
}

fn silhouettes_match(solids: &[ConvexSolid], csg: &CsgNode, camera: &Camera, what: &str) {
    let (traced, _) = trace_solids(
        &tracers(solids),
        csg,
        camera,
        RayMethod::Paper,
        0,
        &|_, _| {},
    );
    let ray = GBuffer {
        width: camera.width,
        height: camera.height,
        hits: traced,
    };
    let mut mesh = GBuffer::new(camera.width, camera.height);
    rasterise(&polygonise_solids(solids, csg, 160), camera, 0, &mut mesh);
    let (mut differ, mut count) = (0, 0);
    for y in 0..camera.height as i64 {
        for x in 0..camera.width as i64 {
            let (a, b) = (covered(&ray, x, y), covered(&mesh, x, y));
            count += a as usize;
            if a != b {
                differ += 1;
                // Within a pixel: the other image's silhouette passes through a neighbour.
                let other = if a { &mesh } else { &ray };
                assert!(
                    near_edge(other, x, y),
                    "{what}: silhouettes differ by more than a pixel at ({x}, {y})"
                );
            }
        }
    }
    assert!(count > 2000, "{what}: {count} pixels");
    assert!(
        differ < count / 20,
        "{what}: {differ} of {count} pixels differ"
    );
}

#[test]
fn ray_traced_silhouettes_match_the_polygonised_solids() {
    let cam = |proj| Camera::framing([0.0, 0.0, 0.0], 1.6, [1.0, -1.4, 0.9], proj, W, H).unwrap();
    let dodeca = polyhedron_solid(
        "dodecahedron",
        1.0,
        [0.0; 3],
        [1.0; 3],
        [0.0; 3],
        Blend::Exponential,
        12.0,
        2.0,
    )
    .unwrap();
    for proj in [
        Projection::Perspective { fov_y_deg: 30.0 },
        Projection::Orthographic { height: 1.0 },
    ] {
        silhouettes_match(
            std::slice::from_ref(&dodeca),
            &CsgNode::Solid(0),
            &cam(proj),
            "dodecahedron",
        );
    }
    // The CSG example: a cube minus an icosahedron.
    let scene = common::example_scene("csg.scene.json");
    let Shape::Solid { solids, csg } = &scene.objects[0].shape else {
        panic!("a solid")
    };
    silhouettes_match(solids, csg, &scene.camera(W, H).unwrap(), "csg");
}

#[test]
fn renders_do_not_depend_on_the_thread_count() {
    let scene = common::example_scene("csg.scene.json");
    let tex = common::example_scene("textured.scene.json");
    for (s, m) in [
        (&scene, Method::Ray),
        (&scene, Method::Mesh),
        (&tex, Method::Depth),
        (&tex, Method::Mesh),
    ] {
        let o = RenderOptions {
            width: 64,
            height: 48,
            samples: 2,
            method: m,
            ..RenderOptions::default()
        };
        let run = |threads| common::with_threads(threads, || render(s, &o, &|_, _| {}).unwrap());
        let (a, b) = (run(1), run(3));
        assert_eq!(a.image, b.image, "{m:?}");
        assert_eq!(a.depth, b.depth, "{m:?}");
    }
}
