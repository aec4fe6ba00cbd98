//! Domains: the manifolds the network's input lives on (paper sections 2 and 8).
//!
//! Every domain is embedded in the unit sphere of its ambient space, so `x . w` is a
//! cosine-like similarity in [-1, 1] for every domain and every blending function
//! keeps its meaning. For the torus that means formula (18) scaled by `1/sqrt(2)`:
//! `x = (cos t, sin t, cos f, sin f) / sqrt(2)` (the Clifford torus in S^3), so
//! `x . w = (cos(dt) + cos(df)) / 2`.

use serde::{Deserialize, Serialize};

use super::error::{Result, SurfaceError};

/// A domain manifold with its parameterisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Domain {
    /// The unit sphere S^(dim-1) in R^dim; `dim = 3` is the ordinary sphere of (7).
    Sphere {
        /// Ambient dimension m (2..=16).
        dim: usize,
    },
    /// The torus of (18), scaled onto S^3 (ambient dimension 4).
    Torus,
    /// The closed 3-ball, lifted to the upper half of S^3 by `b -> (b, sqrt(1 - |b|^2))`.
    ///
    /// Each ball point stands for one of its two S^3 points (the upper one), so any
    /// point set inside the ball (a surface, a solid) can be an input surface.
    Ball,
}

/// A rectangular grid of parameter values and the domain points they give.
#[derive(Debug, Clone)]
pub struct ParamGrid {
    /// Number of columns (first parameter).
    pub cols: usize,
    /// Number of rows (second parameter).
    pub rows: usize,
    /// Parameters, `rows * cols` pairs, row-major.
    pub params: Vec<[f64; 2]>,
    /// Domain points, `rows * cols` vectors of the ambient dimension, row-major flat.
    pub points: Vec<f64>,
    /// Whether the first parameter wraps around (last column joins the first).
    pub wraps_cols: bool,
    /// Whether the second parameter wraps around (last row joins the first).
    pub wraps_rows: bool,
}

impl Domain {
    /// The ordinary sphere S^2 in R^3.
    pub const SPHERE: Domain = Domain::Sphere { dim: 3 };

