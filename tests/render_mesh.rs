//! Meshes: topology (Euler characteristic, closedness), no degenerate triangles, and
//! OBJ/PLY files re-read by strict readers written against the format specifications.

mod common;
use common::{caoen_ok, s};

use std::collections::HashMap;

use caoen::render::mesh::{tessellate, Mesh, NormalMode};
use caoen::render::mesh_io::{write_obj, write_ply};
use caoen::surface::gallery::{blob, ring, six_point};
use caoen::surface::{Blend, SurfaceModel};

fn sphere_models() -> Vec<SurfaceModel> {
    vec![
        six_point(Blend::Exponential, 1.0, false).unwrap(),
        six_point(Blend::Exponential, 6.0, false).unwrap(),
        six_point(Blend::Exponential, 6.0, true).unwrap(),
        six_point(Blend::Power, 3.0, false).unwrap(),
        blob().unwrap(),
        SurfaceModel::load(
            "examples/teapot/body.json".as_ref(),
            &caoen::Limits::default(),
        )
        .unwrap(),
        SurfaceModel::load("examples/morph-b.json".as_ref(), &caoen::Limits::default()).unwrap(),
    ]
}

fn torus_models() -> Vec<SurfaceModel> {
    vec![
        ring().unwrap(),
        SurfaceModel::load(
            "examples/torus-freeform.json".as_ref(),
            &caoen::Limits::default(),
        )
        .unwrap(),
        SurfaceModel::load(
            "examples/teapot/handle.json".as_ref(),
            &caoen::Limits::default(),
        )
        .unwrap(),
    ]
}

fn assert_no_degenerate(mesh: &Mesh, what: &str) {
    let (lo, hi) = mesh.positions.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        },
    );
    let diag2: f64 = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum();
    // A triangle of the finest level covers ~1/F of the surface; far below that is degenerate.
    let floor = 1e-9 * diag2;
    for (i, t) in mesh.triangles.iter().enumerate() {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "{what}: triangle {i} repeats a vertex: {t:?}"
        );
        let a = mesh.triangle_area(i);
        assert!(a > floor, "{what}: triangle {i} has area {a:e}");
    }
}

#[test]
fn sphere_models_have_euler_characteristic_2_and_torus_models_0() {
    for detail in [2, 4] {
        for m in sphere_models() {
            let mesh =
                tessellate(&m, detail, NormalMode::Exact, &caoen::Limits::default()).unwrap();
            assert_eq!(mesh.euler_characteristic(), 2, "{} detail {detail}", m.name);
            assert!(mesh.is_closed_and_consistent(), "{}", m.name);
            assert_no_degenerate(&mesh, &m.name);
        }
        for m in torus_models() {
            let mesh = tessellate(
                &m,
                detail,
                NormalMode::Interpolated,
                &caoen::Limits::default(),
            )
            .unwrap();
            assert_eq!(mesh.euler_characteristic(), 0, "{} detail {detail}", m.name);
            assert!(mesh.is_closed_and_consistent(), "{}", m.name);
            assert_no_degenerate(&mesh, &m.name);
        }
    }
}

#[test]
fn the_checks_catch_broken_meshes() {
    let mut mesh = tessellate(
        &blob().unwrap(),
        2,
        NormalMode::Exact,
        &caoen::Limits::default(),
    )
    .unwrap();
    mesh.triangles.pop();
    assert_ne!(mesh.euler_characteristic(), 2);
    assert!(!mesh.is_closed_and_consistent());
    let r = std::panic::catch_unwind(|| {
        let mut m = tessellate(
            &blob().unwrap(),
            1,
            NormalMode::Exact,
            &caoen::Limits::default(),
        )
        .unwrap();
        m.triangles[0][1] = m.triangles[0][0];
        assert_no_degenerate(&m, "broken");
    });
    assert!(r.is_err());
}

// ---- a strict OBJ reader (Wavefront OBJ spec: v, vt, vn, f, mtllib, usemtl, o, g, s) ----

/// One face corner: vertex, texture-coordinate and normal indices (0-based).
type Corner = (usize, Option<usize>, Option<usize>);

