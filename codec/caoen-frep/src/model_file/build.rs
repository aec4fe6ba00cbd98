//! From a model as written to the model tree: the node and patch counts checked over the
//! whole tree first, then each node's numbers checked against their ranges and its
//! assets loaded as it is built.

use std::path::Path;

use super::form::{FileKind, FileNode, FilePatch, Unary};
use super::values::{Int, Num, Numbers, Scale};
use super::{
    bad, err, number, numbers, MAX_SEED, MAX_TWIST_DEG, MIN_BEND_RADIUS, MIN_NOISE_SCALE, MIN_TAPER,
};
use crate::assets::{self, Picture};
use crate::deform::{Noise, Warp};
use crate::height_map::Base;
use crate::node::{
    bump_quadric, Blended, Node, Patch, Relief, Support, MAX_NODES, MIN_FLOOR, MIN_LENGTH,
    WORLD_LIMIT,
};
use crate::polygon_patch::PolygonSupport;
use crate::primitive::{CaoEnSolid, Primitive};
use crate::rfunction::BlendShape;
use caoen_geometry::transform::Affine;
use caoen_surface::json::FieldError;

/// `v`, or the error that `key` is missing beside the node at `path`.
fn need<T: Clone>(v: &Option<T>, path: &str, key: &str) -> Result<T, FieldError> {
    v.clone()
        .ok_or_else(|| bad(path, format!("missing field `{key}`")))
}

impl FileNode {
    /// Checks the node at `path` and those below it against the model's counts: an
    /// operation's operands, a perturbation's patches, and `count`, the nodes so far
    /// (patches count as nodes).
    pub(super) fn check_limits(&self, path: &str, count: &mut usize) -> Result<(), FieldError> {
        *count += 1;
        if *count > MAX_NODES {
            return err(path, format!("the model has more than {MAX_NODES} nodes"));
        }
        let here = format!("{path}.{}", self.kind.name());
        match &self.kind {
            FileKind::SetOp(_, operands) | FileKind::Blend(_, operands) => {
                let max = match self.kind {
                    FileKind::Blend(..) => 2,
                    _ => MAX_NODES,
                };
                if !(2..=max).contains(&operands.len()) {
                    return err(
                        &here,
                        format!("has {} operands; expected 2 to {max}", operands.len()),
                    );
                }
                for (i, n) in operands.iter().enumerate() {
                    n.check_limits(&format!("{here}[{i}]"), count)?;
                }
            }
            FileKind::Unary(u, operand) => {
                if *u == Unary::Perturb {
                    let Some(list) = &self.params.patches else {
                        return err(path, "`perturb` needs `patches`: a list of patches");
                    };
                    if list.is_empty() || list.len() > MAX_NODES {
                        return err(
                            &format!("{path}.patches"),
                            format!("{} patches: expected 1 to {MAX_NODES}", list.len()),
                        );
                    }
                    *count += list.len();
                    if *count > MAX_NODES {
                        return err(path, format!("the model has more than {MAX_NODES} nodes"));
                    }
                }
                operand.check_limits(&here, count)?;
            }
            _ => {}
        }
        Ok(())
    }

