//! The one runtime dispatch of the hot kernels: a [`Kernel`] runs in a function compiled
//! with FMA and AVX2 when the CPU has them ([`Fused`] arithmetic, four columns per
//! instruction where the loops vectorise), as baseline x86-64 code otherwise ([`Plain`]).
//!
//! The crate is built for baseline x86-64, where `mul_add` would be a slow library call and
//! Rust never contracts `a * b + c` by itself, so the kernels are generic over [`Arith`] and
//! instantiated fused only under `target_feature`. Kernels written with plain `*` and `+`
//! give the same bits in both builds.

use super::lanes::F64x4;

/// Whether the fused build of the kernels can run on this CPU (the same answer on every
/// thread of a process, so every thread produces the same bits).
pub(crate) fn fused_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("fma") && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The arithmetic of the kernels.
pub(crate) trait Arith {
    /// The four-lane vectors of the block recursions, same arithmetic.
    type Vector: F64x4;
    /// c − a·b.
    fn sub_product(c: f64, a: f64, b: f64) -> f64;
    /// c + a·b.
    fn add_product(c: f64, a: f64, b: f64) -> f64;
}

/// Separate multiply and add (portable).
pub(crate) struct Plain;

/// Fused multiply-add: only instantiated inside [`dispatch`]'s FMA build.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) struct Fused;

impl Arith for Plain {
    type Vector = [f64; 4];
    #[inline(always)]
    fn sub_product(c: f64, a: f64, b: f64) -> f64 {
        c - a * b
    }
    #[inline(always)]
    fn add_product(c: f64, a: f64, b: f64) -> f64 {
        c + a * b
    }
}

impl Arith for Fused {
    #[cfg(target_arch = "x86_64")]
    type Vector = super::lanes::Avx2;
    #[cfg(not(target_arch = "x86_64"))]
    type Vector = [f64; 4];
    #[inline(always)]
    fn sub_product(c: f64, a: f64, b: f64) -> f64 {
        (-a).mul_add(b, c)
    }
    #[inline(always)]
    fn add_product(c: f64, a: f64, b: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// A hot loop and its arguments, run by [`dispatch`] in the CPU's best build.
pub(crate) trait Kernel {
    type Output;
    /// The loop in arithmetic `A`. Must be `#[inline(always)]`, and so must everything it
    /// calls in the loop: only code inlined into the dispatcher's functions gets their
    /// target features.
    fn run<A: Arith>(self) -> Self::Output;
}

/// Runs `kernel` in its FMA/AVX2 build where the CPU has FMA and AVX2, its portable build
/// otherwise. Each kernel type gets its own pair of functions (never inlined into the
/// caller: a caller dispatching many kernels, e.g. one per bandwidth, would otherwise grow
/// one function whose loop passes take most of the build time).
#[inline]
pub(crate) fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if fused_available() {
        // SAFETY: the CPU has FMA and AVX2.
        return unsafe { run_fused(kernel) };
    }
    run_plain(kernel)
}

/// `kernel` in its portable build (the tests compare it with the fused one).
#[inline(never)]
pub(crate) fn run_plain<K: Kernel>(kernel: K) -> K::Output {
    kernel.run::<Plain>()
}

/// `kernel` compiled with FMA and AVX2.
///
/// # Safety
/// The CPU has FMA and AVX2 ([`fused_available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma,avx2")]
#[inline(never)]
unsafe fn run_fused<K: Kernel>(kernel: K) -> K::Output {
    kernel.run::<Fused>()
}
