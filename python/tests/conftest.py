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


# The cutting scenario of the time-domain tests (test_time_domain.py, test_lobe_design.py): one
# definition, so both compare the CLI and Python on the same bar.
TIME_DOMAIN_TOML = """
[bar]
mass_kg = 0.1548
stiffness_n_per_m = 2.2e6
damping_ratio = 0.01

[solid_bar]
mass_kg = 0.1548
stiffness_n_per_m = 2.2e6
damping_ratio = 0.01

[damper]
gap_m = 1e-4
ball_mass_kg = 0.026

[cutting]
coefficient_n_m2 = 2e9
width_m = 1e-5
feed_m = 1e-4
spindle_rpm = 5000

[time_domain]
settle_revs = 10
judge_revs = 20
monotonic_checks = 2
"""


@pytest.fixture(scope="session")
def time_domain_toml():
    return TIME_DOMAIN_TOML
