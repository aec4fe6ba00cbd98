//! The fit's sampling: flat faces told from facets, and the spread of vertices on a
//! dense mesh.

use super::conditions::flat_faces;
use super::*;

/// A `n x n` grid of vertices on the unit square, two triangles a cell.
fn square(n: usize) -> PolygonMesh {
    let positions = (0..n * n)
        .map(|i| {
            [
                (i % n) as f64 / (n - 1) as f64,
                (i / n) as f64 / (n - 1) as f64,
                0.0,
            ]
        })
        .collect();
    let mut triangles = Vec::new();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let a = (y * n + x) as u32;
            let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    PolygonMesh {
        positions,
        triangles,
    }
}

#[test]
fn flat_faces_are_a_cube_s_and_a_flat_sheet_s_not_a_faceted_sphere_s() {
    let longest = |mesh: &PolygonMesh| {
        let m = mesh.clone();
        move |t: usize| {
            let tri = m.triangles[t].map(|i| m.positions[i as usize]);
            (0..3)
                .map(|k| norm(sub(tri[(k + 1) % 3], tri[k])))
                .fold(0.0, f64::max)
        }
    };
    let cube = PolygonMesh {
        positions: (0..8)
            .map(|i| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64].map(|v| v - 0.5))
            .collect(),
        triangles: vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ],
    };
    assert!(
        flat_faces(&cube, longest(&cube)).iter().all(|&f| f),
        "square faces meeting at right angles"
    );
    let sheet = square(5);
    assert!(flat_faces(&sheet, longest(&sheet)).iter().all(|&f| f));
    // 16 bands: neighbours meet at 11.25 degrees, neither one face nor a crease.
    let sphere = PolygonMesh::uv_sphere(16, 0.5);
    assert!(flat_faces(&sphere, longest(&sphere)).iter().all(|&f| !f));
}

#[test]
fn spread_vertices_keep_all_under_the_cap_and_cover_the_surface_over_it() {
    let mesh = square(101);
    assert_eq!(spread_vertices(&mesh, 20_000).len(), 101 * 101);
    let cap = 1000;
    let chosen = spread_vertices(&mesh, cap);
    assert!(
        chosen.len() <= cap && chosen.len() > cap / 2,
        "{}",
        chosen.len()
    );
    assert!(chosen.windows(2).all(|w| w[0] < w[1]), "in index order");
    assert_eq!(chosen, spread_vertices(&mesh, cap), "the same on every run");
    // Every vertex has a chosen one within two of the grid's cells (side h, about
    // sqrt(area / cap) = 0.032, grown at most a few times by 1.15).
    for p in &mesh.positions {
        let nearest = chosen
            .iter()
            .map(|&i| norm(sub(mesh.positions[i as usize], *p)))
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 0.1,
            "{p:?} is {nearest} from the nearest kept vertex"
        );
    }
}
