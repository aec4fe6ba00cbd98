//! The Cao En network (paper section 2): `k_i = a_i F_i(x . w_i)`, `y = sum_i k_i t_i`,
//! optionally normalised by `sum_i k_i` (formula 6).
//!
//! Each key point also carries a weight `a_i` (1 by default). A weight of 0 makes an
//! *empty* key point that changes nothing even under normalisation, where a zero shape
//! vector alone would still add to the denominator; morphing pads with such points.
//!
//! Single inputs and the Jacobian are evaluated here; `batch` evaluates many inputs
//! in parallel, and `kernel` holds the per-input sums (SIMD and scalar).

mod batch;
mod kernel;

use std::sync::Arc;

use super::blend::Blend;
use super::error::{check_finite, check_len, Result, SurfaceError};
use super::support_index::SupportIndex;
use kernel::compact_record;

/// Dimensions accepted for source (`m`) and shape (`p`) vectors.
pub const MAX_DIM: usize = 16;

/// One key point: where it sits on the domain and where it pulls the surface.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyPoint {
    /// Source vector `w_i` in R^m (a point of the domain for parametric surfaces).
    pub source: Vec<f64>,
    /// Shape vector `t_i` in R^p (the output point it attracts).
    pub shape: Vec<f64>,
    /// Blending function `F_i`.
    pub blend: Blend,
    /// Sharpness `q_i > 0`.
    pub q: f64,
    /// Weight `a_i >= 0`; 0 makes the key point empty.
    pub weight: f64,
}

impl KeyPoint {
    /// A key point with weight 1.
    pub fn new(source: Vec<f64>, shape: Vec<f64>, blend: Blend, q: f64) -> Self {
        KeyPoint {
            source,
            shape,
            blend,
            q,
            weight: 1.0,
        }
    }
}

/// The two-layer network mapping R^m (usually a domain manifold) to R^p.
#[derive(Clone)]
pub struct Network {
    m: usize,
    p: usize,
    sources: Vec<f64>,
    shapes: Vec<f64>,
    q: Vec<f64>,
    weight: Vec<f64>,
    blend: Vec<Blend>,
    normalised: bool,
    /// Key points without compact support: visited for every input.
    global: Vec<u32>,
    index: Option<Arc<SupportIndex>>,
    /// For m = 3, each compact key point's kernel as the SIMD path reads it (see
    /// [`kernel::Gathered`]): `[c, b, w_x, w_y, w_z]`; zeros for the others, empty for other m.
    compact3: Arc<Vec<[f64; 5]>>,
}

impl std::fmt::Debug for Network {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Network")
            .field("m", &self.m)
            .field("p", &self.p)
            .field("n", &self.len())
            .field("normalised", &self.normalised)
            .finish_non_exhaustive()
    }
}

impl Network {
    /// Builds a network from key points, checking every dimension and value.
    pub fn new(m: usize, p: usize, key_points: &[KeyPoint], normalised: bool) -> Result<Self> {
        if key_points.is_empty() {
            return Err(SurfaceError::Empty);
        }
        let n = key_points.len();
        let mut sources = Vec::with_capacity(n * m);
        let mut shapes = Vec::with_capacity(n * p);
        for (i, k) in key_points.iter().enumerate() {
            check_len(|| format!("key_points[{i}].source"), m, k.source.len())?;
            check_len(|| format!("key_points[{i}].shape"), p, k.shape.len())?;
            sources.extend_from_slice(&k.source);
            shapes.extend_from_slice(&k.shape);
        }
        Self::from_parts(
            m,
            p,
            sources,
            shapes,
            key_points.iter().map(|k| k.q).collect(),
            key_points.iter().map(|k| k.weight).collect(),
            key_points.iter().map(|k| k.blend).collect(),
            normalised,
        )
    }

