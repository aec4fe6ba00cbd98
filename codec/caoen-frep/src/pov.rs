//! POV-Ray export of F-rep models: every node becomes a declared POV-Ray function of
//! `(x, y, z)` in caoen's coordinates, and `max_gradient` is measured near the
//! surface. caoen is right-handed with z up, POV-Ray left-handed with y up: swapping y
//! and z maps one onto the other without mirroring the picture, so every exported
//! vector swaps its last two components (the scene's isosurface calls the model as
//! `f(x, z, y)`; `render::pov`).

use std::fmt::Write as _;

use super::deform::Warp;
use super::height_map::{Base, HeightMap, Interp};
use super::interval::Aabb;
use super::node::{Node, Support};
use super::polygon_patch::{PolygonSupport, Surface};
use super::primitive::Primitive;
use super::rfunction::SetOp;

/// A vector in POV-Ray's axes.
pub fn v3(p: [f64; 3]) -> String {
    format!("<{}, {}, {}>", num(p[0]), num(p[2]), num(p[1]))
}

/// A number POV-Ray reads back exactly (shortest round-trip form; exponents as `e`).
pub fn num(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains("inf") || s.contains("NaN") {
        // Validated models never hold these; a finite stand-in keeps the file parseable.
        return "0".into();
    }
    s
}

