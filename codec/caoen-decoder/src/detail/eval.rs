//! The layer's evaluation: at one position, and summed on a grid with deblocking and
//! lapping.

use super::adaptive::BlockSteps;
use super::budget::{bytes_of, LayerBudget};
use super::dct::{self, COEFFS, N};
use super::deblock::{edge_basis, edge_weight, gate, Deblock};
use super::lapping::Lapping;
use super::weights::{self, WeightTable};
use super::{Detail, DetailPlane, ZERO};
use crate::keyset::Grid;
use crate::CodecError;

/// A chroma block's coefficients with luma factor `a` (eighths): its own (none: all
/// zero) plus `a / 8` times its luma block's, the one rule of the scalar and grid paths.
fn plus_luma(own: Option<[f64; COEFFS]>, a: i32, luma: &[f64; COEFFS]) -> [f64; COEFFS] {
    let own = own.unwrap_or([0.0; COEFFS]);
    std::array::from_fn(|z| own[z] + a as f64 / 8.0 * luma[z])
}

impl Detail {
    /// The layer at one position (coded pixels), one value per plane: the same
    /// function [`DetailEval`] sums on a grid, deblocking included, for callers that
    /// sample anywhere (warps), and the scalar reference its tests compare with.
    pub fn at(&self, x: f64, y: f64) -> Vec<f64> {
        let tables = weights::plane_tables(self.weights, self.planes.len());
        self.planes
            .iter()
            .zip(&self.steps)
            .enumerate()
            .map(|(pi, (p, &step))| {
                let (bx, tx) = locate(x, p.cols);
                let (by, ty) = locate(y, p.rows);
                let series = |bx: usize, by: usize, tx: f64, ty: f64| {
                    let Some(c) = self.block_coefficients(pi, bx, by, &tables) else {
                        return 0.0;
                    };
                    let (bu, bv) = (dct::basis_at(tx), dct::basis_at(ty));
                    let mut sum = 0.0;
                    for v in 0..N {
                        for u in 0..N {
                            sum += c[v * N + u] * bv[v] as f64 * bu[u] as f64;
                        }
                    }
                    sum
                };
                let mut value = match self.lapping {
                    // The post-filter along x, then along y: per axis the position's own
                    // block and, near an edge, the neighbour at the mirror position.
                    Some(l) => {
                        let terms = |p: f64, count: usize, own: usize, t: f64| match l.at(p, count)
                        {
                            Some((_, nb, w)) => {
                                [(own, t, 1.0 - w as f64), (nb, N as f64 - t, w as f64)]
                            }
                            None => [(own, t, 1.0), (own, t, 0.0)],
                        };
                        let mut sum = 0.0;
                        for (bx, tx, wx) in terms(x, p.cols, bx, tx) {
                            for (by, ty, wy) in terms(y, p.rows, by, ty) {
                                if wx * wy != 0.0 {
                                    sum += wx * wy * series(bx, by, tx, ty);
                                }
                            }
                        }
                        sum
                    }
                    None => series(bx, by, tx, ty),
                };
                if let Some(d) = self.deblock {
                    let (t, r) = (d.threshold(step), d.radius_px());
                    let edge = N as f64;
                    if let Some((e, w)) = edge_weight(x, p.cols, r) {
                        let step = series(e, by, 0.0, ty) - series(e - 1, by, edge, ty);
                        value += (w * gate(step as f32, t)) as f64;
                    }
                    if let Some((e, w)) = edge_weight(y, p.rows, r) {
                        let step = series(bx, e, tx, 0.0) - series(bx, e - 1, tx, edge);
                        value += (w * gate(step as f32, t)) as f64;
                    }
                }
                value
            })
            .collect()
    }

