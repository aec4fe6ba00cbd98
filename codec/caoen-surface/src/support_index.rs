//! Spatial index over compact-support key points, so that evaluating an input visits
//! only the key points whose support contains it (cost O(neighbours), not O(n)).
//!
//! A compact key point `i` is active at `x` iff `x . w_i > tau_i` (its support
//! threshold). Since `|x - w|^2 = |x|^2 + |w|^2 - 2 x . w`, activity implies
//! `|x - w_i|^2 < |x|^2 + |w_i|^2 - 2 tau_i`, a Euclidean ball query. Key points are
//! grouped into classes of similar support radius (so one very wide key point does not
//! inflate every query) and each class gets a k-d tree (kiddo). Query results are a
//! superset; the exact test `s > tau_i` is always applied afterwards by the caller.

use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// One k-d tree per supported source dimension; other dimensions scan linearly.
enum Tree {
    K2(ImmutableKdTree<f64, 2>),
    K3(ImmutableKdTree<f64, 3>),
    K4(ImmutableKdTree<f64, 4>),
    K5(ImmutableKdTree<f64, 5>),
    K6(ImmutableKdTree<f64, 6>),
    Linear,
}

/// Key points of one support-radius class.
struct RadiusClass {
    /// Network key-point indices, position `j` in the tree is `members[j]`.
    members: Vec<u32>,
    /// `max_i (|w_i|^2 - 2 tau_i)`: the query radius is `sqrt(|x|^2 + beta)`.
    beta: f64,
    tree: Tree,
}

/// The index: radius classes over the compact key points.
pub struct SupportIndex {
    classes: Vec<RadiusClass>,
    /// Smallest support radius on the unit sphere, used to size batch cells.
    pub finest_radius: f64,
}

fn build_tree(m: usize, sources: &[f64], members: &[u32]) -> Tree {
    macro_rules! tree {
        ($k:literal, $variant:ident) => {{
            let pts: Vec<[f64; $k]> = members
                .iter()
                .map(|&i| {
                    let row = &sources[i as usize * $k..(i as usize + 1) * $k];
                    let mut a = [0.0; $k];
                    a.copy_from_slice(row);
                    a
                })
                .collect();
            match ImmutableKdTree::new_from_slice(&pts) {
                Ok(t) => Tree::$variant(t),
                Err(_) => Tree::Linear,
            }
        }};
    }
    match m {
        2 => tree!(2, K2),
        3 => tree!(3, K3),
        4 => tree!(4, K4),
        5 => tree!(5, K5),
        6 => tree!(6, K6),
        _ => Tree::Linear,
    }
}

impl SupportIndex {
    /// Builds the index over `compact` (key-point indices with their thresholds `tau`).
    pub fn build(m: usize, sources: &[f64], compact: &[(u32, f64)]) -> Self {
        // Class by the unit-sphere support radius sqrt(2 - 2 tau), in octaves.
        let mut keyed: Vec<(i32, u32, f64)> = compact
            .iter()
            .map(|&(i, tau)| {
                let r2 = (2.0 - 2.0 * tau).max(1e-300);
                let class = (0.5 * r2.log2()).floor().clamp(-60.0, 60.0) as i32;
                (class, i, tau)
            })
            .collect();
        keyed.sort_by_key(|&(c, i, _)| (c, i));
        let mut finest_radius = f64::INFINITY;
        let mut classes = Vec::new();
        let mut start = 0;
        while start < keyed.len() {
            let c = keyed[start].0;
            let end = start + keyed[start..].iter().take_while(|e| e.0 == c).count();
            let members: Vec<u32> = keyed[start..end].iter().map(|e| e.1).collect();
            let mut beta = f64::NEG_INFINITY;
            for &(_, i, tau) in &keyed[start..end] {
                let w = &sources[i as usize * m..(i as usize + 1) * m];
                let w2: f64 = w.iter().map(|v| v * v).sum();
                beta = beta.max(w2 - 2.0 * tau);
                finest_radius = finest_radius.min((2.0 - 2.0 * tau).max(0.0).sqrt());
            }
            let tree = build_tree(m, sources, &members);
            classes.push(RadiusClass {
                members,
                beta,
                tree,
            });
            start = end;
        }
        SupportIndex {
            classes,
            finest_radius,
        }
    }

    /// Appends to `out` every compact key point that may be active anywhere in the ball
    /// `|x - centre| <= spread` whose points have `|x|^2 <= max_norm2`. Unsorted.
    pub fn candidates(&self, centre: &[f64], spread: f64, max_norm2: f64, out: &mut Vec<u32>) {
        for class in &self.classes {
            let reach2 = max_norm2 + class.beta;
            if reach2 <= 0.0 {
                continue;
            }
            let r = reach2.sqrt() + spread;
            // Slightly enlarged so rounding in the tree's distance never drops a member.
            let r2 = r * r * (1.0 + 1e-9) + 1e-300;
            macro_rules! query {
                ($t:expr, $k:literal) => {{
                    let mut q = [0.0; $k];
                    q.copy_from_slice(centre);
                    for hit in $t
                        .query(&q)
                        .within::<SquaredEuclidean<f64>>(r2)
                        .unsorted()
                        .execute()
                    {
                        out.push(class.members[hit.item as usize]);
                    }
                }};
            }
            match &class.tree {
                Tree::K2(t) => query!(t, 2),
                Tree::K3(t) => query!(t, 3),
                Tree::K4(t) => query!(t, 4),
                Tree::K5(t) => query!(t, 5),
                Tree::K6(t) => query!(t, 6),
                Tree::Linear => out.extend_from_slice(&class.members),
            }
        }
    }
}
