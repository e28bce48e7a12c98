#!/usr/bin/env bash
# The whole test suite: the Rust crate's tests (`cargo test`, arguments passed on) and docs, then the
# Python package (python/) built by maturin into a virtual environment, target/py-venv, and
# its pytest suite. Needs a Vulkan adapter (lavapipe is enough: scripts/install-vulkan.sh),
# Python 3.9+ with venv and pip, and PyPI for maturin, pytest, numpy and OpenEXR (which reads
# render.exr in python/tests/test_files.py).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test "$@"
# The docs build without warnings: the API as docs.rs shows it (no features), then every
# crate's library with the inner layers.
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps -p raycast
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --workspace --lib
venv=target/py-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/pip" install --quiet maturin pytest numpy OpenEXR
"$venv/bin/pip" install --quiet ./python
"$venv/bin/python" -m pytest -q python/tests
