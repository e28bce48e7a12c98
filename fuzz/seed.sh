#!/bin/sh
# Seeds fuzz/corpus/TARGET from the repository's own scenes, meshes and shade hooks.
# Usage (from the repository root): fuzz/seed.sh
set -e
cd "$(dirname "$0")/.."
for target in scene stl obj ply shade_hook; do mkdir -p "fuzz/corpus/$target"; done
# Flattened names (scenes_course_bunny.json), so that equal names in two folders both stay.
seed() { cp "$1" "fuzz/corpus/$2/$(echo "$1" | tr / _)"; }
for f in scenes/*.json scenes/*/*.json; do seed "$f" scene; done
for ext in stl obj ply; do
    find scenes tests/data -name "*.$ext" -size -200k | while read -r f; do seed "$f" "$ext"; done
done
for f in shaders/examples/*.wgsl; do seed "$f" shade_hook; done
