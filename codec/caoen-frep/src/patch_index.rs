//! A spatial index over the supports of many local terms (the patches of a
//! perturbation): which terms can be non-zero at a point or over a box.
//!
//! Terms are sorted into size classes by the longest side of their support box; each
//! class is a sparse grid whose cell is a power of two at least that long, so a support
//! overlaps at most 2 x 2 x 2 cells and a point query reads one cell per class. Answers
//! are in ascending term order, so a sum over them adds the same numbers in the same
//! order as a sum over every term (the others are exactly zero).

use super::interval::Aabb;

/// Cell coordinates are kept within 21 bits each, packed into one key.
const CELL_LIMIT: i64 = 1 << 20;

/// One size class: `(key, term)` pairs sorted by key.
#[derive(Debug, Clone, PartialEq)]
struct Class {
    cell: f64,
    entries: Vec<(u64, u32)>,
}

/// The index; terms without a bounded support are in every answer.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PatchIndex {
    classes: Vec<Class>,
    everywhere: Vec<u32>,
    len: usize,
}

fn cell_of(x: f64, cell: f64) -> Option<i64> {
    let c = (x / cell).floor();
    (c.abs() < CELL_LIMIT as f64).then_some(c as i64)
}

fn key(c: [i64; 3]) -> u64 {
    let k = |v: i64| (v + CELL_LIMIT) as u64 & ((1 << 21) - 1);
    (k(c[0]) << 42) | (k(c[1]) << 21) | k(c[2])
}

