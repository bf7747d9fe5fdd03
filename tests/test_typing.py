"""The package is typed (it ships `py.typed`): mypy finds no error in its sources, and the
stubs of the compiled module agree with it (mypy's stubtest): every function, class, method
and parameter of `kalmanfield._core` is declared in `_core.pyi` with the runtime's names,
kinds and defaults, and nothing else is."""

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mypy", reason="mypy (test extra) needs Python ≥ 3.10")

ROOT = Path(__file__).resolve().parent.parent


def run_module(module, *args):
    command = [sys.executable, "-m", module, *args]
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600)


def test_sources_type_check(tmp_path):
    config, cache = str(ROOT / "pyproject.toml"), str(tmp_path / "cache")
    run = run_module("mypy", "--config-file", config, "--cache-dir", cache)
    assert run.returncode == 0, run.stdout + run.stderr


def test_core_stub_matches_the_compiled_module(tmp_path):
    config = tmp_path / "mypy.ini"
    config.write_text(f"[mypy]\ncache_dir = {tmp_path / 'cache'}\n")
    allowlist = Path(__file__).with_name("stubtest_allowlist.txt")
    run = run_module(
        "mypy.stubtest",
        "kalmanfield._core",
        "--allowlist",
        str(allowlist),
        "--mypy-config-file",
        str(config),
    )
    assert run.returncode == 0, run.stdout + run.stderr
