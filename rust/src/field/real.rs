//! The floating-point types the field kernels run in.

use num_traits::Float;

/// Floating-point types the kernels run in.
pub trait Real: Float + Send + Sync + 'static {
    /// Whether recursions along lines run two lines at a time. Not for f32: the compiler packs
    /// the two lanes into a 4-lane register whose idle lanes can hold denormals, and the
    /// microcode assists made it 5× slower than one line at a time.
    const PAIRED_LINES: bool;

    /// Rounds an f64 to this type.
    fn from_f64(v: f64) -> Self;
}

impl Real for f64 {
    const PAIRED_LINES: bool = true;

    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
}

impl Real for f32 {
    const PAIRED_LINES: bool = false;

    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
}