impl PatchIndex {
    /// Indexes terms by their support boxes (`None`: unbounded).
    pub fn new(supports: &[Option<Aabb>]) -> PatchIndex {
        let mut classes: Vec<Class> = Vec::new();
        let mut everywhere = Vec::new();
        for (i, s) in supports.iter().enumerate() {
            let Some(b) = s else {
                everywhere.push(i as u32);
                continue;
            };
            let side = (0..3).map(|k| b.hi[k] - b.lo[k]).fold(0.0, f64::max);
            let cell = 2f64.powi(side.max(1e-9).log2().ceil() as i32);
            let lo = b.lo.map(|v| cell_of(v, cell));
            let hi = b.hi.map(|v| cell_of(v, cell));
            let (Some(lo), Some(hi)) = (
                lo.iter().copied().collect::<Option<Vec<_>>>(),
                hi.iter().copied().collect::<Option<Vec<_>>>(),
            ) else {
                everywhere.push(i as u32);
                continue;
            };
            let class = match classes.iter_mut().position(|c| c.cell == cell) {
                Some(c) => &mut classes[c],
                None => {
                    classes.push(Class {
                        cell,
                        entries: Vec::new(),
                    });
                    classes.last_mut().expect("just pushed")
                }
            };
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        class.entries.push((key([x, y, z]), i as u32));
                    }
                }
            }
        }
        for c in &mut classes {
            c.entries.sort_unstable();
        }
        classes.sort_by(|a, b| a.cell.total_cmp(&b.cell));
        PatchIndex {
            classes,
            everywhere,
            len: supports.len(),
        }
    }

    /// How many terms were indexed.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no terms were indexed.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn push_cell(class: &Class, k: u64, out: &mut Vec<u32>) {
        let start = class.entries.partition_point(|e| e.0 < k);
        out.extend(
            class.entries[start..]
                .iter()
                .take_while(|e| e.0 == k)
                .map(|e| e.1),
        );
    }

    /// The terms whose support may hold `p`, ascending, into `out` (cleared first).
    pub fn at_point(&self, p: [f64; 3], out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.everywhere);
        for class in &self.classes {
            let c = p.map(|v| cell_of(v, class.cell));
            if let [Some(x), Some(y), Some(z)] = c {
                Self::push_cell(class, key([x, y, z]), out);
            }
        }
        out.sort_unstable();
    }

    /// The terms whose support may meet the box `b`, ascending and without repeats,
    /// into `out` (cleared first).
    pub fn in_box(&self, b: &Aabb, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.everywhere);
        for class in &self.classes {
            let lo =
                b.lo.map(|v| (v / class.cell).floor().max(-(CELL_LIMIT as f64)));
            let hi =
                b.hi.map(|v| (v / class.cell).floor().min(CELL_LIMIT as f64 - 1.0));
            let cells: f64 = (0..3).map(|k| (hi[k] - lo[k] + 1.0).max(0.0)).product();
            // A box missing the class's range on one axis meets none of it (the loops
            // below would still walk the other two axes' cells).
            if cells < 1.0 {
                continue;
            }
            if cells > class.entries.len() as f64 {
                // A box larger than the class's occupied cells: scan the class.
                let (l, h) = (lo.map(|v| v as i64), hi.map(|v| v as i64));
                for e in &class.entries {
                    let c =
                        [42u32, 21, 0].map(|s| ((e.0 >> s) & ((1 << 21) - 1)) as i64 - CELL_LIMIT);
                    if (0..3).all(|k| c[k] >= l[k] && c[k] <= h[k]) {
                        out.push(e.1);
                    }
                }
                continue;
            }
            for x in lo[0] as i64..=hi[0] as i64 {
                for y in lo[1] as i64..=hi[1] as i64 {
                    for z in lo[2] as i64..=hi[2] as i64 {
                        Self::push_cell(class, key([x, y, z]), out);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_beside_a_fine_class_on_one_axis_is_answered_at_once() {
        // A support of 1e-9 makes a class of 2^-30 cells: a unit box in x and y spans
        // the whole clamped range there (2^21 cells a side), and misses it in z.
        let tiny = Aabb::new([0.0; 3], [1e-9; 3]);
        let index = PatchIndex::new(&[Some(tiny)]);
        let mut out = Vec::new();
        index.in_box(&Aabb::new([-1.0, -1.0, 5.0], [1.0, 1.0, 6.0]), &mut out);
        assert!(out.is_empty());
        index.in_box(&Aabb::new([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]), &mut out);
        assert_eq!(out, [0]);
        // A NaN box may meet anything: the whole class, conservatively.
        index.in_box(&Aabb::new([f64::NAN; 3], [f64::NAN; 3]), &mut out);
        assert_eq!(out, [0]);
    }

    #[test]
    fn answers_hold_every_term_whose_box_holds_the_point_or_meets_the_box() {
        // Boxes of many sizes on a pseudo-random walk, and one unbounded term.
        let mut rng = caoen_base::rng::Lcg::new(12345);
        let mut rnd = || rng.unit();
        let mut boxes = Vec::new();
        for i in 0..400 {
            if i == 17 {
                boxes.push(None);
                continue;
            }
            let c = [rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0];
            let r = 0.01 + rnd() * rnd() * 1.5;
            boxes.push(Some(Aabb::new(c.map(|v| v - r), c.map(|v| v + r))));
        }
        let index = PatchIndex::new(&boxes);
        let mut out = Vec::new();
        for _ in 0..2000 {
            let p = [rnd() * 5.0 - 2.5, rnd() * 5.0 - 2.5, rnd() * 5.0 - 2.5];
            index.at_point(p, &mut out);
            let want: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| match &boxes[i as usize] {
                    None => true,
                    Some(b) => (0..3).all(|k| p[k] >= b.lo[k] && p[k] <= b.hi[k]),
                })
                .collect();
            assert!(want.iter().all(|w| out.contains(w)), "{p:?}");
            assert!(out.windows(2).all(|w| w[0] <= w[1]));
            let h = rnd() * 0.7;
            let q = Aabb::new(p.map(|v| v - h), p.map(|v| v + h));
            index.in_box(&q, &mut out);
            for (i, b) in boxes.iter().enumerate() {
                if let Some(b) = b {
                    if q.intersection(b).is_some() {
                        assert!(out.contains(&(i as u32)), "{i} {q:?}");
                    }
                }
            }
            assert!(out.windows(2).all(|w| w[0] < w[1]));
        }
    }
}
