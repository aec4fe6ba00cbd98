//! The JSON form of F-rep models (`docs/frep.md`): each node an object named by its
//! kind, parameters checked against the model's limits, errors naming the JSON path of
//! the offending value.

use serde_json::Value;

use super::assets::{height_map, picture, surface_field};
use super::deform::{Noise, Warp};
use super::height_map::Interp;
use super::node::{
    bump_quadric, Node, Patch, Support, MAX_DEPTH, MAX_NODES, MIN_LENGTH, WORLD_LIMIT,
};
use super::polygon_patch::PolygonSupport;
use super::primitive::Primitive;
use super::rfunction::SetOp;
use caoen_geometry::transform::Affine;
use caoen_surface::json::FieldError;

/// `reason` about the value at `path`.
pub(super) fn bad(path: &str, reason: impl Into<String>) -> FieldError {
    FieldError::from_reason(path, reason)
}

pub(super) fn err<T>(path: &str, reason: impl Into<String>) -> Result<T, FieldError> {
    Err(bad(path, reason))
}

impl Node {
    /// Parses a node from its JSON form; `path` names it in errors. Image files (height
    /// maps) are relative to `base_dir`.
    pub fn from_json(
        v: &Value,
        path: &str,
        base_dir: &std::path::Path,
    ) -> Result<Node, FieldError> {
        let mut ctx = Context { count: 0, base_dir };
        // Field names and values from the file reach the messages: one printable line.
        parse(v, path, 0, &mut ctx).map_err(FieldError::printable)
    }
}

pub(super) fn number(v: &Value, path: &str, lo: f64, hi: f64) -> Result<f64, FieldError> {
    let Some(x) = v.as_f64() else {
        return err(path, format!("expected a number, found {v}"));
    };
    if !(x >= lo && x <= hi) {
        return err(
            path,
            format!("{x} is outside the allowed range [{lo}, {hi}]"),
        );
    }
    Ok(x)
}

/// `N` numbers in `lo..=hi` as a JSON list; `shape` names the list in the error.
pub(super) fn numbers<const N: usize>(
    v: &Value,
    path: &str,
    lo: f64,
    hi: f64,
    shape: &str,
) -> Result<[f64; N], FieldError> {
    let Some(a) = v.as_array().filter(|a| a.len() == N) else {
        return err(path, format!("expected {shape}"));
    };
    let mut out = [0.0; N];
    for k in 0..N {
        out[k] = number(&a[k], &format!("{path}[{k}]"), lo, hi)?;
    }
    Ok(out)
}

/// The `interp` field of a picture: bilinear (the default) or bicubic.
pub(super) fn interp_of(
    o: &serde_json::Map<String, Value>,
    here: &str,
) -> Result<Interp, FieldError> {
    match o.get("interp").map(|v| v.as_str()) {
        None | Some(Some("bilinear")) => Ok(Interp::Bilinear),
        Some(Some("bicubic")) => Ok(Interp::Bicubic),
        Some(_) => err(
            &format!("{here}.interp"),
            "expected \"bilinear\" or \"bicubic\"",
        ),
    }
}

/// The `image` field of a picture, as a file relative to `base_dir`.
pub(super) fn image_file(
    o: &serde_json::Map<String, Value>,
    here: &str,
    base_dir: &std::path::Path,
) -> Result<std::path::PathBuf, FieldError> {
    match get(o, "image", here)?.as_str() {
        Some(name) => Ok(base_dir.join(name)),
        None => err(&format!("{here}.image"), "expected a file name"),
    }
}

pub(super) fn vec3(v: &Value, path: &str, lo: f64, hi: f64) -> Result<[f64; 3], FieldError> {
    match v.as_array() {
        Some(a) if a.len() == 3 => {
            let mut out = [0.0; 3];
            for k in 0..3 {
                out[k] = number(&a[k], &format!("{path}[{k}]"), lo, hi)?;
            }
            Ok(out)
        }
        _ => err(path, "expected three numbers [x, y, z]"),
    }
}

