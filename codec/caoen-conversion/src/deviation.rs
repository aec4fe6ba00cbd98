//! Deviation analysis, as the polygon-conversion paper measures it, in the mesh's unit
//! cube: the distance from each vertex to the surface (projected along the gradient),
//! the angle between the vertex normal and the gradient there, and the mean difference
//! of depth buffers of the mesh and of the function seen from several sides.

use rayon::prelude::*;

use super::model::ImplicitField;
use super::polygon_mesh::PolygonMesh;
use caoen_geometry::vector::dot;

/// Vertex distances and normal angles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexDeviation {
    /// Mean distance from a vertex to the surface.
    pub mean_distance: f64,
    /// Largest distance.
    pub max_distance: f64,
    /// Mean angle (degrees) between the vertex normal and the surface normal.
    pub mean_angle_deg: f64,
    /// Largest angle.
    pub max_angle_deg: f64,
    /// Vertices whose projection did not converge (their distance is the last
    /// estimate).
    pub unconverged: usize,
}

/// Moves `p` onto the surface along the gradient (Newton steps on `F`, each at most
/// 0.05 long); the point reached and whether it converged.
pub fn project(field: &dyn ImplicitField, p: [f64; 3]) -> ([f64; 3], bool) {
    let mut x = p;
    for _ in 0..40 {
        let (v, g) = field.value_gradient(x);
        let g2 = dot(g, g);
        // A NaN or vanishing gradient gives no direction to move along.
        if g2.is_nan() || g2 <= 1e-300 {
            return (x, false);
        }
        let step = v / g2;
        if (v.abs() / g2.sqrt()) < 1e-10 {
            return (x, true);
        }
        let len = step.abs() * g2.sqrt();
        let s = if len > 0.05 { step * 0.05 / len } else { step };
        x = [0, 1, 2].map(|k| x[k] - s * g[k]);
    }
    let (v, g) = field.value_gradient(x);
    (x, v.abs() / dot(g, g).sqrt() < 1e-7)
}

/// Distances and angles over every vertex of `mesh` (already in the unit cube), with
/// its outward normals.
pub fn vertex_deviation(
    field: &dyn ImplicitField,
    mesh: &PolygonMesh,
    normals: &[[f64; 3]],
) -> VertexDeviation {
    // A vertex no triangle uses has no normal and is not on the surface.
    let per: Vec<(f64, f64, bool)> = mesh
        .positions
        .par_iter()
        .zip(normals)
        .filter(|(_, n)| **n != [0.0; 3])
        .map(|(p, n)| {
            let (x, ok) = project(field, *p);
            let d = (0..3).map(|k| (x[k] - p[k]).powi(2)).sum::<f64>().sqrt();
            let (_, g) = field.value_gradient(x);
            let l = dot(g, g).sqrt();
            let angle = if l > 0.0 {
                (-dot(g, *n) / l).clamp(-1.0, 1.0).acos().to_degrees()
            } else {
                180.0
            };
            (d, angle, ok)
        })
        .collect();
    let n = per.len().max(1) as f64;
    VertexDeviation {
        mean_distance: per.iter().map(|e| e.0).sum::<f64>() / n,
        max_distance: per.iter().map(|e| e.0).fold(0.0, f64::max),
        mean_angle_deg: per.iter().map(|e| e.1).sum::<f64>() / n,
        max_angle_deg: per.iter().map(|e| e.1).fold(0.0, f64::max),
        unconverged: per.iter().filter(|e| !e.2).count(),
    }
}

/// An orthographic view of the unit cube along one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// The viewing direction (into the scene).
    pub dir: [f64; 3],
    /// The image's right axis.
    pub right: [f64; 3],
    /// The image's down axis.
    pub down: [f64; 3],
    /// A name (`+x` looks along +x).
    pub name: &'static str,
}