    /// The cosine-series coefficients of block `(bx, by)` of plane `pi` (row-major),
    /// if any is nonzero: its levels times the step, the block's factor and the
    /// frequency weights (`tables`, per plane), a merged group's block its part of
    /// the group's, and a chroma block with a luma factor `a` that plus `a / 8` times
    /// the luma block's.
    pub fn block_coefficients(
        &self,
        pi: usize,
        bx: usize,
        by: usize,
        tables: &[WeightTable],
    ) -> Option<[f64; COEFFS]> {
        let p = &self.planes[pi];
        let i = by * p.cols + bx;
        let factor = |i: usize| self.block_steps.as_ref().map_or(1.0, |b| b.factor(i));
        let own = p.coefficients(
            bx,
            by,
            self.steps[pi] * factor(p.coded_block_of(i)),
            &tables[pi],
        );
        let a = p.factor(i);
        if a == 0 {
            return own;
        }
        let Some(luma) = self.planes[0].coefficients(bx, by, self.steps[0] * factor(i), &tables[0])
        else {
            return own;
        };
        Some(plus_luma(own, a, &luma))
    }
}

/// One plane prepared for evaluation.
struct PlaneEval {
    /// Dequantised coefficients of the coded blocks, each block's `v1 x u1` corner up
    /// to its last nonzero row and column (row-major), one after the other: most
    /// blocks' high frequencies are zero, so a decoder holds a fraction of 64 values
    /// per block.
    coeffs: Vec<f32>,
    /// Per coded block: where its corner starts in `coeffs`, and `(v1, u1)`.
    extent: Vec<(u32, u8, u8)>,
    /// Per block: index into `extent`, or [`ZERO`].
    index: Vec<u32>,
    /// Blocks per row.
    cols: usize,
}

/// The detail layer prepared for evaluation on one grid.
pub struct DetailEval {
    grid: Grid,
    planes: Vec<PlaneEval>,
    /// Per block column: its first grid column, how many it covers, and where their
    /// basis values start in `basis_t`.
    columns: Vec<(usize, usize, usize)>,
    /// Per block column, the basis transposed: `basis_t[start + u n + k] = b_u` at the
    /// column's `k`-th grid column (`n` columns), so the sum over `u` runs along rows.
    basis_t: Vec<f32>,
    /// Per grid row: block row and basis values.
    rows: Vec<(usize, [f32; N])>,
    /// Grid columns near a vertical block edge: `(column, edge block column, weight)`.
    vcols: Vec<(usize, usize, f32)>,
    /// Per grid row near a horizontal block edge: `(edge block row, weight)`.
    hrows: Vec<Option<(usize, f32)>>,
    /// Per plane: the step below which a step across an edge is smoothed (none
    /// without deblocking).
    thresholds: Vec<f32>,
    /// Grid columns within a pixel of a vertical block edge, with lapping: `(column,
    /// own block column, neighbour block column, weight)`.
    lap_cols: Vec<(usize, usize, usize, f32)>,
    /// Per grid row within a pixel of a horizontal block edge, with lapping:
    /// `(neighbour block row, weight)`.
    lap_rows: Vec<Option<(usize, f32)>>,
}

/// Each plane's deblocking threshold, or none.
fn thresholds(detail: &Detail) -> Vec<f32> {
    match detail.deblock {
        Some(d) => detail.steps.iter().map(|&s| d.threshold(s)).collect(),
        None => Vec::new(),
    }
}

/// Block index and in-block position of coordinate `p` (pixels), clamped to the
/// blocks: positions off the image belong to its edge blocks' series.
#[inline]
fn locate(p: f64, count: usize) -> (usize, f64) {
    let b = (p / N as f64).floor().clamp(0.0, count as f64 - 1.0) as usize;
    (b, p - (b * N) as f64)
}

