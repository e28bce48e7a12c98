#!/usr/bin/env python3
"""Views of a scene rendered as one batch (`raycast render SCENE --orbit N`) against a loop of
one `raycast render` per view, and against the kernel's own rate (`raycast bench`), side by
side in rounds (docs/datasets.md#how-fast).

    python3 benches/views.py [--binary target/release/raycast] [--scene scenes/course/bunny.json]
                             [--views 100] [--size 640x360] [--rounds 3] [--precision P]

Each round runs the batch, then the loop over the same cameras (each view's scene file holds
the camera its camera.json gives), then `raycast bench` on the scene and on every tenth view's
scene file. The batch's rate counts everything from the process's start to its exit (loading,
compiling, preparing, rendering, writing); the loop's too, per view. The kernel's rate is
bench's GPU-timestamp rate of f32 renders. Printed: a line per round and the medians."""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time


def timed(command):
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def bench_rate(binary, scene, size):
    """bench's median GPU-timestamp rate (Mrays/s) of a gpu:f32:robust frame of `scene`."""
    out = subprocess.run(
        [binary, "bench", scene, "--size", size, "--runs", "5", "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    return json.loads(out.splitlines()[0])["mrays_per_s"]


def view_scenes(scene, views_dir, work):
    """A scene file per view: `scene` with the view's camera (camera.json's scene_camera)."""
    with open(scene) as f:
        base = json.load(f)
    for o in base["objects"]:
        for key in ("stl", "obj", "ply"):
            if key in o:
                o[key] = os.path.join(os.path.dirname(os.path.abspath(scene)), o[key])
    stem = os.path.splitext(os.path.basename(scene))[0]
    files = []
    for name in sorted(os.listdir(os.path.join(views_dir, stem))):
        with open(os.path.join(views_dir, stem, name, "camera.json")) as f:
            base["camera"] = json.load(f)["scene_camera"]
        path = os.path.join(work, f"{name}.json")
        with open(path, "w") as f:
            json.dump(base, f)
        files.append(path)
    return files


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--binary", default="target/release/raycast")
    p.add_argument("--scene", default="scenes/course/bunny.json")
    p.add_argument("--views", type=int, default=100)
    p.add_argument("--size", default="640x360")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--precision", default=None, help="f32, f64 or adaptive (default: the render's)")
    a = p.parse_args()
    w, h = (int(x) for x in a.size.split("x"))
    rays = a.views * w * h
    extra = ["--size", a.size] + (["--precision", a.precision] if a.precision else [])
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for r in range(a.rounds):
            batch_out = os.path.join(work, f"batch{r}")
            batch = timed([a.binary, "render", a.scene, "--orbit", str(a.views), "-o", batch_out] + extra)
            scenes = view_scenes(a.scene, batch_out, work)
            loop = sum(timed([a.binary, "render", s, "-o", os.path.join(work, "single")] + extra) for s in scenes)
            scene_rate = bench_rate(a.binary, a.scene, a.size)
            view_rate = statistics.mean(bench_rate(a.binary, s, a.size) for s in scenes[::10])
            batch_rate = rays / batch / 1e6
            row = {
                "batch_s": batch, "loop_s": loop, "loop_over_batch": loop / batch,
                "batch_mrays_per_s": batch_rate,
                "kernel_mrays_per_s_scene": scene_rate, "kernel_mrays_per_s_views": view_rate,
                "batch_over_kernel_scene": batch_rate / scene_rate,
                "batch_over_kernel_views": batch_rate / view_rate,
            }
            rows.append(row)
            print(json.dumps({k: round(v, 3) for k, v in row.items()}), flush=True)
    medians = {k: round(statistics.median(r[k] for r in rows), 3) for k in rows[0]}
    print(json.dumps({"median": medians}))


if __name__ == "__main__":
    sys.exit(main())