#[derive(Debug, Default)]
struct Obj {
    v: Vec<[f64; 3]>,
    vt: Vec<[f64; 2]>,
    vn: Vec<[f64; 3]>,
    faces: Vec<[Corner; 3]>,
    mtllib: Vec<String>,
    usemtl: Vec<String>,
}

fn parse_floats(args: &[&str], min: usize, max: usize, line: usize) -> Result<Vec<f64>, String> {
    if args.len() < min || args.len() > max {
        return Err(format!(
            "line {line}: expected {min}..={max} numbers, got {}",
            args.len()
        ));
    }
    args.iter()
        .map(|a| {
            let v: f64 = a
                .parse()
                .map_err(|_| format!("line {line}: `{a}` is not a number"))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!("line {line}: non-finite `{a}`"))
            }
        })
        .collect()
}

/// Resolves a 1-based (or negative, relative) OBJ index against `count` elements so far.
fn obj_index(s: &str, count: usize, line: usize) -> Result<usize, String> {
    let i: i64 = s
        .parse()
        .map_err(|_| format!("line {line}: bad index `{s}`"))?;
    let r = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        -1
    };
    if r < 0 || r as usize >= count {
        return Err(format!(
            "line {line}: index {i} out of range (have {count})"
        ));
    }
    Ok(r as usize)
}

fn read_obj(text: &str) -> Result<Obj, String> {
    let mut o = Obj::default();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let mut it = content.split_whitespace();
        let kw = it.next().unwrap();
        let args: Vec<&str> = it.collect();
        match kw {
            "v" => {
                let f = parse_floats(&args, 3, 4, line)?;
                o.v.push([f[0], f[1], f[2]]);
            }
            "vt" => {
                let f = parse_floats(&args, 1, 3, line)?;
                o.vt.push([f[0], *f.get(1).unwrap_or(&0.0)]);
            }
            "vn" => {
                let f = parse_floats(&args, 3, 3, line)?;
                o.vn.push([f[0], f[1], f[2]]);
            }
            "f" => {
                if args.len() != 3 {
                    return Err(format!(
                        "line {line}: expected a triangle, got {} corners",
                        args.len()
                    ));
                }
                let mut corners = [(0, None, None); 3];
                let mut shape = None;
                for (k, a) in args.iter().enumerate() {
                    let parts: Vec<&str> = a.split('/').collect();
                    if parts.is_empty() || parts.len() > 3 {
                        return Err(format!("line {line}: bad corner `{a}`"));
                    }
                    let form = (parts.len(), parts.get(1).is_some_and(|s| !s.is_empty()));
                    // All corners of a face must use the same v/vt/vn form.
                    if *shape.get_or_insert(form) != form {
                        return Err(format!("line {line}: mixed corner forms"));
                    }
                    let v = obj_index(parts[0], o.v.len(), line)?;
                    let vt = match parts.get(1) {
                        Some(s) if !s.is_empty() => Some(obj_index(s, o.vt.len(), line)?),
                        _ => None,
                    };
                    let vn = match parts.get(2) {
                        Some(s) => Some(obj_index(s, o.vn.len(), line)?),
                        None => None,
                    };
                    corners[k] = (v, vt, vn);
                }
                o.faces.push(corners);
            }
            "mtllib" if !args.is_empty() => o.mtllib.extend(args.iter().map(|s| s.to_string())),
            "usemtl" if args.len() == 1 => o.usemtl.push(args[0].to_string()),
            "o" | "g" | "s" => {}
            other => {
                return Err(format!(
                    "line {line}: unknown or malformed statement `{other}`"
                ))
            }
        }
    }
    Ok(o)
}

// ---- a strict binary PLY reader (PLY spec: header, elements, scalar and list properties) ----

#[derive(Debug, Clone)]
enum PlyProp {
    Scalar(String, String),
    List(String, String, String),
}

#[derive(Debug)]
struct PlyElement {
    name: String,
    count: usize,
    props: Vec<PlyProp>,
    rows: Vec<Vec<Vec<f64>>>,
}

fn ply_size(t: &str) -> Result<usize, String> {
    Ok(match t {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return Err(format!("unknown PLY type `{t}`")),
    })
}

