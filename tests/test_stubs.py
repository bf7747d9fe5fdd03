"""The type stubs of the compiled module agree with it (mypy's stubtest): every function,
class, method and parameter of `kalmanfield._core` is declared in `_core.pyi` with the
runtime's names, kinds and defaults, and nothing else is."""

import subprocess
import sys
from pathlib import Path


def test_core_stub_matches_the_compiled_module(tmp_path):
    allowlist = Path(__file__).with_name("stubtest_allowlist.txt")
    command = [sys.executable, "-m", "mypy.stubtest", "kalmanfield._core"]
    command += ["--allowlist", str(allowlist), "--mypy-config-file", str(tmp_path / "none")]
    (tmp_path / "none").write_text("[mypy]\ncache_dir = " + str(tmp_path / "cache") + "\n")
    run = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