    /// The node at `path`, its numbers checked and its files (relative to `base_dir`)
    /// loaded.
    pub(super) fn build(
        &self,
        path: &str,
        base_dir: &Path,
        limits: &caoen_base::budget::Limits,
    ) -> Result<Node, FieldError> {
        let here = format!("{path}.{}", self.kind.name());
        let w = WORLD_LIMIT;
        let length = |x: Num, at: &str| number(x, &format!("{here}.{at}"), MIN_LENGTH, w);
        let centre = |c: Numbers<3>| numbers(c, &format!("{here}.centre"), -w, w);
        let prim = match &self.kind {
            FileKind::HeightMap(h) => {
                return assets::height_map(h, &here, base_dir, limits).map(Node::HeightMap)
            }
            FileKind::CaoenSurface(s) => return assets::surface_field(s, &here, base_dir, limits),
            FileKind::CaoEnSolid(s) => Primitive::CaoEn(CaoEnSolid::new(&s.resolve(&here)?)),
            FileKind::Sphere(s) => Primitive::Sphere {
                centre: centre(s.centre)?,
                radius: length(s.radius, "radius")?,
            },
            FileKind::Box(b) => {
                let size = numbers(b.size, &format!("{here}.size"), MIN_LENGTH, w)?;
                Primitive::Box {
                    centre: centre(b.centre)?,
                    half: size.map(|s| 0.5 * s),
                }
            }
            FileKind::Cylinder(c) => Primitive::Cylinder {
                centre: centre(c.centre)?,
                radius: length(c.radius, "radius")?,
                length: length(c.length, "length")?,
            },
            FileKind::Cone(c) => Primitive::Cone {
                centre: centre(c.centre)?,
                radius: length(c.radius, "radius")?,
                length: length(c.length, "length")?,
            },
            FileKind::Torus(t) => Primitive::Torus {
                centre: centre(t.centre)?,
                major: length(t.major, "major")?,
                minor: length(t.minor, "minor")?,
            },
            FileKind::HalfSpace(h) => {
                let point = numbers(h.point, &format!("{here}.point"), -w, w)?;
                let n = numbers(h.normal, &format!("{here}.normal"), -w, w)?;
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if len < MIN_LENGTH {
                    return err(&format!("{here}.normal"), "must not be zero");
                }
                Primitive::HalfSpace {
                    point,
                    normal: n.map(|v| v / len),
                }
            }
            FileKind::Quadric(c) => {
                let c = numbers(*c, &here, -w, w)?;
                if c.iter().all(|v| *v == 0.0) {
                    return err(&here, "all coefficients are zero");
                }
                Primitive::Quadric { coefficients: c }
            }
            FileKind::Superellipsoid(s) => Primitive::Superellipsoid {
                exponents: numbers(s.exponents, &format!("{here}.exponents"), 0.05, 8.0)?,
                centre: centre(s.centre)?,
                radii: numbers(s.radii, &format!("{here}.radii"), MIN_LENGTH, w)?,
            },
            FileKind::Pattern(p) => {
                let level = number(p.level, &format!("{here}.level"), -w, w)?;
                let picture = Picture {
                    image: &p.image,
                    projection: p.projection,
                    rect: p.rect.map(Into::into),
                    interp: p.interp,
                };
                let map = assets::picture(&picture, &here, base_dir, limits, None)?;
                return Ok(Node::Pattern { map, level });
            }
            FileKind::SetOp(op, operands) => {
                return Ok(Node::SetOp {
                    op: *op,
                    a: self.a(path)?,
                    operands: build_all(operands, &here, base_dir, limits)?,
                })
            }
            FileKind::Blend(op, operands) => {
                let a = self.a(path)?;
                let [x, y]: [Node; 2] = build_all(operands, &here, base_dir, limits)?
                    .try_into()
                    .expect("two operands, checked with the limits");
                let p = &self.params;
                let field = |v: &Option<Num>, name: &str, lo: f64| {
                    number(need(v, path, name)?, &format!("{path}.{name}"), lo, w)
                };
                return Ok(Node::Blend(Blended {
                    op: *op,
                    a,
                    shape: BlendShape {
                        a0: field(&p.a0, "a0", -w)?,
                        a1: field(&p.a1, "a1", MIN_LENGTH)?,
                        a2: field(&p.a2, "a2", MIN_LENGTH)?,
                    },
                    operands: Box::new([x, y]),
                }));
            }
            FileKind::Unary(u, operand) => return self.unary(*u, operand, path, base_dir, limits),
        };
        Ok(Node::Primitive(prim))
    }

    /// A set operation's or blend's R-function parameter (default 0).
    fn a(&self, path: &str) -> Result<f64, FieldError> {
        match self.params.a {
            Some(a) => number(a, &format!("{path}.a"), 0.0, 1.0),
            None => Ok(0.0),
        }
    }

