//! Loops over fixed chunks: on rayon's pool for large regions, on the calling thread for small
//! ones (a parallel loop started from outside the pool hands the work over to the pool's
//! threads and waits, ~10 µs per loop: more than a tracker's whole window search takes). The
//! chunks and their order are the same either way, and so are the results.

use rayon::prelude::*;

/// Regions of at least this many pixels are searched in parallel.
pub(crate) const PARALLEL_PIXELS: usize = 1 << 15;

/// f(k, chunk) for the consecutive chunks of `size` entries of `data`.
pub(crate) fn for_each_chunk<T: Send>(
    data: &mut [T],
    size: usize,
    parallel: bool,
    f: impl Fn(usize, &mut [T]) + Sync + Send,
) {
    if parallel {
        data.par_chunks_mut(size)
            .enumerate()
            .for_each(|(k, c)| f(k, c));
    } else {
        data.chunks_mut(size).enumerate().for_each(|(k, c)| f(k, c));
    }
}

/// [f(k, chunk)] over the consecutive chunks of `size` entries of `data`, in chunk order.
pub(crate) fn map_chunks<T: Send, R: Send>(
    data: &mut [T],
    size: usize,
    parallel: bool,
    f: impl Fn(usize, &mut [T]) -> R + Sync + Send,
) -> Vec<R> {
    if parallel {
        data.par_chunks_mut(size)
            .enumerate()
            .map(|(k, c)| f(k, c))
            .collect()
    } else {
        data.chunks_mut(size)
            .enumerate()
            .map(|(k, c)| f(k, c))
            .collect()
    }
}

/// f(k) for k in 0..n.
pub(crate) fn for_each_index(n: usize, parallel: bool, f: impl Fn(usize) + Sync + Send) {
    if parallel {
        (0..n).into_par_iter().for_each(f);
    } else {
        (0..n).for_each(f);
    }
}
