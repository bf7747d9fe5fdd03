"""Type identification by a bank of Kalman filters (source [I]), Rust core."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._validation import pickled_fields, probability, real_array, thread_count
from ._batch import bank_models, frame_batch, restored_batched, run_batch, stream_shape
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

    See Also
    --------
    LinearGaussianModel : The candidate types.
    IMMEstimator : For objects that switch type mid-track.

    Notes
    -----
    A stream follows one trajectory (frames of shape (m,)) or a batch of B trajectories
    (frames (B, m)); a batch runs in Rust over all trajectories at once, threads over
    trajectories, the GIL released. A NaN row is a missed frame (prediction only). The
    identifier pickles mid-stream and resumes exactly. The bank, the decisions and the
    batches are §6.3–6.5 of :doc:`/methods/kalman_bank`.

    The likelihoods include the first frames, where the models' priors weigh most. Wald's
    test stops at its first crossing, so give the types priors of comparable spread: the
    default prior of :meth:`LinearGaussianModel.singer` is diffuse in velocity, that of
    :meth:`LinearGaussianModel.markov_velocity` is not, and that difference alone can decide
    the test at the second frame.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> calm = kf.LinearGaussianModel.markov_velocity(
    ...     1.0, rho=0.98, sigma=0.5, measurement_std=0.5, name="calm"
    ... )
    >>> agile = kf.LinearGaussianModel.singer(
    ...     1.0, rho=0.6, sigma_a=0.8, measurement_std=0.5, name="agile"
    ... )
    >>> _, z = agile.simulate(60, seed=1, start=[0, 1, 0, 0, 0, 0])
    >>> ident = kf.TypeIdentifier([calm, agile])
    >>> decisions = ident.run(z)  # the decision after every frame
    >>> ident.names[ident.decision], ident.posterior.round(3)
    ('agile', array([0., 1.]))
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
        """The candidate types (a list of LinearGaussianModel)."""
        return list(self._models)

    @property
    def names(self) -> list[str]:
        """The models' names (a list of str)."""
        return [m.name for m in self._models]

    @property
    def priors(self) -> np.ndarray:
        """The prior type probabilities (K,)."""
        return np.array(self._priors)

    @property
    def sequential(self) -> bool:
        """Whether the decisions come from Wald's test (alpha and beta given)."""
        return self._errors[0] is not None

    @property
    def thresholds(self) -> tuple[float, float] | None:
        """The (lower, upper) thresholds of L_1 − L_0 of Wald's test, or None."""
        alpha, beta = self._errors
        if alpha is None or beta is None:
            return None
        return float(np.log(beta / (1 - alpha))), float(np.log((1 - beta) / alpha))

    @property
    def frame(self) -> int:
        """The number of frames processed."""
        return self._core.frame

    @property
    def log_likelihoods(self) -> np.ndarray:
        """The accumulated log-likelihoods ln p(z_1..z_k | type i): (K,), or (B, K)."""
        if self._batched is None:
            return np.zeros(len(self._models))
        return self._shaped(self._core.log_likelihoods())

    @property
    def posterior(self) -> np.ndarray:
        """The posterior type probabilities: (K,), or (B, K) for a batch."""
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
        """Process one frame.

        Parameters
        ----------
        measurement : array-like
            (m,) for one trajectory, (B, m) for a batch; a row of NaN is a missed frame.
        threads : int, optional
            Number of threads for a batch (None: all cores).

        Returns
        -------
        int or numpy.ndarray
            :attr:`decision` after the frame: a type index (−1 = undecided), or (B,) int64
            for a batch.

        Raises
        ------
        ValueError
            A frame of the wrong shape, a row partly NaN or with an infinite value, or a
            frame that does not continue the stream (one trajectory against a batch, or
            another batch size).

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> calm = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.98, sigma=0.5, name="calm")
        >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.6, sigma_a=0.8, name="agile")
        >>> ident = kf.TypeIdentifier([calm, agile])
        >>> ident.update([0.0, 0.0])
        0
        >>> ident.update([np.nan, np.nan])  # a missed frame
        0
        >>> ident.frame
        2
        """
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
        """Process a run of frames, continuing the stream.

        Parameters
        ----------
        measurements : array-like
            (n_frames, m) for one trajectory, (n_trajectories, n_frames, m) for a batch;
            a row of NaN is a missed frame.
        return_log_likelihoods : bool, default False
            Also return the accumulated log-likelihoods after every frame.
        threads : int, optional
            Number of threads for a batch (None: all cores).

        Returns
        -------
        decisions : numpy.ndarray
            The decision after every frame (−1 = undecided): int64, (n_frames,) or
            (n_trajectories, n_frames).
        log_likelihoods : numpy.ndarray
            The accumulated log-likelihoods after every frame, (n_frames, K) or
            (n_trajectories, n_frames, K); only if `return_log_likelihoods`.

        Raises
        ------
        ValueError
            Measurements of the wrong shape, a row partly NaN or with an infinite value, or
            a run that does not continue the stream (one trajectory against a batch, or
            another batch size).

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> calm = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.98, sigma=0.5, name="calm")
        >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.6, sigma_a=0.8, name="agile")
        >>> batch = agile.simulate(40, 8, seed=3, start=[0, 1, 0, 0, 0, 0])[1]
        >>> decisions, ll = kf.TypeIdentifier([calm, agile]).run(
        ...     batch, return_log_likelihoods=True
        ... )
        >>> decisions.shape, ll.shape
        ((8, 40), (8, 40, 2))
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
        """Identify the type of every particle of a tracker's output.

        Parameters
        ----------
        tracks : pandas.DataFrame
            Columns ``frame``, ``particle`` and the measured `columns`, as written by
            trackpy, :class:`~kalmanfield.BranchingTracker` or the template tracker. Frames
            a particle skips between its first and last are missed frames.
        models : sequence of LinearGaussianModel
            The candidate types, observing ``len(columns)`` values.
        priors : array-like, optional
            Prior type probabilities (default uniform), as for :class:`TypeIdentifier`.
        alpha : float, optional
            Wald's test: P(decide type 1 | type 0), as for :class:`TypeIdentifier`.
        beta : float, optional
            Wald's test: P(decide type 0 | type 1), as for :class:`TypeIdentifier`.
        columns : sequence of str, default ("x", "y")
            The measured columns.
        threads : int, optional
            Number of threads (None: all cores).

        Returns
        -------
        pandas.DataFrame
            One row per particle: ``particle``, ``first_frame``, ``last_frame``,
            ``n_observed``, ``decision`` (index, −1 undecided), ``type`` (the model's name or
            ``"undecided"``), ``posterior_<name>`` and ``log_likelihood_<name>`` per model.

        Raises
        ------
        TypeError
            `tracks` is not a DataFrame, or a model is not a LinearGaussianModel.
        ValueError
            Missing columns, an empty table, non-integer frames, a particle with two rows
            for one frame, or models and settings :class:`TypeIdentifier` refuses.

        Examples
        --------
        >>> import numpy as np
        >>> import pandas as pd
        >>> import kalmanfield as kf
        >>> calm = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.98, sigma=0.5, name="calm")
        >>> agile = kf.LinearGaussianModel.singer(1.0, rho=0.6, sigma_a=0.8, name="agile")
        >>> _, z = calm.simulate(30, seed=0, start=[0, 1, 0, 0])
        >>> tracks = pd.DataFrame(
        ...     {"frame": np.arange(30), "particle": 7, "x": z[:, 0], "y": z[:, 1]}
        ... )
        >>> kf.TypeIdentifier.run_tracks(tracks, [calm, agile])[["particle", "n_observed", "type"]]
           particle  n_observed  type
        0         7          30  calm
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
        # through the constructor's checks: a pickle is input like any other
        fields = pickled_fields(state, "TypeIdentifier", "models", "priors", "errors", "batched")
        models, priors, errors, batched = fields
        if not isinstance(errors, tuple) or len(errors) != 2:
            raise ValueError("the pickled TypeIdentifier is altered: errors is not (alpha, beta)")
        self.__init__(models, priors, *errors)  # type: ignore[misc]
        self._core.load_state(pickled_fields(state, "TypeIdentifier", "state")[0])
        self._batched = restored_batched(batched, self._core.n_trajectories)

    def __repr__(self) -> str:
        rule = "wald" if self.sequential else "max_posterior"
        return f"TypeIdentifier(models={self.names}, decision_rule={rule!r}, frames={self.frame})"