/// The six axis views, in the order `-z +z -x +x -y +y` (front first); `count` of them.
pub fn views(count: usize) -> Vec<View> {
    let all = [
        View {
            dir: [0.0, 0.0, -1.0],
            right: [1.0, 0.0, 0.0],
            down: [0.0, -1.0, 0.0],
            name: "-z",
        },
        View {
            dir: [0.0, 0.0, 1.0],
            right: [-1.0, 0.0, 0.0],
            down: [0.0, -1.0, 0.0],
            name: "+z",
        },
        View {
            dir: [-1.0, 0.0, 0.0],
            right: [0.0, 0.0, -1.0],
            down: [0.0, -1.0, 0.0],
            name: "-x",
        },
        View {
            dir: [1.0, 0.0, 0.0],
            right: [0.0, 0.0, 1.0],
            down: [0.0, -1.0, 0.0],
            name: "+x",
        },
        View {
            dir: [0.0, -1.0, 0.0],
            right: [1.0, 0.0, 0.0],
            down: [0.0, 0.0, 1.0],
            name: "-y",
        },
        View {
            dir: [0.0, 1.0, 0.0],
            right: [1.0, 0.0, 0.0],
            down: [0.0, 0.0, -1.0],
            name: "+y",
        },
    ];
    all[..count.min(6)].to_vec()
}

/// Half the side of the square each view sees, and where the camera plane sits.
const HALF: f64 = 0.55;
const NEAR: f64 = 0.6;
/// The depth of a pixel that sees nothing: the far end of the viewing volume.
pub const FAR_DEPTH: f64 = 2.0 * NEAR;

/// A depth buffer with the surface normal seen at each pixel.
#[derive(Debug, Clone)]
pub struct DepthImage {
    /// Side in pixels.
    pub size: usize,
    /// Depth from the camera plane, [`FAR_DEPTH`] where nothing is hit.
    pub depth: Vec<f64>,
    /// Unit outward normal at the hit (zero where nothing is hit).
    pub normal: Vec<[f64; 3]>,
}

fn ray(view: &View, size: usize, i: usize, j: usize) -> [f64; 3] {
    let s = -HALF + 2.0 * HALF * (i as f64 + 0.5) / size as f64;
    let t = -HALF + 2.0 * HALF * (j as f64 + 0.5) / size as f64;
    [0, 1, 2].map(|k| -NEAR * view.dir[k] + s * view.right[k] + t * view.down[k])
}

