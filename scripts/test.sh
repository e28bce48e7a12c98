#!/usr/bin/env bash
# The whole test suite: the Rust tests (`cargo test`, arguments passed on) and docs, then the
# Python package's pytest suite in a virtual environment, target/py-venv. Needs a Vulkan adapter
# (lavapipe is enough: scripts/install-vulkan.sh), Python 3.9+ with venv and pip, and PyPI for
# pytest, numpy, OpenEXR (which reads render.exr in python/tests/test_files.py), trimesh
# with rtree (python/tests/test_queries.py runs trimesh's own intersector beside raycast's),
# and Ray Data (python/tests/test_views.py renders a dataset on a local Ray cluster); and
# Debian's Chromium and chromedriver (cli/tests/browser.rs tests `raycast serve`'s page),
# installed here where they are missing.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-browser.sh
# The Python packages the tests need, installed while the Rust side builds and runs: mostly
# downloads and unpacking (Ray's are the largest), which the compiler's work hides.
venv=target/py-venv
pip_log=target/py-venv-install.log
pip_done=target/py-venv-install.status
mkdir -p target
rm -f "$pip_done"
(
    status=0
    { [ -x "$venv/bin/python" ] || python3 -m venv "$venv"; } &&
        "$venv/bin/pip" install --quiet pytest numpy OpenEXR trimesh rtree "ray[data]" ||
        status=$?
    echo "$status" >"$pip_done"
) >"$pip_log" 2>&1 &
# What `cargo test` builds and the Python extension, in one build: one set of features, so the
# dependencies they share are compiled once (maturin's own build would compile them again).
cargo build --quiet --lib --bins --tests --examples
# The docs build without warnings: the API as docs.rs shows it (the library has no features),
# the files written whole (raycast-files), the renders to files (raycast-datasets) and the
# command line's library. The measurement programs (benches/, outside the default members)
# compile; the check shares the dependencies' metadata the docs were built with. Both run
# beside the tests, whose threads wait on lavapipe's compiler and leave the cores a share of
# idle time: cargo holds the build folder only while it builds, and the docs start once
# `cargo test` has found everything built (were they first, it would wait for them).
docs_log=target/docs.log
(
    sleep 5
    RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --lib -p raycast -p raycast-files \
        -p raycast-datasets -p raycast-cli
    cargo check --quiet -p raycast-benches
) >"$docs_log" 2>&1 &
docs=$!
# The Python package as maturin lays it out (python/raycast/ with the extension inside it),
# from the extension built above. `pip install ./python` builds the same in release. Its tests
# run beside the Rust tests, in the time lavapipe's one-kernel-at-a-time compiles leave a core.
package=target/py-package
rm -rf "$package"
mkdir -p "$package"
cp -R python/raycast "$package/"
extension=target/debug/lib_raycast.so
[ "$(uname -s)" = Darwin ] && extension=target/debug/lib_raycast.dylib
cp "$extension" "$package/raycast/_raycast.abi3.so"
py_log=target/py-tests.log
(
    while [ ! -s "$pip_done" ]; do sleep 1; done
    if [ "$(cat "$pip_done")" != 0 ]; then
        cat "$pip_log"
        echo "test.sh: installing the Python test packages failed"
        exit 1
    fi
    PYTHONPATH="$package" "$venv/bin/python" -m pytest -q python/tests
) >"$py_log" 2>&1 &
py_tests=$!
cargo test "$@"
echo "test.sh: Rust tests done at ${SECONDS} s" >&2
if ! wait "$docs"; then
    cat "$docs_log" >&2
    echo "test.sh: the docs or the measurement programs failed" >&2
    exit 1
fi
echo "test.sh: docs done at ${SECONDS} s" >&2
py_status=0
wait "$py_tests" || py_status=$?
cat "$py_log"
if [ "$py_status" -ne 0 ]; then
    echo "test.sh: the Python tests failed" >&2
    exit 1
fi
echo "test.sh: Python tests done at ${SECONDS} s" >&2
