//! The F-rep and mesh-file targets: `frep`, `obj`, `ply`.

use super::*;

/// The format tag of F-rep model files.
const FREP_FORMAT: &str = "caoen-frep/1";

/// The box a model without bounds of its own (a half-space, a quadric) is looked at in.
const UNBOUNDED_BOX: f64 = 2.0;

/// Cells along the longest side of the frep target's meshes: coarse, so a run of a
/// large model stays in milliseconds.
const FREP_CELLS: usize = 6;

/// How far a value computed two ways, or a value and the interval of a box holding its
/// point, may disagree: rounding, relative to the numbers' size.
fn slack(values: &[f64]) -> f64 {
    1e-6 * values
        .iter()
        .filter(|v| v.is_finite())
        .fold(1.0f64, |m, v| m.max(v.abs()))
}

/// Parses an F-rep model file (`{"format": "caoen-frep/1", "model": ...}`, file names
/// in a directory that does not exist), then checks what the renderers and the mesher
/// rely on: at 27 points of the model's box the value and the value of
/// `value_gradient` agree and lie in the interval of the box (and of a small box round
/// the point), the printable mesh on a coarse grid has its indices in range and its
/// vertices finite and inside the box, and rays cast through the box hit inside it.
pub fn frep(data: &[u8]) -> Outcome {
    let text = text(data)?;
    if names_absolute_path(text) {
        return Err("names an absolute path".into());
    }
    let v: serde_json::Value = serde_json::from_str(text).map_err(message)?;
    if v["format"] != FREP_FORMAT {
        return Err("not an F-rep model file".into());
    }
    let node = Node::from_json(
        &v["model"],
        "model",
        Path::new(NO_DIR),
        &caoen::Limits::default(),
    )
    .map_err(message)?;
    assert!(
        node.count() <= MAX_NODES,
        "accepted a model of {} nodes",
        node.count()
    );
    let bounds = node
        .bounds()
        .filter(|b| b.is_bounded() && b.longest() > 0.0)
        .unwrap_or(Aabb::new([-UNBOUNDED_BOX; 3], [UNBOUNDED_BOX; 3]));
    let whole = node.interval(&bounds);
    let at = |i: usize, k: usize| {
        let t = [0.1, 0.5, 0.9][i / [1, 3, 9][k] % 3];
        bounds.lo[k] + t * (bounds.hi[k] - bounds.lo[k])
    };
    for i in 0..27 {
        let p = [at(i, 0), at(i, 1), at(i, 2)];
        let value = node.value(p);
        let (again, gradient) = node.value_gradient(p);
        if value.is_finite() && again.is_finite() {
            assert!(
                (value - again).abs() <= slack(&[value, again]),
                "value {value} and value_gradient {again} differ at {p:?}"
            );
        }
        if !value.is_finite() {
            continue;
        }
        // Within the interval of a box around `p`, to rounding.
        let within = |lo: f64, hi: f64, what: &str| {
            let tol = slack(&[value, lo, hi]);
            assert!(
                lo - tol <= value && value <= hi + tol,
                "value {value} at {p:?} outside {what} interval [{lo}, {hi}]"
            );
        };
        within(whole.lo, whole.hi, "the box's");
        let h = 1e-3 * bounds.longest();
        let small = node.interval(&Aabb::new(p.map(|x| x - h), p.map(|x| x + h)));
        within(small.lo, small.hi, "a small box's");
        let _ = gradient;
    }
    match polygonise::solid_mesh(&node, &bounds, FREP_CELLS) {
        Ok((m, _)) => assert_mesh(&m, Some(&bounds)),
        Err(e) => {
            message(e);
        }
    }
    let caster = Caster::new(
        &node,
        bounds,
        CastOptions {
            resolution: 1e-2,
            ..CastOptions::default()
        },
    );
    let centre = [0, 1, 2].map(|k| 0.5 * (bounds.lo[k] + bounds.hi[k]));
    for dir in [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]] {
        let reach = 2.0 * bounds.longest();
        let origin = [0, 1, 2].map(|k| centre[k] - reach * dir[k]);
        if let Some(t) = caster.first_hit(origin, dir, 0.0, 2.0 * reach) {
            assert!(
                t.is_finite() && (0.0..=2.0 * reach).contains(&t),
                "a ray hit at t = {t}, outside [0, {}]",
                2.0 * reach
            );
        }
    }
    Ok(())
}

