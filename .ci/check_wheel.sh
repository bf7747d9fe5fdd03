#!/usr/bin/env bash
# Builds the release wheel, installs it with plain pip in a fresh virtual environment (no
# Rust, no source tree on the path) and runs a smoke test there: the version, a field sample,
# a filter, a segmentation, `python -m kalmanfield --version` and the console script.
# The wheel is built by pip through maturin (the PEP 517 backend), exactly as `pip install .`
# builds it: a full LTO build on a fresh tree (~5–7 min on 2 cores), after which a
# `pip install .` finds the release build in target/ up to date and takes seconds (CI runs this
# script first for that reason).
#
#   bash .ci/check_wheel.sh [existing-wheel.whl]
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [[ $# -ge 1 ]]; then
    wheel=$1
else
    python3 -m pip wheel --quiet --no-deps --wheel-dir "$work/dist" .
    wheel=$(ls "$work"/dist/kalmanfield-*.whl)
fi
echo "wheel: $(basename "$wheel")"
python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install --quiet --upgrade pip
"$work/venv/bin/python" -m pip install --quiet "$wheel"
cd "$work"  # away from the source tree
"$work/venv/bin/python" - <<'PY'
import importlib.metadata

import numpy as np

import kalmanfield as kf

assert kf.__file__.startswith(__import__("sys").prefix), kf.__file__
assert kf.__version__ == importlib.metadata.version("kalmanfield"), kf.__version__
model = kf.ARFieldModel([0.9, 0.9], [2, 2])
x = model.sample((128, 128), seed=1)
z = x + np.random.default_rng(0).normal(0, 1, x.shape)
x_hat = kf.ScalarRowFilter(model, 1.0, 128, smooth=True).filter(z)
assert np.mean((x_hat - x) ** 2) < 0.1
assert len(kf.segment(np.pad(np.ones((3, 3)), 5), 0.5)) == 1
print("smoke test passed:", kf.__version__, kf._core.__file__)
PY
"$work/venv/bin/python" -m kalmanfield --version
"$work/venv/bin/kalmanfield" --version
"$work/venv/bin/kalmanfield" simulate field --shape 64 64 --out "$work/f.npy" --quiet
echo "wheel OK"
