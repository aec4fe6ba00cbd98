//! The support of a patch over a convex triangle or quad lying on a plane or on a
//! sphere (the perturbation paper's patches over planar and spherical triangles and
//! quads): a function `Q` positive exactly over the polygon, within `depth` of its
//! plane or sphere, and negative elsewhere.
//!
//! `Q` is the Rvachev intersection (`a = 0`: `f1 + f2 - sqrt(f1^2 + f2^2)`) of one
//! signed distance per edge and a band across the surface. For a planar polygon an
//! edge's function is the distance to the edge's line in the plane, positive inward;
//! for a spherical one it is the distance to the plane through the sphere's centre and
//! the edge's great circle, positive inward (a wedge from the centre). The band is
//! `(depth^2 - s^2) / (2 depth)` with `s` the signed distance to the plane, or
//! `|p - centre| - radius` for the sphere. The `a = 0` intersection is smooth wherever
//! not two of its operands vanish together, which happens only on the region's
//! boundary (its corners and rims), where `Q = 0`: so `max(Q, 0)^power` with power 2 or
//! 3 is C1 everywhere, unlike `min` (whose creases would run through the inside of the
//! patch). Every operand is Lipschitz 1, and the intersection is increasing in each, so
//! the interval bound is the R-function of the operands' exact ranges over a box.

use super::interval::{Aabb, Interval};
use super::rfunction::{self, SetOp};
use caoen_geometry::vector::{cross, dot, sub, try_normalise};

/// Why a polygon patch cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PatchError {
    /// Not a triangle or a quad.
    #[error("{0} vertices: a patch is a triangle (3) or a quad (4)")]
    VertexCount(usize),
    /// The vertices span no plane.
    #[error("the vertices are collinear or repeated")]
    Degenerate,
    /// A vertex off the plane of the others.
    #[error("vertex {vertex} is {offset:e} off the plane of the others")]
    OffPlane {
        /// Which vertex.
        vertex: usize,
        /// Its distance from the plane.
        offset: f64,
    },
    /// Two consecutive vertices coincide.
    #[error("edge {0} has no length")]
    ZeroEdge(usize),
    /// A spherical band reaching the sphere's centre.
    #[error(
        "depth {depth} must be below the radius {radius} (the band must not reach the centre)"
    )]
    TooDeep {
        /// The band's half-width.
        depth: f64,
        /// The sphere's radius.
        radius: f64,
    },
    /// A spherical patch's vertex at the sphere's centre.
    #[error("vertex {0} is at the centre")]
    AtCentre(usize),
    /// A spherical patch whose vertices' directions sum to zero.
    #[error("the vertices' directions cancel out")]
    Cancelling,
    /// A spherical edge of no length or across half the sphere.
    #[error("edge {0} has no length or spans half the sphere")]
    SphericalEdge(usize),
    /// A band width that is not positive and finite.
    #[error("depth {0} must be positive")]
    Depth(f64),
    /// A vertex outside another edge.
    #[error(
        "not convex: vertex {vertex} is not inside edge {edge} (from vertex {edge} to {next})"
    )]
    NotConvex {
        /// The vertex outside.
        vertex: usize,
        /// The edge it is outside of.
        edge: usize,
        /// The edge's second vertex.
        next: usize,
    },
}

/// The surface a polygon patch lies on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    /// A plane with this unit normal through the first vertex.
    Plane {
        /// Unit normal (the vertices run anticlockwise about it).
        normal: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Its centre.
        centre: [f64; 3],
        /// Its radius.
        radius: f64,
    },
}

/// A convex triangle or quad on a plane or a sphere with the band's half-depth.
#[derive(Debug, Clone, PartialEq)]
pub struct PolygonSupport {
    surface: Surface,
    /// The vertices (on the surface), anticlockwise seen from outside.
    vertices: Vec<[f64; 3]>,
    /// Per edge: unit inward normal of the edge's plane and a point on it.
    edges: Vec<([f64; 3], [f64; 3])>,
    depth: f64,
}