fn ply_read(t: &str, b: &[u8]) -> f64 {
    match t {
        "char" | "int8" => b[0] as i8 as f64,
        "uchar" | "uint8" => b[0] as f64,
        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
        "int" | "int32" => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "uint" | "uint32" => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "float" | "float32" => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        _ => f64::from_le_bytes(b[..8].try_into().unwrap()),
    }
}

fn read_ply(bytes: &[u8]) -> Result<Vec<PlyElement>, String> {
    let end = b"end_header\n";
    let hdr_len = bytes
        .windows(end.len())
        .position(|w| w == end)
        .ok_or("no end_header")?
        + end.len();
    let header = std::str::from_utf8(&bytes[..hdr_len]).map_err(|_| "header is not ASCII")?;
    let mut lines = header.lines();
    if lines.next() != Some("ply") {
        return Err("missing magic `ply`".into());
    }
    if lines.next() != Some("format binary_little_endian 1.0") {
        return Err("expected format binary_little_endian 1.0".into());
    }
    let mut elements: Vec<PlyElement> = Vec::new();
    for l in lines {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            ["comment", ..] | ["obj_info", ..] => {}
            ["element", name, count] => elements.push(PlyElement {
                name: name.to_string(),
                count: count.parse().map_err(|_| format!("bad count in `{l}`"))?,
                props: Vec::new(),
                rows: Vec::new(),
            }),
            ["property", "list", ct, it, name] => {
                ply_size(ct)?;
                ply_size(it)?;
                elements
                    .last_mut()
                    .ok_or("property before element")?
                    .props
                    .push(PlyProp::List(
                        ct.to_string(),
                        it.to_string(),
                        name.to_string(),
                    ));
            }
            ["property", t, name] => {
                ply_size(t)?;
                elements
                    .last_mut()
                    .ok_or("property before element")?
                    .props
                    .push(PlyProp::Scalar(t.to_string(), name.to_string()));
            }
            ["end_header"] => {}
            _ => return Err(format!("bad header line `{l}`")),
        }
    }
    let mut pos = hdr_len;
    for e in &mut elements {
        for _ in 0..e.count {
            let mut row = Vec::new();
            for p in &e.props {
                match p {
                    PlyProp::Scalar(t, _) => {
                        let s = ply_size(t)?;
                        let b = bytes.get(pos..pos + s).ok_or("truncated body")?;
                        row.push(vec![ply_read(t, b)]);
                        pos += s;
                    }
                    PlyProp::List(ct, it, _) => {
                        let s = ply_size(ct)?;
                        let n =
                            ply_read(ct, bytes.get(pos..pos + s).ok_or("truncated body")?) as usize;
                        pos += s;
                        let is = ply_size(it)?;
                        let mut vals = Vec::with_capacity(n);
                        for _ in 0..n {
                            vals.push(ply_read(
                                it,
                                bytes.get(pos..pos + is).ok_or("truncated body")?,
                            ));
                            pos += is;
                        }
                        row.push(vals);
                    }
                }
            }
            e.rows.push(row);
        }
    }
    if pos != bytes.len() {
        return Err(format!(
            "{} trailing bytes after the last element",
            bytes.len() - pos
        ));
    }
    Ok(elements)
}

#[test]
fn obj_files_reread_strictly_with_the_same_mesh() {
    for m in [blob().unwrap(), ring().unwrap()] {
        let mesh = tessellate(&m, 3, NormalMode::Exact, &caoen::Limits::default()).unwrap();
        let mut bytes = Vec::new();
        write_obj(&mesh, &mut bytes, Some(("x.mtl", "mat"))).unwrap();
        let obj = read_obj(std::str::from_utf8(&bytes).unwrap()).unwrap();
        assert_eq!(obj.v.len(), mesh.positions.len(), "{}", m.name);
        assert_eq!(obj.vn.len(), mesh.normals.len());
        assert_eq!(obj.faces.len(), mesh.triangles.len());
        assert_eq!(obj.mtllib, vec!["x.mtl".to_string()]);
        assert_eq!(obj.usemtl, vec!["mat".to_string()]);
        for (a, b) in obj.v.iter().zip(&mesh.positions) {
            assert!((0..3).all(|k| (a[k] - b[k]).abs() <= 1e-12 * (1.0 + b[k].abs())));
        }
        for (f, t) in obj.faces.iter().zip(&mesh.triangles) {
            for k in 0..3 {
                assert_eq!(f[k].0, t[k] as usize);
                let vt = obj.vt[f[k].1.expect("texture coordinates present")];
                assert!(vt.iter().all(|v| v.is_finite()));
                assert!(f[k].2.is_some());
            }
        }
        // Shared vertices: every vertex is used, so the mesh is one connected surface file.
        let mut used = vec![false; obj.v.len()];
        obj.faces.iter().flatten().for_each(|c| used[c.0] = true);
        assert!(used.iter().all(|u| *u));
    }
}