    /// An operation on one operand, its parameters beside it.
    fn unary(
        &self,
        u: Unary,
        operand: &FileNode,
        path: &str,
        base_dir: &Path,
        limits: &caoen_base::budget::Limits,
    ) -> Result<Node, FieldError> {
        let w = WORLD_LIMIT;
        let here = format!("{path}.{}", self.kind.name());
        let p = &self.params;
        let at = |key: &str| format!("{path}.{key}");
        let operand = || operand.build(&here, base_dir, limits).map(Box::new);
        Ok(match u {
            Unary::Perturb => {
                let power = match p.power {
                    None => 2,
                    Some(Int(k @ 2..=3)) => k as i32,
                    Some(Int(k)) => return err(&at("power"), format!("{k}: expected 2 or 3")),
                };
                let list = p.patches.as_deref().unwrap_or_default();
                let terms = list
                    .iter()
                    .enumerate()
                    .map(|(i, t)| t.build(&format!("{path}.patches[{i}]")))
                    .collect::<Result<Vec<_>, _>>()?;
                Node::perturb(*operand()?, terms, power)
            }
            Unary::Relief => {
                let base = *operand()?;
                let b = base
                    .bounds()
                    .ok_or_else(|| bad(&here, "the relief's base must be bounded"))?;
                let d = number(need(&p.depth, path, "depth")?, &at("depth"), -w, w)?;
                let image = need(&p.image, path, "image")?;
                let picture = Picture {
                    image: &image,
                    projection: p.projection.unwrap_or_default(),
                    rect: p.rect.map(Into::into),
                    interp: p.interp.unwrap_or_default(),
                };
                let map = assets::picture(&picture, path, base_dir, limits, Some(&b))?;
                let ramp = [b.lo[2], b.hi[2]];
                if map.parts().0 == Base::Plane {
                    // Each column is stretched by H / (H + push): a push reaching the
                    // bottom would leave no floor and fold space (W not one-to-one).
                    let h = map.interpolated_range(&b);
                    let span = ramp[1] - ramp[0];
                    let deepest = (d * h.lo).min(d * h.hi);
                    if deepest.is_nan() || span + deepest <= MIN_FLOOR * span {
                        return err(
                            &at("depth"),
                            format!(
                                "{d}: a planar relief must leave a floor: depth times the \
                                 picture's interpolated grey (from {:.4} to {:.4} here) \
                                 must stay above minus the base's height {span}",
                                h.lo, h.hi
                            ),
                        );
                    }
                }
                Node::Relief(Relief {
                    base: Box::new(base),
                    map,
                    depth: d,
                    ramp,
                })
            }
            Unary::Negate => Node::Negate(operand()?),
            Unary::Twist => {
                let deg = number(
                    need(&p.deg_per_unit, path, "deg_per_unit")?,
                    &at("deg_per_unit"),
                    -MAX_TWIST_DEG,
                    MAX_TWIST_DEG,
                )?;
                Node::Warp {
                    warp: Warp::Twist {
                        rate: deg.to_radians(),
                    },
                    operand: operand()?,
                }
            }
            Unary::Taper => {
                let z = numbers(need(&p.z, path, "z")?, &at("z"), -w, w)?;
                if z[1] - z[0] < MIN_LENGTH {
                    return err(&at("z"), "expected z0 < z1");
                }
                let scale = match &p.scale {
                    None => return err(path, "missing field `scale`"),
                    Some(Scale::List(s)) if s.len() == 2 => {
                        numbers([s[0], s[1]], &at("scale"), MIN_TAPER, 1.0 / MIN_TAPER)?
                    }
                    Some(_) => return err(&at("scale"), "expected [s0, s1]"),
                };
                Node::Warp {
                    warp: Warp::Taper { z, scale },
                    operand: operand()?,
                }
            }
            Unary::Bend => Node::Warp {
                warp: Warp::Bend {
                    radius: number(
                        need(&p.radius, path, "radius")?,
                        &at("radius"),
                        MIN_BEND_RADIUS,
                        w,
                    )?,
                },
                operand: operand()?,
            },
            Unary::Noise => {
                let seed = match p.seed {
                    None => 0,
                    Some(Int(k)) if (0..=i128::from(MAX_SEED)).contains(&k) => k as u32,
                    Some(Int(k)) => {
                        return err(
                            &at("seed"),
                            format!("{k}: expected a whole number in [0, {MAX_SEED}]"),
                        )
                    }
                };
                let amplitude = number(
                    need(&p.amplitude, path, "amplitude")?,
                    &at("amplitude"),
                    -w,
                    w,
                )?;
                let scale = match &p.scale {
                    None => return err(path, "missing field `scale`"),
                    Some(Scale::One(s)) => number(*s, &at("scale"), MIN_NOISE_SCALE, w)?,
                    Some(Scale::List(s)) => {
                        return err(
                            &at("scale"),
                            format!("expected a number, found {}", json_list(s)),
                        )
                    }
                };
                Node::Noise {
                    noise: Noise {
                        amplitude,
                        scale,
                        seed,
                    },
                    operand: operand()?,
                }
            }
            Unary::Shell => Node::Shell {
                thickness: number(
                    need(&p.thickness, path, "thickness")?,
                    &at("thickness"),
                    MIN_LENGTH,
                    w,
                )?,
                operand: operand()?,
            },
            Unary::Offset => Node::Offset {
                by: number(need(&p.by, path, "by")?, &at("by"), -w, w)?,
                operand: operand()?,
            },
            Unary::Transform => {
                let scale = match &p.scale {
                    None => [1.0; 3],
                    Some(Scale::One(s)) => [number(*s, &at("scale"), 1e-6, 1e6)?; 3],
                    Some(Scale::List(s)) if s.len() == 3 => {
                        numbers([s[0], s[1], s[2]], &at("scale"), 1e-6, 1e6)?
                    }
                    Some(_) => return err(&at("scale"), "expected three numbers [x, y, z]"),
                };
                let rot = numbers(
                    p.rotate_deg.unwrap_or_default(),
                    &at("rotate_deg"),
                    -1e4,
                    1e4,
                )?;
                let t = numbers(p.translate.unwrap_or_default(), &at("translate"), -w, w)?;
                let forward = Affine::from_parts(scale, rot, t);
                let Some(inverse) = forward.inverse() else {
                    return err(path, "the transform is singular");
                };
                Node::Transform {
                    forward,
                    inverse,
                    operand: operand()?,
                }
            }
        })
    }
}

