//! Denoising of images and stacks (SPEC §2 with locally adapted moments): the adaptive
//! denoiser built on the quasi-optimal row filter, its box moments, the estimate of the
//! observation noise variance σ_θ² (`noise_level`) and the per-thread frame buffers.

mod adaptive_denoise;
mod local_moments;
mod noise_level;
mod scratch;

pub use adaptive_denoise::{adaptive_denoise, AdaptiveSettings, NOMINAL_SAMPLE, SIGNAL_FLOOR};
pub use local_moments::local_moments;
pub use noise_level::haar_mad_noise_var;
