#!/usr/bin/env python3
"""What each render mode costs next to plain f32, as a user sees it: the wall time of
`raycast render` (process start, GPU open, scene load, kernel compile, trace, readback,
writing the files), median over rounds, the modes run in turn within each round so that the
shared machine's load falls on all of them alike. Prints a markdown table of medians and
ratios against `--precision f32` at the same scene, with each mode's target from the
one-render-path issue (every mode shares the traversal, so none should cost much more).

Usage: benches/modes.py [--scene FILE] [--size WxH] [--rounds N] [--binary PATH]
Default: scenes/course/bunny.json at 1920x1080, 5 rounds, target/release/raycast (built with
`cargo build --release` first). Not part of CI: it measures, it asserts nothing.
"""

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def modes(size, half):
    """(label, extra arguments, target ratio against f32 or None) per mode."""
    return [
        ("f32", ["--size", size], None),
        ("adaptive", ["--size", size, "--precision", "adaptive"], 1.25),
        ("f64", ["--size", size, "--precision", "f64"], 1.5),
        ("--shader toon.wgsl", ["--size", size, "--shader", "shaders/examples/toon.wgsl"], 1.25),
        ("--band-rows 270", ["--size", size, "--band-rows", "270"], 1.25),
        (f"--spp 4 at {half}", ["--size", half, "--spp", "4"], 1.3),
    ]


def run(binary, scene, extra, out):
    start = time.perf_counter()
    subprocess.run(
        [binary, "render", scene, "-o", out, "--format", "png,npy", *extra],
        check=True,
        stdout=subprocess.DEVNULL,
        cwd=REPO,
    )
    return time.perf_counter() - start


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="scenes/course/bunny.json")
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--binary", default=str(REPO / "target/release/raycast"))
    a = p.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    half = f"{w // 2}x{h // 2}"
    table = modes(a.size, half)
    times = {label: [] for label, _, _ in table}
    with tempfile.TemporaryDirectory() as out:
        for _ in range(a.rounds + 1):  # the first round warms caches and is dropped
            for label, extra, _ in table:
                times[label].append(run(a.binary, a.scene, extra, out))
    median = {k: statistics.median(v[1:]) for k, v in times.items()}
    print(f"`benches/modes.py --scene {a.scene} --size {a.size} --rounds {a.rounds}`"
          f" (wall time of `raycast render ... --format png,npy`, median of {a.rounds} rounds)\n")
    print("| mode | median s | vs f32 | target |")
    print("|---|---:|---:|---:|")
    for label, _, target in table:
        ratio = median[label] / median["f32"]
        goal = "-" if target is None else f"<= {target}x"
        print(f"| {label} | {median[label]:.3f} | {ratio:.2f}x | {goal} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
