//! The pixel types of frames.

/// A pixel type of a frame: converted exactly to f64.
pub trait Pixel: Copy + Into<f64> + Send + Sync {
    /// Whether a value of this type can be NaN or infinite (floats).
    const MAY_BE_NON_FINITE: bool;
}
impl Pixel for u8 {
    const MAY_BE_NON_FINITE: bool = false;
}
impl Pixel for u16 {
    const MAY_BE_NON_FINITE: bool = false;
}
impl Pixel for f32 {
    const MAY_BE_NON_FINITE: bool = true;
}
impl Pixel for f64 {
    const MAY_BE_NON_FINITE: bool = true;
}