/// Declares the functions of `node` and its operands; returns the name of its own.
pub fn declare(node: &Node, out: &mut String, next: &mut usize) -> String {
    let name = format!("caoen_f{}", *next);
    *next += 1;
    let q = |c: &[f64; 3]| {
        (
            format!("(x - {})", num(c[0])),
            format!("(y - {})", num(c[1])),
            format!("(z - {})", num(c[2])),
        )
    };
    let body = match node {
        Node::Surface(_) => unreachable!("refused by unexportable"),
        Node::HeightMap(m) => {
            let (h, base) = picture(m, out, next);
            format!("{base} + {h}")
        }
        Node::Pattern { map, level } => {
            let (h, _) = picture(map, out, next);
            format!("{h} - {}", num(*level))
        }
        Node::Relief(r) => {
            let (map, depth, ramp) = (&r.map, &r.depth, &r.ramp);
            let f = declare(&r.base, out, next);
            let (h, _) = picture(map, out, next);
            // The pushed height as its own function: the warp reads it up to three times.
            let push = format!("caoen_push{}", *next);
            *next += 1;
            let _ = writeln!(
                out,
                "#declare {push} = function(x, y, z) {{ {} * {h} }}",
                num(*depth)
            );
            match map.parts().0 {
                Base::Plane => {
                    // The column stretch of `relief_warp`: z0 + (z - z0) H / (H + push).
                    let (z0, span) = (num(ramp[0]), num(ramp[1] - ramp[0]));
                    format!(
                        "{f}(x, y, {z0} + (z - {z0}) * {span} / max({span} + {push}(x, y, z), 1e-300))"
                    )
                }
                Base::Cylinder(_) => {
                    let c = "(1 - {push}(x, y, z) / max(sqrt(x*x + y*y), 1e-300))"
                        .replace("{push}", &push);
                    format!("{f}(x * {c}, y * {c}, z)")
                }
                Base::Ellipsoid(_) => {
                    let c = "(1 - {push}(x, y, z) / max(sqrt(x*x + y*y + z*z), 1e-300))"
                        .replace("{push}", &push);
                    format!("{f}(x * {c}, y * {c}, z * {c})")
                }
            }
        }
        Node::Primitive(p) => match p {
            Primitive::Sphere { centre, radius } => {
                let (x, y, z) = q(centre);
                format!("{} - ({x}*{x} + {y}*{y} + {z}*{z})", num(radius * radius))
            }
            Primitive::Box { centre, half } => {
                let (x, y, z) = q(centre);
                format!(
                    "min({} - {x}*{x}, {} - {y}*{y}, {} - {z}*{z})",
                    num(half[0] * half[0]),
                    num(half[1] * half[1]),
                    num(half[2] * half[2])
                )
            }
            Primitive::Cylinder {
                centre,
                radius,
                length,
            } => {
                let (x, y, z) = q(centre);
                format!(
                    "min({} - {x}*{x} - {y}*{y}, {} - {z}*{z})",
                    num(radius * radius),
                    num(0.25 * length * length)
                )
            }
            Primitive::Cone {
                centre,
                radius,
                length,
            } => {
                let (x, y, z) = q(centre);
                let s = format!("({} * (1 - {z} / {}))", num(*radius), num(*length));
                format!(
                    "min({s}*{s} - {x}*{x} - {y}*{y}, {z} * ({} - {z}))",
                    num(*length)
                )
            }
            Primitive::Torus {
                centre,
                major,
                minor,
            } => {
                let (x, y, z) = q(centre);
                let d = format!("(sqrt({x}*{x} + {y}*{y}) - {})", num(*major));
                format!("{} - {d}*{d} - {z}*{z}", num(minor * minor))
            }
            Primitive::HalfSpace { point, normal } => format!(
                "{} * ({} - x) + {} * ({} - y) + {} * ({} - z)",
                num(normal[0]),
                num(point[0]),
                num(normal[1]),
                num(point[1]),
                num(normal[2]),
                num(point[2])
            ),
            Primitive::Quadric { coefficients: c } => quadric(c),
            Primitive::CaoEn(c) => {
                use caoen_base::blend::COMPACT_SUPPORT_U;
                use caoen_surface::Blend;
                let t = c.tracer();
                let (x, y, z) = q(&t.centre());
                let terms: Vec<String> = t
                    .terms()
                    .map(|(w, qq, b)| {
                        let s = format!(
                            "({}*{x} + {}*{y} + {}*{z})",
                            num(w[0]),
                            num(w[1]),
                            num(w[2])
                        );
                        match b {
                            Blend::Exponential => format!("exp({} * ({s} - 1))", num(qq)),
                            Blend::Power => format!("pow(max({s}, 0), {})", num(qq)),
                            Blend::Compact => format!(
                                "pow(max(1 - {} * (1 - {s}) / {}, 0), 3)",
                                num(qq),
                                num(COMPACT_SUPPORT_U)
                            ),
                        }
                    })
                    .collect();
                format!(
                    "ln({} / max({}, 1e-300))",
                    num(t.level()),
                    terms.join(" + ")
                )
            }
            Primitive::Superellipsoid {
                centre,
                radii,
                exponents: [e1, e2],
            } => {
                let (x, y, z) = q(centre);
                let p = |t: &str, r: f64, e: f64| format!("pow(abs({t} / {}), {})", num(r), num(e));
                format!(
                    "1 - (pow({} + {}, {}) + {})",
                    p(&x, radii[0], 2.0 / e2),
                    p(&y, radii[1], 2.0 / e2),
                    num(e2 / e1),
                    p(&z, radii[2], 2.0 / e1)
                )
            }
        },
        Node::SetOp { op, a, operands } => {
            let names: Vec<String> = operands.iter().map(|n| declare(n, out, next)).collect();
            // The left fold f(f(f(f0, f1), f2), f3) written front to back: every opening
            // first, then each operand with its closing (linear in the operands).
            let (r_function, sign) = match op {
                SetOp::Union => ("caoen_union(", ""),
                SetOp::Intersection => ("caoen_intersection(", ""),
                SetOp::Difference => ("caoen_intersection(", "-"),
            };
            let a = num(*a);
            let mut acc = r_function.repeat(names.len() - 1);
            let _ = write!(acc, "{}(x, y, z)", names[0]);
            for n in &names[1..] {
                let _ = write!(acc, ", {sign}{n}(x, y, z), {a})");
            }
            acc
        }
        Node::Blend(b) => {
            let f1 = declare(&b.operands[0], out, next);
            let f2 = declare(&b.operands[1], out, next);
            let (r_function, minus) = match b.op {
                SetOp::Union => ("caoen_blend_union", ""),
                SetOp::Intersection => ("caoen_blend_intersection", ""),
                SetOp::Difference => ("caoen_blend_intersection", "0 - "),
            };
            format!(
                "{r_function}({f1}(x, y, z), {minus}{f2}(x, y, z), {}, {}, {}, {})",
                num(b.a),
                num(b.shape.a0),
                num(b.shape.a1),
                num(b.shape.a2)
            )
        }
        Node::Offset { by, operand } => {
            let f = declare(operand, out, next);
            format!("{f}(x, y, z) + {}", num(*by))
        }
        Node::Shell { thickness, operand } => {
            let f = declare(operand, out, next);
            format!("min({f}(x, y, z), {} - {f}(x, y, z))", num(*thickness))
        }
        Node::Negate(n) => {
            let f = declare(n, out, next);
            // POV-Ray does not parse a function body that starts with a minus sign.
            format!("0 - {f}(x, y, z)")
        }
        Node::Noise { noise, operand } => {
            let f = declare(operand, out, next);
            let k = num(1.0 / noise.scale);
            format!(
                "{f}(x, y, z) + {} * caoen_noise(x * {k}, y * {k}, z * {k}, {})",
                num(noise.amplitude),
                noise.seed
            )
        }
        Node::Warp { warp, operand } => {
            let f = declare(operand, out, next);
            match *warp {
                Warp::Twist { rate } => {
                    let a = format!("({} * z)", num(rate));
                    format!("{f}(x * cos({a}) + y * sin({a}), y * cos({a}) - x * sin({a}), z)")
                }
                Warp::Taper { z, scale } => {
                    let t = format!("min(max((z - {}) / {}, 0), 1)", num(z[0]), num(z[1] - z[0]));
                    let s = format!("({} + {t} * {})", num(scale[0]), num(scale[1] - scale[0]));
                    format!("{f}(x / {s}, y / {s}, z)")
                }
                Warp::Bend { radius } => {
                    let r = num(radius);
                    format!(
                        "{f}({r} * atan2(x, {r} - z), y, {r} - sqrt(x * x + ({r} - z) * ({r} - z)))"
                    )
                }
            }
        }
        Node::Perturb(pt) => {
            let (f, power) = (declare(&pt.base, out, next), pt.power);
            let mut expr = format!("{f}(x, y, z)");
            for t in &pt.terms {
                let c = match &t.support {
                    Support::Polygon(s) => {
                        let q = polygon_support(s);
                        let _ = write!(expr, " + {} * pow(max({q}, 0), {power})", num(t.factor));
                        continue;
                    }
                    Support::Quadric(Primitive::Quadric { coefficients: c }) => c,
                    Support::Quadric(_) => unreachable!("quadric patches are quadrics"),
                };
                let q = quadric(c);
                let _ = write!(expr, " + {} * pow(max(({q}), 0), {power})", num(t.factor));
            }
            expr
        }
        Node::Transform {
            inverse, operand, ..
        } => {
            let f = declare(operand, out, next);
            let row = |i: usize| {
                format!(
                    "{}*x + {}*y + {}*z + {}",
                    num(inverse.m[i][0]),
                    num(inverse.m[i][1]),
                    num(inverse.m[i][2]),
                    num(inverse.t[i])
                )
            };
            format!("{f}({}, {}, {})", row(0), row(1), row(2))
        }
    };
    let _ = writeln!(out, "#declare {name} = function(x, y, z) {{ {body} }}");
    name
}

