//! The mesh readers: OBJ quads, OFF polygons and PLY bodies, ASCII and binary, and
//! the files each must refuse.

use caoen_base::budget::Limits;

use super::*;

#[test]
fn obj_quads_become_two_triangles_and_bad_input_is_refused() {
    let quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let m = read_obj(quad, "q.obj", &Limits::default()).unwrap();
    assert_eq!(m.triangles.len(), 2);
    assert!(matches!(
        read_obj(
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n",
            "b.obj",
            &Limits::default()
        ),
        Err(MeshError::Obj { .. } | MeshError::BadIndex { .. })
    ));
    assert!(matches!(
        read_obj(
            b"v 0 0 nan\nv 1 0 0\nv 1 1 0\nf 1 2 3\n",
            "n.obj",
            &Limits::default()
        ),
        Err(MeshError::NonFinite { vertex: 0, .. })
    ));
    assert!(matches!(
        read_obj(b"v 0 0 0\n", "e.obj", &Limits::default()),
        Err(MeshError::NoTriangles { .. })
    ));
}

#[test]
fn off_polygons_become_fans_and_bad_lines_are_refused() {
    let quad = b"OFF # a square\n4 1 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\n4 0 1 2 3 255 0 0\n";
    let m = read_off(quad, "q.off", &Limits::default()).unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let same_line = read_off(
        b"OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "s.off",
        &Limits::default(),
    )
    .unwrap();
    assert_eq!(same_line.triangles.len(), 1);
    for (text, words) in [
        (
            &b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0 7\n3 0 1 2\n"[..],
            "line 5: vertex 2 has 4 numbers",
        ),
        (
            b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 5\n",
            "1 numbers after its 3 indices",
        ),
        (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "not a polygon"),
        (
            b"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            "face 1 missing",
        ),
        (
            b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 x\n3 0 1 2\n",
            "`x` is not a number",
        ),
        (
            b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n",
            "uses vertex -1",
        ),
        (b"COFF\n3 1 0\n", "expected `OFF`"),
        (b"OFF\n3 1\n", "2 numbers"),
        (b"OFF\n9999999999 1 0\n", "over the limit"),
    ] {
        let e = read_off(text, "b.off", &Limits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{e}");
    }
}

#[test]
fn ply_ascii_and_binary_read_the_same_mesh() {
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float confidence\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n";
    let a = read_ply(ascii, "a.ply", &Limits::default()).unwrap();
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for v in p {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    bin.push(3);
    for i in [0i32, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let b = read_ply(&bin, "b.ply", &Limits::default()).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.triangles, vec![[0, 1, 2]]);
}

#[test]
fn ply_bodies_hold_exactly_what_the_header_declares() {
    let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let extra = format!("{head}0 0 0 9\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert!(matches!(
        read_ply(extra.as_bytes(), "e.ply", &Limits::default()),
        Err(MeshError::ExtraValues {
            index: 0,
            extra: 1,
            ..
        })
    ));
    let more = format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1 0\n");
    assert!(matches!(
        read_ply(more.as_bytes(), "m.ply", &Limits::default()),
        Err(MeshError::TrailingData { declared: 4, .. })
    ));
    let short = format!("{head}0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
    assert!(matches!(
        read_ply(short.as_bytes(), "s.ply", &Limits::default()),
        Err(MeshError::MissingValues { index: 1, .. })
    ));
    let word = format!("{head}0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n");
    assert!(matches!(
        read_ply(word.as_bytes(), "w.ply", &Limits::default()),
        Err(MeshError::BadValue { index: 1, .. })
    ));
}

#[test]
fn binary_triangle_strips_restart_at_minus_one_and_keep_the_winding() {
    let mut bin = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n".to_vec();
    for p in [[0.0f64, 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]] {
        for v in p {
            bin.extend_from_slice(&v.to_be_bytes());
        }
    }
    let strip = [1i32, 0, 2, 3, -1, 3, 0, 1, -1, 1, 2, 3];
    bin.extend_from_slice(&(strip.len() as i32).to_be_bytes());
    for i in strip {
        bin.extend_from_slice(&i.to_be_bytes());
    }
    let m = read_ply(&bin, "t.ply", &Limits::default()).unwrap();
    assert_eq!(
        m.triangles,
        vec![[1, 0, 2], [2, 0, 3], [3, 0, 1], [1, 2, 3]]
    );
    assert!(m.topology().is_closed());
    // One byte too many is a header that lies.
    bin.push(0);
    assert!(matches!(
        read_ply(&bin, "t.ply", &Limits::default()),
        Err(MeshError::TrailingData { bytes: 1, .. })
    ));
}

#[test]
fn a_ply_header_cannot_declare_more_than_the_file_holds() {
    let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
    assert!(matches!(
        read_ply(huge, "h.ply", &Limits::default()),
        Err(MeshError::TooManyElements {
            declared: 4_000_000_000,
            ..
        })
    ));
    let bad = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    assert!(matches!(
        read_ply(bad, "i.ply", &Limits::default()),
        Err(MeshError::BadIndex { index: 7, .. })
    ));
}

/// A tetrahedron, wound outwards.
fn tetrahedron() -> crate::mesh::Mesh {
    crate::mesh::Mesh {
        positions: vec![
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.5e-7],
        ],
        normals: vec![[0.0; 3]; 4],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        ..Default::default()
    }
}

#[test]
fn ascii_stl_holds_every_corner_as_the_binary_does() {
    let m = tetrahedron();
    let mut text = Vec::new();
    write_stl_ascii(&m, &mut text).unwrap();
    let text = String::from_utf8(text).unwrap();
    assert!(text.starts_with("solid caoen\n") && text.ends_with("endsolid caoen\n"));
    assert_eq!(text.matches("facet normal").count(), 4);
    let corners: Vec<[f32; 3]> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("vertex "))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let mut bin = Vec::new();
    write_stl(&m, &mut bin).unwrap();
    let back = read_stl(&bin).unwrap();
    let expect: Vec<[f32; 3]> = back
        .triangles
        .iter()
        .flat_map(|t| t.map(|i| back.positions[i as usize].map(|v| v as f32)))
        .collect();
    assert_eq!(corners, expect);
}

#[test]
fn three_mf_names_its_unit_and_zips_three_parts() {
    let m = tetrahedron();
    let x = three_mf_model(&m, LengthUnit::Inch, "a <b>", Some([1.0, 0.0, 0.5]));
    assert!(x.contains("<model unit=\"inch\""), "{x}");
    assert!(x.contains("name=\"a &lt;b&gt;\""));
    assert!(x.contains("displaycolor=\"#FF00BC\""), "{x}");
    // Decimal numbers without exponents (ST_Number), 1.5e-7 included.
    assert!(x.contains("z=\"0.00000015\""), "{x}");
    assert_eq!(x.matches("<triangle ").count(), 4);
    let mut zip = Vec::new();
    write_3mf(&m, LengthUnit::Millimetre, "t", None, &mut zip).unwrap();
    assert_eq!(&zip[..4], b"PK\x03\x04");
    // The end of central directory record: three entries.
    let end = zip.len() - 22;
    assert_eq!(&zip[end..end + 4], b"PK\x05\x06");
    assert_eq!(u16::from_le_bytes([zip[end + 10], zip[end + 11]]), 3);
    for name in ["[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"] {
        assert_eq!(
            zip.windows(name.len())
                .filter(|w| *w == name.as_bytes())
                .count(),
            2
        );
    }
    assert_eq!(LengthUnit::from_symbol("cm"), Some(LengthUnit::Centimetre));
    assert_eq!(LengthUnit::from_symbol("ft"), None);
}
