"""Type identification by a bank of Kalman filters (source [I]), Rust core."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._validation import probability, real_array, thread_count
from ._batch import bank_models, frame_batch, run_batch, stream_shape
from .model import LinearGaussianModel
from .tracks import tracks_to_batch

#: the decision while Wald's test has crossed no threshold
UNDECIDED = -1


def _priors(priors: npt.ArrayLike | None, k: int) -> list[float]:
    if priors is None:
        return [1.0 / k] * k
    p = real_array(priors, "priors")
    if p.shape != (k,):
        raise ValueError(f"priors must have {k} entries (one per model), got shape {p.shape}")
    if not (np.isfinite(p).all() and (p >= 0).all() and (p <= 1).all()):
        raise ValueError(f"priors must lie in [0, 1], got {p}")
    if abs(p.sum() - 1.0) > 1e-9:
        raise ValueError(f"priors must sum to 1, got {p.sum()!r}")
    return [float(v) for v in p]


class TypeIdentifier:
    """Identify an object's type from its trajectory with a bank of Kalman filters [I].

    Each of the K models runs a Kalman filter on the same measurements and accumulates the
    log-likelihood L_i of its innovations; after every frame the decision is the maximum
    posterior type argmax ln π_i + L_i, or — for two types with ``alpha`` and ``beta`` —
    Wald's sequential probability-ratio test on L_1 − L_0 with thresholds
    ln(β/(1 − α)) (type 0) and ln((1 − β)/α) (type 1), undecided (−1) until one is crossed;
    the test stops at its first crossing.

    Parameters
    ----------
    models : sequence of LinearGaussianModel
        At least two candidate types observing measurements of one length m.
    priors : array-like, optional
        Prior type probabilities (default uniform); they must sum to 1.
    alpha, beta : float, optional
        Allowed confusion probabilities of the sequential test (two models): α = P(decide
        type 1 | type 0), β = P(decide type 0 | type 1). Give both or neither.

    Raises
    ------
    ValueError
        Fewer than two models, models observing different lengths, priors not summing to 1,
        α or β outside (0, 1), α + β ≥ 1, or α/β with more than two models.
    TypeError
        Models that are not LinearGaussianModel.

    Notes
    -----
    A stream follows one trajectory (frames of shape (m,)) or a batch of B trajectories
    (frames (B, m)); a batch runs in Rust over all trajectories at once, threads over
    trajectories, the GIL released. A NaN row is a missed frame (prediction only). The
    identifier pickles mid-stream and resumes exactly. See the method page *Kalman filter
    bank*.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> calm = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.95, sigma=1.0, name="calm")
    >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.8, sigma_a=0.5, name="agile")
    >>> _, z = agile.simulate(60, seed=1, start=[0, 1, 0, 0, -1, 0])
    >>> ident = kf.TypeIdentifier([calm, agile])
    >>> int(ident.run(z)[-1]), ident.names[ident.decision]
    (1, 'agile')
    """

    def __init__(
        self,
        models: Sequence[LinearGaussianModel],
        priors: npt.ArrayLike | None = None,
        alpha: float | None = None,
        beta: float | None = None,
    ) -> None:
        self._models = bank_models(models)
        k = len(self._models)
        self._priors = _priors(priors, k)
        if (alpha is None) != (beta is None):
            raise ValueError("give both alpha and beta (the sequential test) or neither")
        if alpha is not None and beta is not None:
            alpha, beta = probability(alpha, "alpha"), probability(beta, "beta")
            if k != 2:
                raise ValueError(f"the sequential test (alpha, beta) needs two models, got {k}")
            if alpha + beta >= 1:
                raise ValueError(f"alpha + beta must be below 1, got {alpha + beta}")
        self._errors = (alpha, beta)
        self._core = self._new_core()
        self._batched: bool | None = None

    def _new_core(self) -> _core.TypeIdentifier:
        arrays = [m.arrays() for m in self._models]
        return _core.TypeIdentifier(arrays, self._priors, *self._errors)

    # ------------------------------------------------------------------ properties
    @property
    def models(self) -> list[LinearGaussianModel]:
        """The candidate types."""
        return list(self._models)

    @property
    def names(self) -> list[str]:
        """The models' names."""
        return [m.name for m in self._models]

    @property
    def priors(self) -> np.ndarray:
        """Prior type probabilities."""
        return np.array(self._priors)

    @property
    def sequential(self) -> bool:
        """Whether decisions come from Wald's test (alpha and beta given)."""
        return self._errors[0] is not None

    @property
    def thresholds(self) -> tuple[float, float] | None:
        """(lower, upper) thresholds of L_1 − L_0 for Wald's test, else None."""
        alpha, beta = self._errors
        if alpha is None or beta is None:
            return None
        return float(np.log(beta / (1 - alpha))), float(np.log((1 - beta) / alpha))

    @property
    def frame(self) -> int:
        """Frames processed."""
        return self._core.frame

    @property
    def log_likelihoods(self) -> np.ndarray:
        """Accumulated log-likelihood ln p(z_1..z_k | type i): (K,), or (B, K) for a batch."""
        if self._batched is None:
            return np.zeros(len(self._models))
        return self._shaped(self._core.log_likelihoods())

    @property
    def posterior(self) -> np.ndarray:
        """Posterior type probabilities: (K,), or (B, K) for a batch."""
        if self._batched is None:
            return self.priors
        return self._shaped(self._core.posterior())

    @property
    def decision(self) -> Any:
        """The current decision: a type index (−1 = undecided), an array for a batch."""
        if self._batched is None:
            return UNDECIDED if self.sequential else int(np.argmax(self._priors))
        decisions = self._core.decisions()
        return decisions if self._batched else int(decisions[0])

    def _shaped(self, a: np.ndarray) -> np.ndarray:
        return a if self._batched else a[0]

    # ------------------------------------------------------------------ processing
    def update(self, measurement: npt.ArrayLike, threads: int | None = None) -> Any:
        """Processes one frame: (m,) for one trajectory, (B, m) for a batch; a NaN row is a
        missed frame. Returns :attr:`decision`."""
        z, batched = frame_batch(measurement, self._models[0].measurement_dim)
        self._advance(z, batched, thread_count(threads), False)
        return self.decision

    def run(
        self,
        measurements: npt.ArrayLike,
        *,
        return_log_likelihoods: bool = False,
        threads: int | None = None,
    ) -> Any:
        """Processes frames (continuing the stream): (n_frames, m) for one trajectory,
        (n_trajectories, n_frames, m) for a batch, NaN rows missed.

        Returns
        -------
        decisions : ndarray of int64, (n_frames,) or (n_trajectories, n_frames)
            The decision after every frame (−1 = undecided).
        log_likelihoods : ndarray, (n_frames, K) or (n_trajectories, n_frames, K)
            The accumulated log-likelihoods after every frame, if ``return_log_likelihoods``.
        """
        z, batched = run_batch(measurements, self._models[0].measurement_dim)
        decisions, ll = self._advance(z, batched, thread_count(threads), return_log_likelihoods)
        if not batched:
            decisions, ll = decisions[0], None if ll is None else ll[0]
        return (decisions, ll) if return_log_likelihoods else decisions

    def _advance(self, z: np.ndarray, batched: bool, threads: int | None, keep: bool) -> Any:
        stream_shape(batched, self._batched, z.shape[0], self._core.n_trajectories)
        out = self._core.run(z, keep, threads)
        self._batched = batched
        return out

    # ------------------------------------------------------------------ tracker output
    @staticmethod
    def run_tracks(
        tracks: pd.DataFrame,
        models: Sequence[LinearGaussianModel],
        priors: npt.ArrayLike | None = None,
        alpha: float | None = None,
        beta: float | None = None,
        *,
        columns: Sequence[str] = ("x", "y"),
        threads: int | None = None,
    ) -> pd.DataFrame:
        """Identifies the type of every particle of a tracker's output.

        Parameters
        ----------
        tracks : DataFrame
            Columns ``frame``, ``particle`` and the measured ``columns`` (default x, y), as
            written by trackpy, :class:`kalmanfield.BranchingTracker` or the template
            tracker. Frames a particle skips between its first and last are missed frames.
        models, priors, alpha, beta
            As for :class:`TypeIdentifier` (the models observe ``len(columns)`` values).

        Returns
        -------
        DataFrame
            One row per particle: ``particle``, ``first_frame``, ``last_frame``,
            ``n_observed``, ``decision`` (index, −1 undecided), ``type`` (the model's name or
            ``"undecided"``), ``posterior_<name>`` and ``log_likelihood_<name>`` per model.
        """
        ident = TypeIdentifier(models, priors, alpha, beta)
        z, info = tracks_to_batch(tracks, columns)
        ident.run(z, threads=threads)
        table = info.copy()
        decisions = ident._core.decisions()
        table["decision"] = decisions
        names = ident.names
        table["type"] = [names[d] if d >= 0 else "undecided" for d in decisions]
        posterior, ll = ident._core.posterior(), ident._core.log_likelihoods()
        for i, name in enumerate(names):
            table[f"posterior_{name}"] = posterior[:, i]
        for i, name in enumerate(names):
            table[f"log_likelihood_{name}"] = ll[:, i]
        return table

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        return {
            "models": self._models,
            "priors": self._priors,
            "errors": self._errors,
            "batched": self._batched,
            "state": self._core.state_bytes(),
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._models = list(state["models"])
        self._priors = list(state["priors"])
        self._errors = tuple(state["errors"])
        self._batched = state["batched"]
        self._core = self._new_core()
        self._core.load_state(state["state"])

    def __repr__(self) -> str:
        rule = "wald" if self.sequential else "max_posterior"
        return f"TypeIdentifier(models={self.names}, decision_rule={rule!r}, frames={self.frame})"