/// The expression of the quadric with coefficients `c`, one term per monomial.
fn quadric(c: &[f64; 10]) -> String {
    const MONOMIALS: [&str; 10] = [
        "*x*x", "*y*y", "*z*z", "*x*y", "*y*z", "*x*z", "*x", "*y", "*z", "",
    ];
    let terms: Vec<String> = c
        .iter()
        .zip(MONOMIALS)
        .map(|(k, m)| format!("{}{m}", num(*k)))
        .collect();
    terms.join(" + ")
}

/// The expression of the signed distance (times `|n|`) from the plane through `p`
/// with normal `n`.
fn plane(n: [f64; 3], p: [f64; 3]) -> String {
    let terms: Vec<String> = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(k, a)| format!("{} * ({a} - {})", num(n[k]), num(p[k])))
        .collect();
    format!("({})", terms.join(" + "))
}

/// The expression of a polygon patch's `Q`: the band across its plane or sphere
/// intersected with each edge's half-space by the `a = 0` R-function.
fn polygon_support(s: &PolygonSupport) -> String {
    let (surface, vertices, depth) = s.parts();
    let across = match surface {
        Surface::Plane { normal: n } => plane(n, vertices[0]),
        Surface::Sphere { centre: c, radius } => format!(
            "(sqrt((x - {0})*(x - {0}) + (y - {1})*(y - {1}) + (z - {2})*(z - {2})) - {3})",
            num(c[0]),
            num(c[1]),
            num(c[2]),
            num(radius)
        ),
    };
    let mut q = format!(
        "(({} - {across}*{across}) / {})",
        num(depth * depth),
        num(2.0 * depth)
    );
    for (n, p) in s.edge_planes() {
        q = format!("caoen_intersection({q}, {}, 0)", plane(*n, *p));
    }
    q
}

