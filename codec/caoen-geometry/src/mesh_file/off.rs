//! OFF: read strictly, line by line (the counts checked before anything is allocated).

use caoen_base::budget::Limits;

use super::{budget, finish, MeshError, MAX_ELEMENTS};
use crate::polygon_mesh::PolygonMesh;

/// Parses an OFF file: the keyword `OFF`, the counts `vertices faces edges` (on the
/// keyword's line or the next), one line `x y z` per vertex, one line `n i_1 ... i_n`
/// per face (polygons become fans; three or four colour numbers may follow the
/// indices). `#` starts a comment. The counts are checked against the bytes that
/// follow and against the budget before anything is allocated; a line with too few or
/// too many numbers, a face naming a missing vertex and anything after the last face
/// are refused.
pub fn read_off(bytes: &[u8], name: &str, limits: &Limits) -> Result<PolygonMesh, MeshError> {
    let bad = |line: usize, what: String| MeshError::BadOff {
        path: name.into(),
        line,
        what,
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count()
            + 1;
        bad(line, "not text".into())
    })?;
    // Lines with their numbers (from 1), comments and blank lines left out.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("")))
        .filter(|(_, l)| !l.trim().is_empty());
    let (first, head) = lines.next().ok_or_else(|| bad(1, "no `OFF` line".into()))?;
    let mut words = head.split_whitespace();
    if words.next() != Some("OFF") {
        return Err(bad(
            first,
            format!("`{}`: expected `OFF`", caoen_base::printable(head.trim())),
        ));
    }
    let mut counts: Vec<&str> = words.collect();
    let mut counts_line = first;
    if counts.is_empty() {
        let (l, c) = lines.next().ok_or_else(|| bad(first, "no counts".into()))?;
        counts = c.split_whitespace().collect();
        counts_line = l;
    }
    let [v, f, _e] = counts[..] else {
        return Err(bad(
            counts_line,
            format!("{} numbers; expected vertices, faces, edges", counts.len()),
        ));
    };
    let count = |t: &str, what: &str| -> Result<u64, MeshError> {
        let n: u64 = t.parse().map_err(|_| {
            bad(
                counts_line,
                format!("{what} count `{}`", caoen_base::printable(t)),
            )
        })?;
        if n > MAX_ELEMENTS {
            return Err(MeshError::TooManyElements {
                path: name.into(),
                element: what.into(),
                declared: n,
                max: MAX_ELEMENTS,
            });
        }
        Ok(n)
    };
    let (vertices, faces) = (count(v, "vertex")?, count(f, "face")?);
    // A vertex line takes at least 6 bytes (`0 0 0\n`), a face line 8 (`3 0 1 2\n`
    // less one separator); the mesh made is at most 24 bytes a vertex and 12 a
    // triangle, with fans of a polygon as many triangles as its line has numbers.
    let body = bytes.len() as u64;
    for (element, declared, need) in [
        ("vertex", vertices, vertices.saturating_mul(6)),
        (
            "face",
            faces,
            vertices
                .saturating_mul(6)
                .saturating_add(faces.saturating_mul(7)),
        ),
    ] {
        if need > body {
            return Err(MeshError::ShortBody {
                path: name.into(),
                element: element.into(),
                declared,
                body,
            });
        }
    }
    budget(name, vertices * 24 + body * 12, limits)?;
    let mut mesh = PolygonMesh {
        positions: Vec::with_capacity(vertices as usize),
        triangles: Vec::with_capacity(faces as usize),
    };
    let mut last = counts_line;
    for index in 0..vertices {
        let (l, line) = lines.next().ok_or_else(|| {
            bad(
                last + 1,
                format!("vertex {index} missing ({vertices} declared)"),
            )
        })?;
        last = l;
        let nums: Vec<&str> = line.split_whitespace().collect();
        if nums.len() != 3 {
            return Err(bad(
                l,
                format!("vertex {index} has {} numbers; expected 3", nums.len()),
            ));
        }
        let mut p = [0.0; 3];
        for (k, t) in nums.iter().enumerate() {
            p[k] = t.parse().map_err(|_| {
                bad(
                    l,
                    format!(
                        "vertex {index}: `{}` is not a number",
                        caoen_base::printable(t)
                    ),
                )
            })?;
        }
        mesh.positions.push(p);
    }
    for face in 0..faces as usize {
        let (l, line) = lines
            .next()
            .ok_or_else(|| bad(last + 1, format!("face {face} missing ({faces} declared)")))?;
        last = l;
        let nums: Vec<&str> = line.split_whitespace().collect();
        let n: usize = nums
            .first()
            .and_then(|t| t.parse().ok())
            .filter(|n| (3..=nums.len() - 1).contains(n))
            .ok_or_else(|| {
                bad(
                    l,
                    format!(
                        "face {face}: `{}` is not a polygon of 3 or more listed vertices",
                        caoen_base::printable(line.trim())
                    ),
                )
            })?;
        let colour = nums.len() - 1 - n;
        if ![0, 3, 4].contains(&colour) {
            return Err(bad(l, format!("face {face} has {colour} numbers after its {n} indices; expected none or a colour of 3 or 4")));
        }
        let mut idx = Vec::with_capacity(n);
        for t in &nums[1..=n] {
            let i: i64 = t.parse().map_err(|_| {
                bad(
                    l,
                    format!(
                        "face {face}: `{}` is not a vertex index",
                        caoen_base::printable(t)
                    ),
                )
            })?;
            if i < 0 || i as u64 >= vertices {
                return Err(MeshError::BadIndex {
                    path: name.into(),
                    face,
                    index: i,
                    vertices: vertices as usize,
                });
            }
            idx.push(i as u32);
        }
        for k in 1..n - 1 {
            mesh.triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    if let Some((l, _)) = lines.next() {
        return Err(bad(
            l,
            format!(
                "data after the {faces} faces the header declares (a count that is too small?)"
            ),
        ));
    }
    finish(mesh, name)
}
