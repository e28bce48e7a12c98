#!/usr/bin/env python3
"""raycast's Python RaycastingScene against Open3D's on the same mesh and rays (not in CI:
Open3D is large). Needs numpy, open3d and raycast (`pip install ./python`) in one environment,
e.g. the peers' venv of benches/peers.sh:

    target/peers-venv/bin/pip install ./python
    target/peers-venv/bin/python benches/open3d_rays.py target/bench/torus.obj \
        --raycast target/release/raycast --scene target/bench/torus.json

Casts the peer camera's 1920x1080 rays (../shared/bench/peer_bench.py's convention, unit
directions from (0, -3, 2.5) at the origin, vertical fov 40) with both, in one process, and
prints one JSON line: hit/miss disagreements, the largest relative t_hit difference, the
fraction of hits with equal primitive ids, the largest difference of create_rays_pinhole's
rays, and the rates (Mrays/s, median of --repeats) of both and of raycast's single-ray call.
With --raycast and --scene (the same mesh and camera as a scene file: benches/peers.sh writes
target/bench/torus.json), `raycast bench` runs too and the rate through Python is also given
as a ratio of bench's (kernel time, and wall time of its trace stage): in --rounds rounds,
each a bench run and then the casts through Python, the ratio the median of the rounds'
(the machine's speed drifts: side by side, not one after the other).
With --random the rays are incoherent instead, as many: origins uniform in [-2, 2]^3 about the
mesh and uniformly random directions (seed 1), which the GPU traces one by one, not in packets
(and `raycast bench`, which casts a camera's rays, is not run).
"""
import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "shared" / "bench"))
import peer_bench  # noqa: E402  (the peers' OBJ reader and camera)

import open3d as o3d  # noqa: E402
import raycast  # noqa: E402