/// The fields of a parameter object: each key once, no others than `allowed`.
pub(super) fn fields<'a>(
    v: &'a Value,
    path: &str,
    allowed: &[&str],
) -> Result<&'a serde_json::Map<String, Value>, FieldError> {
    let Some(o) = v.as_object() else {
        return err(path, "expected an object");
    };
    for k in o.keys() {
        if !allowed.contains(&k.as_str()) {
            return err(
                path,
                format!(
                    "unknown field `{k}` (expected one of: {})",
                    allowed.join(", ")
                ),
            );
        }
    }
    Ok(o)
}

pub(super) fn get<'a>(
    o: &'a serde_json::Map<String, Value>,
    key: &str,
    path: &str,
) -> Result<&'a Value, FieldError> {
    o.get(key)
        .ok_or_else(|| bad(path, format!("missing field `{key}`")))
}

const PRIMITIVES: [&str; 11] = [
    "cao_en_solid",
    "caoen_surface",
    "height_map",
    "sphere",
    "box",
    "cylinder",
    "cone",
    "torus",
    "half_space",
    "quadric",
    "superellipsoid",
];
const OPERATIONS: [&str; 17] = [
    "negate",
    "shell",
    "blend_difference",
    "twist",
    "taper",
    "bend",
    "noise",
    "pattern",
    "relief",
    "perturb",
    "union",
    "intersection",
    "difference",
    "blend_union",
    "blend_intersection",
    "offset",
    "transform",
];

/// Largest twist, in degrees per unit of z.
pub const MAX_TWIST_DEG: f64 = 1e5;
/// Smallest taper scale (the largest is its inverse).
pub const MIN_TAPER: f64 = 1e-3;
/// Smallest bend radius: the bend's gradient grows as its inverse.
pub const MIN_BEND_RADIUS: f64 = 1e-6;
/// Smallest noise scale: the noise's gradient grows as its inverse.
pub const MIN_NOISE_SCALE: f64 = 1e-6;
/// Largest noise seed.
pub const MAX_SEED: u64 = 1_000_000;

/// What parsing carries through the tree.
struct Context<'a> {
    count: usize,
    base_dir: &'a std::path::Path,
}

