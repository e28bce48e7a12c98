#!/usr/bin/env bash
# Makes sure Chromium and chromedriver are installed (Debian's chromium and chromium-driver),
# which cli/tests/browser.rs drives to test `raycast serve`'s page. Does nothing when both are
# there.
set -euo pipefail

if [ -x /usr/bin/chromium ] && [ -x /usr/bin/chromedriver ]; then exit 0; fi
if ! command -v apt-get >/dev/null; then
    echo "install-browser: install Chromium and chromedriver at /usr/bin/chromium and /usr/bin/chromedriver" >&2
    exit 1
fi
as_root() {
    if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
        echo "install-browser: need root (or sudo) to run: $*" >&2; exit 1
    fi
}
# install-vulkan.sh has brought the package lists up to date, where it installed anything.
as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver ||
    { as_root apt-get update -qq &&
      as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver; }
