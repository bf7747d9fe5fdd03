import os

import numpy as np
from hypothesis import HealthCheck, settings

from kalmanfield.reference import row_filters as ref

# CI draws the same examples every run (a failure there is reproducible, never luck); the dev
# profile keeps exploring new ones
settings.register_profile(
    "ci",
    max_examples=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=25, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


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