fn parse(v: &Value, path: &str, depth: usize, count: &mut Context<'_>) -> Result<Node, FieldError> {
    if depth > MAX_DEPTH {
        return err(path, format!("nested deeper than {MAX_DEPTH} levels"));
    }
    count.count += 1;
    if count.count > MAX_NODES {
        return err(path, format!("the model has more than {MAX_NODES} nodes"));
    }
    let Some(o) = v.as_object() else {
        return err(path, "expected a node object like {\"sphere\": {...}}");
    };
    let kind = o
        .keys()
        .find(|k| PRIMITIVES.contains(&k.as_str()) || OPERATIONS.contains(&k.as_str()))
        .ok_or_else(|| {
            bad(
                path,
                format!(
                    "no node kind; expected one of: {}, {}",
                    PRIMITIVES.join(", "),
                    OPERATIONS.join(", ")
                ),
            )
        })?
        .clone();
    let here = format!("{path}.{kind}");
    let body = &o[&kind];
    let w = WORLD_LIMIT;
    let length = |v: &Value, p: &str| number(v, p, MIN_LENGTH, w);
    if PRIMITIVES.contains(&kind.as_str()) {
        if o.len() != 1 {
            return err(
                path,
                format!("a `{kind}` node takes no fields beside `{kind}`"),
            );
        }
        let centre = |o: &serde_json::Map<String, Value>| match o.get("centre") {
            Some(c) => vec3(c, &format!("{here}.centre"), -w, w),
            None => Ok([0.0; 3]),
        };
        let prim = match kind.as_str() {
            "height_map" => return height_map(body, &here, count.base_dir).map(Node::HeightMap),
            "caoen_surface" => return surface_field(body, &here, count.base_dir),
            "cao_en_solid" => {
                let solid = super::convex_solid::convex_solid_from_json(body, &here)?;
                Primitive::CaoEn(super::primitive::CaoEnSolid::new(&solid))
            }
            "sphere" => {
                let f = fields(body, &here, &["centre", "radius"])?;
                Primitive::Sphere {
                    centre: centre(f)?,
                    radius: length(get(f, "radius", &here)?, &format!("{here}.radius"))?,
                }
            }
            "box" => {
                let f = fields(body, &here, &["centre", "size"])?;
                let size = vec3(
                    get(f, "size", &here)?,
                    &format!("{here}.size"),
                    MIN_LENGTH,
                    w,
                )?;
                Primitive::Box {
                    centre: centre(f)?,
                    half: size.map(|s| 0.5 * s),
                }
            }
            "cylinder" | "cone" => {
                let f = fields(body, &here, &["centre", "radius", "length"])?;
                let (c, r, l) = (
                    centre(f)?,
                    length(get(f, "radius", &here)?, &format!("{here}.radius"))?,
                    length(get(f, "length", &here)?, &format!("{here}.length"))?,
                );
                if kind == "cylinder" {
                    Primitive::Cylinder {
                        centre: c,
                        radius: r,
                        length: l,
                    }
                } else {
                    Primitive::Cone {
                        centre: c,
                        radius: r,
                        length: l,
                    }
                }
            }
            "torus" => {
                let f = fields(body, &here, &["centre", "major", "minor"])?;
                Primitive::Torus {
                    centre: centre(f)?,
                    major: length(get(f, "major", &here)?, &format!("{here}.major"))?,
                    minor: length(get(f, "minor", &here)?, &format!("{here}.minor"))?,
                }
            }
            "half_space" => {
                let f = fields(body, &here, &["point", "normal"])?;
                let point = match f.get("point") {
                    Some(p) => vec3(p, &format!("{here}.point"), -w, w)?,
                    None => [0.0; 3],
                };
                let n = vec3(get(f, "normal", &here)?, &format!("{here}.normal"), -w, w)?;
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if len < MIN_LENGTH {
                    return err(&format!("{here}.normal"), "must not be zero");
                }
                Primitive::HalfSpace {
                    point,
                    normal: n.map(|v| v / len),
                }
            }
            "quadric" => {
                let c: [f64; 10] = numbers(
                    body,
                    &here,
                    -w,
                    w,
                    "ten coefficients [a, b, c, d, e, f, g, h, i, j]",
                )?;
                if c.iter().all(|v| *v == 0.0) {
                    return err(&here, "all coefficients are zero");
                }
                Primitive::Quadric { coefficients: c }
            }
            _ => {
                let f = fields(body, &here, &["centre", "radii", "exponents"])?;
                let e = match f.get("exponents") {
                    Some(Value::Array(a)) if a.len() == 2 => [
                        number(&a[0], &format!("{here}.exponents[0]"), 0.05, 8.0)?,
                        number(&a[1], &format!("{here}.exponents[1]"), 0.05, 8.0)?,
                    ],
                    Some(_) => return err(&format!("{here}.exponents"), "expected [e1, e2]"),
                    None => [1.0, 1.0],
                };
                Primitive::Superellipsoid {
                    centre: centre(f)?,
                    radii: vec3(
                        get(f, "radii", &here)?,
                        &format!("{here}.radii"),
                        MIN_LENGTH,
                        w,
                    )?,
                    exponents: e,
                }
            }
        };
        return Ok(Node::Primitive(prim));
    }
    if kind == "pattern" {
        if o.len() != 1 {
            return err(path, "a `pattern` node takes no fields beside `pattern`");
        }
        let f = fields(
            body,
            &here,
            &["image", "projection", "rect", "level", "interp"],
        )?;
        let level = match f.get("level") {
            Some(l) => number(l, &format!("{here}.level"), -w, w)?,
            None => 0.5,
        };
        let map = picture(body, &here, count.base_dir, None)?;
        return Ok(Node::Pattern { map, level });
    }
    // Operations: the operands under the kind's key, parameters beside it.
    let op_fields: &[&str] = match kind.as_str() {
        "union" | "intersection" | "difference" => &["a"],
        "blend_union" | "blend_intersection" | "blend_difference" => &["a", "a0", "a1", "a2"],
        "negate" => &[],
        "twist" => &["deg_per_unit"],
        "taper" => &["z", "scale"],
        "bend" => &["radius"],
        "noise" => &["amplitude", "scale", "seed"],
        "offset" => &["by"],
        "shell" => &["thickness"],
        "perturb" => &["patches", "power"],
        "relief" => &["image", "projection", "rect", "depth", "interp"],
        _ => &["scale", "rotate_deg", "translate"],
    };
    for k in o.keys() {
        if *k != kind && !op_fields.contains(&k.as_str()) {
            return err(
                path,
                format!(
                    "unknown field `{k}` beside `{kind}` (expected: {})",
                    op_fields.join(", ")
                ),
            );
        }
    }
    let a = match o.get("a") {
        Some(v) => number(v, &format!("{path}.a"), 0.0, 1.0)?,
        None => 0.0,
    };
    let mut operands = |min: usize, max: usize| -> Result<Vec<Node>, FieldError> {
        let Some(list) = body.as_array() else {
            return err(&here, "expected a list of operand nodes");
        };
        if list.len() < min || list.len() > max {
            return err(
                &here,
                format!("has {} operands; expected {min} to {max}", list.len()),
            );
        }
        list.iter()
            .enumerate()
            .map(|(i, n)| parse(n, &format!("{here}[{i}]"), depth + 1, count))
            .collect()
    };
    Ok(match kind.as_str() {
        "union" | "intersection" | "difference" => Node::SetOp {
            op: match kind.as_str() {
                "union" => SetOp::Union,
                "intersection" => SetOp::Intersection,
                _ => SetOp::Difference,
            },
            a,
            operands: operands(2, MAX_NODES)?,
        },
        "blend_union" | "blend_intersection" | "blend_difference" => {
            let [x, y]: [Node; 2] = operands(2, 2)?.try_into().expect("two operands");
            Node::Blend {
                op: match kind.as_str() {
                    "blend_union" => SetOp::Union,
                    "blend_intersection" => SetOp::Intersection,
                    _ => SetOp::Difference,
                },
                a,
                a0: number(get(o, "a0", path)?, &format!("{path}.a0"), -w, w)?,
                a1: length(get(o, "a1", path)?, &format!("{path}.a1"))?,
                a2: length(get(o, "a2", path)?, &format!("{path}.a2"))?,
                operands: Box::new([x, y]),
            }
        }
        "perturb" => {
            let power = match o.get("power") {
                None => 2,
                Some(v) => match v.as_i64() {
                    Some(p @ 2..=3) => p as i32,
                    _ => return err(&format!("{path}.power"), format!("{v}: expected 2 or 3")),
                },
            };
            let Some(list) = o.get("patches").and_then(Value::as_array) else {
                return err(path, "`perturb` needs `patches`: a list of patches");
            };
            if list.is_empty() || list.len() > MAX_NODES {
                return err(
                    &format!("{path}.patches"),
                    format!("{} patches: expected 1 to {MAX_NODES}", list.len()),
                );
            }
            count.count += list.len();
            if count.count > MAX_NODES {
                return err(path, format!("the model has more than {MAX_NODES} nodes"));
            }
            let terms = list
                .iter()
                .enumerate()
                .map(|(i, t)| patch(t, &format!("{path}.patches[{i}]")))
                .collect::<Result<Vec<_>, _>>()?;
            Node::perturb(parse(body, &here, depth + 1, count)?, terms, power)
        }
        "relief" => {
            let base = parse(body, &here, depth + 1, count)?;
            let b = base
                .bounds()
                .ok_or_else(|| bad(&here, "the relief's base must be bounded"))?;
            let d = number(get(o, "depth", path)?, &format!("{path}.depth"), -w, w)?;
            let map = picture(&Value::Object(o.clone()), path, count.base_dir, Some(&b))?;
            let ramp = [b.lo[2], b.hi[2]];
            if map.parts().0 == super::height_map::Base::Plane {
                // The push fades in over the base's height: steeper than the height
                // allows, it would fold space over (W no longer one-to-one).
                let h = map.perturbation_range(&b);
                let most = d.abs() * h.lo.abs().max(h.hi.abs());
                if most.is_nan() || 1.5 * most >= ramp[1] - ramp[0] {
                    return err(
                        &format!("{path}.depth"),
                        format!(
                            "{d}: a planar relief's depth times the brightest grey must stay \
                             under 2/3 of the base's height {}",
                            ramp[1] - ramp[0]
                        ),
                    );
                }
            }
            Node::Relief {
                base: Box::new(base),
                map,
                depth: d,
                ramp,
            }
        }
        "negate" => Node::Negate(Box::new(parse(body, &here, depth + 1, count)?)),
        "twist" | "taper" | "bend" => {
            let warp = match kind.as_str() {
                "twist" => {
                    let deg = number(
                        get(o, "deg_per_unit", path)?,
                        &format!("{path}.deg_per_unit"),
                        -MAX_TWIST_DEG,
                        MAX_TWIST_DEG,
                    )?;
                    Warp::Twist {
                        rate: deg.to_radians(),
                    }
                }
                "taper" => {
                    let z = numbers(get(o, "z", path)?, &format!("{path}.z"), -w, w, "[z0, z1]")?;
                    if z[1] - z[0] < MIN_LENGTH {
                        return err(&format!("{path}.z"), "expected z0 < z1");
                    }
                    let scale = numbers(
                        get(o, "scale", path)?,
                        &format!("{path}.scale"),
                        MIN_TAPER,
                        1.0 / MIN_TAPER,
                        "[s0, s1]",
                    )?;
                    Warp::Taper { z, scale }
                }
                _ => Warp::Bend {
                    radius: number(
                        get(o, "radius", path)?,
                        &format!("{path}.radius"),
                        MIN_BEND_RADIUS,
                        w,
                    )?,
                },
            };
            Node::Warp {
                warp,
                operand: Box::new(parse(body, &here, depth + 1, count)?),
            }
        }
        "noise" => {
            let seed = match o.get("seed") {
                None => 0,
                Some(v) => match v.as_u64() {
                    Some(k) if k <= MAX_SEED => k as u32,
                    _ => {
                        return err(
                            &format!("{path}.seed"),
                            format!("{v}: expected a whole number in [0, {MAX_SEED}]"),
                        )
                    }
                },
            };
            Node::Noise {
                noise: Noise {
                    amplitude: number(
                        get(o, "amplitude", path)?,
                        &format!("{path}.amplitude"),
                        -w,
                        w,
                    )?,
                    scale: number(
                        get(o, "scale", path)?,
                        &format!("{path}.scale"),
                        MIN_NOISE_SCALE,
                        w,
                    )?,
                    seed,
                },
                operand: Box::new(parse(body, &here, depth + 1, count)?),
            }
        }
        "shell" => Node::Shell {
            thickness: length(get(o, "thickness", path)?, &format!("{path}.thickness"))?,
            operand: Box::new(parse(body, &here, depth + 1, count)?),
        },
        "offset" => Node::Offset {
            by: number(get(o, "by", path)?, &format!("{path}.by"), -w, w)?,
            operand: Box::new(parse(body, &here, depth + 1, count)?),
        },
        _ => {
            let scale = match o.get("scale") {
                None => [1.0; 3],
                Some(Value::Number(_)) => {
                    [number(&o["scale"], &format!("{path}.scale"), 1e-6, 1e6)?; 3]
                }
                Some(s) => vec3(s, &format!("{path}.scale"), 1e-6, 1e6)?,
            };
            let rot = match o.get("rotate_deg") {
                Some(r) => vec3(r, &format!("{path}.rotate_deg"), -1e4, 1e4)?,
                None => [0.0; 3],
            };
            let t = match o.get("translate") {
                Some(t) => vec3(t, &format!("{path}.translate"), -w, w)?,
                None => [0.0; 3],
            };
            let forward = Affine::from_parts(scale, rot, t);
            let Some(inverse) = forward.inverse() else {
                return err(path, "the transform is singular");
            };
            Node::Transform {
                forward,
                inverse,
                operand: Box::new(parse(body, &here, depth + 1, count)?),
            }
        }
    })
}