impl PlaneEval {
    /// One plane's coefficients (levels times `step`, the block's factor and the
    /// frequency weights) and their extents; a chroma plane's blocks with a luma factor
    /// add that times the luma block's coefficients (`luma`: the plane, its step and
    /// weights).
    fn new(
        p: &DetailPlane,
        step: f64,
        block_steps: Option<&BlockSteps>,
        weights: &WeightTable,
        luma: Option<(&DetailPlane, f64, &WeightTable)>,
    ) -> Self {
        let (n_coeffs, n_extents) = PlaneEval::sizes(p, luma.is_some());
        let mut coeffs = Vec::with_capacity(n_coeffs);
        coeffs.resize(p.levels.len(), 0.0f32);
        for (i, &k) in p.index.iter().enumerate() {
            if k != ZERO {
                let (at, v1, u1) = p.spans[k as usize];
                let s = step * block_steps.map_or(1.0, |b| b.factor(i));
                let (at, u1) = (at as usize, u1 as usize);
                for v in 0..v1 as usize {
                    let row = at + v * u1..at + v * u1 + u1;
                    for ((c, &q), w) in coeffs[row.clone()]
                        .iter_mut()
                        .zip(&p.levels[row])
                        .zip(&weights[0][v * N..])
                    {
                        *c = (q as f64 * s * w) as f32;
                    }
                }
            }
        }
        let mut extent = Vec::with_capacity(n_extents);
        extent.extend_from_slice(&p.spans);
        let mut eval = PlaneEval {
            coeffs,
            extent,
            index: p.index.clone(),
            cols: p.cols,
        };
        // A merged group's blocks get their quadrants' coefficients, appended (its
        // first block's levels stay unused where they are).
        for i in (0..p.index.len()).filter(|&i| p.merged[i] != 0) {
            // The group is quantised with its first block's step.
            let s = step * block_steps.map_or(1.0, |b| b.factor(p.coded_block_of(i)));
            eval.replace(i, p.coefficients(i % p.cols, i / p.cols, s, weights));
        }
        // So do chroma blocks with a luma factor, their own series plus the factor
        // times luma's.
        if let Some((l, lstep, lw)) = luma {
            for i in (0..p.index.len()).filter(|&i| p.factor(i) != 0) {
                let f = block_steps.map_or(1.0, |b| b.factor(i));
                let (bx, by) = (i % p.cols, i / p.cols);
                let Some(l) = l.coefficients(bx, by, lstep * f, lw) else {
                    continue;
                };
                eval.replace(
                    i,
                    Some(plus_luma(
                        p.coefficients(bx, by, step * f, weights),
                        p.factor(i),
                        &l,
                    )),
                );
            }
        }
        eval
    }

    /// How many coefficients and extents the plane's evaluator holds at most: its
    /// levels' and, appended, a whole block for each block of a merged group and, with
    /// luma (`with_luma`), each block with a luma factor.
    fn sizes(p: &DetailPlane, with_luma: bool) -> (usize, usize) {
        let merged = p.merged.iter().filter(|&&g| g != 0).count();
        let factors = if with_luma {
            p.factors.iter().filter(|&&a| a != 0).count()
        } else {
            0
        };
        let appended = merged + factors;
        (p.levels.len() + appended * COEFFS, p.spans.len() + appended)
    }

    /// The bytes [`PlaneEval::new`] allocates for `p`'s coefficients and extents.
    fn bytes(p: &DetailPlane, with_luma: bool) -> u64 {
        let (c, e) = PlaneEval::sizes(p, with_luma);
        bytes_of::<f32>(c) + bytes_of::<(u32, u8, u8)>(e)
    }

    /// Block `i`'s coefficients become `c` (none: all zero), appended.
    fn replace(&mut self, i: usize, c: Option<[f64; COEFFS]>) {
        let Some(c) = c else {
            self.index[i] = ZERO;
            return;
        };
        let v1 = (0..N)
            .rev()
            .find(|&v| c[v * N..v * N + N].iter().any(|&x| x != 0.0))
            .map_or(0, |v| v + 1);
        let u1 = (0..N)
            .rev()
            .find(|&u| (0..N).any(|v| c[v * N + u] != 0.0))
            .map_or(0, |u| u + 1);
        if v1 == 0 {
            self.index[i] = ZERO;
            return;
        }
        self.index[i] = self.extent.len() as u32;
        self.extent
            .push((self.coeffs.len() as u32, v1 as u8, u1 as u8));
        for v in 0..v1 {
            self.coeffs
                .extend(c[v * N..v * N + u1].iter().map(|&x| x as f32));
        }
    }
}

