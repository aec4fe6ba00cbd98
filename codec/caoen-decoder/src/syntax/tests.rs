//! The split flags' contexts against their definition, the values and residuals read
//! back as written, and the neighbours against the owner map.

use super::tree::{walk_tree, TREE_LEVELS};
use super::*;
use crate::entropy::{AnsSink, CostSink, CDF_FLOOR, CDF_ONE};
use crate::quadtree::{pruned_one_level, random_tree, TreeShape};

/// The split-flag contexts by their definition: per level, a map of which visited
/// nodes were split.
fn tree_contexts_by_split_maps(shape: &TreeShape, leaves: &[Cell]) -> Vec<(Cell, (usize, usize))> {
    let leaf_set: std::collections::HashSet<Cell> = leaves.iter().copied().collect();
    let mut maps: Vec<(u32, Vec<u8>)> = (0..=shape.block_log2)
        .map(|l| {
            let cols = shape.width.div_ceil(1 << l) + 1;
            let rows = shape.height.div_ceil(1 << l) + 1;
            (cols, vec![0u8; (cols * rows) as usize])
        })
        .collect();
    let mut out = Vec::new();
    shape.walk(|c| {
        let (cols, map) = &mut maps[c.log2 as usize];
        let (i, j) = (c.x0 >> c.log2, c.y0 >> c.log2);
        let split_at = |i: u32, j: u32| map[(j * *cols + i) as usize] == 2;
        let n = usize::from(i > 0 && split_at(i - 1, j)) + usize::from(j > 0 && split_at(i, j - 1));
        let level = ((shape.block_log2 - c.log2) as usize).min(TREE_LEVELS - 1);
        out.push((*c, (level, n)));
        let split = !leaf_set.contains(c);
        map[(j * *cols + i) as usize] = if split { 2 } else { 1 };
        split
    });
    out
}

/// Random trees from sparse to dense (splitting where a draw is below `num` of 5),
/// over odd, degenerate and whole-block sizes: `(width, height, shape, leaves)`.
fn test_trees() -> impl Iterator<Item = (u32, u32, TreeShape, Vec<Cell>)> {
    [
        (37, 21, 1u32, 2u32),
        (64, 64, 2, 1),
        (64, 64, 2, 3),
        (5, 3, 3, 2),
        (100, 17, 4, 3),
        (1, 1, 5, 2),
        (129, 70, 6, 2),
        (48, 80, 7, 4),
    ]
    .into_iter()
    .map(|(w, h, seed, num)| {
        let (shape, leaves) = random_tree(w, h, seed, |d| d % 5 < num);
        (w, h, shape, leaves)
    })
}

#[test]
fn tree_contexts_match_the_split_maps() {
    for (w, h, shape, leaves) in test_trees() {
        let leaf_set: std::collections::HashSet<Cell> = leaves.iter().copied().collect();
        let mut got = Vec::new();
        let walked = walk_tree(&shape, 0, |c, ctx, _| {
            got.push((*c, ctx));
            Ok::<_, ()>(!leaf_set.contains(c))
        })
        .unwrap();
        assert_eq!(walked, leaves);
        assert_eq!(got, tree_contexts_by_split_maps(&shape, &leaves), "{w}x{h}");
        let mut sink = AnsSink::new();
        assert_eq!(
            write_tree(&shape, |c| !leaf_set.contains(c), &mut sink),
            leaves
        );
        let bytes = sink.finish();
        let mut src = AnsSource::new(&bytes, got.len() as u64).unwrap();
        assert_eq!(read_tree(&shape, 1, &mut src).unwrap(), leaves);
        assert!(src.finished_cleanly());
    }
}

#[test]
fn corrupt_payloads_give_errors_or_bounded_results() {
    let (shape, cells) = random_tree(61, 37, 9, |d| d % 5 < 3);
    let nbs = neighbours(&cells, 61, 37);
    let mut k = 7u32;
    for words in [0usize, 1, 2, 3, 5, 17, 200] {
        for _ in 0..20 {
            let bytes: Vec<u8> = (0..words * 4)
                .map(|_| {
                    k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    (k >> 16) as u8
                })
                .collect();
            let budget = MAX_SYMBOLS_PER_VALUE * cells.len() as u64;
            for on in [false, true] {
                let levels = LevelSteps {
                    root_log2: shape.block_log2,
                    on,
                };
                if let Ok(mut src) = AnsSource::new(&bytes, budget) {
                    if let Ok(values) = read_values(&cells, &nbs, levels, &mut src) {
                        assert!(values.iter().all(|v| v.abs() <= MAX_VALUE));
                    }
                }
            }
            if let Ok(mut src) = AnsSource::new(&bytes, 10_000) {
                if let Ok(leaves) = read_tree(&shape, 0, &mut src) {
                    assert!(leaves.len() as u64 <= shape.max_leaves());
                }
            }
        }
    }
    // A payload ending in a zero word is not one any encoder writes.
    assert!(AnsSource::new(&[1, 0, 0, 0, 0, 0, 0, 0], 10).is_err());
    assert!(AnsSource::new(&[1, 2, 3], 10).is_err());
}

