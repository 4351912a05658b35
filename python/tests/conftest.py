"""Shared fixtures: the repository root and the command-line binary the Python results are
compared with (built by scripts/test.sh before pytest; a missing binary fails, never skips)."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def cli():
    exe = pathlib.Path(os.environ.get("VIBROBAR_BIN", ROOT / "target" / "release" / "vibrobar"))
    assert exe.is_file(), f"{exe} missing: build it with `cargo build --release` (scripts/test.sh does)"

    def run(*args, cwd=None):
        p = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, cwd=cwd)
        assert p.returncode == 0, f"vibrobar {' '.join(map(str, args))} failed:\n{p.stderr}"
        return p

    return run
