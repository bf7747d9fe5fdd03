//! Runtime SIMD: the one FMA/AVX2 dispatch of the hot kernels, four-lane vectors and the
//! `vzeroupper` that clean vector state needs after faer's kernels.

mod dispatch;
mod lanes;
mod vzeroupper;

pub(crate) use dispatch::{dispatch, fused_available, Arith, Kernel};
#[cfg(test)]
pub(crate) use dispatch::{run_plain, Plain};
pub(crate) use lanes::{block, block_mut, F64x4};
pub(crate) use vzeroupper::clear_upper_state;
