//! Vectors of four f64 lanes, for the block recursions of `linalg::banded::steady_blocks`
//! (one lane per position of a block, G ≤ 4, so that a block product is G multiply-adds of
//! a matrix column by one broadcast lane), and fixed-length blocks of a slice as arrays.
//! Two implementations of one interface: plain arrays (portable, separate multiply and add)
//! and AVX2 registers with fused multiply-adds (x86-64).
//!
//! The AVX2 kernels are written with intrinsics: with arrays, LLVM's vectoriser mixed the
//! lanes of the two blocks of a look-ahead step into shuffled half-vectors, which ran
//! slower than the plain recursion.

/// A vector of four f64 lanes.
///
/// # Safety
/// Values come only from [`F64x4::load`] and [`F64x4::splat`], whose callers
/// guarantee the instructions the implementation needs; the arithmetic on values that
/// exist is then safe.
pub(crate) unsafe trait F64x4: Copy {
    /// The four lanes of `c`.
    ///
    /// # Safety
    /// The CPU has the implementation's instructions (AVX2 and FMA for [`Avx2`]).
    unsafe fn load(c: &[f64; 4]) -> Self;
    /// `x` in every lane.
    ///
    /// # Safety
    /// As [`F64x4::load`].
    unsafe fn splat(x: &f64) -> Self;
    /// Lane q (< 4) in every lane.
    fn lane(self, q: usize) -> Self;
    /// m ∘ v.
    fn mul(m: Self, v: Self) -> Self;
    /// c + m ∘ v.
    fn add_product(c: Self, m: Self, v: Self) -> Self;
    /// c − m ∘ v.
    fn sub_product(c: Self, m: Self, v: Self) -> Self;
    /// a − b.
    fn sub(a: Self, b: Self) -> Self;
    /// Lanes 0..G (G ≤ 4) into `out`.
    fn store_lanes<const G: usize>(self, out: &mut [f64; G]);
}

// SAFETY: plain arrays need no special instructions.
unsafe impl F64x4 for [f64; 4] {
    #[inline(always)]
    unsafe fn load(c: &[f64; 4]) -> Self {
        *c
    }
    #[inline(always)]
    unsafe fn splat(x: &f64) -> Self {
        [*x; 4]
    }
    #[inline(always)]
    fn lane(self, q: usize) -> Self {
        [self[q]; 4]
    }
    #[inline(always)]
    fn mul(m: Self, v: Self) -> Self {
        std::array::from_fn(|p| m[p] * v[p])
    }
    #[inline(always)]
    fn add_product(c: Self, m: Self, v: Self) -> Self {
        std::array::from_fn(|p| c[p] + m[p] * v[p])
    }
    #[inline(always)]
    fn sub_product(c: Self, m: Self, v: Self) -> Self {
        std::array::from_fn(|p| c[p] - m[p] * v[p])
    }
    #[inline(always)]
    fn sub(a: Self, b: Self) -> Self {
        std::array::from_fn(|p| a[p] - b[p])
    }
    #[inline(always)]
    fn store_lanes<const G: usize>(self, out: &mut [f64; G]) {
        out.copy_from_slice(&self[..G]);
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::F64x4;
    use std::arch::x86_64::*;

    /// An AVX2 register; the multiply-adds are fused. Only instantiated by the `Fused`
    /// arithmetic (`simd::dispatch`: compiled with AVX2 and FMA, run only on CPUs that have
    /// them), into which every method is inlined.
    #[derive(Clone, Copy)]
    pub(crate) struct Avx2(__m256d);

    // SAFETY (every `unsafe` block below): an `Avx2` exists only after `load` or `splat`,
    // whose callers guarantee AVX2 and FMA.
    unsafe impl F64x4 for Avx2 {
        #[inline(always)]
        unsafe fn load(c: &[f64; 4]) -> Self {
            Avx2(_mm256_loadu_pd(c.as_ptr()))
        }
        #[inline(always)]
        unsafe fn splat(x: &f64) -> Self {
            Avx2(_mm256_broadcast_sd(x))
        }
        #[inline(always)]
        fn lane(self, q: usize) -> Self {
            let v = self.0;
            Avx2(unsafe {
                match q {
                    0 => _mm256_broadcastsd_pd(_mm256_castpd256_pd128(v)),
                    1 => _mm256_permute4x64_pd::<0x55>(v),
                    2 => _mm256_permute4x64_pd::<0xAA>(v),
                    _ => _mm256_permute4x64_pd::<0xFF>(v),
                }
            })
        }
        #[inline(always)]
        fn mul(m: Self, v: Self) -> Self {
            Avx2(unsafe { _mm256_mul_pd(m.0, v.0) })
        }
        #[inline(always)]
        fn add_product(c: Self, m: Self, v: Self) -> Self {
            Avx2(unsafe { _mm256_fmadd_pd(m.0, v.0, c.0) })
        }
        #[inline(always)]
        fn sub_product(c: Self, m: Self, v: Self) -> Self {
            Avx2(unsafe { _mm256_fnmadd_pd(m.0, v.0, c.0) })
        }
        #[inline(always)]
        fn sub(a: Self, b: Self) -> Self {
            Avx2(unsafe { _mm256_sub_pd(a.0, b.0) })
        }
        #[inline(always)]
        fn store_lanes<const G: usize>(self, out: &mut [f64; G]) {
            let (v, to) = (self.0, out.as_mut_ptr());
            // each arm writes exactly G lanes
            unsafe {
                match G {
                    4 => _mm256_storeu_pd(to, v),
                    3 => {
                        _mm_storeu_pd(to, _mm256_castpd256_pd128(v));
                        _mm_store_sd(to.add(2), _mm256_extractf128_pd::<1>(v));
                    }
                    _ => {
                        let mut all = [0.0; 4];
                        _mm256_storeu_pd(all.as_mut_ptr(), v);
                        out.copy_from_slice(&all[..G]);
                    }
                }
            }
        }
    }
}

/// The K entries of v from `at`, as an array.
#[inline(always)]
pub(crate) fn block<const K: usize>(v: &[f64], at: usize) -> &[f64; K] {
    v[at..at + K].try_into().unwrap()
}

/// The K entries of v from `at`, to write.
#[inline(always)]
pub(crate) fn block_mut<const K: usize>(v: &mut [f64], at: usize) -> &mut [f64; K] {
    (&mut v[at..at + K]).try_into().unwrap()
}