/// Declares a picture's image as a pigment function and returns the expression of its
/// thresholded height at `(x, y, z)` (caoen's axes) and of its base solid. The image is
/// read by POV-Ray itself (`interpolate 2` bilinear or `interpolate 3` Catmull-Rom,
/// raw grey levels with `gamma 1`). caoen's samples sit on the rectangle's corners,
/// POV-Ray's at pixel centres: the coordinates are mapped so the samples coincide.
fn picture(m: &HeightMap, out: &mut String, next: &mut usize) -> (String, String) {
    let name = format!("caoen_image{}", *next);
    *next += 1;
    let (path, scale) = m.source().expect("checked by unexportable");
    let (base, [u0, v0, u1, v1], threshold, interp) = m.parts();
    let (w, h) = m.size();
    let kind = image_kind(path).expect("checked by unexportable");
    // POV-Ray 3.7's `interpolate 3` is Catmull-Rom on the same pixel grid as caoen's
    // bicubic (weights -t(1-t)^2/2, ..., edge pixels repeated), `interpolate 2` bilinear.
    let mode = match interp {
        Interp::Bilinear => 2,
        Interp::Bicubic => 3,
    };
    // A grey image has equal channels: one lookup instead of three.
    let grey_image = caoen_io::load(path).is_ok_and(|r| r.layout().colour_channels() == 1);
    // An absolute path: the scene file may be rendered from anywhere.
    let path = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let _ = writeln!(
        out,
        "#declare {name} = function {{ pigment {{ image_map {{ {kind} \"{}\" gamma 1.0 interpolate {mode} once }} }} }}",
        path.display()
    );
    let (u, v, g) = match base {
        Base::Plane => ("x".to_string(), "y".to_string(), "-z".to_string()),
        Base::Cylinder(r) => (
            "atan2(y, x)".to_string(),
            "z".to_string(),
            format!("1 - (x*x + y*y) / {}", num(r * r)),
        ),
        Base::Ellipsoid([a, b, c]) => {
            let (xx, yy, zz) = (
                format!("(x / {})", num(a)),
                format!("(y / {})", num(b)),
                format!("(z / {})", num(c)),
            );
            (
                format!("atan2({yy}, {xx})"),
                format!("atan2({zz}, sqrt({xx}*{xx} + {yy}*{yy}))"),
                format!("1 - ({xx}*{xx} + {yy}*{yy} + {zz}*{zz})"),
            )
        }
    };
    let un = format!("(({u}) - {}) / {}", num(u0), num(u1 - u0));
    let vn = format!("(({v}) - {}) / {}", num(v0), num(v1 - v0));
    // Sample i of w at u = i / (w - 1) is POV-Ray's pixel centre (i + 0.5) / w.
    let px = format!(
        "(({un}) * {} + 0.5) / {}",
        num((w - 1) as f64),
        num(w as f64)
    );
    let py = format!(
        "(({vn}) * {} + 0.5) / {}",
        num((h - 1) as f64),
        num(h as f64)
    );
    let grey = if grey_image {
        format!("{name}({px}, {py}, 0).red")
    } else {
        format!(
            "(({name}({px}, {py}, 0).red + {name}({px}, {py}, 0).green + {name}({px}, {py}, 0).blue) / 3)"
        )
    };
    let inside =
        format!("select({un}, 0, select(1 - {un}, 0, select({vn}, 0, select(1 - {vn}, 0, 1))))");
    let height = format!("({} * {grey} * {inside})", num(scale));
    let thresholded = if threshold == f64::NEG_INFINITY {
        height
    } else {
        format!("select({height} - {}, 0, {height})", num(threshold))
    };
    (format!("({thresholded})"), format!("({g})"))
}

/// The image_map file type POV-Ray reads for a file, by its extension.
fn image_kind(path: &std::path::Path) -> Option<&'static str> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some("png"),
        "jpg" | "jpeg" => Some("jpeg"),
        "gif" => Some("gif"),
        "tif" | "tiff" => Some("tiff"),
        "ppm" | "pgm" => Some("ppm"),
        _ => None,
    }
}

