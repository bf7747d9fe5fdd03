//! Frame-sized scratch buffers reused across calls on the same thread.
//!
//! A kernel that allocates a few frame-sized temporaries per call pays a page fault per
//! 4 KiB page on every call once glibc hands the freed memory back to the system (the main
//! thread's heap is trimmed when more than twice the mmap threshold is free at its top;
//! blocks over 32 MiB are always mapped afresh): a quarter of a small `denoise` call's time.
//! A [`Scratch`] buffer goes back to its thread's spare list when dropped, and the next
//! request of that thread reuses it; each thread keeps at most
//! [`RETAINED_BYTES`] of spares (the largest ones), freed when the thread ends.

use std::cell::RefCell;
use std::ops::{Deref, DerefMut};

/// Most bytes of spare buffers one thread keeps between calls (256 MiB: four 2048² float64
/// frames, the adaptive denoiser's need).
pub(crate) const RETAINED_BYTES: usize = 256 << 20;

const RETAINED_VALUES: usize = RETAINED_BYTES / std::mem::size_of::<f64>();

thread_local! {
    static SPARES: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

/// A zero-filled `f64` buffer taken from (and given back to) the thread's spare list.
#[derive(Debug)]
pub(crate) struct Scratch(Vec<f64>);

impl Scratch {
    /// `len` zeros: the smallest spare of at least `len` values, or a fresh allocation.
    pub fn zeros(len: usize) -> Self {
        let spare = SPARES.with(|spares| {
            let mut spares = spares.borrow_mut();
            let best = (0..spares.len())
                .filter(|&k| spares[k].capacity() >= len)
                .min_by_key(|&k| spares[k].capacity());
            best.map(|k| spares.swap_remove(k))
        });
        match spare {
            Some(mut values) => {
                values.clear();
                values.resize(len, 0.0);
                Scratch(values)
            }
            None => Scratch(vec![0.0; len]),
        }
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let values = std::mem::take(&mut self.0);
        if values.capacity() == 0 || values.capacity() > RETAINED_VALUES {
            return;
        }
        // (`try_with`: the thread's list may already be gone when a thread-local drops us)
        let _ = SPARES.try_with(|spares| {
            let mut spares = spares.borrow_mut();
            spares.push(values);
            spares.sort_unstable_by_key(|v| std::cmp::Reverse(v.capacity()));
            let mut kept = 0;
            spares.retain(|v| {
                kept += v.capacity();
                kept <= RETAINED_VALUES
            });
        });
    }
}

impl Deref for Scratch {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.0
    }
}

impl DerefMut for Scratch {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bytes of spare buffers this thread holds now.
    fn retained_bytes() -> usize {
        SPARES.with(|spares| {
            let values: usize = spares.borrow().iter().map(Vec::capacity).sum();
            values * std::mem::size_of::<f64>()
        })
    }

    #[test]
    fn a_dropped_buffer_is_reused_zeroed() {
        let address = {
            let mut first = Scratch::zeros(1000);
            first.fill(7.0);
            first.as_ptr()
        };
        assert_eq!(retained_bytes(), 8000);
        let second = Scratch::zeros(900);
        assert_eq!(second.as_ptr(), address);
        assert_eq!(second.len(), 900);
        assert!(second.iter().all(|&v| v == 0.0));
        assert_eq!(retained_bytes(), 0);
    }

    #[test]
    fn the_smallest_fitting_spare_is_taken_and_a_short_one_is_left() {
        let (small, large) = (Scratch::zeros(100), Scratch::zeros(10_000));
        let (small_at, large_at) = (small.as_ptr(), large.as_ptr());
        drop((small, large));
        let middle = Scratch::zeros(50);
        assert_eq!(middle.as_ptr(), small_at);
        let wide = Scratch::zeros(20_000);
        assert_ne!(wide.as_ptr(), large_at);
        assert_eq!(retained_bytes(), 80_000);
    }

    #[test]
    fn retention_is_capped_keeping_the_largest() {
        let quarter = RETAINED_VALUES / 4;
        let buffers: Vec<Scratch> = (0..5).map(|k| Scratch::zeros(quarter + k)).collect();
        drop(buffers);
        // the four largest would exceed the cap by 1 + 2 + 3 + 4 values: three are kept
        assert!(retained_bytes() <= RETAINED_BYTES);
        assert_eq!(retained_bytes() / 8, 3 * quarter + 4 + 3 + 2);
        drop(Scratch::zeros(RETAINED_VALUES + 1));
        assert_eq!(retained_bytes() / 8, 3 * quarter + 4 + 3 + 2);
    }

    #[test]
    fn threads_keep_their_own_spares() {
        drop(Scratch::zeros(64));
        let elsewhere = std::thread::spawn(retained_bytes).join().unwrap();
        assert_eq!(elsewhere, 0);
        assert_eq!(retained_bytes(), 512);
    }
}
