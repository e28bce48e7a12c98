#!/usr/bin/env bash
# One command from a fresh checkout to a rendered picture: installs a Vulkan driver if none is
# present, builds raycast (release), prints the adapter and renders the default scene to ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null; then
    echo "setup: cargo (Rust 1.95 or newer) is needed; install it with rustup first" >&2
    exit 1
fi
scripts/install-vulkan.sh
cargo build --release
target/release/raycast info
target/release/raycast render -o out "$@"
