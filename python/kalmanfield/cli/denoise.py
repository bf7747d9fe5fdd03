"""``kalmanfield denoise``: image files in; the filtered image and its error-variance map
out."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import tqdm

from ..denoising import denoise, estimate_noise_var
from ..identification import model_from_noisy
from ..io import read_model, write_image
from ..io.images import PICTURE_SUFFIXES
from ..rowfilter import ScalarRowFilter, VectorRowFilter
from ._common import OK, common, load_data, positive_float, say

FORMATS = ("same", ".tif", ".npy", ".png")


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "denoise",
        help="denoise image files with the row Kalman filters",
        description="Denoises each image z = x + white noise with the smoothed row Kalman "
        "filter and writes <stem>_denoised and <stem>_error_variance (the filter's predicted "
        "error variance per pixel). The field model and the noise level are estimated from "
        "each image unless given. Colour images are denoised channel by channel; a stack "
        "(TIFF, .npy, zarr) frame by frame with one model.",
    )
    p.add_argument("images", type=Path, nargs="+", help="image files (or stacks)")
    p.add_argument("--out-dir", type=Path, default=Path("."), help="output folder (default .)")
    p.add_argument(
        "--format",
        choices=FORMATS,
        default="same",
        help="output format (default: the input's; a picture's error map is "
        "always written as .tif, to keep its values)",
    )
    level = p.add_mutually_exclusive_group()
    level.add_argument("--sigma", type=positive_float, help="noise std (default: estimated)")
    level.add_argument("--noise-var", type=positive_float, help="noise variance")
    p.add_argument("--model", type=Path, help="field model JSON (default: fitted to each image)")
    p.add_argument(
        "--method",
        choices=["stationary", "vector", "adaptive"],
        default="stationary",
        help="stationary: O(W) row filter (default); vector: the optimal O(W²) "
        "filter; adaptive: local-statistics filter (no error map)",
    )
    p.add_argument("--causal", action="store_true", help="no smoothing pass over the rows")
    common(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    model = read_model(args.model) if args.model is not None else None
    noise_var = args.sigma**2 if args.sigma is not None else args.noise_var
    for path in tqdm.tqdm(args.images, desc="denoise", unit="image", disable=args.quiet):
        data, colour = load_data(path)
        if colour:
            pairs = [_grey(data[..., c], model, noise_var, args) for c in range(data.shape[-1])]
            estimate = np.stack([p[0] for p in pairs], axis=-1)
            error = None if pairs[0][1] is None else np.stack([p[1] for p in pairs], axis=-1)
        else:
            estimate, error = _grey(data, model, noise_var, args)
        written = _write(path, data, estimate, error, args)
        say(args, f"{path} → {', '.join(map(str, written))}")
    return OK


def _grey(z: np.ndarray, model, noise_var: float | None, args: argparse.Namespace):
    """(estimate, error-variance map or None) of an image or a stack."""
    z = np.asarray(z, dtype=np.float64)
    smooth = not args.causal
    if args.method == "adaptive":
        return denoise(z, noise_var=noise_var, method="adaptive", smooth=smooth), None
    if model is None:
        model, mean, fitted_var = model_from_noisy(z)
        noise_var = fitted_var if noise_var is None else noise_var
        if not noise_var > 0:
            raise ValueError("the estimated noise variance is 0: give --sigma")
    else:
        mean = float(np.nanmean(z))
        noise_var = estimate_noise_var(z) if noise_var is None else noise_var
    kind = VectorRowFilter if args.method == "vector" else ScalarRowFilter
    row_filter = kind(model, noise_var, z.shape[-1], smooth=smooth, mean=mean)
    return row_filter.filter(z), row_filter.error_variance(z.shape[-2])


def _write(path: Path, data: np.ndarray, estimate, error, args) -> list[Path]:
    suffix = path.suffix.lower() if args.format == "same" else args.format
    if suffix not in (".tif", ".tiff", ".npy", *PICTURE_SUFFIXES):
        suffix = ".tif"  # stacks from folders, zarr or video
    if suffix in PICTURE_SUFFIXES and data.dtype in (np.uint8, np.uint16):
        limit = np.iinfo(data.dtype).max
        estimate = np.clip(np.round(estimate), 0, limit).astype(data.dtype)
    out = [args.out_dir / f"{path.stem}_denoised{suffix}"]
    _save(out[0], estimate)
    if error is not None:
        error_suffix = ".tif" if suffix in PICTURE_SUFFIXES else suffix
        out.append(args.out_dir / f"{path.stem}_error_variance{error_suffix}")
        _save(out[1], error)
    return out


def _save(path: Path, array: np.ndarray) -> None:
    from ..io import write_stack

    if array.ndim == 3 and array.shape[-1] not in (3, 4) or array.ndim == 4:
        write_stack(path, array)
    else:
        write_image(path, array)
