//! Work buffers kept between calls: a large buffer allocated afresh on every call is
//! page-faulted in again each time (~1.5 µs per 4 KiB page here, 12 ms for a 2048² float64
//! image: a fifth of the smoothed (1,1) row filter's time).

use std::sync::Mutex;

/// Buffers of f64 handed out to one caller at a time and returned after use; concurrent
/// callers (the frames of a stack on several threads) each get their own.
#[derive(Default)]
pub(crate) struct BufferPool {
    buffers: Mutex<Vec<Vec<f64>>>,
}

impl BufferPool {
    /// A buffer of `len` entries (contents unspecified: the caller overwrites them).
    pub(crate) fn take(&self, len: usize) -> Vec<f64> {
        let mut buffer = self.lock().pop().unwrap_or_default();
        buffer.resize(len, 0.0);
        buffer
    }

    /// Returns `buffer` for the next caller.
    pub(crate) fn give(&self, buffer: Vec<f64>) {
        self.lock().push(buffer);
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Vec<f64>>> {
        self.buffers.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl std::fmt::Debug for BufferPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let held: usize = self.lock().iter().map(Vec::capacity).sum();
        write!(f, "BufferPool({held} f64 held)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_returned_buffer_is_reused_and_concurrent_takers_get_distinct_buffers() {
        let pool = BufferPool::default();
        let first = pool.take(1000);
        let address = first.as_ptr();
        let second = pool.take(10);
        assert_ne!(second.as_ptr(), address);
        assert_eq!((first.len(), second.len()), (1000, 10));
        pool.give(first);
        let again = pool.take(500);
        assert_eq!((again.as_ptr(), again.len()), (address, 500));
    }
}
