#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls exactly this): format check, clippy with
# warnings as errors, then every test in release mode (the solvers are slow in debug builds),
# then the Python package's tests (scripts/test-python.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all -- --check
cargo clippy --workspace --all-targets --release --locked -- -D warnings
cargo test --workspace --release --locked
scripts/test-python.sh
