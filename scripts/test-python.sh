#!/usr/bin/env bash
# The Python package (issue #10): a venv under target/ (created once, reused), the build and test
# tools from PyPI, the package built from this tree (maturin, the committed Cargo.lock), then
# pytest on python/tests, whose examples and bit-identity tests need matplotlib/pandas/xarray
# (and the universal-file cross-checks pyuff)
# and the release `vibrobar` binary beside the package.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="${VIBROBAR_VENV:-target/py-venv}"
PYTHON="${PYTHON:-python3}"
if [ ! -x "$VENV/bin/python" ]; then
    "$PYTHON" -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
    "maturin>=1.7,<2" numpy pytest pandas xarray matplotlib "dask[distributed]" "pyuff>=2.4,<3" "sdypy-EMA>=0.31,<1"
cargo build --release --locked -p vibrobar-cli
VIRTUAL_ENV="$PWD/$VENV" "$VENV/bin/maturin" develop --release --locked --quiet
status=0
VIBROBAR_REQUIRE_EXTRAS=1 VIBROBAR_BIN="$PWD/target/release/vibrobar" \
    "$VENV/bin/python" -m pytest -q -p no:cacheprovider python/tests || status=$?
if [ "$status" -eq 5 ]; then
    echo "pytest collected no test: python/tests is missing or broken" >&2
fi
exit "$status"