#[test]
fn initial_tables_respect_the_floor_and_total() {
    let check = |f: &[u16]| {
        let mut left = 0;
        for &v in f.iter().chain([&CDF_ONE]) {
            assert!(v >= left + CDF_FLOOR, "{f:?}");
            left = v;
        }
    };
    TOKEN_INIT.iter().for_each(|t| check(t));
    check(&CLASS_INIT);
}

/// Values over a random tree: a smooth ramp with noise, some large jumps (escapes
/// of every class), and the extremes of the value range.
fn test_values(n: usize, seed: u32) -> Vec<i64> {
    let mut k = seed;
    let mut next = || {
        k = k.wrapping_mul(1_103_515_245).wrapping_add(12345);
        k >> 8
    };
    (0..n)
        .map(|i| match next() % 50 {
            0 => MAX_VALUE,
            1 => -MAX_VALUE,
            2 => (next() as i64 % (2 * MAX_VALUE + 1)) - MAX_VALUE,
            3..=8 => (i as i64 / 7) + (next() % 600) as i64 - 300,
            _ => (i as i64 / 7) + (next() % 5) as i64 - 2,
        })
        .collect()
}

#[test]
fn values_round_trip_and_costs_track_the_real_size() {
    for on in [false, true] {
        for (w, h, seed) in [(61u32, 37u32, 1u32), (128, 96, 2), (3, 200, 3)] {
            let (shape, cells) = random_tree(w, h, seed, |d| d % 5 < 3);
            let levels = LevelSteps {
                root_log2: shape.block_log2,
                on,
            };
            assert_eq!(
                on,
                cells.iter().any(|c| levels.shift(c) > 0),
                "the tree has small cells"
            );
            let nbs = neighbours(&cells, w, h);
            let channels = [
                test_values(cells.len(), seed),
                test_values(cells.len(), !seed),
            ];
            let mut sink = AnsSink::new();
            let mut cost = CostSink::default();
            for v in &channels {
                write_values(&cells, &nbs, v, levels, &mut sink);
                write_values(&cells, &nbs, v, levels, &mut cost);
            }
            let bytes = sink.finish();
            let est = cost.cost as f64 / 2048.0;
            assert!(
                (bytes.len() as f64 - est).abs() < 0.005 * est + 8.0,
                "real {} estimated {est}",
                bytes.len()
            );
            let max = MAX_SYMBOLS_PER_VALUE * cells.len() as u64 * 2;
            let mut src = AnsSource::new(&bytes, max).unwrap();
            for v in &channels {
                assert_eq!(&read_values(&cells, &nbs, levels, &mut src).unwrap(), v);
            }
            assert!(src.finished_cleanly());
            let mut src = AnsSource::new(&bytes, max).unwrap();
            assert_eq!(
                read_channels(&cells, w, h, 2, levels, &mut src).unwrap(),
                channels
            );
            assert!(src.finished_cleanly());
        }
    }
}

#[test]
fn level_steps_predict_in_root_steps_rounded_to_the_cell_s_own() {
    let levels = LevelSteps {
        root_log2: 5,
        on: true,
    };
    let cell = |log2| Cell { x0: 0, y0: 0, log2 };
    assert_eq!([5, 4, 3, 0].map(|l| levels.shift(&cell(l))), [0, 1, 2, 5]);
    assert_eq!(levels.step(&cell(3), 0.25), 1.0);
    assert_eq!(LevelSteps::FLAT.shift(&cell(0)), 0);
    // One neighbour above, 5 root steps: a cell of twice the root step predicts
    // 2.5 rounded up, one of four times 1.25 rounded to 1; -5 gives -2 and -1.
    let above = Neighbours {
        above: 0,
        left: NONE,
        above_left: NONE,
    };
    assert_eq!(predict(&[5], &above, 0, 1), (3, 1));
    assert_eq!(predict(&[5], &above, 0, 2), (1, 1));
    assert_eq!(predict(&[-5], &above, 0, 1), (-2, 1));
    assert_eq!(predict(&[-5], &above, 0, 2), (-1, 1));
    // The median edge detector runs in root steps, the activity is in the cell's.
    let all = Neighbours {
        above: 0,
        left: 1,
        above_left: 2,
    };
    assert_eq!(predict(&[40, 8, 0], &all, 0, 2), (10, 2));
    assert_eq!(predict(&[4, 0, 0], &all, 0, 2), (1, 1));
    assert_eq!(predict(&[3, 0, 0], &all, 0, 2), (1, 0));
    // A prediction beyond the range in the cell's steps is clamped to it.
    assert_eq!(predict(&[MAX_VALUE << 3], &above, 0, 0).0, MAX_VALUE);
}

