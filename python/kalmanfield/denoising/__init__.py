"""One-call denoising by the row filters, the noise-level estimate and local moments
(method page *Denoising*)."""

from .denoise import denoise, estimate_noise_var, estimate_sigma, local_moments

__all__ = ["denoise", "estimate_noise_var", "estimate_sigma", "local_moments"]
