"""Twins of the denoising kernels."""
