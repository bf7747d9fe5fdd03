"""Shared helpers of the row-filter tests: noisy scenes and exact MSE of a linear filter."""

import numpy as np

from kalmanfield.reference.rowfilter import row_filters as ref


def noisy(model, shape, noise_var, seed):
    """(x, z = x + θ): a field of `model` and white noise of variance `noise_var`."""
    x = model.sample(shape, seed=seed)
    return x, x + np.sqrt(noise_var) * np.random.default_rng(seed).standard_normal(shape)


def exact_mse_map(filt, model, noise_var, shape):
    """Exact per-pixel MSE map of a linear filter (basis images, no Monte Carlo)."""

    def estimator(zb):
        return np.moveaxis(filt.filter(np.ascontiguousarray(np.moveaxis(zb, 2, 0))), 0, 2)

    rho, order, sigma = model.rho, model.order, model.sigma
    return ref.linear_estimator_mse(estimator, rho, order, sigma, noise_var, shape)


def exact_mse(filt, model, noise_var, shape):
    """Exact mean MSE of a linear filter."""
    return float(exact_mse_map(filt, model, noise_var, shape).mean())