#[test]
fn the_obj_reader_rejects_malformed_files() {
    for bad in [
        "v 1 2\n",
        "v 0 0 0\nf 1 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n",
        "bogus 1\n",
        "v 0 0 nan\n",
    ] {
        assert!(read_obj(bad).is_err(), "accepted {bad:?}");
    }
    assert!(read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
}

#[test]
fn ply_files_reread_strictly_with_the_same_mesh() {
    for m in [blob().unwrap(), ring().unwrap()] {
        let mesh = tessellate(&m, 3, NormalMode::Interpolated, &caoen::Limits::default()).unwrap();
        let mut bytes = Vec::new();
        write_ply(&mesh, &mut bytes).unwrap();
        let els = read_ply(&bytes).unwrap();
        let by_name: HashMap<&str, &PlyElement> =
            els.iter().map(|e| (e.name.as_str(), e)).collect();
        let v = by_name["vertex"];
        let f = by_name["face"];
        assert_eq!(v.count, mesh.positions.len(), "{}", m.name);
        assert_eq!(f.count, mesh.triangles.len());
        let names: Vec<String> = v
            .props
            .iter()
            .map(|p| match p {
                PlyProp::Scalar(_, n) => n.clone(),
                PlyProp::List(_, _, n) => n.clone(),
            })
            .collect();
        assert_eq!(&names[..3], ["x", "y", "z"]);
        for (row, p) in v.rows.iter().zip(&mesh.positions) {
            for k in 0..3 {
                assert!((row[k][0] - p[k]).abs() <= 1e-6 * (1.0 + p[k].abs()));
            }
        }
        for (row, t) in f.rows.iter().zip(&mesh.triangles) {
            let idx: Vec<u32> = row[0].iter().map(|v| *v as u32).collect();
            assert_eq!(idx, t.to_vec());
        }
    }
    // Strictness: truncation and trailing bytes are errors.
    let mesh = tessellate(
        &blob().unwrap(),
        1,
        NormalMode::Exact,
        &caoen::Limits::default(),
    )
    .unwrap();
    let mut bytes = Vec::new();
    write_ply(&mesh, &mut bytes).unwrap();
    assert!(read_ply(&bytes[..bytes.len() - 1]).is_err());
    let mut extra = bytes.clone();
    extra.push(0);
    assert!(read_ply(&extra).is_err());
}

#[test]
fn cli_mesh_writes_obj_with_material_and_texture() {
    let dir = common::kept_dir("render-mesh");
    let obj = dir.join("tex.obj");
    caoen_ok(&[
        "--quiet",
        "surface",
        "mesh",
        "examples/textured-blob.json",
        "--detail",
        "3",
        "-o",
        s(&obj),
    ]);
    let text = std::fs::read_to_string(&obj).unwrap();
    let parsed = read_obj(&text).unwrap();
    assert_eq!(parsed.v.len(), 10 * 4usize.pow(3) + 2);
    assert_eq!(parsed.mtllib, vec!["tex.mtl".to_string()]);
    let mtl = std::fs::read_to_string(dir.join("tex.mtl")).unwrap();
    assert!(
        mtl.lines().any(|l| l.trim() == "map_Kd tex-texture.png"),
        "{mtl}"
    );
    assert!(mtl
        .lines()
        .any(|l| l.trim() == format!("newmtl {}", parsed.usemtl[0])));
    let png = image::open(dir.join("tex-texture.png")).unwrap();
    assert_eq!((png.width(), png.height()), (256, 128));
    std::fs::remove_dir_all(&dir).ok();
}
