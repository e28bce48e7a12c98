#!/usr/bin/env bash
# Makes sure a Vulkan driver is installed: Mesa's lavapipe (software Vulkan, any CPU) and the
# Vulkan loader. On Debian 12 it takes Mesa 25 from bookworm-backports: Debian 12's own
# Mesa 22.3 ran our kernels 1.45x (BVH) to 1.9x (brute-force spheres) slower.
# Does nothing when a driver is already there (and, on Debian 12, is Mesa 25 or newer).
set -euo pipefail

as_root() {
    if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
        echo "install-vulkan: need root (or sudo) to run: $*" >&2; exit 1
    fi
}

# grep reads all of ldconfig's output: `grep -q` would stop at the first match, and ldconfig,
# still writing, would die of SIGPIPE, which pipefail reports as a failure (now and then).
have_driver() {
    ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null &&
        compgen -G '/usr/share/vulkan/icd.d/*.json' >/dev/null
}

installed_mesa_major() {
    dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -E 's/^([0-9]+:)?([0-9]+).*/\2/'
}

# The Debian mirror this machine already uses (first non-security URI of its apt sources).
debian_mirror() {
    { grep -hsE '^URIs:' /etc/apt/sources.list.d/*.sources | awk '{print $2}' || true
      grep -hsE '^deb ' /etc/apt/sources.list /etc/apt/sources.list.d/*.list |
          sed -E 's/^deb (\[[^]]*\] )?//' | awk '{print $1}' || true
    } 2>/dev/null | grep -v security | grep -i debian | head -n 1 || true
}

codename=""
[ -r /etc/os-release ] && codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")

if [ "$codename" = bookworm ]; then
    major=$(installed_mesa_major || true)
    if have_driver && [ "${major:-0}" -ge 25 ]; then exit 0; fi
    mirror=$(debian_mirror)
    if [ -z "$mirror" ]; then
        echo "install-vulkan: cannot find this machine's Debian mirror in /etc/apt" >&2; exit 1
    fi
    list=/etc/apt/sources.list.d/raycast-bookworm-backports.list
    [ -f "$list" ] || echo "deb $mirror bookworm-backports main" | as_root tee "$list" >/dev/null
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
        -t bookworm-backports mesa-vulkan-drivers libvulkan1
elif ! have_driver; then
    if ! command -v apt-get >/dev/null; then
        echo "install-vulkan: no Vulkan driver found; install Mesa's Vulkan drivers (lavapipe) and the Vulkan loader with your package manager" >&2
        exit 1
    fi
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1
fi
have_driver || { echo "install-vulkan: still no Vulkan driver after installing" >&2; exit 1; }