impl PolygonSupport {
    /// A planar convex polygon of 3 or 4 vertices, `depth` the band's half-width across
    /// the plane. The vertices may run either way round; they must lie on one plane (to
    /// 10^-9 of the polygon's size) and make a convex polygon.
    pub fn planar(vertices: &[[f64; 3]], depth: f64) -> Result<Self, PatchError> {
        check_count(vertices)?;
        let v = vertices;
        // Newell's normal: robust for a quad and oriented by the vertex order.
        let mut n = [0.0; 3];
        for i in 0..v.len() {
            n = [0, 1, 2].map(|k| n[k] + cross(v[i], v[(i + 1) % v.len()])[k]);
        }
        let normal = try_normalise(n).ok_or(PatchError::Degenerate)?;
        let size = (1..v.len())
            .map(|i| dot(sub(v[i], v[0]), sub(v[i], v[0])).sqrt())
            .fold(0.0, f64::max);
        for (i, p) in v.iter().enumerate() {
            let off = dot(normal, sub(*p, v[0]));
            if off.abs() > 1e-9 * size {
                return Err(PatchError::OffPlane {
                    vertex: i,
                    offset: off,
                });
            }
        }
        let edges = (0..v.len())
            .map(|i| {
                let e = sub(v[(i + 1) % v.len()], v[i]);
                let inward = try_normalise(cross(normal, e)).ok_or(PatchError::ZeroEdge(i))?;
                Ok((inward, v[i]))
            })
            .collect::<Result<Vec<_>, PatchError>>()?;
        Self::new(Surface::Plane { normal }, v.to_vec(), edges, depth)
    }

    /// A convex spherical polygon of 3 or 4 vertices (each projected onto the sphere
    /// along its direction from the centre), smaller than a hemisphere; `depth` the
    /// band's half-width across the sphere, below the radius.
    pub fn spherical(
        centre: [f64; 3],
        radius: f64,
        vertices: &[[f64; 3]],
        depth: f64,
    ) -> Result<Self, PatchError> {
        check_count(vertices)?;
        if depth >= radius {
            return Err(PatchError::TooDeep { depth, radius });
        }
        let dirs = vertices
            .iter()
            .enumerate()
            .map(|(i, p)| try_normalise(sub(*p, centre)).ok_or(PatchError::AtCentre(i)))
            .collect::<Result<Vec<_>, PatchError>>()?;
        // Oriented so the vertices' mean direction is inside every edge's wedge.
        let mean = try_normalise(
            dirs.iter()
                .fold([0.0; 3], |a, d| [a[0] + d[0], a[1] + d[1], a[2] + d[2]]),
        )
        .ok_or(PatchError::Cancelling)?;
        let mut edges = Vec::with_capacity(dirs.len());
        for i in 0..dirs.len() {
            let m = try_normalise(cross(dirs[i], dirs[(i + 1) % dirs.len()]))
                .ok_or(PatchError::SphericalEdge(i))?;
            edges.push((m, centre));
        }
        if dot(edges[0].0, mean) < 0.0 {
            for e in &mut edges {
                e.0 = e.0.map(|v| -v);
            }
        }
        let on_sphere = dirs
            .iter()
            .map(|d| [0, 1, 2].map(|k| centre[k] + radius * d[k]))
            .collect();
        Self::new(Surface::Sphere { centre, radius }, on_sphere, edges, depth)
    }

    fn new(
        surface: Surface,
        vertices: Vec<[f64; 3]>,
        edges: Vec<([f64; 3], [f64; 3])>,
        depth: f64,
    ) -> Result<Self, PatchError> {
        if !(depth > 0.0 && depth.is_finite()) {
            return Err(PatchError::Depth(depth));
        }
        // Convex (and consistently oriented): every vertex on the inner side of every
        // edge, strictly for the vertices not on the edge.
        let size = vertices
            .iter()
            .map(|p| dot(sub(*p, vertices[0]), sub(*p, vertices[0])).sqrt())
            .fold(0.0, f64::max);
        for (i, (n, q)) in edges.iter().enumerate() {
            for (j, p) in vertices.iter().enumerate() {
                let k = vertices.len();
                if j == i || j == (i + 1) % k {
                    continue;
                }
                if dot(*n, sub(*p, *q)) <= 1e-9 * size {
                    return Err(PatchError::NotConvex {
                        vertex: j,
                        edge: i,
                        next: (i + 1) % k,
                    });
                }
            }
        }
        Ok(PolygonSupport {
            surface,
            vertices,
            edges,
            depth,
        })
    }

