"""A field model (or a whole fit of :func:`~kalmanfield.identify`) as JSON."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Union

from ..field import ARFieldModel
from ..identification import IdentifiedModel

PathLike = Union[str, Path]

#: the format's name and version, written into every file
FORMAT = "kalmanfield.model/1"


def _fit_record(fit: IdentifiedModel) -> dict[str, Any]:
    return {
        "mean": fit.mean,
        "variance": fit.variance,
        "sample_variance": fit.sample_variance,
        "axes": list(fit.axes),
        "fits": [
            {
                "axis": f.axis,
                "order": f.order,
                "rho": f.rho,
                "whiteness": {
                    "statistic": f.whiteness.statistic,
                    "dof": f.whiteness.dof,
                    "pvalue": f.whiteness.pvalue,
                },
            }
            for f in fit.fits
        ],
        "summary": fit.summary(),
    }


def write_model(path: PathLike, model: ARFieldModel | IdentifiedModel) -> None:
    """Write a field model, or an identified one with its diagnostics, as JSON.

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file (its folder is made if missing).
    model : ARFieldModel or IdentifiedModel
        The model; a fit of :func:`~kalmanfield.identify` adds its mean, variances, per-axis
        fits (order, ρ, whiteness test) and its summary in words.

    Raises
    ------
    TypeError
        `model` is neither.

    Examples
    --------
    >>> import tempfile
    >>> import kalmanfield as kf
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/model.json"
    >>> io.write_model(path, kf.ARFieldModel([0.9, 0.8], [2, 1]))
    >>> io.read_model(path)
    ARFieldModel(rho=(0.9, 0.8), order=(2, 1), sigma=1.0)
    """
    if isinstance(model, IdentifiedModel):
        record: dict[str, Any] = {"format": FORMAT, **_model_record(model.model)}
        record["identified"] = _fit_record(model)
    elif isinstance(model, ARFieldModel):
        record = {"format": FORMAT, **_model_record(model)}
    else:
        raise TypeError(f"model must be an ARFieldModel or an IdentifiedModel, got {model!r}")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")


def _model_record(model: ARFieldModel) -> dict[str, Any]:
    return {"rho": list(model.rho), "order": list(model.order), "sigma": model.sigma}


def read_model(path: PathLike) -> ARFieldModel:
    """Read the field model of a JSON file written by :func:`write_model`.

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file: an object with ``rho`` and ``order`` (lists, one value per axis) and
        optionally ``sigma``.

    Returns
    -------
    ARFieldModel
        The model.

    Raises
    ------
    FileNotFoundError
        No such file.
    ValueError
        Not JSON, keys missing, or values :class:`~kalmanfield.ARFieldModel` refuses.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from kalmanfield import io
    >>> path = Path(tempfile.mkdtemp()) / "model.json"
    >>> _ = path.write_text('{"rho": [0.95, 0.9], "order": [1, 2], "sigma": 2.0}')
    >>> io.read_model(path).order
    (1, 2)
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no such model file: {p}")
    try:
        record = json.loads(p.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{p} is not a JSON model file: {err}") from err
    if not isinstance(record, dict) or not {"rho", "order"} <= record.keys():
        raise ValueError(f"{p} must hold a JSON object with the keys 'rho' and 'order'")
    try:
        return ARFieldModel(record["rho"], record["order"], record.get("sigma", 1.0))
    except TypeError as err:
        raise ValueError(f"{p}: {err}") from err
