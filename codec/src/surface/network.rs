//! The Cao En network (paper section 2): `k_i = a_i F_i(x . w_i)`, `y = sum_i k_i t_i`,
//! optionally normalised by `sum_i k_i` (formula 6).
//!
//! Each key point also carries a weight `a_i` (1 by default). A weight of 0 makes an
//! *empty* key point that changes nothing even under normalisation, where a zero shape
//! vector alone would still add to the denominator; morphing pads with such points.

use std::sync::Arc;

use pulp::{Arch, Simd, WithSimd};
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
const BATCH_BLOCK: usize = 16384;
/// Highest input dimension binned into cells; larger ones fall back to one query each.
const MAX_BIN_DIM: usize = 6;
/// Side of a binning cell as a fraction of the finest support radius: larger cells mean
/// fewer spatial queries but more candidates per input.
const CELL_FACTOR: f64 = 0.5;

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
    /// [`Gathered`]): `[c, b, w_x, w_y, w_z]`; zeros for the others, empty for other m.
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
    ///
    /// For m = 3 with compact support the kernel runs in SIMD lanes (AVX2 + FMA, or
    /// plain scalar on CPUs without them, chosen at run time by `pulp`). Its sums are
    /// split across lanes and use fused multiply-adds where the CPU has them, so a batch
    /// result can differ from [`Self::eval`] (and between CPUs with and without AVX2) by
    /// rounding only; tests hold both to brute force within 1e-12. On one CPU the output
    /// bits are the same for any thread count.
    pub fn eval_batch(&self, xs: &[f64]) -> Result<Vec<f64>> {
        if !xs.len().is_multiple_of(self.m) {
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
            .for_each_init(Scratch::default, |scratch, (ys, xs)| {
                Arch::new().dispatch(Block {
                    net: self,
                    xs,
                    ys,
                    scratch,
                })
            });
        Ok(out)
    }

    /// Evaluates one block sequentially: inputs are binned into spatial cells, each cell
    /// makes one spatial query, and its inputs are evaluated against those candidates.
    #[inline(always)]
    fn eval_block<S: Simd>(&self, simd: S, xs: &[f64], ys: &mut [f64], scratch: &mut Scratch) {
        let (m, p) = (self.m, self.p);
        let Scratch {
            bins,
            cand,
            gathered,
        } = scratch;
        let Some(index) = &self.index else {
            self.candidates(&[], 0.0, 0.0, cand);
            for (x, y) in xs.chunks_exact(m).zip(ys.chunks_exact_mut(p)) {
                self.accumulate(x, cand, y);
            }
            return;
        };
        bins.bin(xs, m, CELL_FACTOR * index.finest_radius);
        // With no global key point every candidate is compact: the SIMD kernel applies.
        let fast = m == 3 && self.global.is_empty();
        let mut centre = [0.0; MAX_DIM];
        let centre = &mut centre[..m];
        for group in bins.starts.windows(2) {
            let group = &bins.order[group[0] as usize..group[1] as usize];
            let (spread, max_norm2) = bounding_ball(xs, m, group, centre);
            self.candidates(centre, spread, max_norm2, cand);
            let members = group.iter().map(|&j| j as usize);
            if fast {
                gathered.load(simd, self, cand);
                gathered.eval_compact3(simd, self.normalised, xs, ys, members);
            } else {
                for j in members {
                    self.accumulate(&xs[j * m..(j + 1) * m], cand, &mut ys[j * p..(j + 1) * p]);
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

/// `[c, b, w]` of a compact key point, `a F(x . w) = (c + b (x . w - 1))^3`: see
/// [`Gathered`].
fn compact_record(a: f64, q: f64, w: &[f64]) -> [f64; 5] {
    let c = if a == 1.0 { 1.0 } else { a.cbrt() };
    let b = c * q * (1.0 / super::blend::COMPACT_SUPPORT_U);
    [c, b, w[0], w[1], w[2]]
}

/// The inputs of a block grouped by the cubic binning cell they fall in: group `g` is
/// `order[starts[g]..starts[g + 1]]`, groups in order of first appearance, members
/// ascending (deterministic). Buffers are kept from block to block.
#[derive(Default)]
struct Bins {
    /// Cell key of each input.
    keys: Vec<u64>,
    /// Group of each input.
    group: Vec<u32>,
    /// Open-addressing hash table: cell key, group, and the `stamp` of the block that
    /// wrote the slot (older slots count as empty, so the table is never cleared).
    table: Vec<(u64, u32, u32)>,
    stamp: u32,
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl Bins {
    /// Bins the inputs `xs` (N x m) into cells of side `cell`.
    #[inline(always)]
    fn bin(&mut self, xs: &[f64], m: usize, cell: f64) {
        let count = xs.len() / m;
        self.order.clear();
        self.starts.clear();
        if m > MAX_BIN_DIM || cell.is_nan() || cell <= 0.0 {
            // One group per input.
            self.order.extend(0..count as u32);
            self.starts.extend(0..=count as u32);
            return;
        }
        let inv = 1.0 / cell;
        // Cell coordinates packed into one key below 2^63 (so `u64::MAX` is never a key),
        // `bits` per axis; coordinates beyond the range clamp into the edge cell, which
        // only widens that group's query (still exact). Truncating after the offset is
        // floor() up to rounding at cell borders, which only moves an input to the
        // neighbouring cell: grouping never affects exactness.
        let bits = 63 / m as u32;
        let half = (1u64 << (bits - 1)) as f64;
        let top = ((1u64 << bits) - 1) as f64;
        self.keys.clear();
        for x in xs.chunks_exact(m) {
            let mut key = 0u64;
            for v in x {
                key = (key << bits) | (v * inv + half).clamp(0.0, top) as i64 as u64;
            }
            self.keys.push(key);
        }
        let size = (2 * count).next_power_of_two().max(16);
        let shift = 64 - size.trailing_zeros();
        self.stamp = self.stamp.wrapping_add(1);
        if self.table.len() < size || self.stamp == 0 {
            self.table.clear();
            self.table.resize(size.max(self.table.len()), (0, 0, 0));
            self.stamp = 1;
        }
        let stamp = self.stamp;
        let table = &mut self.table[..size];
        self.group.clear();
        // Counts per group first, in `starts`.
        let mut last = (u64::MAX, 0u32);
        for &key in &self.keys {
            if key != last.0 {
                let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> shift) as usize;
                let g = loop {
                    let slot = &mut table[h];
                    if slot.2 != stamp {
                        *slot = (key, self.starts.len() as u32, stamp);
                        self.starts.push(0);
                        break slot.1;
                    }
                    if slot.0 == key {
                        break slot.1;
                    }
                    h = (h + 1) & (size - 1);
                };
                last = (key, g);
            }
            self.starts[last.1 as usize] += 1;
            self.group.push(last.1);
        }
        // Exclusive prefix sums, then scatter (members stay ascending).
        let mut sum = 0;
        for s in self.starts.iter_mut() {
            let c = *s;
            *s = sum;
            sum += c;
        }
        self.starts.push(sum);
        self.order.resize(count, 0);
        let mut next = self.starts.clone();
        for (j, &g) in self.group.iter().enumerate() {
            self.order[next[g as usize] as usize] = j as u32;
            next[g as usize] += 1;
        }
    }
}

/// Centre (written to `centre`), radius and largest squared norm of a group of inputs
/// (binning keys): the centre and half diagonal of their bounding box.
#[inline(always)]
fn bounding_ball(xs: &[f64], m: usize, group: &[u32], centre: &mut [f64]) -> (f64, f64) {
    let mut lo = [f64::INFINITY; MAX_DIM];
    let mut hi = [f64::NEG_INFINITY; MAX_DIM];
    let mut max_norm2 = 0.0f64;
    for &j in group {
        let j = j as usize;
        let x = &xs[j * m..(j + 1) * m];
        let mut n2 = 0.0;
        for (a, &v) in x.iter().enumerate() {
            lo[a] = lo[a].min(v);
            hi[a] = hi[a].max(v);
            n2 += v * v;
        }
        max_norm2 = max_norm2.max(n2);
    }
    let (mut spread2, mut size) = (0.0, 0.0f64);
    for a in 0..m {
        centre[a] = 0.5 * (lo[a] + hi[a]);
        let h = 0.5 * (hi[a] - lo[a]);
        spread2 += h * h;
        size = size.max(centre[a].abs());
    }
    // Pad for the rounding of the centre, so the query stays a superset.
    let spread = spread2.sqrt();
    (spread + 1e-12 * (spread + size) + 1e-15, max_norm2)
}

/// Per-thread scratch of batch evaluation, reused from block to block.
#[derive(Default)]
struct Scratch {
    bins: Bins,
    cand: Vec<u32>,
    gathered: Gathered,
}

/// One block of [`Network::eval_batch`], compiled for the SIMD level `pulp` picks.
struct Block<'a> {
    net: &'a Network,
    xs: &'a [f64],
    ys: &'a mut [f64],
    scratch: &'a mut Scratch,
}

impl WithSimd for Block<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        self.net.eval_block(simd, self.xs, self.ys, self.scratch);
    }
}

/// Candidate key points of one cell in contiguous arrays (structure of arrays), padded to
/// whole SIMD vectors, so the per-input loop is branch-free and runs in SIMD lanes: the
/// fast path for m = 3 with compact support only; [`Network::accumulate`] is its scalar
/// reference, tested equal to 1e-12.
///
/// The compact kernel with its weight is `a (1 - q (1 - s)/3)^3 = (c + b (s - 1))^3` with
/// `c = a^(1/3)`, `b = c q / 3`, clamped at 0 outside the support. `s - 1` is exact for
/// `s >= 1/2` and never cancels, so this is as accurate as the scalar reference;
/// folding it further into an affine form `alpha + w' . x` would save two operations but
/// cancel terms of size q/3, losing ~q ulps.
#[derive(Default)]
struct Gathered {
    c: Vec<f64>,
    b: Vec<f64>,
    wx: Vec<f64>,
    wy: Vec<f64>,
    wz: Vec<f64>,
    /// Shape vectors output-major: `t[j * len + c]`.
    t: Vec<f64>,
    p: usize,
}

impl Gathered {
    /// Loads the candidates (all compact), padded to whole vectors of `S`.
    #[inline(always)]
    fn load<S: Simd>(&mut self, _simd: S, net: &Network, cand: &[u32]) {
        let p = net.p;
        // Padding entries have c = b = 0: k = 0 exactly.
        let len = cand.len().div_ceil(S::F64_LANES) * S::F64_LANES;
        let records = &net.compact3[..];
        for (c, v) in [
            &mut self.c,
            &mut self.b,
            &mut self.wx,
            &mut self.wy,
            &mut self.wz,
        ]
        .into_iter()
        .enumerate()
        {
            v.clear();
            v.extend(cand.iter().map(|&i| records[i as usize][c]));
            v.resize(len, 0.0);
        }
        self.t.clear();
        for j in 0..p {
            self.t
                .extend(cand.iter().map(|&i| net.shapes[i as usize * p + j]));
            self.t.resize((j + 1) * len, 0.0);
        }
        self.p = p;
    }

    /// Evaluates the inputs `members` (indices into the block) against the loaded
    /// candidates, two at a time where the output dimension allows.
    #[inline(always)]
    fn eval_compact3<S: Simd>(
        &self,
        simd: S,
        normalised: bool,
        xs: &[f64],
        ys: &mut [f64],
        members: impl Iterator<Item = usize>,
    ) {
        match self.p {
            1 => self.pairs::<S, 1>(simd, normalised, xs, ys, members),
            2 => self.pairs::<S, 2>(simd, normalised, xs, ys, members),
            3 => self.pairs::<S, 3>(simd, normalised, xs, ys, members),
            4 => self.pairs::<S, 4>(simd, normalised, xs, ys, members),
            p => {
                for j in members {
                    let den =
                        self.sums_any(simd, &xs[j * 3..j * 3 + 3], &mut ys[j * p..(j + 1) * p]);
                    finish(normalised, den, &mut ys[j * p..(j + 1) * p]);
                }
            }
        }
    }

    #[inline(always)]
    fn pairs<S: Simd, const P: usize>(
        &self,
        simd: S,
        normalised: bool,
        xs: &[f64],
        ys: &mut [f64],
        mut members: impl Iterator<Item = usize>,
    ) {
        let x = |j: usize| -> [f64; 3] { [xs[j * 3], xs[j * 3 + 1], xs[j * 3 + 2]] };
        let mut put = |j: usize, (mut y, den): ([f64; P], f64)| {
            finish(normalised, den, &mut y);
            ys[j * P..(j + 1) * P].copy_from_slice(&y);
        };
        while let Some(a) = members.next() {
            match members.next() {
                Some(b) => {
                    let [ra, rb] = self.sums::<S, P, 2>(simd, [x(a), x(b)]);
                    put(a, ra);
                    put(b, rb);
                }
                None => {
                    let [ra] = self.sums::<S, P, 1>(simd, [x(a)]);
                    put(a, ra);
                }
            }
        }
    }

    /// `y_j = sum_c k_c t_cj` for P outputs and `sum_c k_c`, for N inputs at once (the
    /// candidates' loads are shared; each input's arithmetic is the same for any N).
    #[inline(always)]
    fn sums<S: Simd, const P: usize, const N: usize>(
        &self,
        simd: S,
        x: [[f64; 3]; N],
    ) -> [([f64; P], f64); N] {
        let cs = S::as_simd_f64s(&self.c).0;
        let bs = S::as_simd_f64s(&self.b).0;
        let wx = S::as_simd_f64s(&self.wx).0;
        let wy = S::as_simd_f64s(&self.wy).0;
        let wz = S::as_simd_f64s(&self.wz).0;
        let len = self.c.len();
        let t: [&[S::f64s]; P] =
            std::array::from_fn(|j| S::as_simd_f64s(&self.t[j * len..(j + 1) * len]).0);
        let groups = cs.len();
        assert!(
            bs.len() == groups && wx.len() == groups && wy.len() == groups && wz.len() == groups
        );
        assert!(t.iter().all(|t| t.len() == groups));
        let zero = simd.splat_f64s(0.0);
        let one = simd.splat_f64s(1.0);
        let mut xv = [[zero; 3]; N];
        for n in 0..N {
            for a in 0..3 {
                xv[n][a] = simd.splat_f64s(x[n][a]);
            }
        }
        let mut den = [zero; N];
        let mut acc = [[zero; P]; N];
        for g in 0..groups {
            for n in 0..N {
                let s = simd.mul_f64s(xv[n][2], wz[g]);
                let s = simd.mul_add_e_f64s(xv[n][1], wy[g], s);
                let s = simd.mul_add_e_f64s(xv[n][0], wx[g], s);
                let v = simd.mul_add_e_f64s(bs[g], simd.sub_f64s(s, one), cs[g]);
                let v = simd.max_f64s(v, zero);
                let k = simd.mul_f64s(simd.mul_f64s(v, v), v);
                den[n] = simd.add_f64s(den[n], k);
                for j in 0..P {
                    acc[n][j] = simd.mul_add_e_f64s(k, t[j][g], acc[n][j]);
                }
            }
        }
        let mut out = [([0.0; P], 0.0); N];
        for ((y, d), (acc, den)) in out.iter_mut().zip(acc.iter().zip(den)) {
            for (y, &a) in y.iter_mut().zip(acc) {
                *y = simd.reduce_sum_f64s(a);
            }
            *d = simd.reduce_sum_f64s(den);
        }
        out
    }

    /// [`Self::sums`] for any number of outputs, one input.
    #[inline(always)]
    fn sums_any<S: Simd>(&self, _simd: S, x: &[f64], y: &mut [f64]) -> f64 {
        let len = self.c.len();
        y.fill(0.0);
        let mut den = 0.0;
        for c in 0..len {
            let s = x[0] * self.wx[c] + x[1] * self.wy[c] + x[2] * self.wz[c];
            let v = (self.c[c] + self.b[c] * (s - 1.0)).max(0.0);
            let k = v * v * v;
            den += k;
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += k * self.t[j * len + c];
            }
        }
        den
    }
}

/// Normalises `y` by `den` if the network is normalised (0 where nothing reaches).
#[inline(always)]
fn finish(normalised: bool, den: f64, y: &mut [f64]) {
    if normalised {
        if den > 0.0 {
            let inv = 1.0 / den;
            y.iter_mut().for_each(|v| *v *= inv);
        } else {
            y.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SplitMix64 in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn unit3(state: &mut u64) -> Vec<f64> {
        loop {
            let v: Vec<f64> = (0..3).map(|_| 2.0 * uniform(state) - 1.0).collect();
            let n = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if n > 0.1 && n <= 1.0 {
                return v.into_iter().map(|a| a / n).collect();
            }
        }
    }

    /// One block through `eval_block` at the given SIMD level.
    fn block_with<S: Simd>(simd: S, net: &Network, xs: &[f64]) -> Vec<f64> {
        let mut ys = vec![0.0; xs.len() / 3 * net.p];
        Block {
            net,
            xs,
            ys: &mut ys,
            scratch: &mut Scratch::default(),
        }
        .with_simd(simd);
        ys
    }

    /// The SIMD kernel at every level this CPU has (and plain scalar, what a CPU without
    /// AVX2 runs) equals brute force: n not a multiple of any lane count, weights other
    /// than 1 (cube roots in the kernel's form) and 0, inputs reached by no key point,
    /// every output dimension of the specialised and the general kernel.
    #[test]
    fn simd_kernel_equals_brute_force_at_every_level() {
        let mut st = 5;
        for (n, p) in [(1usize, 1usize), (7, 2), (13, 3), (61, 4), (203, 5), (9, 7)] {
            let kps: Vec<KeyPoint> = (0..n)
                .map(|i| {
                    let mut k = KeyPoint::new(
                        unit3(&mut st),
                        (0..p).map(|_| uniform(&mut st) - 0.5).collect(),
                        Blend::Compact,
                        20.0 + 200.0 * uniform(&mut st),
                    );
                    k.weight = [1.0, 0.0, 0.3, 2.5][i % 4];
                    k
                })
                .collect();
            for normalised in [true, false] {
                let net = Network::new(3, p, &kps, normalised).unwrap();
                // Unordered inputs plus a far-away one: many reach no key point at all.
                let mut xs: Vec<f64> = (0..501).flat_map(|_| unit3(&mut st)).collect();
                xs.extend([5.0, -7.0, 9.0]);
                let brute: Vec<f64> = xs
                    .chunks_exact(3)
                    .flat_map(|x| net.eval_brute_force(x).unwrap())
                    .collect();
                assert!(brute.iter().filter(|v| **v == 0.0).count() > 0);
                let scalar = block_with(pulp::Scalar::new(), &net, &xs);
                let dispatched = net.eval_batch(&xs).unwrap();
                #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
                let v3 = pulp::x86::V3::try_new().map(|s| block_with(s, &net, &xs));
                #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
                let v3: Option<Vec<f64>> = None;
                for got in [Some(scalar), Some(dispatched), v3].into_iter().flatten() {
                    for (a, b) in got.iter().zip(&brute) {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                            "n={n} p={p}: {a} vs {b}"
                        );
                    }
                }
            }
        }
    }

    /// Binning groups every input exactly once, members ascending, whatever the cell;
    /// one `Bins` reused across blocks of different sizes (its table is never cleared).
    #[test]
    fn bins_partition_the_block() {
        let mut st = 9;
        let mut bins = Bins::default();
        let xs: Vec<f64> = (0..3000).map(|_| 4.0 * uniform(&mut st) - 2.0).collect();
        for (m, cell) in [
            (3usize, 0.3),
            (3, 1e-9),
            (3, 1e9),
            (1, 0.01),
            (6, 0.5),
            (10, 0.5),
            (3, 0.0),
        ] {
            let xs = &xs[..xs.len() / m * m / (1 + m % 2)];
            bins.bin(xs, m, cell);
            let mut seen = vec![false; xs.len() / m];
            for g in bins.starts.windows(2) {
                let members = &bins.order[g[0] as usize..g[1] as usize];
                assert!(!members.is_empty() && members.windows(2).all(|w| w[0] < w[1]));
                members.iter().for_each(|&j| seen[j as usize] = true);
            }
            assert!(seen.iter().all(|s| *s) && bins.order.len() == seen.len());
            // Same cells, same groups, when the block is binned again.
            let before = (bins.starts.clone(), bins.order.clone());
            bins.bin(xs, m, cell);
            assert_eq!(before, (bins.starts.clone(), bins.order.clone()));
        }
    }
}
