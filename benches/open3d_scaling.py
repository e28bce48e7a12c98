#!/usr/bin/env python3
"""Open3D's scaling curve on the tori and camera of `benches/bvh_scaling.rs` (not in CI: Open3D
is large), to set beside raycast's (docs/performance.md, "Scaling"). Needs numpy and open3d,
e.g. in the peers' venv of benches/peers.sh:

    target/peers-venv/bin/python benches/open3d_scaling.py [--runs 3]

Builds each torus (radii 1 and 0.4, nu = 2.5 nv cells of two triangles, 10k to 5.12M
triangles) as bvh_scaling does, casts the 1920x1080 rays of its camera (eye (0, -3, 2.5)
looking at the origin, image plane 1.294 x 0.728 at distance 1) with Open3D's
RaycastingScene, and prints a markdown table: the build (the first query), the median of
--runs casts after a warm-up, Mrays/s, the fraction of rays that hit, and each cast's time
against the smallest torus's. The casts' times include Open3D's Python side (the rays in,
the hits out), as a user's do.
"""
import argparse
import time

import numpy as np
import open3d as o3d

SIZES = [10_000, 40_000, 160_000, 640_000, 2_560_000, 5_120_000]


def torus(n):
    """bvh_scaling's torus of about n triangles: vertices (float32) and triangles (uint32)."""
    nv = int(round((n / 5.0) ** 0.5))
    nu = n // (2 * nv)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    u = 2 * np.pi * i / nu
    v = 2 * np.pi * j / nv
    r = 1.0 + 0.4 * np.cos(v)
    vertices = np.stack([r * np.cos(u), r * np.sin(u), 0.4 * np.sin(v)], -1).reshape(-1, 3)

    def index(a, b):
        return (a % nu) * nv + (b % nv)

    a, b = i.ravel(), j.ravel()
    first = np.stack([index(a, b), index(a + 1, b), index(a + 1, b + 1)], -1)
    second = np.stack([index(a, b), index(a + 1, b + 1), index(a, b + 1)], -1)
    triangles = np.stack([first, second], 1).reshape(-1, 3)
    return vertices.astype(np.float32), triangles.astype(np.uint32)


def camera_rays(width=1920, height=1080):
    """bvh_scaling's camera: rays through pixel centres, origin and direction per row."""
    eye = np.array([0.0, -3.0, 2.5])
    look = np.array([0.0, 3.0, -2.5])
    up = np.array([0.0, 0.0, 1.0])
    w = -look / np.linalg.norm(look)
    u = np.cross(up, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    plane_w, plane_h = 1.2941163885020528, 0.7279404685324047
    us = (np.arange(width) + 0.5) / width * plane_w - plane_w / 2
    vs = plane_h / 2 - (np.arange(height) + 0.5) / height * plane_h
    directions = us[None, :, None] * u + vs[:, None, None] * v - w
    origins = np.broadcast_to(eye, directions.shape)
    return np.concatenate([origins, directions], -1).reshape(-1, 6).astype(np.float32)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="timed casts per torus")
    args = parser.parse_args()
    rays = o3d.core.Tensor(camera_rays())
    n = rays.shape[0]
    smallest = None
    print(f"Open3D {o3d.__version__}, {n} rays")
    print("| triangles | build s | cast s | Mrays/s | hit | vs smallest |")
    print("|---:|---:|---:|---:|---:|---:|")
    for size in SIZES:
        vertices, triangles = torus(size)
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))
        start = time.perf_counter()
        scene.count_intersections(rays[:1])  # builds the BVH
        build = time.perf_counter() - start
        times = []
        for _ in range(args.runs + 1):
            start = time.perf_counter()
            answer = scene.cast_rays(rays)
            times.append(time.perf_counter() - start)
        cast = sorted(times[1:])[len(times[1:]) // 2]
        hit = np.isfinite(answer["t_hit"].numpy()).mean()
        smallest = smallest or cast
        print(
            f"| {len(triangles):,} | {build:.3f} | {cast:.4f} | {n / cast / 1e6:.1f} "
            f"| {hit:.3f} | {cast / smallest:.2f}x |",
            flush=True,
        )


if __name__ == "__main__":
    main()
