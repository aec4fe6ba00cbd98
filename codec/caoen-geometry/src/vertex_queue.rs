//! A priority queue with one entry per vertex that can be changed in place: mesh
//! simplification re-ranks a vertex each time its neighbourhood changes, and a plain
//! binary heap then fills with stale entries that cost more to pop than the work.

/// Each vertex's current key, least first (a binary heap with each vertex's place in
/// it), ties broken by the vertex id so the order depends on nothing else.
#[derive(Debug, Clone, Default)]
pub struct VertexQueue {
    heap: Vec<(f64, u32)>,
    place: Vec<u32>,
}

const ABSENT: u32 = u32::MAX;

impl VertexQueue {
    /// An empty queue for vertices `0..n`.
    pub fn new(n: usize) -> Self {
        VertexQueue {
            heap: Vec::with_capacity(n),
            place: vec![ABSENT; n],
        }
    }

    /// Entries in the queue.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether the queue is empty.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    fn less(a: (f64, u32), b: (f64, u32)) -> bool {
        a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).is_lt()
    }

    fn swap(&mut self, i: usize, j: usize) {
        self.heap.swap(i, j);
        self.place[self.heap[i].1 as usize] = i as u32;
        self.place[self.heap[j].1 as usize] = j as u32;
    }

    fn up(&mut self, mut i: usize) {
        while i > 0 {
            let parent = (i - 1) / 2;
            if !Self::less(self.heap[i], self.heap[parent]) {
                break;
            }
            self.swap(i, parent);
            i = parent;
        }
    }

    fn down(&mut self, mut i: usize) {
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut least = i;
            if l < self.heap.len() && Self::less(self.heap[l], self.heap[least]) {
                least = l;
            }
            if r < self.heap.len() && Self::less(self.heap[r], self.heap[least]) {
                least = r;
            }
            if least == i {
                break;
            }
            self.swap(i, least);
            i = least;
        }
    }

    /// Sets `v`'s key, or takes `v` out with `None`.
    pub fn set(&mut self, v: u32, key: Option<f64>) {
        let at = self.place[v as usize];
        match (at, key) {
            (ABSENT, None) => {}
            (ABSENT, Some(k)) => {
                self.heap.push((k, v));
                let i = self.heap.len() - 1;
                self.place[v as usize] = i as u32;
                self.up(i);
            }
            (i, Some(k)) => {
                let i = i as usize;
                self.heap[i].0 = k;
                self.up(i);
                self.down(self.place[v as usize] as usize);
            }
            (i, None) => {
                let i = i as usize;
                let last = self.heap.len() - 1;
                self.swap(i, last);
                self.heap.pop();
                self.place[v as usize] = ABSENT;
                if i < self.heap.len() {
                    self.up(i);
                    self.down(self.place[self.heap[i].1 as usize] as usize);
                }
            }
        }
    }

    /// Takes out the vertex with the least key.
    pub fn pop(&mut self) -> Option<(f64, u32)> {
        let first = *self.heap.first()?;
        self.set(first.1, None);
        Some(first)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Any sequence of changes pops in the order a sort of the final keys gives.
    #[test]
    fn pops_in_key_order_after_any_changes() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        let n = 300;
        let mut q = VertexQueue::new(n);
        let mut keys: Vec<Option<f64>> = vec![None; n];
        for _ in 0..5000 {
            let v = next() % n as u32;
            let key = if next() % 5 == 0 {
                None
            } else {
                Some(f64::from(next() % 50))
            };
            q.set(v, key);
            keys[v as usize] = key;
        }
        let mut want: Vec<(f64, u32)> = keys
            .iter()
            .enumerate()
            .filter_map(|(v, k)| k.map(|k| (k, v as u32)))
            .collect();
        want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(q.len(), want.len());
        let got: Vec<(f64, u32)> = std::iter::from_fn(|| q.pop()).collect();
        assert_eq!(got, want);
        assert!(q.is_empty());
    }
}