impl DetailEval {
    /// Prepares `detail` for evaluation at the positions of `grid` (coded pixels).
    pub fn new(detail: &Detail, grid: &Grid) -> Self {
        let (cols, rows) = detail.planes.first().map_or((1, 1), |p| (p.cols, p.rows));
        let mut eval = DetailEval::geometry(cols, rows, grid, detail.deblock, detail.lapping);
        eval.thresholds = thresholds(detail);
        let tables = weights::plane_tables(detail.weights, detail.planes.len());
        eval.planes = detail
            .planes
            .iter()
            .enumerate()
            .map(|(pi, p)| {
                let luma = (pi > 0).then(|| (&detail.planes[0], detail.steps[0], &tables[0]));
                PlaneEval::new(
                    p,
                    detail.steps[pi],
                    detail.block_steps.as_ref(),
                    &tables[pi],
                    luma,
                )
            })
            .collect();
        eval
    }

    /// [`DetailEval::new`] taking the layer, each plane's levels freed as soon as its
    /// coefficients are made: the decoder's peak holds one plane's levels, not all.
    pub fn from_layer(detail: Detail, grid: &Grid) -> Self {
        DetailEval::from_layer_within(detail, grid, &LayerBudget::unlimited())
            .expect("an unlimited budget refuses nothing")
    }

    /// [`DetailEval::from_layer`] with each plane's coefficients taken from `budget`
    /// before they are made and its levels given back as they are freed.
    pub fn from_layer_within(
        detail: Detail,
        grid: &Grid,
        budget: &LayerBudget,
    ) -> Result<Self, CodecError> {
        let (cols, rows) = detail.planes.first().map_or((1, 1), |p| (p.cols, p.rows));
        let mut eval = DetailEval::geometry(cols, rows, grid, detail.deblock, detail.lapping);
        eval.thresholds = thresholds(&detail);
        let tables = weights::plane_tables(detail.weights, detail.planes.len());
        let mut planes = detail.planes.into_iter();
        let Some(luma) = planes.next() else {
            return Ok(eval);
        };
        let (steps, block_steps) = (detail.steps, detail.block_steps.as_ref());
        budget.take(PlaneEval::bytes(&luma, false))?;
        eval.planes.push(PlaneEval::new(
            &luma,
            steps[0],
            block_steps,
            &tables[0],
            None,
        ));
        // Chroma's luma factors need the luma levels: those are freed last.
        for (pi, p) in planes.enumerate().map(|(k, p)| (k + 1, p)) {
            budget.take(PlaneEval::bytes(&p, true))?;
            let l = Some((&luma, steps[0], &tables[0]));
            eval.planes
                .push(PlaneEval::new(&p, steps[pi], block_steps, &tables[pi], l));
            budget.free(p.levels);
            budget.free(p.spans);
        }
        budget.free(luma.levels);
        budget.free(luma.spans);
        Ok(eval)
    }

