#!/usr/bin/env python3
"""The pictures of docs/distance.md, made with raycast's point queries (numpy for the meshes
and the colours, PNG written with zlib; no plotting library):

    docs/images/distance-slice.png   signed distance on a plane through the benchmark torus
    docs/images/distance-signs.png   inside by ray parity and by winding number, three scenes

Needs numpy and raycast importable (`pip install ./python`, or PYTHONPATH to a folder holding
the package, as benches/open3d_queries.py describes), and ../shared/bench/peer_bench.py for
the torus. From the repository root (a few seconds on 2 cores):

    python scripts/distance_pictures.py            # or --out another/folder
"""
import argparse
import struct
import sys
import zlib
from pathlib import Path

import numpy as np

import raycast

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT.parent / "shared" / "bench"))
import peer_bench  # noqa: E402  (the benchmark torus)


def write_png(path, rgb):
    """An (h, w, 3) uint8 image as an 8-bit RGB PNG."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    Path(path).write_bytes(png)


# Diverging colours: blue (negative) through near-white to red (positive).
BLUE, WHITE, RED = np.array([40, 90, 170]), np.array([247, 247, 244]), np.array([190, 50, 40])
# Inside blue and outside light red in every picture, as the signed distance's sign.
INSIDE, OUTSIDE, LINE = np.array([95, 135, 200]), np.array([246, 228, 220]), np.array([25, 25, 30])


def diverging(x):
    """Colours for `x` in [-1, 1] (clipped): blue, white at 0, red."""
    x = np.clip(x, -1, 1)[..., None]
    return np.where(x < 0, WHITE + (BLUE - WHITE) * -x, WHITE + (RED - WHITE) * x)


def plane(u_range, v_range, size, at, axes):
    """Pixel centres of a `size` (w, h) slice: coordinate axes[0] across over u_range, axes[1]
    up over v_range, the third axis at `at`. Rows from the top."""
    w, h = size
    u = u_range[0] + (np.arange(w) + 0.5) * (u_range[1] - u_range[0]) / w
    v = v_range[1] - (np.arange(h) + 0.5) * (v_range[1] - v_range[0]) / h
    uu, vv = np.meshgrid(u, v)
    points = np.full((h, w, 3), float(at))
    points[..., axes[0]], points[..., axes[1]] = uu, vv
    return points, (u_range[1] - u_range[0]) / w


def contour(values, level, pixel):
    """Where `values` crosses `level` within about one pixel (`pixel`: its size in the units
    of `values` per pixel, from the local gradient)."""
    gy, gx = np.gradient(values)
    slope = np.maximum(np.hypot(gx, gy), 1e-12)
    return np.abs(values - level) / slope < 0.75 * pixel


def slice_picture(out):
    """Signed distance on the plane z = 0.1 through the benchmark torus: blue inside, red
    outside, bands every 0.05, the surface dark."""
    v, f = peer_bench.displaced_torus()
    scene = raycast.RaycastingScene()
    scene.add_triangles(v, f)
    points, _ = plane((-1.6, 1.6), (-1.6, 1.6), (512, 512), 0.1, (0, 1))
    sd = scene.compute_signed_distance(points).numpy().astype(np.float64)
    rgb = diverging(sd / 0.6)
    bands = (np.floor(sd / 0.05) % 2 == 0) & (np.abs(sd) > 0.01)
    rgb = np.where(bands[..., None], rgb * 0.93, rgb)
    rgb = np.where(contour(sd, 0.0, 1.0)[..., None], LINE, rgb)
    write_png(out / "distance-slice.png", rgb.astype(np.uint8))


def uv_sphere(n_lat=24, n_lon=48):
    """A unit sphere of latitude rings (outward normals), its poles single vertices."""
    lat = np.pi * np.arange(1, n_lat) / n_lat
    lon = 2 * np.pi * np.arange(n_lon) / n_lon
    ring = np.stack([np.outer(np.sin(lat), np.cos(lon)), np.outer(np.sin(lat), np.sin(lon)),
                     np.outer(np.cos(lat), np.ones(n_lon))], axis=-1).reshape(-1, 3)
    v = np.concatenate([[[0, 0, 1]], ring, [[0, 0, -1]]])
    idx = lambda i, j: 1 + i * n_lon + (j % n_lon)  # noqa: E731
    f = [(0, idx(0, j), idx(0, j + 1)) for j in range(n_lon)]
    for i in range(n_lat - 2):
        for j in range(n_lon):
            f += [(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)),
                  (idx(i, j), idx(i + 1, j + 1), idx(i, j + 1))]
    last = len(v) - 1
    f += [(last, idx(n_lat - 2, j + 1), idx(n_lat - 2, j)) for j in range(n_lon)]
    return v, np.array(f)


def unit_box():
    """The cube [0, 1]^3, two triangles a face, normals out."""
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return v, np.array(f)


def signs_row(meshes, points, pixel):
    """Three panels: inside by parity (Open3D's rule), inside by winding number, the winding
    number itself; the slice of the surface dark in each. `meshes`: (vertices, triangles)
    pairs, each added as a mesh of its own."""
    scene = raycast.RaycastingScene()
    for v, f in meshes:
        scene.add_triangles(v, f)
    parity = scene.compute_occupancy(points).numpy() > 0.5
    winding = scene.compute_occupancy(points, sign="winding").numpy() > 0.5
    w = scene.compute_winding_number(points).numpy()
    surface = scene.compute_distance(points, precision="f64").numpy() < 0.75 * pixel
    panels = [np.where(inside[..., None], INSIDE, OUTSIDE) for inside in (parity, winding)]
    panels.append(diverging(-w))  # white at 0, blue at 1 (and above), red below 0
    return [np.where(surface[..., None], LINE, p) for p in panels]


def signs_picture(out):
    """Rows: a sphere with its top cap cut off (open), two overlapping boxes in one mesh, and a
    box whose top face is given again as a second mesh; columns: parity, winding occupancy,
    winding number."""
    size = 160
    rows = []
    # Open: the sphere without the triangles whose centroid has z > 0.6, cut through y = 0.
    v, f = uv_sphere()
    f = f[v[f].mean(axis=1)[:, 2] <= 0.6]
    points, pixel = plane((-1.5, 1.5), (-1.5, 1.5), (size, size), 0.013, (0, 2))
    rows.append(signs_row([(v, f)], points, pixel))
    # Overlapping: the unit box and a copy moved by (0.5, 0.5, 0.25), as one mesh, cut through
    # z = 0.5 on pixel centres off the boxes' edges and diagonals (odd offsets).
    v, f = unit_box()
    v2, f2 = np.concatenate([v, v + [0.5, 0.5, 0.25]]), np.concatenate([f, f + len(v)])
    across, up = (-0.7463, 2.2537), (-0.7429, 2.2571)
    points, pixel = plane(across, up, (size, size), 0.5 + 1 / 1024, (0, 1))
    rows.append(signs_row([(v2, f2)], points, pixel))
    # A face given twice: the unit box, and its top face (z = 1) again as a mesh of its own,
    # cut through y = 0.5 (x across, z up). A ray leaving through the top crosses both.
    top = f[np.all(v[f][:, :, 2] == 1, axis=1)]
    points, pixel = plane(across, up, (size, size), 0.5 + 1 / 1024, (0, 2))
    rows.append(signs_row([(v, f), (v, top)], points, pixel))
    gap = 6
    height = len(rows) * size + (len(rows) - 1) * gap
    width = 3 * size + 2 * gap
    image = np.full((height, width, 3), 255, dtype=np.uint8)
    for r, row in enumerate(rows):
        for c, panel in enumerate(row):
            y, x = r * (size + gap), c * (size + gap)
            image[y : y + size, x : x + size] = panel.astype(np.uint8)
    write_png(out / "distance-signs.png", image)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    slice_picture(a.out)
    signs_picture(a.out)
    print(f"wrote {a.out / 'distance-slice.png'} and {a.out / 'distance-signs.png'}")


if __name__ == "__main__":
    main()