    /// The surface, the vertices on it, and the band's half-depth (for exports).
    pub fn parts(&self) -> (Surface, &[[f64; 3]], f64) {
        (self.surface, &self.vertices, self.depth)
    }

    /// Per edge: the unit inward normal of its plane and a point on that plane.
    pub fn edge_planes(&self) -> &[([f64; 3], [f64; 3])] {
        &self.edges
    }

    /// The signed distance across the surface (to the plane, or radially to the sphere)
    /// and its gradient.
    fn across(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self.surface {
            Surface::Plane { normal } => (dot(normal, sub(p, self.vertices[0])), normal),
            Surface::Sphere { centre, radius } => {
                let d = sub(p, centre);
                let r = dot(d, d).sqrt();
                // At the centre the band is far below zero (depth < radius): any
                // direction serves.
                let g = if r > 0.0 {
                    d.map(|v| v / r)
                } else {
                    [0.0, 0.0, 1.0]
                };
                (r - radius, g)
            }
        }
    }

    /// `Q` and its exact gradient at `p`.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let (s, gs) = self.across(p);
        let d = self.depth;
        let band = (d * d - s * s) / (2.0 * d);
        let mut acc = (band, gs.map(|v| -s / d * v));
        for (n, q) in &self.edges {
            let e = dot(*n, sub(p, *q));
            let (r, d1, d2) = rfunction::partials(SetOp::Intersection, acc.0, e, 0.0);
            acc = (r, [0, 1, 2].map(|k| d1 * acc.1[k] + d2 * n[k]));
        }
        acc
    }

    /// Bounds of `Q` over a box.
    pub fn interval(&self, b: &Aabb) -> Interval {
        let s = match self.surface {
            Surface::Plane { normal } => linear(normal, self.vertices[0], b),
            Surface::Sphere { centre, radius } => {
                let near: f64 = (0..3)
                    .map(|k| {
                        (b.lo[k] - centre[k])
                            .max(centre[k] - b.hi[k])
                            .max(0.0)
                            .powi(2)
                    })
                    .sum();
                let far: f64 = (0..3)
                    .map(|k| {
                        (b.lo[k] - centre[k])
                            .abs()
                            .max((b.hi[k] - centre[k]).abs())
                            .powi(2)
                    })
                    .sum();
                Interval::new(near.sqrt() - radius, far.sqrt() - radius)
            }
        };
        let d = self.depth;
        let band = (Interval::point(d * d) - s.sqr()).scale(0.5 / d);
        self.edges.iter().fold(band, |acc, (n, q)| {
            rfunction::interval(SetOp::Intersection, acc, linear(*n, *q, b), 0.0)
        })
    }

    /// A box holding the region where `Q > 0`.
    pub fn positive_box(&self) -> Aabb {
        match self.surface {
            Surface::Plane { normal } => {
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for v in &self.vertices {
                    for k in 0..3 {
                        let reach = self.depth * normal[k].abs();
                        lo[k] = lo[k].min(v[k] - reach);
                        hi[k] = hi[k].max(v[k] + reach);
                    }
                }
                Aabb::new(lo, hi)
            }
            Surface::Sphere { centre, radius } => {
                let r = radius + self.depth;
                Aabb::new(centre.map(|c| c - r), centre.map(|c| c + r))
            }
        }
    }
}

/// The exact range of `n . (p - q)` over a box.
fn linear(n: [f64; 3], q: [f64; 3], b: &Aabb) -> Interval {
    let (mut lo, mut hi) = (0.0, 0.0);
    for k in 0..3 {
        let (a, c) = (n[k] * (b.lo[k] - q[k]), n[k] * (b.hi[k] - q[k]));
        lo += a.min(c);
        hi += a.max(c);
    }
    Interval::new(lo, hi)
}

fn check_count(vertices: &[[f64; 3]]) -> Result<(), PatchError> {
    if !(3..=4).contains(&vertices.len()) {
        return Err(PatchError::VertexCount(vertices.len()));
    }
    Ok(())
}
