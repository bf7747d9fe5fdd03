"""The module paths of kalmanfield 0.1.0 (one flat package) as aliases of today's domain
subpackages: old imports (``kalmanfield.scalar_row_filter``…) and old pickles still work."""

from __future__ import annotations

import functools
import importlib.abc
import importlib.util
import sys
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

#: old module (under kalmanfield) → today's
MOVED = {
    "ar_field_model": "field.model",
    "field_stream": "field.stream",
    "stream_state": "field.stream_state",
    "product_field": "field.product",
    "identification": "identification.fit",
    "sample_correlation": "identification.sample_correlation",
    "yule_walker": "identification.yule_walker",
    "_row_filter": "rowfilter.base",
    "scalar_row_filter": "rowfilter.scalar",
    "vector_row_filter": "rowfilter.vector",
    "wiener_bound": "rowfilter.wiener_bound",
    "denoise": "denoising.denoise",
    "segmentation": "tracking.segment",
    "branching_tracker": "tracking.branching_tracker",
    "link": "tracking.link",
    "reference.ar_field": "reference.field.ar_field",
    "reference.identification": "reference.identification.kernels",
    "reference.row_filters": "reference.rowfilter.row_filters",
    "reference.adaptive_denoise": "reference.denoising.adaptive_denoise",
    "reference.local_moments": "reference.denoising.local_moments",
    "reference.noise_level": "reference.denoising.noise_level",
    "reference.segmentation": "reference.tracking.segment",
    "reference.branching": "reference.tracking.branching",
}


def install_aliases() -> None:
    """Makes every old path importable (found on first import, as the same module object)."""
    sys.meta_path.append(_OldPaths())


class _Alias(importlib.abc.Loader):
    """Loads an old path as the module now at `target` (no second copy)."""

    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec):  # noqa: ARG002
        return importlib.import_module(self.target)

    def exec_module(self, module) -> None:
        pass


class _OldPaths(importlib.abc.MetaPathFinder):
    """Finds ``kalmanfield.<old module>`` paths."""

    def find_spec(self, fullname, path=None, target=None):  # noqa: ARG002
        old = fullname.removeprefix("kalmanfield.")
        if fullname == old or old not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, _Alias(f"kalmanfield.{MOVED[old]}"))


def keyword_only(*names: str) -> Callable[[F], F]:
    """Lets a function whose parameters `names` became keyword-only still take them by
    position, as 0.1.0 did, with a DeprecationWarning naming them."""

    def wrap(func: F) -> F:
        @functools.wraps(func)
        def call(*args: Any, **kwargs: Any) -> Any:
            head, extra = args[:1], args[1:]
            if extra:
                if len(extra) > len(names):
                    raise TypeError(
                        f"{func.__name__}() takes 1 positional argument but {len(args)} were given"
                    )
                given = names[: len(extra)]
                warnings.warn(
                    f"pass {', '.join(given)} to {func.__name__}() by keyword "
                    f"({func.__name__}(image, {given[0]}=…)); by position is deprecated",
                    DeprecationWarning,
                    stacklevel=2,
                )
                for name, value in zip(given, extra):
                    if name in kwargs:
                        raise TypeError(f"{func.__name__}() got {name} twice")
                    kwargs[name] = value
            return func(*head, **kwargs)

        return call  # type: ignore[return-value]

    return wrap