/// The R-functions the exported functions call (`a = 1` is max/min exactly, as
/// in caoen), and `caoen_noise(x, y, z, seed)`: the gradient noise of
/// `frep::deform::Noise` in lattice units, the same integer hash and formulas.
pub const R_FUNCTIONS: &str = "\
#declare caoen_m289 = function(a) { a - 289 * floor(a / 289) }
#declare caoen_perm = function(a) { caoen_m289((34 * a + 1) * a) }
#declare caoen_hash0 = function(a) { a - 16 * floor(a / 16) }
#declare caoen_hash = function(ci, cj, ck) { caoen_hash0(caoen_perm(caoen_m289(caoen_perm(caoen_m289(caoen_perm(caoen_m289(ci)) + cj)) + ck))) }
#declare caoen_grad = function(hh, x, y, z) { (1 - 2 * (hh - 2 * floor(hh / 2))) * select(hh - 8, x, y) + (1 - 2 * (floor(hh / 2) - 2 * floor(hh / 4))) * select(hh - 4, y, select(abs((hh - 12) * (hh - 14)) - 0.5, x, z)) }
#declare caoen_fade = function(a) { a * a * a * (a * (a * 6 - 15) + 10) }
#declare caoen_noise_cell = function(ci, cj, ck, x, y, z, wx, wy, wz) {
  (1 - wz) * ((1 - wy) * ((1 - wx) * caoen_grad(caoen_hash(ci, cj, ck), x, y, z) + wx * caoen_grad(caoen_hash(ci + 1, cj, ck), x - 1, y, z))
           + wy * ((1 - wx) * caoen_grad(caoen_hash(ci, cj + 1, ck), x, y - 1, z) + wx * caoen_grad(caoen_hash(ci + 1, cj + 1, ck), x - 1, y - 1, z)))
  + wz * ((1 - wy) * ((1 - wx) * caoen_grad(caoen_hash(ci, cj, ck + 1), x, y, z - 1) + wx * caoen_grad(caoen_hash(ci + 1, cj, ck + 1), x - 1, y, z - 1))
           + wy * ((1 - wx) * caoen_grad(caoen_hash(ci, cj + 1, ck + 1), x, y - 1, z - 1) + wx * caoen_grad(caoen_hash(ci + 1, cj + 1, ck + 1), x - 1, y - 1, z - 1))) }
#declare caoen_noise_at = function(ci, cj, ck, x, y, z) { caoen_noise_cell(ci, cj, ck, x, y, z, caoen_fade(x), caoen_fade(y), caoen_fade(z)) }
#declare caoen_noise = function(x, y, z, sd) { caoen_noise_at(floor(x) + sd, floor(y), floor(z), x - floor(x), y - floor(y), z - floor(z)) }
#declare caoen_union = function(p, q, k) { select(k - 1, (p + q + sqrt(max(0, p*p + q*q - 2*k*p*q))) / (1 + k), max(p, q)) }
#declare caoen_intersection = function(p, q, k) { select(k - 1, (p + q - sqrt(max(0, p*p + q*q - 2*k*p*q))) / (1 + k), min(p, q)) }
#declare caoen_blend_union = function(p, q, k, b0, b1, b2) { caoen_union(p, q, k) + b0 / (1 + (p/b1)*(p/b1) + (q/b2)*(q/b2)) }
#declare caoen_blend_intersection = function(p, q, k, b0, b1, b2) { caoen_intersection(p, q, k) + b0 / (1 + (p/b1)*(p/b1) + (q/b2)*(q/b2)) }
";

/// POV-Ray's `max_gradient` for `node` over `b`: the largest gradient length at 27
/// points of every cell of a `2^levels`-per-side octree (shallower for a large model,
/// see [`MAX_GRADIENT_WORK`]) that the interval bound cannot keep off the surface,
/// times 1.25 for what falls between the points. POV-Ray uses it
/// as a Lipschitz bound when it looks for the surface along a ray, so only the gradient
/// near the surface matters: a picture's `atan2` parameters make the gradient grow
/// without bound near their axis, far from any surface, and a whole-box grid either
/// samples that (a bound far too high: slow) or misses a picture's steep edges (too
/// low: holes).
pub fn max_gradient(node: &Node, b: &Aabb, levels: u32) -> f64 {
    max_gradient_with(node, b, levels, &|_, _| {})
}

/// Node evaluations (points times the model's node count) the search for the largest
/// gradient may spend: past it the octree stops short of `levels`, so a 10,000-node
/// model takes about as long as a 100-node one (its cells are coarser; the 27 points a
/// cell and the factor 1.25 cover what falls between).
pub const MAX_GRADIENT_WORK: u64 = 40_000_000;