/// A mesh caoen made: every index names a vertex, every coordinate is finite and, when
/// `inside` is given, within that box (with rounding slack).
fn assert_mesh(m: &Mesh, inside: Option<&Aabb>) {
    for t in &m.triangles {
        assert!(
            t.iter().all(|&i| (i as usize) < m.positions.len()),
            "triangle {t:?} names a vertex past {}",
            m.positions.len()
        );
    }
    for p in &m.positions {
        assert!(p.iter().all(|x| x.is_finite()), "vertex {p:?} not finite");
        if let Some(b) = inside {
            let tol = 1e-6 * b.longest();
            assert!(
                (0..3).all(|k| b.lo[k] - tol <= p[k] && p[k] <= b.hi[k] + tol),
                "vertex {p:?} outside the mesh's box {b:?}"
            );
        }
    }
}

/// What every mesh the readers accept satisfies: triangles name vertices that exist,
/// with three different corners; coordinates are finite. Written by caoen's OBJ writer
/// it reads back as the same triangles.
fn assert_read_mesh(mesh: &PolygonMesh) {
    assert!(
        !mesh.triangles.is_empty(),
        "accepted a mesh without triangles"
    );
    for t in &mesh.triangles {
        assert!(
            t.iter().all(|&i| (i as usize) < mesh.positions.len()),
            "triangle {t:?} names a vertex past {}",
            mesh.positions.len()
        );
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "triangle {t:?} repeats a corner"
        );
    }
    for p in &mesh.positions {
        assert!(p.iter().all(|x| x.is_finite()), "vertex {p:?} not finite");
    }
    let written = Mesh {
        positions: mesh.positions.clone(),
        normals: vec![[0.0, 0.0, 1.0]; mesh.positions.len()],
        triangles: mesh.triangles.clone(),
        ..Mesh::default()
    };
    let mut bytes = Vec::new();
    caoen::render::mesh_io::write_obj(&written, &mut bytes, None).expect("writing to memory");
    let again = mesh_file::read_obj(&bytes, "written.obj", &caoen::Limits::default())
        .unwrap_or_else(|e| panic!("a mesh written as OBJ does not read back: {e}"));
    // The OBJ reader numbers vertices in the order the faces use them: the triangles'
    // corners, not the indices, must come back.
    let corners = |m: &PolygonMesh| -> Vec<[[f64; 3]; 3]> {
        m.triangles
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect()
    };
    let (before, after) = (corners(mesh), corners(&again));
    assert!(
        before == after,
        "a mesh written as OBJ reads back as another mesh: {} triangles, {} after; first {:?}, after {:?}",
        before.len(),
        after.len(),
        before.first(),
        after.first()
    );
}

/// Reads an OBJ file through caoen's mesh reader (`conversion::mesh_file::read_obj`);
/// an accepted mesh passes [`assert_read_mesh`].
pub fn obj(data: &[u8]) -> Outcome {
    let mesh = mesh_file::read_obj(data, "fuzz.obj", &caoen::Limits::default()).map_err(message)?;
    assert_read_mesh(&mesh);
    Ok(())
}

/// Reads a PLY file, ASCII or binary, through caoen's strict reader
/// (`conversion::mesh_file::read_ply`); an accepted mesh passes [`assert_read_mesh`].
pub fn ply(data: &[u8]) -> Outcome {
    let mesh = mesh_file::read_ply(data, "fuzz.ply", &caoen::Limits::default()).map_err(message)?;
    assert_read_mesh(&mesh);
    Ok(())
}
