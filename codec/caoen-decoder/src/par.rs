//! The decoder's data parallelism: rayon with the `parallel` feature, else the same calls
//! on the caller's thread. Every parallel loop here writes disjoint outputs or combines
//! integers, so both give the same bytes; the sequential twin is what the WebAssembly
//! build runs.

#[cfg(feature = "parallel")]
pub use rayon::join;
#[cfg(feature = "parallel")]
pub use rayon::prelude::*;

#[cfg(not(feature = "parallel"))]
pub use sequential::*;

/// Threads the parallel loops may run at once: each holds its own task buffers.
pub fn workers() -> usize {
    #[cfg(feature = "parallel")]
    return rayon::current_num_threads();
    #[cfg(not(feature = "parallel"))]
    return 1;
}

#[cfg(not(feature = "parallel"))]
mod sequential {
    /// Runs `a`, then `b`.
    pub fn join<A, B, RA, RB>(a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA,
        B: FnOnce() -> RB,
    {
        let ra = a();
        (ra, b())
    }

    /// `into_par_iter` as a plain iterator.
    pub trait IntoParallelIterator: IntoIterator + Sized {
        /// The plain iterator.
        fn into_par_iter(self) -> Self::IntoIter {
            self.into_iter()
        }
    }
    impl<T: IntoIterator> IntoParallelIterator for T {}

    /// `par_iter` and `par_chunks_mut` of slices as plain iterators.
    pub trait ParallelSlice<T> {
        /// The slice's plain iterator.
        fn par_iter(&self) -> std::slice::Iter<'_, T>;
        /// The slice's plain mutable chunks.
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T>;
    }
    impl<T> ParallelSlice<T> for [T] {
        fn par_iter(&self) -> std::slice::Iter<'_, T> {
            self.iter()
        }
        fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T> {
            self.chunks_mut(size)
        }
    }

    /// rayon's per-worker state calls, with one state for the whole loop.
    pub trait ParallelIterator: Iterator + Sized {
        /// `for_each` with a state made once.
        fn for_each_init<S, I, F>(self, init: I, mut f: F)
        where
            I: Fn() -> S,
            F: FnMut(&mut S, Self::Item),
        {
            let mut state = init();
            self.for_each(|item| f(&mut state, item));
        }

        /// `map` with a state made once.
        fn map_init<S, I, F, R>(self, init: I, f: F) -> MapInit<Self, S, F>
        where
            I: Fn() -> S,
            F: FnMut(&mut S, Self::Item) -> R,
        {
            MapInit {
                iter: self,
                state: init(),
                f,
            }
        }

        /// Collects into `out`, replacing its contents.
        fn collect_into_vec(self, out: &mut Vec<Self::Item>) {
            out.clear();
            out.extend(self);
        }
    }
    impl<T: Iterator> ParallelIterator for T {}

    /// The iterator of [`ParallelIterator::map_init`].
    pub struct MapInit<I, S, F> {
        iter: I,
        state: S,
        f: F,
    }

    impl<I: Iterator, S, R, F: FnMut(&mut S, I::Item) -> R> Iterator for MapInit<I, S, F> {
        type Item = R;
        fn next(&mut self) -> Option<R> {
            let item = self.iter.next()?;
            Some((self.f)(&mut self.state, item))
        }
    }
}
