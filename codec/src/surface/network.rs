//! The Cao En network (paper section 2): `k_i = a_i F_i(x . w_i)`, `y = sum_i k_i t_i`,
//! optionally normalised by `sum_i k_i` (formula 6).
//!
//! Each key point also carries a weight `a_i` (1 by default). A weight of 0 makes an
//! *empty* key point that changes nothing even under normalisation, where a zero shape
//! vector alone would still add to the denominator; morphing pads with such points.

use std::sync::Arc;

use rayon::prelude::*;

use super::blend::Blend;
use super::error::{check_finite, check_len, Result, SurfaceError};
use super::support_index::SupportIndex;

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

/// Inputs per parallel task in batch evaluation (fixed, so output never depends on threads).
const BATCH_BLOCK: usize = 4096;
/// Longest run of inputs that share one spatial query.
const MAX_RUN: usize = 256;

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
        })
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
            index.candidates(centre, spread, max_norm2, out);
            // Ascending order makes the sum's order that of a plain loop over all key points.
            out.sort_unstable();
        }
    }

    /// Layer 1 and 2 at `x` over the key points `cand`; returns the denominator `sum k_i`.
    #[inline]
    fn accumulate(&self, x: &[f64], cand: &[u32], y: &mut [f64]) -> f64 {
        let (m, p) = (self.m, self.p);
        y.fill(0.0);
        let mut denom = 0.0;
        for &i in cand {
            let i = i as usize;
            let w = &self.sources[i * m..(i + 1) * m];
            let s: f64 = x.iter().zip(w).map(|(a, b)| a * b).sum();
            let k = self.weight[i] * self.blend[i].value(s, self.q[i]);
            if k != 0.0 {
                denom += k;
                let t = &self.shapes[i * p..(i + 1) * p];
                for (yj, tj) in y.iter_mut().zip(t) {
                    *yj += k * tj;
                }
            }
        }
        if self.normalised {
            if denom > 0.0 {
                let inv = 1.0 / denom;
                y.iter_mut().for_each(|v| *v *= inv);
            } else {
                y.fill(0.0);
            }
        }
        denom
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

    /// Evaluates a batch of inputs (`xs` is N x m row-major) in parallel; returns N x p.
    ///
    /// Consecutive inputs that lie close together share one spatial query, so batches
    /// ordered along the domain (grids, scanlines, tiles) are fastest. The result does
    /// not depend on the number of threads.
    pub fn eval_batch(&self, xs: &[f64]) -> Result<Vec<f64>> {
        if xs.len() % self.m != 0 {
            return Err(SurfaceError::Dimension {
                what: "batch of inputs (N x m)".into(),
                expected: (xs.len() / self.m + 1) * self.m,
                got: xs.len(),
            });
        }
        check_finite(|| "batch input".into(), xs)?;
        let (m, p) = (self.m, self.p);
        let count = xs.len() / m;
        let mut out = vec![0.0; count * p];
        out.par_chunks_mut(BATCH_BLOCK * p)
            .zip(xs.par_chunks(BATCH_BLOCK * m))
            .for_each(|(ys, xs)| self.eval_block(xs, ys));
        Ok(out)
    }

    /// Evaluates one block sequentially, grouping nearby consecutive inputs per query.
    fn eval_block(&self, xs: &[f64], ys: &mut [f64]) {
        let (m, p) = (self.m, self.p);
        let count = xs.len() / m;
        let mut cand = Vec::new();
        let Some(index) = &self.index else {
            self.candidates(&[], 0.0, 0.0, &mut cand);
            for (x, y) in xs.chunks_exact(m).zip(ys.chunks_exact_mut(p)) {
                self.accumulate(x, &cand, y);
            }
            return;
        };
        // Runs stay within half the finest support radius of their first input, so the
        // candidate superset stays within ~(1.5)^d of the true neighbour count.
        let reach = 0.5 * index.finest_radius;
        let mut start = 0;
        while start < count {
            let c = &xs[start * m..(start + 1) * m];
            let mut end = start;
            let mut spread2: f64 = 0.0;
            let mut max_norm2: f64 = 0.0;
            while end < count && end - start < MAX_RUN {
                let x = &xs[end * m..(end + 1) * m];
                let d2: f64 = x.iter().zip(c).map(|(a, b)| (a - b) * (a - b)).sum();
                if end > start && d2 > reach * reach {
                    break;
                }
                spread2 = spread2.max(d2);
                max_norm2 = max_norm2.max(x.iter().map(|v| v * v).sum());
                end += 1;
            }
            self.candidates(c, spread2.sqrt(), max_norm2, &mut cand);
            for j in start..end {
                self.accumulate(&xs[j * m..(j + 1) * m], &cand, &mut ys[j * p..(j + 1) * p]);
            }
            start = end;
        }
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
