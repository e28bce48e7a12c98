#!/usr/bin/env python3
"""raycast against Mitsuba 3's instances (a `shapegroup` placed by `instance` shapes, the
llvm_ad_rgb variant) on the same scene and rays (#64; not in CI: Mitsuba is large). Needs
numpy, mitsuba and raycast (`pip install ./python`) in one environment:

    raycast workload instances -o target/bench/instances
    python benches/instances_mitsuba.py target/bench/instances/instances.json --size 640x360

Reads the workload's scene file (meshes declared once, placed by transforms: translate,
rotate about an axis, scale, or a 4x4 matrix) and its binary STL mesh, places the same
instances in Mitsuba, and casts the scene camera's rays (Open3D's create_rays_pinhole from
raycast, the scene's vertical fov turned horizontal) with both, in --rounds rounds, each
raycast's cast then Mitsuba's. Prints one JSON line: the rays, how many both miss, how many
hit the same instance (and the largest relative gap of their distances), how many disagree, and of those how many are near a tie (the two
distances within 1e-4 of each other, relative) or graze a silhouette (one misses, the other
hits within 1e-4 of a triangle's edge, barycentric); the rates (Mrays/s, median of the
rounds) of raycast (--precision) and of Mitsuba's ray_intersect_preliminary.
"""
import argparse
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

import drjit as dr
import mitsuba as mi
import raycast


def stl_triangles(path: Path) -> np.ndarray:
    """A binary STL's triangles, (n, 3, 3) float64."""
    data = path.read_bytes()
    n = int.from_bytes(data[80:84], "little")
    records = np.frombuffer(data, dtype=np.uint8, count=50 * n, offset=84).reshape(n, 50)
    corners = records[:, 12:48].copy().view("<f4").reshape(n, 3, 3)
    return corners.astype(np.float64)


def matrix(transform) -> np.ndarray:
    """A scene file's transform as a 4x4 matrix: scale, then rotate, then translate."""
    if isinstance(transform, list):
        return np.array(transform, dtype=np.float64)
    m = np.eye(4)
    scale = transform.get("scale", 1.0)
    s = np.diag(np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,)))
    r = np.eye(3)
    rotate = transform.get("rotate")
    if rotate and "axis" in rotate:
        axis = np.asarray(rotate["axis"], dtype=np.float64)
        x, y, z = axis / np.linalg.norm(axis)
        a = math.radians(rotate["degrees"])
        c, sn = math.cos(a), math.sin(a)
        k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        r = np.eye(3) + sn * k + (1 - c) * (k @ k)
    elif rotate:
        w, x, y, z = np.asarray(rotate["quaternion"], dtype=np.float64) / np.linalg.norm(
            rotate["quaternion"]
        )
        r = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    m[:3, :3] = r @ s
    m[:3, 3] = transform.get("translate", [0.0, 0.0, 0.0])
    return m


