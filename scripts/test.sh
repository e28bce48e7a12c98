#!/usr/bin/env bash
# The whole test suite: the Rust crate's tests (`cargo test`, arguments passed on) and docs, then the
# Python package (python/) built by maturin into a virtual environment, target/py-venv, and
# its pytest suite. Needs a Vulkan adapter (lavapipe is enough: scripts/install-vulkan.sh),
# Python 3.9+ with venv and pip, and PyPI for maturin, pytest, numpy and OpenEXR (which reads
# render.exr in python/tests/test_files.py).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test "$@"
echo "test.sh: Rust tests done at ${SECONDS} s" >&2
# The docs build without warnings: the API as docs.rs shows it (no features), then the
# library with the inner layers and the command line's library.
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps -p raycast
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --lib -p raycast -p raycast-cli
# The measurement programs (benches/, outside the default members) compile; the check shares
# the dependencies' metadata the docs were built with.
cargo check --quiet -p raycast-benches
echo "test.sh: docs done at ${SECONDS} s" >&2
venv=target/py-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/pip" install --quiet maturin pytest numpy OpenEXR
# The extension is built in the dev profile (the test profile's settings), in the workspace's
# target folder, so it reuses the dependencies `cargo test` compiled; pip's own build would
# compile them all again in release.
wheels=target/wheels/test
rm -rf "$wheels"
"$venv/bin/maturin" build --quiet --profile dev --manifest-path python/Cargo.toml --out "$wheels"
"$venv/bin/pip" install --quiet --force-reinstall --no-deps "$wheels"/*.whl
echo "test.sh: Python package built at ${SECONDS} s" >&2
"$venv/bin/python" -m pytest -q python/tests
echo "test.sh: Python tests done at ${SECONDS} s" >&2