#[test]
fn every_residual_magnitude_class_round_trips() {
    let mut rs: Vec<i64> = vec![0, 1, -1, 7, -7, 8, -8, 9, 22, -23];
    for b in 0..=25 {
        for d in [-1i64, 0, 1] {
            let m = (1i64 << b) + d + LITERALS as i64 - 1;
            if m > 0 && m <= 2 * MAX_VALUE {
                rs.extend([m, -m]);
            }
        }
    }
    rs.push(2 * MAX_VALUE);
    let mut ctx = ValueContexts::default();
    let mut sink = AnsSink::new();
    for (i, &r) in rs.iter().enumerate() {
        write_residual(&mut ctx, i % SIZE_CLASSES, i % ACTIVITY, r, &mut sink);
    }
    let bytes = sink.finish();
    let mut src = AnsSource::new(&bytes, MAX_SYMBOLS_PER_VALUE * rs.len() as u64).unwrap();
    let mut ctx = ValueContexts::default();
    for (i, &r) in rs.iter().enumerate() {
        assert_eq!(
            read_residual(&mut ctx, i % SIZE_CLASSES, i % ACTIVITY, &mut src).unwrap(),
            r
        );
    }
    assert!(src.finished_cleanly());
}

/// The neighbours by their definition: the owners of three pixels in a full
/// per-pixel owner map.
fn neighbours_by_owner_map(cells: &[Cell], width: u32, height: u32) -> Vec<Neighbours> {
    let w = width as usize;
    let mut owner = vec![NONE; w * height as usize];
    for (i, c) in cells.iter().enumerate() {
        let (x0, y0, x1, y1) = c.clip(width, height);
        for y in y0 as usize..y1 as usize {
            owner[y * w + x0 as usize..y * w + x1 as usize].fill(i as u32);
        }
    }
    let at = |x: u32, y: u32| owner[y as usize * w + x as usize];
    cells
        .iter()
        .map(|c| {
            let (x0, y0, x1, y1) = c.clip(width, height);
            let (cx, cy) = ((x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2);
            Neighbours {
                above: if y0 > 0 { at(cx, y0 - 1) } else { NONE },
                left: if x0 > 0 { at(x0 - 1, cy) } else { NONE },
                above_left: if x0 > 0 && y0 > 0 {
                    at(x0 - 1, y0 - 1)
                } else {
                    NONE
                },
            }
        })
        .collect()
}

#[test]
fn neighbours_match_the_owner_map() {
    for (w, h, shape, leaves) in test_trees() {
        for cells in [leaves.clone(), pruned_one_level(&shape, &leaves)] {
            let fast = neighbours(&cells, w, h);
            let slow = neighbours_by_owner_map(&cells, w, h);
            assert_eq!(fast, slow, "{w}x{h}, {} cells", cells.len());
        }
    }
}

/// A tree split wherever it can be has the most flags; near thin or tiny images its
/// nodes have single children, so there are more flags than leaves.
#[test]
fn max_flags_counts_the_fully_split_tree() {
    for (width, height, block_log2, min_log2) in [
        (1, 1, 7, 0),
        (1, 37, 7, 0),
        (37, 1, 5, 1),
        (3, 3, 2, 0),
        (100, 60, 6, 2),
    ] {
        let shape = TreeShape {
            width,
            height,
            block_log2,
            min_log2,
        };
        let flags = std::cell::Cell::new(0u64);
        let mut sink = AnsSink::new();
        let leaves = write_tree(
            &shape,
            |_| {
                flags.set(flags.get() + 1);
                true
            },
            &mut sink,
        );
        assert_eq!(flags.get(), shape.max_flags(), "{width}x{height}");
        assert_eq!(leaves.len() as u64, shape.max_leaves(), "{width}x{height}");
    }
}
