#!/usr/bin/env python3
"""What the order of incoherent rays is worth (issue #48's "reorder" lever), measured before
building it: the random rays of `open3d_rays.py --random` (origins uniform in [-2, 2]^3, unit
directions uniform, seed 1, 1920x1080 of them) cast in the caller's order and sorted by several
keys, by raycast on the GPU and the CPU reference (f32) and by Open3D, each the median of
--repeats casts; the sort's own time is not counted. Not in CI (Open3D is large); run it in an
environment with numpy, open3d and raycast, e.g. the peers' venv of benches/peers.sh:

    target/peers-venv/bin/python benches/ray_order.py target/bench/torus.ply

Prints a line per device and order: Mrays/s and the ratio to that device's unsorted rate.
"""
import argparse
import time

import numpy as np
import open3d as o3d
import raycast


def spread(x, bits):
    """The bits of x spread to every third position (x < 2^bits, bits <= 21)."""
    x = x.astype(np.uint64)
    out = np.zeros_like(x)
    for b in range(bits):
        out |= ((x >> np.uint64(b)) & np.uint64(1)) << np.uint64(3 * b)
    return out


def morton(p, lo, hi, bits):
    """The Morton code of points p in the cube [lo, hi]^3 at `bits` bits an axis."""
    q = np.clip(((p - lo) / (hi - lo) * (1 << bits)).astype(np.int64), 0, (1 << bits) - 1)
    x, y, z = (spread(q[:, k], bits) for k in range(3))
    return x | (y << np.uint64(1)) | (z << np.uint64(2))


def median_seconds(f, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return sorted(times)[repeats // 2]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mesh", help="a triangle mesh Open3D reads (the torus: target/bench/torus.ply)")
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args()
    mesh = o3d.io.read_triangle_mesh(a.mesh)
    V = np.asarray(mesh.vertices)
    F = np.asarray(mesh.triangles).astype(np.uint32)
    n = 1920 * 1080
    rng = np.random.default_rng(1)
    o = rng.uniform(-2.0, 2.0, (n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rays = np.concatenate([o, d], 1).astype(np.float32)
    octant = sum((d[:, k] > 0).astype(np.uint64) << np.uint64(k) for k in range(3))
    keys = {
        "caller's order": None,
        "origin": morton(o, -2, 2, 10),
        "octant, origin": (octant << np.uint64(30)) | morton(o, -2, 2, 10),
        "origin and direction (6-D)": (morton(o, -2, 2, 5) << np.uint64(15)) | morton(d, -1, 1, 5),
        "direction, origin": (morton(d, -1, 1, 4) << np.uint64(30)) | morton(o, -2, 2, 10),
    }
    ordered = {
        name: rays if key is None else np.ascontiguousarray(rays[np.argsort(key, kind="stable")])
        for name, key in keys.items()
    }
    ours = raycast.RaycastingScene()
    ours.add_triangles(V, F)
    theirs = o3d.t.geometry.RaycastingScene()
    theirs.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F))
    casts = {
        "raycast gpu f32": lambda r: ours.cast_rays(r, precision="f32", device="gpu"),
        "raycast cpu f32": lambda r: ours.cast_rays(r, precision="f32", device="cpu"),
        "open3d": lambda r: theirs.cast_rays(o3d.core.Tensor(r)),
    }
    for who, cast in casts.items():
        base = None
        for name, r in ordered.items():
            rate = n / median_seconds(lambda: cast(r), a.repeats) / 1e6
            base = base or rate
            print(f"{who:16s} {name:28s} {rate:6.2f} Mrays/s {rate / base:5.2f}x", flush=True)


if __name__ == "__main__":
    main()
