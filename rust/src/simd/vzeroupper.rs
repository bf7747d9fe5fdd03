//! Clearing the upper halves of the vector registers after faer's kernels.
//!
//! faer picks AVX2/AVX-512 kernels at run time and can return with the upper register halves
//! dirty; this crate's own loops are baseline x86-64 (SSE2) code, and on Intel cores every
//! SSE instruction executed in that state pays a penalty. Measured here: the row filters ran
//! 5× slower on a thread that had just run an eigendecomposition. `vzeroupper` restores the
//! clean state; it is called after every faer call and at the start of the hot loops (rayon
//! workers may have run faer tasks before).

/// Executes `vzeroupper` when the CPU has AVX (a no-op elsewhere).
#[inline]
pub(crate) fn clear_upper_state() {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU supports AVX (checked just above).
            unsafe { zero_upper() }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn zero_upper() {
    std::arch::x86_64::_mm256_zeroupper()
}
