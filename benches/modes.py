#!/usr/bin/env python3
"""What each render mode costs next to plain f32, as a user sees it: the wall time of
`raycast render` (process start, GPU open, scene load, kernel compile, trace, readback,
writing the files), median over rounds, the modes run in turn within each round so that the
shared machine's load falls on all of them alike. Prints a markdown table of medians and
ratios against `--precision f32` at the same scene, with each mode's target from the
one-render-path issue (every mode shares the traversal, so none should cost much more).

With `--baseline PATH` (a raycast binary built from another commit) every mode also runs on
that binary, in turn with this one within each round, and the table gains the ratio of the
two: how a change moved each mode, measured side by side.

Usage: benches/modes.py [--scene FILE] [--size WxH] [--rounds N] [--binary PATH]
                        [--baseline PATH] [--only LABEL,...]
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
        ("f32", ["--size", size, "--precision", "f32"], None),
        ("default (adaptive)", ["--size", size], 1.25),
        ("adaptive", ["--size", size, "--precision", "adaptive"], 1.25),
        ("f64", ["--size", size, "--precision", "f64"], 1.5),
        ("f32 textbook", ["--size", size, "--algorithm", "textbook"], None),
        ("f64 textbook", ["--size", size, "--precision", "f64", "--algorithm", "textbook"], None),
        ("cpu f32", ["--size", size, "--device", "cpu", "--precision", "f32"], None),
        ("cpu f64", ["--size", size, "--device", "cpu"], None),
        ("--shader toon.wgsl", ["--size", size, "--shader", "shaders/examples/toon.wgsl"], 1.25),
        ("--band-rows 270", ["--size", size, "--band-rows", "270"], 1.25),
        (f"--spp 4 at {half}", ["--size", half, "--spp", "4", "--precision", "f32"], 1.3),
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
    p.add_argument("--baseline", help="another raycast binary, run side by side")
    p.add_argument("--only", help="comma-separated mode labels to run (f32 always runs)")
    a = p.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    half = f"{w // 2}x{h // 2}"
    table = modes(a.size, half)
    if a.only:
        keep = {"f32", *a.only.split(",")}
        table = [m for m in table if m[0] in keep]
    binaries = [a.binary] + ([a.baseline] if a.baseline else [])
    times = {(b, label): [] for b in binaries for label, _, _ in table}
    with tempfile.TemporaryDirectory() as out:
        for _ in range(a.rounds + 1):  # the first round warms caches and is dropped
            for label, extra, _ in table:
                for b in binaries:
                    times[b, label].append(run(b, a.scene, extra, out))
    median = {k: statistics.median(v[1:]) for k, v in times.items()}
    print(f"`benches/modes.py --scene {a.scene} --size {a.size} --rounds {a.rounds}"
          f"{' --baseline ' + a.baseline if a.baseline else ''}"
          f"{' --only ' + a.only if a.only else ''}`"
          f" (wall time of `raycast render ... --format png,npy`, median of {a.rounds} rounds)\n")
    extra = " | baseline s | this / baseline" if a.baseline else ""
    print(f"| mode | median s | vs f32 | target{extra} |")
    print("|---|---:|---:|---:" + ("|---:|---:" if a.baseline else "") + "|")
    for label, _, target in table:
        this = median[a.binary, label]
        ratio = this / median[a.binary, "f32"]
        goal = "-" if target is None else f"<= {target}x"
        row = f"| {label} | {this:.3f} | {ratio:.2f}x | {goal}"
        if a.baseline:
            base = median[a.baseline, label]
            row += f" | {base:.3f} | {this / base:.2f}x"
        print(row + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