/// One patch: `{"quadric": [10 coefficients], "factor": f}`, a bump
/// `{"bump": {"centre", "radius", "height"}}` (`Q = height (1 - |p - centre|^2 / radius^2)`,
/// positive in the ball), or a `polygon` or `spherical_polygon` (`polygon_support`).
fn patch(v: &Value, path: &str) -> Result<Patch, FieldError> {
    let w = WORLD_LIMIT;
    let kinds = ["quadric", "bump", "polygon", "spherical_polygon"];
    let f = fields(v, path, &[&kinds[..], &["factor"]].concat())?;
    let factor = match f.get("factor") {
        Some(x) => number(x, &format!("{path}.factor"), -w, w)?,
        None => 1.0,
    };
    let given: Vec<&str> = kinds.into_iter().filter(|k| f.contains_key(*k)).collect();
    let [kind] = given[..] else {
        return err(
            path,
            format!("give exactly one of `{}`", kinds.join("`, `")),
        );
    };
    if kind == "polygon" || kind == "spherical_polygon" {
        let here = format!("{path}.{kind}");
        let support = polygon_support(&f[kind], &here, kind == "spherical_polygon")?;
        return Ok(Patch {
            support: Support::Polygon(support),
            factor,
        });
    }
    let coefficients = match (f.get("quadric"), f.get("bump")) {
        (Some(q), None) => numbers(q, &format!("{path}.quadric"), -w, w, "ten coefficients")?,
        (None, Some(b)) => {
            let here = format!("{path}.bump");
            let g = fields(b, &here, &["centre", "radius", "height"])?;
            let c = match g.get("centre") {
                Some(c) => vec3(c, &format!("{here}.centre"), -w, w)?,
                None => [0.0; 3],
            };
            let r = number(
                get(g, "radius", &here)?,
                &format!("{here}.radius"),
                MIN_LENGTH,
                w,
            )?;
            let h = number(
                get(g, "height", &here)?,
                &format!("{here}.height"),
                MIN_LENGTH,
                w,
            )?;
            bump_quadric(c, r, h)
        }
        _ => unreachable!("exactly one kind, checked above"),
    };
    Ok(Patch {
        support: Support::Quadric(Primitive::Quadric { coefficients }),
        factor,
    })
}

