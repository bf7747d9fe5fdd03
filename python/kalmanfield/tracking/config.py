"""The branching tracker's configuration: one frozen dataclass used by
:class:`~kalmanfield.BranchingTracker`, its NumPy twin, :func:`~kalmanfield.link` and the
Rust core (which reads its fields by name)."""

from __future__ import annotations

import dataclasses
import numbers
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Union

import numpy as np

from .. import _core
from .._validation import (
    SeedLike,
    nonnegative_int,
    positive_float,
    positive_int,
    probability,
    real_number,
    real_value,
    resolve_seed,
)

__all__ = ["TrackerConfig"]

#: the most parameters a measurement vector may have (each has its own filter and column)
MAX_PARAMS = 2**16

PerParam = Union[float, Sequence[float]]
SELECTIONS = ("llr", "index_per_dof", "pvalue")


@dataclass(frozen=True)
class TrackerConfig:
    """Every setting of the branching tracker, with its default.

    A setting given per parameter takes a scalar (the same for every parameter) or one value
    per parameter; :meth:`for_params` checks a configuration for k parameters and fills the
    defaults that depend on others.

    Parameters
    ----------
    order : int or sequence of int, default 1
        Order ν of the polynomial motion model per parameter (≤ 4): 1 = nearly constant
        velocity.
    process_std : float or sequence of float, default 0.1
        Std of the white (ν+1)-th derivative per parameter (px/frame² for ν = 1).
    diffusion_std : float or sequence of float, default 0.0
        Std of a random walk of the value itself per unit time, added to the motion model
        (diffusion, px/frame^½; 0 = none): with ν = 1, drift plus diffusion.
    measurement_std : float or sequence of float, default 0.5
        Measurement noise std per parameter. The stds, ``dt``, ``max_speed`` and
        ``maneuver_std`` must be at most 1e100 (the filters square them).
    confidence : float, default 0.99
        Confidence β of the χ² index test that gates a measurement into a sequence.
    memory : int, default 4
        N, the index increments kept (sliding memory; 1…256).
    max_misses : int, default 2
        Longest run of coasted (missed) frames of a sequence.
    dt : float, default 1.0
        Frame step when :meth:`BranchingTracker.update` gets no time.
    p_detect : float, default 0.9
        Detection probability used by the score.
    clutter_density : float or None, default None
        Clutter points per unit of parameter space per frame; None = estimated from the
        measurement counts and their bounding box.
    max_speed : float, default 6.0
        Largest speed between the first ν+1 points of a sequence (gates the start).
    n_spatial : int or None, default None
        Parameters that are positions (the first ones); None = min(k, 2).
    n_confirm, confirm_llr, confirm_window : int, float, int or None
        A sequence is confirmed once it has ``n_confirm`` measurements and a score ≥
        ``confirm_llr``; an unconfirmed one dies ``confirm_window`` frames after its start
        (None = n_confirm + max_misses + 1). Defaults 4, 0.0, None.
    delete_llr : float or None, default -5.0
        An unconfirmed sequence whose score falls below it dies at once (None = time-out only,
        the literal [K93] rule).
    max_per_tree, max_hypotheses, max_seeds : int
        Hypothesis limits: per track tree, in all, new sequences per frame (defaults 8,
        20 000, 2 000).
    max_children : int or None, default 16
        Most measurements a sequence branches on per frame (the nearest in its gate); None =
        every one, the literal [K93] rule.
    merge_depth : int, default 3
        D, the last measurements that identify a sequence's future (pruning; 1…256).
    commit_lag : int or None, default 1
        N-scan commitment (not in [K93]): the measurement a sequence of the online answer
        took this many frames ago belongs to its tree; other trees' sequences holding it
        die (1…256; None = never, as the first version did).
    maneuver_std : float, sequence of float, "auto" or None, default "auto"
        Velocity-jump branch per parameter (not in [K93]): a second child per gated
        measurement with an extra velocity jump of that std (0 = none for that parameter;
        None = no branch). "auto": ``max_speed / 4`` on the positions (a bounce reverses a
        velocity of up to ``max_speed``), 0 on the other parameters.
    maneuver_prob : float, default 0.01
        Prior probability of that jump.
    min_hits, final_llr : int or None, float
        Filter of the final answer (None = ``n_confirm``). Defaults None, 5.0.
    max_shared : int, default 2
        Measurements a chosen sequence may lose to better ones in the final answer.
    selection : {"llr", "index_per_dof", "pvalue"}, default "llr"
        Ranking of the final answer: decreasing score, or the literal [K93] rules.
    seed : int, numpy.random.Generator or None, default 0
        Seed of the deterministic subset of new starts beyond ``max_seeds``.

    See Also
    --------
    BranchingTracker : Takes one, or its settings as keywords.

    Notes
    -----
    What each setting does in the method, and the choices where the source is silent:
    :doc:`/methods/tracking` (§3.1–3.3). A pickled tracker stores its configuration and
    checks it at load.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> config = kf.TrackerConfig(measurement_std=0.3, maneuver_std=1.5)
    >>> config.for_params(2).n_spatial
    2
    """

    order: int | Sequence[int] = 1
    process_std: PerParam = 0.1
    diffusion_std: PerParam = 0.0
    measurement_std: PerParam = 0.5
    confidence: float = 0.99
    memory: int = 4
    max_misses: int = 2
    dt: float = 1.0
    p_detect: float = 0.9
    clutter_density: float | None = None
    max_speed: float = 6.0
    n_spatial: int | None = None
    n_confirm: int = 4
    confirm_llr: float = 0.0
    confirm_window: int | None = None
    delete_llr: float | None = -5.0
    max_per_tree: int = 8
    max_hypotheses: int = 20_000
    max_seeds: int = 2_000
    max_children: int | None = 16
    merge_depth: int = 3
    commit_lag: int | None = 1
    maneuver_std: PerParam | str | None = "auto"
    maneuver_prob: float = 0.01
    min_hits: int | None = None
    final_llr: float = 5.0
    max_shared: int = 2
    selection: str = "llr"
    seed: SeedLike = 0

    @classmethod
    def from_settings(
        cls, settings: dict[str, Any], caller: str = "TrackerConfig"
    ) -> TrackerConfig:
        """A configuration from a dict of settings.

        Parameters
        ----------
        settings : dict
            Setting name to value.
        caller : str, default "TrackerConfig"
            The name an error message gives for the caller.

        Returns
        -------
        TrackerConfig
            The configuration (not yet checked: see :meth:`for_params`).

        Raises
        ------
        TypeError
            An unknown setting (the message names `caller` and the settings it accepts).
        """
        unknown = sorted(set(settings) - {f.name for f in dataclasses.fields(cls)})
        if unknown:
            raise TypeError(
                f"{caller} got unknown settings {unknown}; the tracker's settings are "
                f"{[f.name for f in dataclasses.fields(cls)]}"
            )
        return cls(**settings)

    def replace(self, **settings: Any) -> TrackerConfig:
        """A copy with some settings changed.

        Parameters
        ----------
        **settings
            Settings to change.

        Returns
        -------
        TrackerConfig
            The copy.

        Raises
        ------
        TypeError
            An unknown setting.
        """
        if not settings:
            return self
        return TrackerConfig.from_settings({**self.as_dict(), **settings})

    def as_dict(self) -> dict[str, Any]:
        """The settings as a dict (the pickled form).

        Returns
        -------
        dict
            Setting name to value.
        """
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def for_params(self, n_params: int) -> TrackerConfig:
        """This configuration checked for measurement vectors of `n_params` parameters.

        Parameters
        ----------
        n_params : int
            The length k of a measurement vector.

        Returns
        -------
        TrackerConfig
            Per-parameter settings as tuples of k values, every default filled, the seed an
            int.

        Raises
        ------
        ValueError
            A setting out of its range (the message names it).
        TypeError
            A setting of the wrong type.
        """
        k = positive_int(n_params, "n_params")
        if k > MAX_PARAMS:
            raise ValueError(f"n_params must be at most {MAX_PARAMS}, got {k}")
        s = min(k, 2) if self.n_spatial is None else positive_int(self.n_spatial, "n_spatial")
        if s > k:
            raise ValueError(f"n_spatial ({s}) cannot exceed n_params ({k})")
        n_confirm = positive_int(self.n_confirm, "n_confirm")
        max_misses = nonnegative_int(self.max_misses, "max_misses")
        orders = tuple(nonnegative_int(o, "order") for o in _per_param(self.order, k, "order", int))
        if max(orders) > _core.MAX_MOTION_ORDER:
            raise ValueError(f"order must be at most {_core.MAX_MOTION_ORDER}, got {max(orders)}")
        if self.selection not in SELECTIONS:
            raise ValueError(
                f"selection must be 'llr', 'index_per_dof' or 'pvalue', got {self.selection!r}"
            )
        optional = _optional
        return TrackerConfig(
            order=orders,
            process_std=tuple(_per_param(self.process_std, k, "process_std")),
            diffusion_std=tuple(_per_param(self.diffusion_std, k, "diffusion_std")),
            measurement_std=tuple(_per_param(self.measurement_std, k, "measurement_std")),
            n_spatial=s,
            confidence=probability(self.confidence, "confidence"),
            memory=positive_int(self.memory, "memory"),
            max_misses=max_misses,
            dt=positive_float(self.dt, "dt"),
            p_detect=probability(self.p_detect, "p_detect"),
            clutter_density=optional(self.clutter_density, positive_float, "clutter_density"),
            max_speed=positive_float(self.max_speed, "max_speed"),
            n_confirm=n_confirm,
            confirm_llr=real_number(self.confirm_llr, "confirm_llr"),
            confirm_window=(
                n_confirm + max_misses + 1
                if self.confirm_window is None
                else positive_int(self.confirm_window, "confirm_window")
            ),
            delete_llr=optional(self.delete_llr, real_number, "delete_llr"),
            max_per_tree=positive_int(self.max_per_tree, "max_per_tree"),
            max_hypotheses=positive_int(self.max_hypotheses, "max_hypotheses"),
            max_seeds=positive_int(self.max_seeds, "max_seeds"),
            max_children=optional(self.max_children, positive_int, "max_children"),
            merge_depth=positive_int(self.merge_depth, "merge_depth"),
            commit_lag=optional(self.commit_lag, positive_int, "commit_lag"),
            maneuver_std=self._maneuver_std(k, s),
            maneuver_prob=probability(self.maneuver_prob, "maneuver_prob"),
            min_hits=(
                n_confirm if self.min_hits is None else positive_int(self.min_hits, "min_hits")
            ),
            final_llr=real_number(self.final_llr, "final_llr"),
            max_shared=nonnegative_int(self.max_shared, "max_shared"),
            selection=self.selection,
            seed=resolve_seed(self.seed),
        )

    def _maneuver_std(self, k: int, n_spatial: int) -> tuple[float, ...] | None:
        """The manoeuvre stds for k parameters, "auto" resolved."""
        if self.maneuver_std is None:
            return None
        if isinstance(self.maneuver_std, str):
            if self.maneuver_std != "auto":
                raise ValueError(
                    f"maneuver_std must be numbers, 'auto' or None, got {self.maneuver_std!r}"
                )
            jump = positive_float(self.max_speed, "max_speed") / 4.0
            return (jump,) * n_spatial + (0.0,) * (k - n_spatial)
        return tuple(_per_param(self.maneuver_std, k, "maneuver_std"))

    def __getitem__(self, name: str) -> Any:
        """Deprecated dict-style access (``tracker.config["dt"]`` of 0.1.0)."""
        warnings.warn(
            "the tracker's config is a TrackerConfig: use attribute access (config.dt)",
            DeprecationWarning,
            stacklevel=2,
        )
        try:
            return getattr(self, name)
        except AttributeError:
            raise KeyError(name) from None


def _optional(value: Any, check: Any, name: str) -> Any:
    return None if value is None else check(value, name)


def _per_param(value: Any, k: int, name: str, kind: type = float) -> list:
    """One value per parameter (a scalar is repeated)."""
    values = [value] * k if np.ndim(value) == 0 else list(np.asarray(value).ravel())
    if len(values) != k:
        raise ValueError(f"{name} needs {k} values (one per parameter), got {len(values)}")
    out = []
    for v in values:
        number = real_value(v, name, "hold real numbers")
        if kind is not int:
            out.append(number)
        elif isinstance(v, numbers.Integral):
            out.append(int(v))
        elif number.is_integer():
            out.append(int(number))
        else:
            raise TypeError(f"{name} must hold integers, got {v!r}")
    return out