def mitsuba_scene(triangles: np.ndarray, placements: list):
    """The mesh in a shapegroup, placed by an instance a transform; the instances' shape
    pointers, in the scene's object order, as the ids ray_intersect_preliminary gives."""
    n = len(triangles)
    mesh = mi.Mesh("mesh", vertex_count=3 * n, face_count=n)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(triangles.reshape(-1).astype(np.float32))
    params["faces"] = mi.UInt32(np.arange(3 * n, dtype=np.uint32))
    params.update()
    scene = {"type": "scene", "group": {"type": "shapegroup", "mesh": mesh}}
    for k, m in enumerate(placements):
        scene[f"i{k:05d}"] = {
            "type": "instance",
            "shapegroup": {"type": "ref", "id": "group"},
            "to_world": mi.ScalarTransform4f(m.tolist()),
        }
    return mi.load_dict(scene)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("--size", default="640x360")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--precision", default="adaptive")
    args = parser.parse_args()
    mi.set_variant("llvm_ad_rgb")
    spec = json.loads(args.scene.read_text())
    (mesh_name, mesh), = spec["meshes"].items()
    triangles = stl_triangles(args.scene.parent / mesh["stl"])
    placements = [matrix(o.get("transform", np.eye(4).tolist())) for o in spec["objects"]]
    assert all(o["type"] == "instance" and o["mesh"] == mesh_name for o in spec["objects"])
    width, height = (int(x) for x in args.size.split("x"))
    cam = spec["camera"]
    vfov = math.radians(cam["fov"])
    hfov = math.degrees(2 * math.atan(math.tan(vfov / 2) * width / height))
    rays = np.asarray(
        raycast.RaycastingScene.create_rays_pinhole(
            hfov, cam["look_at"], cam["eye"], cam["up"], width, height
        )
    ).reshape(-1, 6)

    ours = raycast.load(args.scene)
    theirs = mitsuba_scene(triangles, placements)
    shape_ids = np.array(
        [dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0] for s in theirs.shapes()]
    )
    order = np.argsort(shape_ids)
    o = mi.Point3f(*(rays[:, k].astype(np.float32) for k in range(3)))
    d = mi.Vector3f(*(rays[:, 3 + k].astype(np.float32) for k in range(3)))
    mray = mi.Ray3f(o, d)

    rates = {"raycast": [], "mitsuba": []}
    for _ in range(args.rounds):
        clock = time.perf_counter()
        hit = ours.cast_rays(rays, precision=args.precision)
        rates["raycast"].append(len(rays) / (time.perf_counter() - clock) / 1e6)
        clock = time.perf_counter()
        pi = theirs.ray_intersect_preliminary(mray)
        t_m = np.array(pi.t)
        inst = np.array(dr.reinterpret_array(mi.UInt32, pi.instance))
        uv = np.array(pi.prim_uv).T
        rates["mitsuba"].append(len(rays) / (time.perf_counter() - clock) / 1e6)

    ids = np.asarray(hit["geometry_ids"]).astype(np.int64)
    t_r = np.asarray(hit["t_hit"], dtype=np.float64)
    miss_r = ~np.isfinite(np.asarray(hit["t_hit"], dtype=np.float64))
    miss_m = ~np.isfinite(t_m)
    position = np.searchsorted(shape_ids[order], inst)
    objects_m = np.where(miss_m, -1, order[np.clip(position, 0, len(order) - 1)])
    objects_r = np.where(miss_r, -1, ids)
    differ = objects_m != objects_r
    both = ~miss_r & ~miss_m
    with np.errstate(invalid="ignore"):
        gap = np.abs(t_r - t_m) / np.maximum(np.abs(t_r), np.abs(t_m))
    tie = both & (gap <= 1e-4)
    # A hit near its triangle's edge (a barycentric coordinate within 1e-4 of 0).
    def near_edge(uv: np.ndarray) -> np.ndarray:
        u, v = uv[:, 0], uv[:, 1]
        return np.minimum(np.minimum(u, v), 1 - u - v) <= 1e-4

    uv_r = np.asarray(hit["primitive_uvs"], dtype=np.float64).reshape(-1, 2)
    graze = (miss_r & ~miss_m & near_edge(uv)) | (miss_m & ~miss_r & near_edge(uv_r))
    explained = differ & (tie | graze)
    print(
        json.dumps(
            {
                "rays": int(len(rays)),
                "instances": len(placements),
                "both_miss": int((miss_r & miss_m).sum()),
                "same_instance": int((~differ & both).sum()),
                "disagree": int(differ.sum()),
                "disagree_near_tie_or_edge": int(explained.sum()),
                "disagree_unexplained": int((differ & ~explained).sum()),
                "same_instance_t_gap_max": float(gap[~differ & both].max(initial=0.0)),
                "raycast_precision": args.precision,
                "raycast_mrays_s": round(statistics.median(rates["raycast"]), 2),
                "mitsuba_llvm_mrays_s": round(statistics.median(rates["mitsuba"]), 2),
            }
        )
    )


if __name__ == "__main__":
    main()