    /// The evaluation geometry of `cols x rows` blocks on `grid`, without planes.
    fn geometry(
        cols: usize,
        rows: usize,
        grid: &Grid,
        deblock: Option<Deblock>,
        lapping: Option<Lapping>,
    ) -> Self {
        // Grid positions increase, so each block column covers a contiguous run.
        let mut columns = vec![(0usize, 0usize, 0usize); cols];
        let mut per_column: Vec<Vec<[f32; N]>> = vec![Vec::new(); cols];
        for i in 0..grid.nx {
            let (b, t) = locate(grid.x(i), cols);
            if per_column[b].is_empty() {
                columns[b].0 = i;
            }
            per_column[b].push(dct::basis_at(t));
        }
        let mut basis_t = Vec::with_capacity(grid.nx * N);
        for (c, basis) in columns.iter_mut().zip(&per_column) {
            c.1 = basis.len();
            c.2 = basis_t.len();
            for u in 0..N {
                basis_t.extend(basis.iter().map(|b| b[u]));
            }
        }
        let rows_basis = (0..grid.ny)
            .map(|j| {
                let (b, t) = locate(grid.y(j), rows);
                (b, dct::basis_at(t))
            })
            .collect();
        let r = deblock.map_or(0.0, Deblock::radius_px);
        let vcols = (0..grid.nx)
            .filter_map(|i| edge_weight(grid.x(i), cols, r).map(|(e, w)| (i, e, w)))
            .collect();
        let hrows = (0..grid.ny)
            .map(|j| edge_weight(grid.y(j), rows, r))
            .collect();
        let (lap_cols, lap_rows) = match lapping {
            Some(l) => (
                (0..grid.nx)
                    .filter_map(|i| l.at(grid.x(i), cols).map(|(own, nb, w)| (i, own, nb, w)))
                    .collect(),
                (0..grid.ny)
                    .map(|j| l.at(grid.y(j), rows).map(|(_, nb, w)| (nb, w)))
                    .collect(),
            ),
            None => (Vec::new(), vec![None; grid.ny]),
        };
        DetailEval {
            grid: *grid,
            planes: Vec::new(),
            columns,
            basis_t,
            rows: rows_basis,
            vcols,
            hrows,
            thresholds: Vec::new(),
            lap_cols,
            lap_rows,
        }
    }