/// The operands of the node at `here`, built in order.
fn build_all(
    operands: &[FileNode],
    here: &str,
    base_dir: &Path,
    limits: &caoen_base::budget::Limits,
) -> Result<Vec<Node>, FieldError> {
    operands
        .iter()
        .enumerate()
        .map(|(i, n)| n.build(&format!("{here}[{i}]"), base_dir, limits))
        .collect()
}

/// A list of numbers as JSON writes it, for messages.
fn json_list(v: &[f64]) -> String {
    serde_json::to_string(v).unwrap_or_default()
}

impl FilePatch {
    /// The patch at `path`: `{"quadric": [10 coefficients], "factor": f}`, a bump
    /// `{"bump": {"centre", "radius", "height"}}` (`Q = height (1 - |p - centre|^2 /
    /// radius^2)`, positive in the ball), or a `polygon` or `spherical_polygon`.
    fn build(&self, path: &str) -> Result<Patch, FieldError> {
        let w = WORLD_LIMIT;
        let factor = number(self.factor, &format!("{path}.factor"), -w, w)?;
        let support = match (
            &self.quadric,
            &self.bump,
            &self.polygon,
            &self.spherical_polygon,
        ) {
            (Some(q), None, None, None) => {
                let coefficients = numbers(*q, &format!("{path}.quadric"), -w, w)?;
                Support::Quadric(Primitive::Quadric { coefficients })
            }
            (None, Some(b), None, None) => {
                let here = format!("{path}.bump");
                let c = numbers(b.centre, &format!("{here}.centre"), -w, w)?;
                let r = number(b.radius, &format!("{here}.radius"), MIN_LENGTH, w)?;
                let h = number(b.height, &format!("{here}.height"), MIN_LENGTH, w)?;
                Support::Quadric(Primitive::Quadric {
                    coefficients: bump_quadric(c, r, h),
                })
            }
            (None, None, Some(p), None) => {
                let here = format!("{path}.polygon");
                let (vertices, depth) = polygon(&p.vertices, p.depth, &here)?;
                Support::Polygon(
                    PolygonSupport::planar(&vertices, depth)
                        .map_err(|e| bad(&here, e.to_string()))?,
                )
            }
            (None, None, None, Some(p)) => {
                let here = format!("{path}.spherical_polygon");
                let (vertices, depth) = polygon(&p.vertices, p.depth, &here)?;
                let centre = numbers(p.centre, &format!("{here}.centre"), -w, w)?;
                let radius = number(p.radius, &format!("{here}.radius"), MIN_LENGTH, w)?;
                Support::Polygon(
                    PolygonSupport::spherical(centre, radius, &vertices, depth)
                        .map_err(|e| bad(&here, e.to_string()))?,
                )
            }
            _ => {
                return err(
                    path,
                    "give exactly one of `quadric`, `bump`, `polygon`, `spherical_polygon`",
                )
            }
        };
        Ok(Patch { support, factor })
    }
}

/// A polygon patch's corners (3 or 4, each in the world) and its depth.
fn polygon(
    vertices: &[Numbers<3>],
    depth: Num,
    here: &str,
) -> Result<(Vec<[f64; 3]>, f64), FieldError> {
    let w = WORLD_LIMIT;
    let at = format!("{here}.vertices");
    if !(3..=4).contains(&vertices.len()) {
        return err(&at, "expected 3 or 4 vertices [[x, y, z], ...]");
    }
    let vertices = vertices
        .iter()
        .enumerate()
        .map(|(i, p)| numbers(*p, &format!("{at}[{i}]"), -w, w))
        .collect::<Result<Vec<_>, _>>()?;
    let depth = number(depth, &format!("{here}.depth"), MIN_LENGTH, w)?;
    Ok((vertices, depth))
}