def median_seconds(fn, repeats):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("mesh")
    p.add_argument("--width", type=int, default=1920)
    p.add_argument("--height", type=int, default=1080)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--precision", default="f32")
    p.add_argument("--raycast", help="the raycast binary, to run `raycast bench` beside")
    p.add_argument("--scene", help="the scene file of the same mesh and camera, for bench")
    p.add_argument("--rounds", type=int, default=3, help="bench and Python in turn, this often")
    p.add_argument("--random", action="store_true", help="incoherent rays (module docs)")
    a = p.parse_args()
    if a.random and (a.raycast or a.scene):
        p.error("--random casts other rays than bench's camera: leave out --raycast and --scene")
    V, F = peer_bench.load_obj(a.mesh)
    o, d = peer_bench.make_rays(a.width, a.height, (0, -3.0, 2.5), (0, 0, 0), (0, 0, 1), 40)
    if a.random:
        rng = np.random.default_rng(1)
        o = rng.uniform(-2.0, 2.0, (a.width * a.height, 3))
        d = rng.normal(size=(a.width * a.height, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
    # As a camera's rays come (create_rays_pinhole): (height, width, 6).
    rays = np.concatenate([o, d], 1).astype(np.float32).reshape(a.height, a.width, 6)
    n = a.width * a.height

    ours = raycast.RaycastingScene()
    ours.add_triangles(V, F)
    theirs = o3d.t.geometry.RaycastingScene()
    theirs.add_triangles(o3d.core.Tensor(V), o3d.core.Tensor(F.astype(np.uint32)))
    rays_o3d = o3d.core.Tensor(rays)

    flat = lambda answer: {k: v.reshape(n, *v.shape[2:]) for k, v in answer.items()}
    a_ours = flat(ours.cast_rays(rays, precision=a.precision))
    a_theirs = flat({k: v.numpy() for k, v in theirs.cast_rays(rays_o3d).items()})
    hit_ours = a_ours["geometry_ids"] != raycast.RaycastingScene.INVALID_ID
    hit_theirs = a_theirs["geometry_ids"] != o3d.t.geometry.RaycastingScene.INVALID_ID
    both = hit_ours & hit_theirs
    t_ours, t_theirs = a_ours["t_hit"][both].astype(np.float64), a_theirs["t_hit"][both]
    rel = np.abs(t_ours - t_theirs) / np.abs(t_theirs)
    same_prim = np.mean(a_ours["primitive_ids"][both] == a_theirs["primitive_ids"][both])
    normals = np.abs(a_ours["primitive_normals"][both] - a_theirs["primitive_normals"][both])
    uvs = np.abs(a_ours["primitive_uvs"][both] - a_theirs["primitive_uvs"][both])

    pinhole = {}
    for name, args in {
        "fov": dict(fov_deg=60.0, center=[0, 0, 0], eye=[1, 2, 3], up=[0, 0, 1], width_px=640, height_px=480),
        "matrices": dict(
            intrinsic_matrix=[[500.0, 0, 320], [0, 500, 240], [0, 0, 1]],
            extrinsic_matrix=[[1.0, 0, 0, 0.5], [0, 0, -1, 1], [0, 1, 0, 3], [0, 0, 0, 1]],
            width_px=640,
            height_px=480,
        ),
    }.items():
        mine = raycast.RaycastingScene.create_rays_pinhole(**args)
        o3d_args = {k: (o3d.core.Tensor(np.asarray(v, np.float64)) if isinstance(v, list) else v)
                    for k, v in args.items()}
        ref = o3d.t.geometry.RaycastingScene.create_rays_pinhole(**o3d_args).numpy()
        pinhole[name] = float(np.max(np.abs(mine - ref)))

    cast_ours = lambda: ours.cast_rays(rays, precision=a.precision)  # noqa: E731
    s_theirs = median_seconds(lambda: theirs.cast_rays(rays_o3d), a.repeats)
    one = rays.reshape(n, 6)[n // 2: n // 2 + 1]
    s_one = median_seconds(lambda: ours.cast_rays(one, precision=a.precision), 50)
    bench = {}
    if a.raycast and a.scene:
        rounds = []
        for _ in range(a.rounds):
            out = subprocess.run(
                [a.raycast, "bench", a.scene, "--json", "--runs", str(a.repeats),
                 "--mode", f"gpu:{a.precision}"],
                check=True, capture_output=True, text=True).stdout
            b = json.loads(out.splitlines()[-1])
            mine = n / median_seconds(cast_ours, a.repeats) / 1e6
            rounds.append((mine, b["mrays_per_s"], b["mrays_per_s_wall"]))
        ours_rates, kernel, wall = zip(*rounds)
        s_ours = n / (statistics.median(ours_rates) * 1e6)
        bench = dict(
            bench_mrays_per_s=statistics.median(kernel),
            bench_mrays_per_s_wall=statistics.median(wall),
            ratio_to_bench=statistics.median(m / k for m, k, _ in rounds),
            ratio_to_bench_wall=statistics.median(m / w for m, _, w in rounds),
            rounds=[dict(raycast=m, bench=k, bench_wall=w) for m, k, w in rounds])
    else:
        s_ours = median_seconds(cast_ours, a.repeats)
    print(json.dumps(dict(
        mesh=a.mesh, rays=n, random=a.random, precision=a.precision, adapter=raycast.info()["name"],
        open3d=o3d.__version__,
        hits=int(hit_ours.sum()), hit_miss_disagree=int(np.sum(hit_ours != hit_theirs)),
        t_hit_max_rel=float(rel.max()) if both.any() else None,
        primitive_ids_equal=float(same_prim),
        normals_max_abs=float(normals.max()) if both.any() else None,
        uvs_max_abs=float(uvs.max()) if both.any() else None,
        create_rays_pinhole_max_abs=pinhole,
        raycast_mrays_per_s=n / s_ours / 1e6, open3d_mrays_per_s=n / s_theirs / 1e6,
        ratio=(n / s_ours) / (n / s_theirs), single_ray_ms=s_one * 1e3, **bench,
    )))


if __name__ == "__main__":
    main()
