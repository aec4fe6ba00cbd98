//! The paper's camera network (section 5) against the exact camera: axis generators
//! reproduce an orthographic view exactly (formula 15 is an identity); a perspective
//! network, shape vectors projected to the screen, is off by an error that falls as the
//! camera moves away at fixed framing: second order in the spread of the shape vectors
//! a point blends, over the distance squared, times the focal length, which framing
//! makes proportional to the distance, so it falls as 1/distance.

use caoen::render::renderer::{render, RenderOptions};
use caoen::render::Scene;

fn scene(camera: serde_json::Value) -> Scene {
    let text = serde_json::json!({
        "format": "caoen-scene/1", "camera": camera, "objects": [{"surface": "builtin:blob"}]
    });
    Scene::from_json(
        &text.to_string(),
        std::path::Path::new("."),
        &caoen::Limits::default(),
    )
    .unwrap()
}

fn shot(scene: &Scene, network: bool) -> caoen::render::Rendered {
    let opts = RenderOptions {
        width: 256,
        height: 192,
        samples: 1,
        mesh_detail: 4,
        network_camera: network,
        ..Default::default()
    };
    render(scene, &opts, &|_, _| {}).unwrap()
}

#[test]
fn orthographic_network_is_the_exact_camera() {
    let s = scene(serde_json::json!({"projection": "orthographic", "view_from": [1.0, -1.6, 0.9]}));
    let (exact, net) = (shot(&s, false), shot(&s, true));
    let [max, _] = net.stats.projection_error.unwrap();
    assert!(max < 1e-9, "{max}");
    assert_eq!(exact.image.pixels, net.image.pixels);
}

#[test]
fn perspective_network_error_falls_as_one_over_distance() {
    let mut last: Option<f64> = None;
    for fov in [40.0, 20.0, 10.0, 5.0] {
        // Automatic framing keeps the blob's size on screen: halving the field of view
        // doubles the distance.
        let s = scene(serde_json::json!({"fov_deg": fov, "view_from": [1.0, -1.6, 0.9]}));
        let [max, mean] = shot(&s, true).stats.projection_error.unwrap();
        println!("fov {fov}: max {max:.4} px, mean {mean:.4} px");
        assert!(max > 0.0 && mean <= max);
        if let Some(prev) = last {
            let ratio = max / prev;
            assert!(
                (0.4..0.6).contains(&ratio),
                "doubling the distance: ratio {ratio:.3}"
            );
        }
        last = Some(max);
    }
}

#[test]
fn network_camera_needs_the_mesh_method() {
    let s = scene(serde_json::json!({"view_from": [1.0, -1.6, 0.9]}));
    let opts = RenderOptions {
        method: caoen::render::Method::Depth,
        network_camera: true,
        ..Default::default()
    };
    assert!(render(&s, &opts, &|_, _| {}).is_err());
}
