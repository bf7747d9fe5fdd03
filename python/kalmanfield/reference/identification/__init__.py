"""Twins of the identification kernels."""
