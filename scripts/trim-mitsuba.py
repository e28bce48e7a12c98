#!/usr/bin/env python3
"""Trims Mitsuba 3's wheel to the variants and plugins that peer_bench.py's Mitsuba peers use,
so that it travels to a GPU machine with little room (scripts/gpu-check.sh --pack --mitsuba).

    trim-mitsuba.py WHEEL OUT_DIR [VARIANT ...]     (default variant: cuda_ad_rgb)

Keeps the package's Python files, its shared libraries, the named variants (and scalar_rgb,
which every variant's scene description uses), and the plugins of a scene of spheres or an
in-memory mesh seen by a perspective sensor through an aov integrator; drops the other
variants and plugins, headers and CMake files. The wheel's RECORD is written anew.
"""
import base64
import hashlib
import os
import re
import sys
import zipfile

PLUGINS = {"sphere", "perspective", "hdrfilm", "box", "gaussian", "stratified", "independent",
           "aov", "path", "merge", "direct", "diffuse", "regular", "uniform", "srgb", "d65"}


def keep(name, variants):
    parts = name.split("/")
    if len(parts) > 1 and parts[1] in ("include", "cmake"):
        return False
    variant = re.match(r"mitsuba/((?:scalar|llvm|cuda)_[a-z_]+)\.cpython", name)
    if variant:
        return variant.group(1) in variants
    plugin = re.match(r"mitsuba/plugins/([a-z0-9_]+)\.so$", name)
    if plugin:
        return plugin.group(1) in PLUGINS
    return True


def record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return "%s,sha256=%s,%d" % (name, digest, len(data))


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: trim-mitsuba.py WHEEL OUT_DIR [VARIANT ...]")
    wheel, out_dir = sys.argv[1], sys.argv[2]
    variants = set(sys.argv[3:] or ["cuda_ad_rgb"]) | {"scalar_rgb"}
    os.makedirs(out_dir, exist_ok=True)
    out = os.path.join(out_dir, os.path.basename(wheel))
    with zipfile.ZipFile(wheel) as src, zipfile.ZipFile(out + ".tmp", "w", zipfile.ZIP_DEFLATED) as dst:
        record_name = next(n for n in src.namelist() if n.endswith(".dist-info/RECORD"))
        lines = []
        for info in src.infolist():
            if info.filename == record_name or not keep(info.filename, variants):
                continue
            data = src.read(info)
            dst.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED)
            lines.append(record_line(info.filename, data))
        lines.append(record_name + ",,")
        dst.writestr(record_name, "\n".join(lines) + "\n")
    os.replace(out + ".tmp", out)
    print("%s: %.1f MB (from %.1f MB)" % (out, os.path.getsize(out) / 1e6, os.path.getsize(wheel) / 1e6))


if __name__ == "__main__":
    main()
