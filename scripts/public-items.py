#!/usr/bin/env python3
"""Counts the library's public items: modules, types, traits, functions and methods, constants,
statics, type aliases and macros reachable from the crate root (fields and enum variants are
not counted, nor trait impls' methods). Reads rustdoc's JSON, which needs a nightly toolchain:

    scripts/public-items.py            # the count
    scripts/public-items.py --list     # every item's path, then the count
"""
import collections
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COUNTED = {"module", "struct", "enum", "union", "trait", "function", "constant", "static",
           "type_alias", "macro", "assoc_const", "assoc_type", "trait_alias"}


def rustdoc_json():
    subprocess.run(["cargo", "+nightly", "rustdoc", "-q", "--lib", "-p", "raycast", "--",
                    "-Z", "unstable-options", "--output-format", "json"],
                   cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    with open(os.path.join(target, "doc", "raycast.json")) as f:
        return json.load(f)


def public_items(doc):
    index = doc["index"]
    found = {}

    def visit(item_id, path):
        key = str(item_id)
        item = index.get(key)
        if item is None or item["crate_id"] != 0 or key in found:
            return
        kind, inner = next(iter(item["inner"].items()))
        name = item.get("name") or ""
        here = path + [name] if name else path
        if kind not in ("impl", "use"):
            found[key] = (kind, "::".join(here))
        if kind == "module":
            for child in inner["items"]:
                visit(child, here)
        elif kind in ("struct", "enum", "union"):
            for impl in inner["impls"]:
                visit(impl, here)
        elif kind == "impl" and inner["trait"] is None:
            for child in inner["items"]:
                visit(child, path)
        elif kind == "trait":
            for child in inner["items"]:
                visit(child, here)
        elif kind == "use" and inner.get("id") is not None:
            visit(inner["id"], path)

    visit(doc["root"], [])
    return sorted(p for k, p in found.values() if k in COUNTED)


def main():
    items = public_items(rustdoc_json())
    if "--list" in sys.argv[1:]:
        print("\n".join(items))
    print(len(items))


if __name__ == "__main__":
    main()