/// [`max_gradient`], calling `progress(done, total)` as the finest cells are measured
/// (in parallel).
pub fn max_gradient_with(
    node: &Node,
    b: &Aabb,
    levels: u32,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> f64 {
    use rayon::prelude::*;
    let per_point = node.count() as u64;
    // Breadth first: each level keeps the cells the interval bound cannot keep off the
    // surface, and goes one deeper while the next level's points fit the work cap
    // (about half of a cell's eight children meet a surface).
    let mut cells = vec![*b];
    let mut level = 0;
    loop {
        cells = cells
            .into_par_iter()
            .filter(|c| node.interval(c).contains(0.0))
            .collect();
        let next = (cells.len() as u64)
            .saturating_mul(4 * 27)
            .saturating_mul(per_point);
        if level >= levels || cells.is_empty() || next > MAX_GRADIENT_WORK {
            break;
        }
        cells = cells.iter().flat_map(octants).collect();
        level += 1;
    }
    let total = cells.len() as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    let best = cells
        .par_chunks(64)
        .map(|chunk| {
            let best = chunk
                .iter()
                .map(|c| cell_gradient(node, c))
                .fold(0.0, f64::max);
            let d = done.fetch_add(chunk.len() as u64, std::sync::atomic::Ordering::Relaxed)
                + chunk.len() as u64;
            progress(d, total);
            best
        })
        .reduce(|| 0.0, f64::max);
    1.25 * best.max(1e-6)
}

/// The eight octants of `cell`.
fn octants(cell: &Aabb) -> impl Iterator<Item = Aabb> + '_ {
    let mid = [0, 1, 2].map(|k| 0.5 * (cell.lo[k] + cell.hi[k]));
    (0..8).map(move |octant| {
        let pick = |k: usize| (octant >> k) & 1 == 1;
        let lo = [0, 1, 2].map(|k| if pick(k) { mid[k] } else { cell.lo[k] });
        let hi = [0, 1, 2].map(|k| if pick(k) { cell.hi[k] } else { mid[k] });
        Aabb::new(lo, hi)
    })
}

/// The largest gradient length at 27 points of `cell` (corners, edge and face middles,
/// centre).
fn cell_gradient(node: &Node, cell: &Aabb) -> f64 {
    let mut best: f64 = 0.0;
    for i in 0..27 {
        let t = [i % 3, (i / 3) % 3, i / 9].map(|v| 0.5 * v as f64);
        let p = [0, 1, 2].map(|k| cell.lo[k] + t[k] * (cell.hi[k] - cell.lo[k]));
        let (_, g) = node.value_gradient(p);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if len.is_finite() {
            best = best.max(len);
        }
    }
    best
}

/// What in a model POV-Ray cannot draw.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unexportable {
    /// A picture that exists only in memory.
    #[error("a picture built in memory has no file for POV-Ray to read")]
    InMemoryPicture,
    /// A picture in a format POV-Ray does not read.
    #[error("POV-Ray does not read {} (PNG, JPEG, GIF, TIFF, PPM)", .0.display())]
    PictureFormat(std::path::PathBuf),
    /// The inside of a Cao En surface.
    #[error("a Cao En surface's inside (a distance to its tessellation) is not exported")]
    SurfaceInside,
}

/// Why a node cannot be exported, if it cannot: a picture POV-Ray cannot read.
pub fn unexportable(node: &Node) -> Option<Unexportable> {
    let map = |m: &HeightMap| match m.source() {
        None => Some(Unexportable::InMemoryPicture),
        Some((p, _)) if image_kind(p).is_none() => {
            Some(Unexportable::PictureFormat(p.to_path_buf()))
        }
        Some(_) => None,
    };
    match node {
        Node::HeightMap(m) | Node::Pattern { map: m, .. } => map(m),
        Node::Surface(_) => Some(Unexportable::SurfaceInside),
        Node::Relief(r) => map(&r.map).or_else(|| unexportable(&r.base)),
        Node::Primitive(_) => None,
        Node::SetOp { operands, .. } => operands.iter().find_map(unexportable),
        Node::Blend(b) => b.operands.iter().find_map(unexportable),
        Node::Perturb(pt) => unexportable(&pt.base),
        Node::Offset { operand, .. }
        | Node::Shell { operand, .. }
        | Node::Transform { operand, .. }
        | Node::Warp { operand, .. }
        | Node::Noise { operand, .. } => unexportable(operand),
        Node::Negate(n) => unexportable(n),
    }
}