    /// Builds a network from flat arrays: `sources` is n x m and `shapes` n x p, row-major.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        m: usize,
        p: usize,
        sources: Vec<f64>,
        shapes: Vec<f64>,
        q: Vec<f64>,
        weight: Vec<f64>,
        blend: Vec<Blend>,
        normalised: bool,
    ) -> Result<Self> {
        for (what, d) in [("source dimension m", m), ("shape dimension p", p)] {
            if d == 0 || d > MAX_DIM {
                return Err(SurfaceError::Parameter {
                    what: what.into(),
                    value: d as f64,
                    reason: "must be in 1..=16",
                });
            }
        }
        let n = q.len();
        if n == 0 {
            return Err(SurfaceError::Empty);
        }
        if n > u32::MAX as usize {
            return Err(SurfaceError::Parameter {
                what: "key point count".into(),
                value: n as f64,
                reason: "too many key points",
            });
        }
        check_len(|| "sources (n x m)".into(), n * m, sources.len())?;
        check_len(|| "shapes (n x p)".into(), n * p, shapes.len())?;
        check_len(|| "weights".into(), n, weight.len())?;
        check_len(|| "blends".into(), n, blend.len())?;
        for i in 0..n {
            check_finite(
                || format!("key_points[{i}].source"),
                &sources[i * m..(i + 1) * m],
            )?;
            check_finite(
                || format!("key_points[{i}].shape"),
                &shapes[i * p..(i + 1) * p],
            )?;
            if !(q[i].is_finite() && q[i] > 0.0) {
                return Err(SurfaceError::Parameter {
                    what: format!("key_points[{i}].q"),
                    value: q[i],
                    reason: "sharpness must be finite and > 0",
                });
            }
            if !(weight[i].is_finite() && weight[i] >= 0.0) {
                return Err(SurfaceError::Parameter {
                    what: format!("key_points[{i}].weight"),
                    value: weight[i],
                    reason: "weight must be finite and >= 0",
                });
            }
        }
        let mut global = Vec::new();
        let mut compact = Vec::new();
        for i in 0..n {
            match blend[i].support_threshold(q[i]) {
                Some(tau) => compact.push((i as u32, tau)),
                None => global.push(i as u32),
            }
        }
        let index =
            (!compact.is_empty()).then(|| Arc::new(SupportIndex::build(m, &sources, &compact)));
        let compact3 = if m == 3 {
            (0..n)
                .map(|i| match blend[i] {
                    Blend::Compact => compact_record(weight[i], q[i], &sources[i * 3..i * 3 + 3]),
                    _ => [0.0; 5],
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Network {
            m,
            p,
            sources,
            shapes,
            q,
            weight,
            blend,
            normalised,
            global,
            index,
            compact3: Arc::new(compact3),
        })
    }

    /// The normalised network over `sources` (n x m) with one blend and per-key-point
    /// sharpness `q` whose value at each key point's own source is exactly its row of
    /// `targets` (n x p): the shape vectors solve the interpolation system
    /// `sum_i K_ji t_i = target_j`, `K_ji` the normalised blend of key point i at source j
    /// (by LU decomposition, nalgebra). Used for warps whose control points must land
    /// exactly where they are told.
    pub fn interpolating(
        m: usize,
        p: usize,
        sources: Vec<f64>,
        q: Vec<f64>,
        blend: Blend,
        targets: &[f64],
    ) -> Result<Self> {
        let n = q.len();
        check_len(|| "sources (n x m)".into(), n * m, sources.len())?;
        check_len(|| "targets (n x p)".into(), n * p, targets.len())?;
        // Build with placeholder shapes first: this validates sources and sharpness.
        let net = Self::from_parts(
            m,
            p,
            sources,
            vec![0.0; n * p],
            q,
            vec![1.0; n],
            vec![blend; n],
            true,
        )?;
        let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
        for j in 0..n {
            let x = &net.sources[j * m..(j + 1) * m];
            let mut sum = 0.0;
            for i in 0..n {
                let w = &net.sources[i * m..(i + 1) * m];
                let s: f64 = x.iter().zip(w).map(|(a, b)| a * b).sum();
                let v = blend.value(s, net.q[i]);
                k[(j, i)] = v;
                sum += v;
            }
            if sum.is_nan() || sum <= 0.0 {
                return Err(SurfaceError::Parameter {
                    what: format!("key point {j} coverage"),
                    value: sum,
                    reason: "no key point reaches this source",
                });
            }
            for i in 0..n {
                k[(j, i)] /= sum;
            }
        }
        let rhs = nalgebra::DMatrix::from_row_slice(n, p, targets);
        let t = k
            .lu()
            .solve(&rhs)
            .filter(|t| t.iter().all(|v| v.is_finite()))
            .ok_or_else(|| SurfaceError::Parameter {
                what: "interpolation system".into(),
                value: n as f64,
                reason: "singular: key points too close together for their sharpness",
            })?;
        let shapes: Vec<f64> = (0..n)
            .flat_map(|i| (0..p).map(move |c| (i, c)))
            .map(|(i, c)| t[(i, c)])
            .collect();
        net.with_shapes(p, shapes)
    }

    /// Number of key points `n`.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Always false: a network has at least one key point.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Source dimension `m`.
    pub fn input_dim(&self) -> usize {
        self.m
    }

    /// Shape dimension `p`.
    pub fn output_dim(&self) -> usize {
        self.p
    }

    /// Whether the first layer is normalised (formula 6).
    pub fn is_normalised(&self) -> bool {
        self.normalised
    }

    /// Source vectors, n x m row-major.
    pub fn sources(&self) -> &[f64] {
        &self.sources
    }

    /// Shape vectors, n x p row-major.
    pub fn shapes(&self) -> &[f64] {
        &self.shapes
    }

    /// Sharpness per key point.
    pub fn sharpness(&self) -> &[f64] {
        &self.q
    }

    /// Weight per key point.
    pub fn weights(&self) -> &[f64] {
        &self.weight
    }

    /// Blending function per key point.
    pub fn blends(&self) -> &[Blend] {
        &self.blend
    }

    /// Key point `i` as an owned value.
    pub fn key_point(&self, i: usize) -> KeyPoint {
        KeyPoint {
            source: self.sources[i * self.m..(i + 1) * self.m].to_vec(),
            shape: self.shapes[i * self.p..(i + 1) * self.p].to_vec(),
            blend: self.blend[i],
            q: self.q[i],
            weight: self.weight[i],
        }
    }

    /// All key points as owned values.
    pub fn key_points(&self) -> Vec<KeyPoint> {
        (0..self.len()).map(|i| self.key_point(i)).collect()
    }

    /// The same first layer with new shape vectors (n x `p` row-major): extra generators.
    ///
    /// Projections, normal interpolation and colour channels are all such networks; the
    /// spatial index is shared, not rebuilt.
    pub fn with_shapes(&self, p: usize, shapes: Vec<f64>) -> Result<Self> {
        if p == 0 || p > MAX_DIM {
            return Err(SurfaceError::Parameter {
                what: "shape dimension p".into(),
                value: p as f64,
                reason: "must be in 1..=16",
            });
        }
        check_len(|| "shapes (n x p)".into(), self.len() * p, shapes.len())?;
        check_finite(|| "shapes".into(), &shapes)?;
        Ok(Network {
            p,
            shapes,
            ..self.clone()
        })
    }

    /// Whether any key point has compact support (evaluation then uses the spatial index).
    pub fn uses_support_index(&self) -> bool {
        self.index.is_some()
    }

    fn check_input(&self, x: &[f64]) -> Result<()> {
        check_len(|| "input x".into(), self.m, x.len())?;
        check_finite(|| "input x".into(), x)
    }

    /// Key points that may be active in the ball `|x - centre| <= spread`, ascending.
    fn candidates(&self, centre: &[f64], spread: f64, max_norm2: f64, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.global);
        if let Some(index) = &self.index {
            // Tree order, not index order: deterministic for a given query, and the sums
            // only need to match a plain loop to rounding.
            index.candidates(centre, spread, max_norm2, out);
        }
    }

    /// Evaluates `y(x)` over every key point, ignoring the spatial index.
    ///
    /// The reference the indexed paths are tested against.
    pub fn eval_brute_force(&self, x: &[f64]) -> Result<Vec<f64>> {
        self.check_input(x)?;
        let all: Vec<u32> = (0..self.len() as u32).collect();
        let mut y = vec![0.0; self.p];
        self.accumulate(x, &all, &mut y);
        Ok(y)
    }

    /// Evaluates `y(x)` for one input.
    pub fn eval(&self, x: &[f64]) -> Result<Vec<f64>> {
        Ok(self.eval_with_coverage(x)?.0)
    }

    /// Evaluates `y(x)` and the layer-1 sum `sum_i k_i` (0 where no key point reaches x).
    pub fn eval_with_coverage(&self, x: &[f64]) -> Result<(Vec<f64>, f64)> {
        self.check_input(x)?;
        let mut cand = Vec::new();
        let n2 = x.iter().map(|v| v * v).sum();
        self.candidates(x, 0.0, n2, &mut cand);
        let mut y = vec![0.0; self.p];
        let d = self.accumulate(x, &cand, &mut y);
        Ok((y, d))
    }

    /// `y(x)` and its Jacobian `dy/dx` (p x m row-major), exactly, by the derivative
    /// network of formula (12) and the quotient rule for the normalised blend.
    pub fn eval_with_jacobian(&self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        self.check_input(x)?;
        let (m, p) = (self.m, self.p);
        let mut cand = Vec::new();
        let n2 = x.iter().map(|v| v * v).sum();
        self.candidates(x, 0.0, n2, &mut cand);
        let mut y = vec![0.0; p];
        // jac_num = sum a F' t w^T (the derivative network), dden = sum a F' w^T.
        let mut jac = vec![0.0; p * m];
        let mut dden = vec![0.0; m];
        let mut denom = 0.0;
        for &i in &cand {
            let i = i as usize;
            let w = &self.sources[i * m..(i + 1) * m];
            let t = &self.shapes[i * p..(i + 1) * p];
            let s: f64 = x.iter().zip(w).map(|(a, b)| a * b).sum();
            let (f, df) = self.blend[i].value_and_slope(s, self.q[i]);
            let (k, dk) = (self.weight[i] * f, self.weight[i] * df);
            denom += k;
            for g in 0..p {
                y[g] += k * t[g];
                for h in 0..m {
                    jac[g * m + h] += dk * t[g] * w[h];
                }
            }
            for h in 0..m {
                dden[h] += dk * w[h];
            }
        }
        if self.normalised {
            if denom > 0.0 {
                let inv = 1.0 / denom;
                y.iter_mut().for_each(|v| *v *= inv);
                for g in 0..p {
                    for h in 0..m {
                        jac[g * m + h] = (jac[g * m + h] - y[g] * dden[h]) * inv;
                    }
                }
            } else {
                y.fill(0.0);
                jac.fill(0.0);
            }
        }
        Ok((y, jac))
    }
}

/// Random draws the network's tests share.
#[cfg(test)]
mod test_rng {
    /// SplitMix64 in [0, 1).
    pub(super) fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    pub(super) fn unit3(state: &mut u64) -> Vec<f64> {
        loop {
            let v: Vec<f64> = (0..3).map(|_| 2.0 * uniform(state) - 1.0).collect();
            let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if n > 0.1 && n <= 1.0 {
                return v.into_iter().map(|a| a / n).collect();
            }
        }
    }
}