/// The mesh's depth buffer (pixel centres inside a triangle take its depth).
pub fn mesh_depth(mesh: &PolygonMesh, view: &View, size: usize) -> DepthImage {
    let mut depth = vec![FAR_DEPTH; size * size];
    let mut normal = vec![[0.0; 3]; size * size];
    let px = |p: [f64; 3]| -> [f64; 3] {
        [
            (dot(p, view.right) + HALF) / (2.0 * HALF) * size as f64 - 0.5,
            (dot(p, view.down) + HALF) / (2.0 * HALF) * size as f64 - 0.5,
            dot(p, view.dir) + NEAR,
        ]
    };
    for t in 0..mesh.triangles.len() {
        let v = mesh.triangles[t].map(|i| px(mesh.positions[i as usize]));
        let area =
            (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
        if area.abs() < 1e-18 {
            continue;
        }
        let fnorm = {
            let n = mesh.face_normal(t);
            let l = dot(n, n).sqrt().max(1e-300);
            n.map(|x| x / l)
        };
        let lo = |k: usize| {
            v.iter()
                .map(|p| p[k])
                .fold(f64::INFINITY, f64::min)
                .ceil()
                .max(0.0) as usize
        };
        let hi = |k: usize| {
            v.iter()
                .map(|p| p[k])
                .fold(f64::NEG_INFINITY, f64::max)
                .floor()
                .min(size as f64 - 1.0)
        };
        let (x1, y1) = (hi(0), hi(1));
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        for y in lo(1)..=y1 as usize {
            for x in lo(0)..=x1 as usize {
                let (fx, fy) = (x as f64, y as f64);
                let w0 = ((v[1][0] - fx) * (v[2][1] - fy) - (v[2][0] - fx) * (v[1][1] - fy)) / area;
                let w1 = ((v[2][0] - fx) * (v[0][1] - fy) - (v[0][0] - fx) * (v[2][1] - fy)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * v[0][2] + w1 * v[1][2] + w2 * v[2][2];
                let k = y * size + x;
                if z < depth[k] {
                    depth[k] = z;
                    normal[k] = fnorm;
                }
            }
        }
    }
    DepthImage {
        size,
        depth,
        normal,
    }
}

/// Field values on a lattice over the viewing volume. Rays skip through it where a
/// cell's corners stay further below zero than they differ from each other (no surface
/// within about a cell), and march the exact field elsewhere, so a part thinner than a
/// cell (a tail, a horn, an ear), which the lattice's interpolant would miss, is seen.
pub struct FieldGrid {
    n: usize,
    values: Vec<f64>,
    /// Per cell (`(n - 1)^3`): whether the surface may pass through it.
    near: Vec<bool>,
}

impl FieldGrid {
    /// Samples `field` on `n^3` points over `[-0.6, 0.6]^3`, and marks the cells the
    /// surface may cross: a cell's largest corner value is within its slope of zero,
    /// the slope being the largest step between neighbouring lattice values in and
    /// around it (around it too, so a ridge between two lattice planes, whose corners
    /// all read alike, still counts).
    pub fn new(field: &dyn ImplicitField, n: usize) -> FieldGrid {
        let values: Vec<f64> = (0..n * n * n)
            .into_par_iter()
            .map(|i| {
                let c = [i % n, (i / n) % n, i / (n * n)];
                field.value(c.map(|c| -NEAR + 2.0 * NEAR * c as f64 / (n - 1) as f64))
            })
            .collect();
        let m = n - 1;
        let node = |x: usize, y: usize, z: usize| values[(z * n + y) * n + x];
        // (largest corner value, largest step along a cell edge) per cell.
        let cells: Vec<(f64, f64)> = (0..m * m * m)
            .into_par_iter()
            .map(|c| {
                let (x, y, z) = (c % m, (c / m) % m, c / (m * m));
                let (mut hi, mut step) = (f64::NEG_INFINITY, 0.0f64);
                for k in 0..8 {
                    let (dx, dy, dz) = (k & 1, (k >> 1) & 1, k >> 2);
                    let v = node(x + dx, y + dy, z + dz);
                    hi = hi.max(v);
                    if dx == 0 {
                        step = step.max((v - node(x + 1, y + dy, z + dz)).abs());
                    }
                    if dy == 0 {
                        step = step.max((v - node(x + dx, y + 1, z + dz)).abs());
                    }
                    if dz == 0 {
                        step = step.max((v - node(x + dx, y + dy, z + 1)).abs());
                    }
                }
                (hi, step)
            })
            .collect();
        let near = (0..m * m * m)
            .into_par_iter()
            .map(|c| {
                let (x, y, z) = (c % m, (c / m) % m, c / (m * m));
                let mut step = 0.0f64;
                for zz in z.saturating_sub(1)..(z + 2).min(m) {
                    for yy in y.saturating_sub(1)..(y + 2).min(m) {
                        for xx in x.saturating_sub(1)..(x + 2).min(m) {
                            step = step.max(cells[(zz * m + yy) * m + xx].1);
                        }
                    }
                }
                cells[c].0 + step >= 0.0
            })
            .collect();
        FieldGrid { n, values, near }
    }

    /// Whether the surface may pass through the cell holding `p`.
    fn near_surface(&self, p: [f64; 3]) -> bool {
        let m = self.n - 1;
        let i =
            p.map(|v| ((v + NEAR) / (2.0 * NEAR) * m as f64).clamp(0.0, m as f64 - 1e-9) as usize);
        self.near[(i[2] * m + i[1]) * m + i[0]]
    }

    fn at(&self, p: [f64; 3]) -> f64 {
        let n = self.n;
        let g = p.map(|v| {
            ((v + NEAR) / (2.0 * NEAR) * (n - 1) as f64).clamp(0.0, (n - 1) as f64 - 1e-9)
        });
        let i = g.map(|v| v.floor() as usize);
        let f = [0, 1, 2].map(|k| g[k] - i[k] as f64);
        let v = |dx: usize, dy: usize, dz: usize| {
            self.values[(i[2] + dz) * n * n + (i[1] + dy) * n + i[0] + dx]
        };
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let x00 = lerp(v(0, 0, 0), v(1, 0, 0), f[0]);
        let x10 = lerp(v(0, 1, 0), v(1, 1, 0), f[0]);
        let x01 = lerp(v(0, 0, 1), v(1, 0, 1), f[0]);
        let x11 = lerp(v(0, 1, 1), v(1, 1, 1), f[0]);
        lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
    }
}

/// The field's depth buffer: the first point along each ray where `F >= 0`.
pub fn field_depth(
    field: &dyn ImplicitField,
    grid: &FieldGrid,
    view: &View,
    size: usize,
) -> DepthImage {
    let h = NEAR / (grid.n - 1) as f64;
    let px: Vec<(f64, [f64; 3])> = (0..size * size)
        .into_par_iter()
        .map(|k| {
            let o = ray(view, size, k % size, k / size);
            let at = |t: f64| [0, 1, 2].map(|c| o[c] + t * view.dir[c]);
            let mut prev = grid.at(o);
            if prev >= 0.0 {
                return (0.0, [0.0; 3]);
            }
            let mut t = 0.0;
            let mut near = grid.near_surface(o);
            while t < FAR_DEPTH {
                // A quarter step near the surface: thin parts are crossed by rays that
                // spend less than a half cell inside them.
                let dt = if near { 0.25 * h } else { h };
                let t0 = t;
                t = (t + dt).min(FAR_DEPTH);
                near = grid.near_surface(at(t));
                let v = if near {
                    field.value(at(t))
                } else {
                    grid.at(at(t))
                };
                if v >= 0.0 {
                    let (mut a, mut b) = (t0, t);
                    let t_hit = if field.value(at(a)) < 0.0 && field.value(at(b)) >= 0.0 {
                        // Regula falsi with the Illinois halving, keeping the bracket,
                        // to 1e-10: a handful of evaluations where bisection takes 40.
                        let (mut fa, mut fb) = (field.value(at(a)), field.value(at(b)));
                        let mut last = 0;
                        for _ in 0..60 {
                            if b - a <= 1e-10 {
                                break;
                            }
                            let m = if fb > fa {
                                (a - fa * (b - a) / (fb - fa)).clamp(a, b)
                            } else {
                                0.5 * (a + b)
                            };
                            let fm = field.value(at(m));
                            if fm >= 0.0 {
                                b = m;
                                fb = fm;
                                if last == 1 {
                                    fa *= 0.5;
                                }
                                last = 1;
                            } else {
                                a = m;
                                fa = fm;
                                if last == -1 {
                                    fb *= 0.5;
                                }
                                last = -1;
                            }
                            if fm == 0.0 {
                                break;
                            }
                        }
                        b
                    } else {
                        t0 + (t - t0) * prev / (prev - v)
                    };
                    let (_, g) = field.value_gradient(at(t_hit));
                    let l = dot(g, g).sqrt();
                    let n = if l > 0.0 { g.map(|x| -x / l) } else { [0.0; 3] };
                    return (t_hit, n);
                }
                prev = v;
            }
            (FAR_DEPTH, [0.0; 3])
        })
        .collect();
    DepthImage {
        size,
        depth: px.iter().map(|p| p.0).collect(),
        normal: px.iter().map(|p| p.1).collect(),
    }
}

/// How two depth buffers differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthDeviation {
    /// Mean |depth difference| over the pixels where either buffer sees the model
    /// (a pixel only one of them covers counts its distance to the far plane).
    pub mean: f64,
    /// Pixels where either sees the model.
    pub covered: usize,
    /// Of those, pixels where only one does.
    pub silhouette_mismatch: usize,
    /// Mean |depth difference| over every pixel of the buffers, a pixel neither sees
    /// counting 0 (the paper's "all points of the buffers").
    pub mean_all: f64,
    /// Mean |depth difference| over the pixels where both see the model.
    pub mean_both: f64,
}

/// Compares a mesh's and a field's depth buffers.
pub fn compare_depth(a: &DepthImage, b: &DepthImage) -> DepthDeviation {
    let (mut sum, mut covered, mut mismatch, mut both) = (0.0, 0, 0, 0.0);
    for (x, y) in a.depth.iter().zip(&b.depth) {
        let (ha, hb) = (*x < FAR_DEPTH, *y < FAR_DEPTH);
        if ha || hb {
            covered += 1;
            sum += (x - y).abs();
            if ha != hb {
                mismatch += 1;
            } else {
                both += (x - y).abs();
            }
        }
    }
    DepthDeviation {
        mean: sum / covered.max(1) as f64,
        covered,
        silhouette_mismatch: mismatch,
        mean_all: sum / a.depth.len().max(1) as f64,
        mean_both: both / (covered - mismatch).max(1) as f64,
    }
}

/// A grey picture of a depth image, lit from the camera.
pub fn shade(img: &DepthImage, view: &View) -> Vec<u8> {
    img.depth
        .iter()
        .zip(&img.normal)
        .map(|(d, n)| {
            if *d >= FAR_DEPTH {
                255
            } else {
                let l = (-dot(*n, view.dir)).abs();
                (30.0 + 200.0 * l).round() as u8
            }
        })
        .collect()
}

/// The per-pixel |difference| as a colour ramp (black 0, yellow at `scale` and above);
/// white where neither sees the model.
pub fn difference_picture(a: &DepthImage, b: &DepthImage, scale: f64) -> Vec<[u8; 3]> {
    a.depth
        .iter()
        .zip(&b.depth)
        .map(|(x, y)| {
            if *x >= FAR_DEPTH && *y >= FAR_DEPTH {
                return [255, 255, 255];
            }
            let t = ((x - y).abs() / scale).min(1.0);
            [
                (255.0 * (2.0 * t).min(1.0)) as u8,
                (255.0 * (2.0 * t - 1.0).max(0.0)) as u8,
                (80.0 * (1.0 - t)) as u8,
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Ball(f64);
    impl ImplicitField for Ball {
        fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
            (self.0 * self.0 - dot(p, p), p.map(|v| -2.0 * v))
        }
    }

    /// A disc of radius 0.3 and thickness 0.004 centred at z = 0.009, between two
    /// lattice planes of a 65^3 grid (0.019 apart), so no lattice point is inside it.
    struct ThinDisc;
    impl ImplicitField for ThinDisc {
        fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
            let z = p[2] - 0.009;
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt().max(1e-12);
            let slab = 0.002 - z.abs();
            let rim = 0.3 - r;
            if slab < rim {
                (slab, [0.0, 0.0, -z.signum()])
            } else {
                (rim, [-p[0] / r, -p[1] / r, 0.0])
            }
        }
    }

    #[test]
    fn a_part_thinner_than_a_lattice_cell_is_seen_at_its_depth() {
        let grid = FieldGrid::new(&ThinDisc, 65);
        assert!(
            grid.values.iter().all(|&v| v < 0.0),
            "no lattice point inside"
        );
        let view = &views(1)[0];
        assert_eq!(view.dir, [0.0, 0.0, -1.0]);
        let size = 64;
        let d = field_depth(&ThinDisc, &grid, view, size);
        // Rays through the disc's middle meet its top face, z = 0.011.
        let mid = size / 2 * size + size / 2;
        let expected = NEAR - 0.011;
        assert!(
            (d.depth[mid] - expected).abs() < 1e-6,
            "{} against {expected}",
            d.depth[mid]
        );
        // The disc covers about pi 0.3^2 of the 1.1^2 square.
        let covered = d.depth.iter().filter(|&&t| t < FAR_DEPTH).count() as f64;
        let share = covered / (size * size) as f64;
        let expected = std::f64::consts::PI * 0.09 / (2.0 * HALF).powi(2);
        assert!(
            (share - expected).abs() < 0.02,
            "covers {share}, the disc {expected}"
        );
    }

    #[test]
    fn a_fine_sphere_mesh_and_the_ball_agree_and_a_wrong_radius_shows() {
        let mesh = PolygonMesh::ellipsoid([0.4; 3], 5);
        let normals = mesh.outward_normals();
        let d = vertex_deviation(&Ball(0.4), &mesh, &normals);
        assert!(d.max_distance < 1e-12 && d.mean_angle_deg < 0.5, "{d:?}");
        let d = vertex_deviation(&Ball(0.41), &mesh, &normals);
        assert!((d.mean_distance - 0.01).abs() < 1e-9, "{d:?}");
        for v in views(6) {
            let grid = FieldGrid::new(&Ball(0.4), 65);
            let m = mesh_depth(&mesh, &v, 64);
            let f = field_depth(&Ball(0.4), &grid, &v, 64);
            let c = compare_depth(&m, &f);
            // The mesh's chords sit inside the sphere by at most ~1e-3 here.
            assert!(c.mean < 1e-3 && c.covered > 1500, "{} {c:?}", v.name);
            let f2 = field_depth(&Ball(0.42), &FieldGrid::new(&Ball(0.42), 65), &v, 64);
            assert!(compare_depth(&m, &f2).mean > 0.01);
        }
    }
}
