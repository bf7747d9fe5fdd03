"""Imports of the optional libraries, with a message that says which extra installs them."""

from __future__ import annotations

import importlib
from types import ModuleType

#: module → the extra that installs it
EXTRA = {
    "imageio": "io",
    "imageio.v3": "io",
    "tifffile": "io",
    "zarr": "io",
    "dask": "dask",
    "dask.array": "dask",
    "dask.dataframe": "dask",
    "distributed": "dask",
    "matplotlib": "demo",
    "matplotlib.pyplot": "demo",
}


class MissingDependency(ImportError):
    """An optional library that a function needs is not installed."""


def optional(module: str, purpose: str) -> ModuleType:
    """`module`, imported; MissingDependency naming the extra that installs it if absent."""
    try:
        return importlib.import_module(module)
    except ImportError as err:
        extra = EXTRA.get(module, "io")
        raise MissingDependency(
            f"{purpose} needs {module.split('.')[0]}, which is not installed: "
            f'pip install "kalmanfield[{extra}]"'
        ) from err