/// A polygon patch's support: `{"vertices": [[x, y, z], ...], "depth": d}` (3 or 4
/// vertices on a plane), or on a sphere with `"centre"` (default the origin) and
/// `"radius"` as well.
fn polygon_support(v: &Value, here: &str, spherical: bool) -> Result<PolygonSupport, FieldError> {
    let w = WORLD_LIMIT;
    let allowed: &[&str] = if spherical {
        &["vertices", "depth", "centre", "radius"]
    } else {
        &["vertices", "depth"]
    };
    let g = fields(v, here, allowed)?;
    let at = format!("{here}.vertices");
    let Some(list) = get(g, "vertices", here)?
        .as_array()
        .filter(|a| (3..=4).contains(&a.len()))
    else {
        return err(&at, "expected 3 or 4 vertices [[x, y, z], ...]");
    };
    let vertices = list
        .iter()
        .enumerate()
        .map(|(i, p)| vec3(p, &format!("{at}[{i}]"), -w, w))
        .collect::<Result<Vec<_>, _>>()?;
    let depth = number(
        get(g, "depth", here)?,
        &format!("{here}.depth"),
        MIN_LENGTH,
        w,
    )?;
    let made = if spherical {
        let centre = match g.get("centre") {
            Some(c) => vec3(c, &format!("{here}.centre"), -w, w)?,
            None => [0.0; 3],
        };
        let radius = number(
            get(g, "radius", here)?,
            &format!("{here}.radius"),
            MIN_LENGTH,
            w,
        )?;
        PolygonSupport::spherical(centre, radius, &vertices, depth)
    } else {
        PolygonSupport::planar(&vertices, depth)
    };
    made.map_err(|e| bad(here, e.to_string()))
}