    /// Checks that the domain's own parameters are valid.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Domain::Sphere { dim } if !(2..=super::network::MAX_DIM).contains(&dim) => {
                Err(SurfaceError::Parameter {
                    what: "domain.dim".into(),
                    value: dim as f64,
                    reason: "sphere dimension must be in 2..=16",
                })
            }
            _ => Ok(()),
        }
    }

    /// Ambient dimension `m` of the domain's points (the network's input dimension).
    pub fn ambient_dim(&self) -> usize {
        match *self {
            Domain::Sphere { dim } => dim,
            Domain::Torus | Domain::Ball => 4,
        }
    }

    /// Number of parameters (the manifold's own dimension).
    pub fn param_dim(&self) -> usize {
        match *self {
            Domain::Sphere { dim } => dim - 1,
            Domain::Torus => 2,
            Domain::Ball => 3,
        }
    }

    /// The domain point for `params`.
    ///
    /// Sphere: hyperspherical angles; for S^2 `(t, f)` gives `(cos t sin f, sin t sin f,
    /// cos f)` as in (7). Torus: `(t, f)`. Ball: the ball point `b` itself.
    pub fn point(&self, params: &[f64]) -> Result<Vec<f64>> {
        super::error::check_len(
            || "domain parameters".into(),
            self.param_dim(),
            params.len(),
        )?;
        super::error::check_finite(|| "domain parameters".into(), params)?;
        Ok(match *self {
            Domain::Sphere { dim: 3 } => {
                let (t, f) = (params[0], params[1]);
                vec![t.cos() * f.sin(), t.sin() * f.sin(), f.cos()]
            }
            Domain::Sphere { dim } => {
                // x_k = cos(a_k) prod_{j<k} sin(a_j); the last angle is the full circle.
                let mut x = vec![0.0; dim];
                let mut prod = 1.0;
                for k in 0..dim - 1 {
                    let a = params[dim - 2 - k];
                    if k == dim - 2 {
                        x[0] = prod * a.cos();
                        x[1] = prod * a.sin();
                    } else {
                        x[dim - 1 - k] = prod * a.cos();
                        prod *= a.sin();
                    }
                }
                x
            }
            Domain::Torus => {
                let r = std::f64::consts::FRAC_1_SQRT_2;
                let (t, f) = (params[0], params[1]);
                vec![r * t.cos(), r * t.sin(), r * f.cos(), r * f.sin()]
            }
            Domain::Ball => {
                let b2: f64 = params.iter().map(|v| v * v).sum();
                if b2 > 1.0 + 1e-12 {
                    return Err(SurfaceError::Parameter {
                        what: "ball point |b|".into(),
                        value: b2.sqrt(),
                        reason: "must be <= 1",
                    });
                }
                vec![params[0], params[1], params[2], (1.0 - b2).max(0.0).sqrt()]
            }
        })
    }

    /// The nearest domain point to an arbitrary vector `x` of the ambient dimension.
    pub fn project(&self, x: &[f64]) -> Result<Vec<f64>> {
        super::error::check_len(|| "point".into(), self.ambient_dim(), x.len())?;
        super::error::check_finite(|| "point".into(), x)?;
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        match *self {
            Domain::Sphere { .. } | Domain::Ball => {
                let n = norm(x);
                if n == 0.0 {
                    return Err(SurfaceError::Parameter {
                        what: "point norm".into(),
                        value: 0.0,
                        reason: "the origin has no nearest sphere point",
                    });
                }
                let mut y: Vec<f64> = x.iter().map(|v| v / n).collect();
                if *self == Domain::Ball && y[3] < 0.0 {
                    y[3] = 0.0;
                    let n = norm(&y);
                    y.iter_mut().for_each(|v| *v /= n);
                }
                Ok(y)
            }
            Domain::Torus => {
                let (a, b) = (norm(&x[..2]), norm(&x[2..]));
                if a == 0.0 || b == 0.0 {
                    return Err(SurfaceError::Parameter {
                        what: "point circle radius".into(),
                        value: 0.0,
                        reason: "a circle's centre has no nearest torus point",
                    });
                }
                let r = std::f64::consts::FRAC_1_SQRT_2;
                Ok(vec![r * x[0] / a, r * x[1] / a, r * x[2] / b, r * x[3] / b])
            }
        }
    }

    /// Two tangent vectors at domain point `x` for 2-parameter domains, ordered so that
    /// for the identity map of S^2 their cross product points outward.
    ///
    /// Trig-free as in (13): the angles' sines and cosines come from `x` itself. Sphere:
    /// `(dx/df, dx/dt)` with `dx/dt = (-x2, x1, 0)` and `dx/df = (x1 x3, x2 x3, -r^2)/r`,
    /// `r = sqrt(x1^2 + x2^2)`; at a pole, where (7) is singular, an orthonormal pair.
    /// Torus: `(dx/dt, dx/df)`.
    pub fn tangents(&self, x: &[f64]) -> Result<([f64; 4], [f64; 4])> {
        super::error::check_len(|| "point".into(), self.ambient_dim(), x.len())?;
        match *self {
            Domain::Sphere { dim: 3 } => {
                let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
                if r < 1e-9 {
                    let s = if x[2] >= 0.0 { 1.0 } else { -1.0 };
                    return Ok(([1.0, 0.0, 0.0, 0.0], [0.0, s, 0.0, 0.0]));
                }
                let df = [x[0] * x[2] / r, x[1] * x[2] / r, -r, 0.0];
                let dt = [-x[1], x[0], 0.0, 0.0];
                Ok((df, dt))
            }
            Domain::Torus => Ok(([-x[1], x[0], 0.0, 0.0], [0.0, 0.0, -x[3], x[2]])),
            _ => Err(SurfaceError::Parameter {
                what: "domain parameter count".into(),
                value: self.param_dim() as f64,
                reason: "tangent pairs exist for 2-parameter domains (sphere S^2, torus)",
            }),
        }
    }

    /// A parameter grid for sampling a 2-parameter domain.
    ///
    /// Sphere: `cols` longitudes (wrapping) by `rows` latitudes from pole to pole
    /// inclusive. Torus: `cols` by `rows` angles, both wrapping.
    pub fn grid(&self, cols: usize, rows: usize) -> Result<ParamGrid> {
        use std::f64::consts::{PI, TAU};
        let (wraps_rows, row_angle): (bool, Box<dyn Fn(usize) -> f64>) = match *self {
            Domain::Sphere { dim: 3 } if rows >= 2 => {
                (false, Box::new(move |r| PI * r as f64 / (rows - 1) as f64))
            }
            Domain::Torus if rows >= 3 => (true, Box::new(move |r| TAU * r as f64 / rows as f64)),
            _ => {
                return Err(SurfaceError::Parameter {
                    what: "grid rows".into(),
                    value: rows as f64,
                    reason: "grids exist for S^2 (rows >= 2) and the torus (rows >= 3)",
                })
            }
        };
        if cols < 3 {
            return Err(SurfaceError::Parameter {
                what: "grid cols".into(),
                value: cols as f64,
                reason: "need at least 3 columns",
            });
        }
        let mut params = Vec::with_capacity(rows * cols);
        let mut points = Vec::with_capacity(rows * cols * self.ambient_dim());
        for r in 0..rows {
            for c in 0..cols {
                let pr = [TAU * c as f64 / cols as f64, row_angle(r)];
                points.extend(self.point(&pr)?);
                params.push(pr);
            }
        }
        Ok(ParamGrid {
            cols,
            rows,
            params,
            points,
            wraps_cols: true,
            wraps_rows,
        })
    }
}

impl ParamGrid {
    /// Triangles of a grid that wraps both ways (the torus), consistently wound,
    /// two per cell: a closed surface with `V - E + F = 0`.
    pub fn wrapped_triangles(&self) -> Result<Vec<[u32; 3]>> {
        if !(self.wraps_cols && self.wraps_rows) {
            return Err(SurfaceError::Parameter {
                what: "grid wrapping".into(),
                value: 0.0,
                reason: "closed grid triangles need a grid that wraps both ways (torus)",
            });
        }
        let (c, r) = (self.cols, self.rows);
        let id = |i: usize, j: usize| ((j % r) * c + (i % c)) as u32;
        let mut tris = Vec::with_capacity(2 * c * r);
        for j in 0..r {
            for i in 0..c {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        Ok(tris)
    }
}