    /// Adds the layer to grid rows `j0..j0 + n`: `out[c]` holds plane `c`'s rows, `n`
    /// rows of the grid's width each.
    pub fn add_rows(&self, j0: usize, out: &mut [&mut [f32]]) {
        let nx = self.grid.nx;
        for (pi, (p, plane)) in self.planes.iter().zip(out.iter_mut()).enumerate() {
            if p.extent.is_empty() {
                continue;
            }
            let t = self.thresholds.get(pi).copied().unwrap_or(0.0);
            let mut el = vec![0f32; p.cols];
            let mut er = vec![0f32; p.cols];
            let mut delta = vec![0f32; nx];
            let lapped = !self.lap_cols.is_empty();
            // Per block column, the row of its (lapped) series at this y.
            let mut gs = vec![[0f32; N]; if lapped { p.cols } else { 0 }];
            let corner = |i: u32| {
                let (at, v1, u1) = p.extent[i as usize];
                let (v1, u1) = (v1 as usize, u1 as usize);
                (&p.coeffs[at as usize..at as usize + v1 * u1], v1, u1)
            };
            for (r, row) in plane.chunks_exact_mut(nx).enumerate() {
                let (by, bv) = self.rows[j0 + r];
                let lap_row = self.lap_rows[j0 + r];
                el.fill(0.0);
                er.fill(0.0);
                for bx in 0..p.cols {
                    let i = p.index[by * p.cols + bx];
                    let (c0, n, start) = self.columns[bx];
                    // The block's row of the series at this y: g(u) = sum_v C[v][u] b_v(y).
                    let mut g = [0f32; N];
                    let mut width = 0;
                    if i != ZERO {
                        let (c, v1, u1) = corner(i);
                        for v in 0..v1 {
                            let b = bv[v];
                            for u in 0..u1 {
                                g[u] += c[v * u1 + u] * b;
                            }
                        }
                        if t > 0.0 {
                            // The row's values at the block's left and right edges.
                            for (u, &gu) in g.iter().enumerate().take(u1) {
                                el[bx] += gu * edge_basis(u, false);
                                er[bx] += gu * edge_basis(u, true);
                            }
                        }
                        width = u1;
                    }
                    if let Some((nb, w)) = lap_row {
                        // Towards the series of the block across the edge at the mirror
                        // position: its rows with odd v negated, at this y.
                        for gu in g.iter_mut().take(width) {
                            *gu *= 1.0 - w;
                        }
                        let k = p.index[nb * p.cols + bx];
                        if k != ZERO {
                            let (c, v1, u1) = corner(k);
                            for v in 0..v1 {
                                let b = if v % 2 == 1 { -w * bv[v] } else { w * bv[v] };
                                for u in 0..u1 {
                                    g[u] += c[v * u1 + u] * b;
                                }
                            }
                            width = width.max(u1);
                        }
                    }
                    if lapped {
                        gs[bx] = g;
                    }
                    if width == 0 || n == 0 {
                        continue;
                    }
                    let out = &mut row[c0..c0 + n];
                    for (u, &gu) in g.iter().enumerate().take(width) {
                        let basis = &self.basis_t[start + u * n..start + (u + 1) * n];
                        for (o, &b) in out.iter_mut().zip(basis) {
                            *o += gu * b;
                        }
                    }
                }
                for &(i, own, nb, w) in &self.lap_cols {
                    // Towards the neighbour's row at the mirror position: its odd
                    // columns negated, with this column's basis.
                    let (c0, n, start) = self.columns[own];
                    let (a, b) = (&gs[own], &gs[nb]);
                    let mut d = 0.0;
                    for u in 0..N {
                        let m = if u % 2 == 1 { -b[u] } else { b[u] };
                        d += (m - a[u]) * self.basis_t[start + u * n + i - c0];
                    }
                    row[i] += w * d;
                }
                if t <= 0.0 {
                    continue;
                }
                for &(i, e, w) in &self.vcols {
                    row[i] += w * gate(el[e] - er[e - 1], t);
                }
                if let Some((e, w)) = self.hrows[j0 + r] {
                    delta.fill(0.0);
                    for bx in 0..p.cols {
                        let (c0, n, start) = self.columns[bx];
                        if n == 0 {
                            continue;
                        }
                        let mut h = [0f32; N];
                        let below = p.index[e * p.cols + bx];
                        let above = p.index[(e - 1) * p.cols + bx];
                        if below == ZERO && above == ZERO {
                            continue;
                        }
                        // The step's series along x: the block below at its top edge
                        // minus the block above at its bottom edge.
                        for (idx, above) in [(below, false), (above, true)] {
                            if idx == ZERO {
                                continue;
                            }
                            let (at, v1, u1) = p.extent[idx as usize];
                            let (v1, u1) = (v1 as usize, u1 as usize);
                            let c = &p.coeffs[at as usize..at as usize + v1 * u1];
                            for v in 0..v1 {
                                let b = edge_basis(v, above);
                                let b = if above { -b } else { b };
                                for u in 0..u1 {
                                    h[u] += c[v * u1 + u] * b;
                                }
                            }
                        }
                        let out = &mut delta[c0..c0 + n];
                        for (u, &hu) in h.iter().enumerate() {
                            if hu == 0.0 {
                                continue;
                            }
                            let basis = &self.basis_t[start + u * n..start + (u + 1) * n];
                            for (o, &b) in out.iter_mut().zip(basis) {
                                *o += hu * b;
                            }
                        }
                    }
                    for (o, &d) in row.iter_mut().zip(&delta) {
                        *o += w * gate(d, t);
                    }
                }
            }
        }
    }
    /// The layer on the whole grid, one plane per channel (for the forward path).
    pub fn eval(&self) -> Vec<Vec<f32>> {
        let n = self.grid.nx * self.grid.ny;
        let mut planes = vec![vec![0f32; n]; self.planes.len()];
        {
            let mut out: Vec<&mut [f32]> = planes.iter_mut().map(|p| p.as_mut_slice()).collect();
            self.add_rows(0, &mut out);
        }
        planes
    }
}
