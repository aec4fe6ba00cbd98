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
/// Highest input dimension binned into cells; larger ones fall back to one query each.
const MAX_BIN_DIM: usize = 6;

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
            if !(sum > 0.0) {
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

    /// Evaluates one block sequentially: inputs are binned into spatial cells, each cell
    /// makes one spatial query, and its inputs are evaluated against those candidates.
    fn eval_block(&self, xs: &[f64], ys: &mut [f64]) {
        let (m, p) = (self.m, self.p);
        let mut cand = Vec::new();
        let Some(index) = &self.index else {
            self.candidates(&[], 0.0, 0.0, &mut cand);
            for (x, y) in xs.chunks_exact(m).zip(ys.chunks_exact_mut(p)) {
                self.accumulate(x, &cand, y);
            }
            return;
        };
        let mut gathered = Gathered::default();
        for group in bin_by_cell(xs, m, 0.5 * index.finest_radius) {
            let (centre, spread, max_norm2) = bounding_ball(xs, m, &group);
            self.candidates(&centre, spread, max_norm2, &mut cand);
            if m == 3 && gathered.load(self, &cand) {
                for &j in &group {
                    let j = j as usize;
                    gathered.eval_compact3(
                        &xs[j * 3..j * 3 + 3],
                        self.normalised,
                        &mut ys[j * p..(j + 1) * p],
                    );
                }
            } else {
                for &j in &group {
                    let j = j as usize;
                    self.accumulate(&xs[j * m..(j + 1) * m], &cand, &mut ys[j * p..(j + 1) * p]);
                }
            }
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

/// Groups the inputs of a block (indices into `xs`) by the cubic cell of side `cell`
/// they fall in, in a deterministic order.
fn bin_by_cell(xs: &[f64], m: usize, cell: f64) -> Vec<Vec<u32>> {
    let count = xs.len() / m;
    if m > MAX_BIN_DIM || !(cell > 0.0) {
        return (0..count as u32).map(|j| vec![j]).collect();
    }
    let inv = 1.0 / cell;
    // Cell coordinates packed into one integer, `bits` per axis; coordinates beyond the
    // range clamp into the edge cell, which only widens that group's query (still exact).
    let bits = 63 / m as u32;
    let half = 1i64 << (bits - 1);
    let mut keyed: Vec<(u64, u32)> = (0..count)
        .map(|j| {
            let mut key = 0u64;
            for v in &xs[j * m..(j + 1) * m] {
                let c = ((v * inv).floor() as i64).clamp(-half, half - 1) + half;
                key = (key << bits) | c as u64;
            }
            (key, j as u32)
        })
        .collect();
    keyed.sort_unstable();
    let mut groups: Vec<Vec<u32>> = Vec::new();
    let mut last = None;
    for (key, j) in keyed {
        if last != Some(key) {
            groups.push(Vec::new());
            last = Some(key);
        }
        groups.last_mut().expect("pushed above").push(j);
    }
    groups
}

/// Centre (the centroid), radius and largest squared norm of a group of inputs.
fn bounding_ball(xs: &[f64], m: usize, group: &[u32]) -> (Vec<f64>, f64, f64) {
    let mut centre = vec![0.0; m];
    let mut max_norm2 = 0.0f64;
    for &j in group {
        let x = &xs[j as usize * m..(j as usize + 1) * m];
        centre.iter_mut().zip(x).for_each(|(c, v)| *c += v);
        max_norm2 = max_norm2.max(x.iter().map(|v| v * v).sum());
    }
    let inv = 1.0 / group.len() as f64;
    centre.iter_mut().for_each(|c| *c *= inv);
    let spread2 = group
        .iter()
        .map(|&j| {
            xs[j as usize * m..(j as usize + 1) * m]
                .iter()
                .zip(&centre)
                .map(|(a, b)| (a - b) * (a - b))
                .sum()
        })
        .fold(0.0f64, f64::max);
    // Pad for the rounding of the centroid, so the query stays a superset.
    (centre, spread2.sqrt() * (1.0 + 1e-12) + 1e-15, max_norm2)
}

/// Candidate key points of one cell in contiguous arrays (structure of arrays), so the
/// per-input loop is branch-free and vectorisable: the fast path for m = 3 with compact
/// support only; [`Network::accumulate`] is its scalar reference, tested equal to 1e-12.
///
/// The compact kernel is folded into an affine form per key point:
/// `a (1 - q (1 - s)/3)^3 = (alpha + w' . x)^3` with `c = a^(1/3)`, `alpha = c (1 - q/3)`,
/// `w' = c q w / 3`, clamped at 0 outside the support.
#[derive(Default)]
struct Gathered {
    alpha: Vec<f64>,
    wx: Vec<f64>,
    wy: Vec<f64>,
    wz: Vec<f64>,
    /// Shape vectors output-major: `t[j * len + c]`.
    t: Vec<f64>,
    p: usize,
}

/// Accumulator lanes of the fast path's sums (breaks the add dependency chain).
const LANES: usize = 4;

impl Gathered {
    /// Loads the candidates; false if any is not compact (the caller then falls back).
    fn load(&mut self, net: &Network, cand: &[u32]) -> bool {
        if cand
            .iter()
            .any(|&i| net.blend[i as usize] != Blend::Compact)
        {
            return false;
        }
        let p = net.p;
        // Padding entries have alpha = 0 and w' = 0: k = 0 exactly.
        let len = cand.len().div_ceil(LANES) * LANES;
        for v in [&mut self.alpha, &mut self.wx, &mut self.wy, &mut self.wz] {
            v.clear();
            v.resize(len, 0.0);
        }
        self.t.clear();
        self.t.resize(len * p, 0.0);
        self.p = p;
        let third = 1.0 / super::blend::COMPACT_SUPPORT_U;
        for (c, &i) in cand.iter().enumerate() {
            let i = i as usize;
            let a = net.weight[i];
            let cube_root = if a == 1.0 { 1.0 } else { a.cbrt() };
            let b = cube_root * net.q[i] * third;
            self.alpha[c] = cube_root - b;
            self.wx[c] = b * net.sources[i * 3];
            self.wy[c] = b * net.sources[i * 3 + 1];
            self.wz[c] = b * net.sources[i * 3 + 2];
            for j in 0..p {
                self.t[j * len + c] = net.shapes[i * p + j];
            }
        }
        true
    }

    fn eval_compact3(&self, x: &[f64], normalised: bool, y: &mut [f64]) {
        let denom = match self.p {
            1 => self.sums::<1>(x, y),
            2 => self.sums::<2>(x, y),
            3 => self.sums::<3>(x, y),
            4 => self.sums::<4>(x, y),
            5 => self.sums::<5>(x, y),
            _ => self.sums_any(x, y),
        };
        if normalised {
            if denom > 0.0 {
                let inv = 1.0 / denom;
                y.iter_mut().for_each(|v| *v *= inv);
            } else {
                y.fill(0.0);
            }
        }
    }

    /// `y_j = sum_c k_c t_cj` for P outputs and the returned `sum_c k_c`, in one pass.
    #[inline]
    fn sums<const P: usize>(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let (x0, x1, x2) = (x[0], x[1], x[2]);
        let len = self.alpha.len();
        let mut den = [0.0; LANES];
        let mut acc = [[0.0; LANES]; P];
        let t: [&[f64]; P] = std::array::from_fn(|j| &self.t[j * len..(j + 1) * len]);
        let groups = self
            .alpha
            .chunks_exact(LANES)
            .zip(self.wx.chunks_exact(LANES))
            .zip(self.wy.chunks_exact(LANES).zip(self.wz.chunks_exact(LANES)));
        for (g, ((al, wx), (wy, wz))) in groups.enumerate() {
            let (al, wx, wy, wz): (&[f64; LANES], &[f64; LANES], &[f64; LANES], &[f64; LANES]) = (
                al.try_into().expect("exact chunk"),
                wx.try_into().expect("exact chunk"),
                wy.try_into().expect("exact chunk"),
                wz.try_into().expect("exact chunk"),
            );
            let mut k = [0.0; LANES];
            for l in 0..LANES {
                let v = (al[l] + x0 * wx[l] + x1 * wy[l] + x2 * wz[l]).max(0.0);
                k[l] = v * v * v;
                den[l] += k[l];
            }
            for j in 0..P {
                let tj: &[f64; LANES] = t[j][g * LANES..(g + 1) * LANES]
                    .try_into()
                    .expect("exact chunk");
                for l in 0..LANES {
                    acc[j][l] += k[l] * tj[l];
                }
            }
        }
        for j in 0..P {
            y[j] = (acc[j][0] + acc[j][1]) + (acc[j][2] + acc[j][3]);
        }
        (den[0] + den[1]) + (den[2] + den[3])
    }

    /// [`Self::sums`] for any number of outputs.
    fn sums_any(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let len = self.alpha.len();
        y.fill(0.0);
        let mut den = 0.0;
        for c in 0..len {
            let v = (self.alpha[c] + x[0] * self.wx[c] + x[1] * self.wy[c] + x[2] * self.wz[c])
                .max(0.0);
            let k = v * v * v;
            den += k;
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += k * self.t[j * len + c];
            }
        }
        den
    }
}
