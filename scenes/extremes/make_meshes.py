#!/usr/bin/env python3
"""Writes the scenes of scenes/extremes/ listed in main() and the OBJ meshes they use.

Run from anywhere: `python3 scenes/extremes/make_meshes.py`. The output is committed; this
script is its source, so numbers that must be exact (dyadic coordinates, pixel-centre
positions, translations and power-of-two scales) are computed here rather than typed.

Every scene has a top-level `comment` object: `probes` (what it stresses), `invariant` (what
every correct mode must show), `kind`, and for `translated` / `scaled` scenes `base` (the
untransformed scene) and `translation` or `scale`.

Exactness checks done here:
- every number written to a scene JSON is parsed back the way serde_json (without its
  `float_roundtrip` feature, as raycast builds it) parses it, and must give the same f64;
- every OBJ coordinate of the translated and scaled meshes must be exactly representable in
  f32 (raycast reads OBJ in f64, but a robust f32 render rounds the camera-relative
  coordinates to f32), so they are the base mesh moved exactly in every precision.
"""

import json
import math
import os
import re
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

# ---------------------------------------------------------------------------------------------
# Exactness helpers


def serde_json_f64(text):
    """The f64 serde_json 1.0 (no float_roundtrip) makes of a JSON number `text`."""
    m = re.fullmatch(r"(-?)(\d+)(?:\.(\d+))?(?:[eE]([+-]?\d+))?", text)
    assert m, text
    sign, whole, frac, exp = m.group(1), m.group(2), m.group(3) or "", m.group(4)
    if not frac and exp is None:
        return float(int(sign + whole))  # an integer: parsed as i64/u64, then widened
    digits = (whole + frac).lstrip("0") or "0"
    assert len(digits) <= 19, f"{text}: significand overflows u64"
    significand = int(digits)
    exponent = (int(exp) if exp else 0) - len(frac)
    f = float(significand)
    while True:
        if abs(exponent) <= 308:
            p = float(f"1e{abs(exponent)}")
            f = f * p if exponent >= 0 else f / p
            break
        if f == 0.0:
            break
        f /= 1e308
        exponent += 308
    return -f if sign else f


def num(x):
    """JSON text for the number x, checked to parse back to exactly x in raycast."""
    if isinstance(x, int) or (isinstance(x, float) and x.is_integer() and abs(x) < 2**53):
        text = str(int(x))
    else:
        text = repr(float(x))
    assert serde_json_f64(text) == float(x), f"{x!r} ({text}) does not parse back exactly"
    return text


def is_f32(x):
    return struct.unpack("f", struct.pack("f", x))[0] == x


def dumps(value, indent=""):
    """Compact JSON: numbers through num(), short lists and objects on one line."""
    if isinstance(value, bool) or value is None:
        return json.dumps(value)
    if isinstance(value, (int, float)):
        return num(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(dumps(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {dumps(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def write_scene(name, comment, camera, objects):
    lines = ["{", '  "comment": {']
    items = list(comment.items())
    for i, (k, v) in enumerate(items):
        sep = "," if i + 1 < len(items) else ""
        lines.append(f"    {json.dumps(k)}: {dumps(v)}{sep}")
    lines.append("  },")
    lines.append('  "camera": {')
    items = list(camera.items())
    for i, (k, v) in enumerate(items):
        sep = "," if i + 1 < len(items) else ""
        lines.append(f"    {json.dumps(k)}: {dumps(v)}{sep}")
    lines.append("  },")
    lines.append('  "objects": [')
    for i, o in enumerate(objects):
        sep = "," if i + 1 < len(objects) else ""
        lines.append(f"    {dumps(o)}{sep}")
    lines.append("  ]")
    lines.append("}")
    text = "\n".join(lines) + "\n"
    json.loads(text)  # well-formed
    with open(os.path.join(HERE, name), "w") as f:
        f.write(text)
    SCENES.append(name)


def indexed(name, triangles):
    """(vertices, faces) of `triangles`: each distinct corner once, faces as 0-based indices;
    every coordinate f32-exact (exact 2^k scaling of the scenes relies on it)."""
    index = {}
    vertices = []
    faces = []
    for tri in triangles:
        face = []
        for p in tri:
            p = tuple(float(c) for c in p)
            if p not in index:
                index[p] = len(vertices)
                vertices.append(p)
            face.append(index[p])
        faces.append(face)
    for c in (c for v in vertices for c in v):
        assert is_f32(c), f"{name}: {c!r} is not exact in f32"
    return vertices, faces


def write_obj(name, triangles, header):
    """Triangles as an indexed OBJ (shared corners written once)."""
    vertices, faces = indexed(name, triangles)
    with open(os.path.join(HERE, name), "w") as f:
        f.write(f"# {header}\n# Written by make_meshes.py; {len(triangles)} triangles.\n")
        for v in vertices:
            f.write("v " + " ".join(repr(c) for c in v) + "\n")
        for face in faces:
            f.write("f " + " ".join(str(k + 1) for k in face) + "\n")
    MESHES.append(name)


def write_ply(name, triangles, header, binary):
    """Triangles as an indexed PLY with double coordinates: ASCII (f64 text) or binary little
    endian (the reader keeps the declared type)."""
    vertices, faces = indexed(name, triangles)
    fmt = "binary_little_endian" if binary else "ascii"
    head = (f"ply\nformat {fmt} 1.0\ncomment {header}\ncomment Written by make_meshes.py; "
            f"{len(triangles)} triangles.\nelement vertex {len(vertices)}\nproperty double x\n"
            f"property double y\nproperty double z\nelement face {len(faces)}\n"
            "property list uchar int vertex_indices\nend_header\n")
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(head.encode())
        if binary:
            for v in vertices:
                f.write(struct.pack("<3d", *v))
            for face in faces:
                f.write(struct.pack("<B3i", 3, *face))
        else:
            for v in vertices:
                f.write((" ".join(repr(c) for c in v) + "\n").encode())
            for face in faces:
                f.write(("3 " + " ".join(str(k) for k in face) + "\n").encode())
    MESHES.append(name)


SCENES = []
MESHES = []

# ---------------------------------------------------------------------------------------------
# Meshes


def cell_triangles(p00, p10, p11, p01, flip):
    """Two triangles of the quad p00 p10 p11 p01 (counter-clockwise seen from the side the
    normal points to), split along p00-p11 (flip False) or p10-p01. The shared diagonal is the
    edge b-c of both triangles: the edge Cramer's rule tests as beta + gamma <= 1, where two
    rounded quotients must sum to at most 1 (the worst case for the textbook test)."""
    if not flip:
        return [(p10, p11, p00), (p01, p00, p11)]
    return [(p00, p10, p01), (p11, p01, p10)]


def grid_triangles(xs, ys, z_of):
    tris = []
    for a in range(len(xs) - 1):
        for b in range(len(ys) - 1):
            def p(i, j):
                x, y = xs[i], ys[j]
                return (x, y, z_of(x, y))

            tris += cell_triangles(p(a, b), p(a + 1, b), p(a + 1, b + 1), p(a, b + 1), (a + b) % 2 == 1)
    return tris


def box_triangles(lo, hi, n):
    """A closed box [lo, hi]^3 (per axis), each face an n x n grid with alternating diagonals,
    outward normals by corner order."""
    tris = []
    steps = [[lo[k] + (hi[k] - lo[k]) * i / n for i in range(n + 1)] for k in range(3)]
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for side, value in ((1, hi[axis]), (-1, lo[axis])):
            for a in range(n):
                for b in range(n):
                    def p(i, j):
                        q = [0.0, 0.0, 0.0]
                        q[axis] = value
                        q[u_axis] = steps[u_axis][i]
                        q[v_axis] = steps[v_axis][j]
                        return tuple(q)

                    # (u, v, axis) is right-handed, so u-then-v order faces +axis.
                    quad = [p(a, b), p(a + 1, b), p(a + 1, b + 1), p(a, b + 1)]
                    if side < 0:
                        quad = [quad[0], quad[3], quad[2], quad[1]]
                    tris += cell_triangles(*quad, (a + b) % 2 == 1)
    return tris


# ---------------------------------------------------------------------------------------------
# Scenes

PERSPECTIVE_Z = {"type": "perspective", "look": [0, 0, -1], "up": [0, 1, 0]}


def camera(eye, focal, width, height, resolution=(64, 48), **kw):
    c = {"type": kw.pop("type", "perspective"), "eye": list(eye), "look": kw.pop("look", [0, 0, -1]),
         "up": kw.pop("up", [0, 1, 0]), "focal_length": focal, "width": width, "height": height,
         "resolution": list(resolution)}
    assert not kw, kw
    return c


def sphere(c, r):
    return {"type": "sphere", "center": list(c), "radius": r}


def plane(p, n):
    return {"type": "plane", "point": list(p), "normal": list(n)}


def triangle(a, b, c):
    return {"type": "triangle", "corners": [list(a), list(b), list(c)]}


def far_spheres():
    for k in (2, 3, 4, 5):
        d = 10.0**k
        write_scene(
            f"far-sphere-1e{k}.json",
            {
                "probes": f"a unit sphere at the origin seen from distance 1e{k}, from the "
                "direction (2,1,2)/3 (general position: no coordinate of the eye or the rays is "
                "exact or axis-aligned): the textbook discriminant b^2 - 4ac cancels about "
                "2*log10(distance) digits, so f32 has none left at 1e4 and beyond; camera-relative "
                "f32 loses about log2(distance) bits in the perpendicular l (normals)",
                "invariant": "a pixel hits exactly when its ray passes within 1 of the centre (a "
                "disc of radius about 16 pixels in the middle of the 64x48 view); distance about "
                f"{d:g} - 1 at the centre, normals facing the camera",
                "kind": "far-sphere",
            },
            camera([2 * d / 3, d / 3, 2 * d / 3], 1, 4 / d, 3 / d, look=[-2, -1, -2]),
            [sphere([0, 0, 0], 1)],
        )


def big_sphere():
    write_scene(
        "big-sphere-horizon.json",
        {
            "probes": "an eye 1 unit above a sphere of radius 1000, looking horizontally "
            "(perpendicular to the radius) at the horizon, about 44.7 units away: rays below the "
            "horizon graze the sphere, |eye - centre|^2 - r^2 = 2001 cancels six digits of 1e6",
            "invariant": "the sphere fills the image below the horizon curve (dip angle "
            "acos(1000/1001) = 2.56 degrees: rows 31..47 of 48) and nothing above it; hit "
            "distances grow smoothly towards the horizon (at most about 44.7)",
            "kind": "big-sphere",
        },
        camera([0, 1001, 0], 1, 0.4, 0.3),
        [sphere([0, 0, 0], 1000)],
    )
    write_scene(
        "big-sphere-horizon-oblique.json",
        {
            "probes": "big-sphere-horizon.json in general position: the eye 1001 (2,1,2)/3 from "
            "the centre (no coordinate exact), looking along (1,0,-1), perpendicular to the "
            "radius, up (2,1,2) along it; there |eye - centre|^2 - r^2 = 2001 is itself rounded "
            "from 1e6-sized terms, in the textbook as in the perpendicular-distance formula",
            "invariant": "the same picture as big-sphere-horizon.json: the sphere on rows 31..47 "
            "below a straight horizon, nothing above",
            "kind": "big-sphere",
        },
        camera([2002 / 3, 1001 / 3, 2002 / 3], 1, 0.4, 0.3, look=[1, 0, -1], up=[2, 1, 2]),
        [sphere([0, 0, 0], 1000)],
    )


def tangent():
    # Orthographic, 96x72, pixel pitch 1/32: pixel centres at odd multiples of 1/64. The centre
    # (1/64, 1/64) is pixel (row 35, column 48); r = 25/32 is 25 pixels, and 25^2 = 0^2 + 25^2
    # = 7^2 + 24^2 = 15^2 + 20^2, so 20 pixel-centre rays pass at exactly r from the centre.
    offsets = sorted({(sx * a, sy * b) for a, b in [(0, 25), (25, 0), (7, 24), (24, 7), (15, 20), (20, 15)]
                      for sx in (1, -1) for sy in (1, -1)})
    assert len(offsets) == 20 and all(dx * dx + dy * dy == 625 for dx, dy in offsets)
    pixels = sorted((35 - dy, 48 + dx) for dx, dy in offsets)
    listed = ", ".join(f"({r},{c})" for r, c in pixels)
    write_scene(
        "tangent-ortho.json",
        {
            "probes": "rays exactly tangent to a sphere: orthographic camera, pixel pitch 1/32, "
            "centre (1/64, 1/64, 0) on the ray of pixel (row 35, column 48), radius 25/32 = 25 "
            "pixels; the rays of the 20 pixels (row, column) " + listed + " pass at exactly "
            "distance r from the centre (offsets (0,25), (7,24), (15,20) and their mirror images; "
            "every input is dyadic, so the discriminant is exactly 0 in every precision)",
            "invariant": "the 20 tangent pixels hit (a zero discriminant is a hit), at distance "
            "exactly 4 with normals perpendicular to the view; the hit set is the pixels with "
            "dx^2 + dy^2 <= 625 (in pixels from the centre pixel), the same in every mode",
            "kind": "tangent",
        },
        camera([0, 0, 4], 1, 3, 2.25, (96, 72), type="orthographic"),
        [sphere([1 / 64, 1 / 64, 0], 25 / 32)],
    )


def shared_edges_grid():
    # Pixel centres (64x48, pitch 1/16) are at odd multiples of 1/32 in x and y. Grid lines at
    # (4k+1)/32: every second pixel column and row; cell centres lie on both diagonals, so every
    # pixel-centre ray goes through a vertex, an axis edge or a diagonal.
    xs = [(4 * k + 1) / 32 for k in range(-17, 18)]
    ys = [(4 * k + 1) / 32 for k in range(-13, 14)]
    assert xs[0] < -63 / 32 and xs[-1] > 63 / 32 and ys[0] < -47 / 32 and ys[-1] > 47 / 32
    tris = grid_triangles(xs, ys, lambda x, y: x / 2 + y / 4)
    write_obj("grid.obj", tris, "A tilted flat grid (z = x/2 + y/4), vertices over pixel centres "
              "of shared-edges-grid.json, alternating diagonals.")
    write_scene(
        "shared-edges-grid.json",
        {
            "probes": f"a flat tilted grid of {len(tris)} triangles (plane z = x/2 + y/4, cells 2 "
            "pixels wide, diagonals alternating) filling the whole orthographic view, its vertices "
            "exactly over pixel centres: every pixel-centre ray passes through a vertex (odd rows, "
            "even columns), an axis-parallel edge or a diagonal (the cell centres); diagonals are "
            "the edge b-c of both triangles (Cramer's beta + gamma <= 1 test)",
            "invariant": "every one of the 3072 pixels hits the grid (object 0): zero misses, zero "
            "cracks; distance 4 - x/2 - y/4 at pixel centre (x, y)",
            "kind": "shared-edges",
        },
        camera([0, 0, 4], 1, 4, 3, type="orthographic"),
        [{"type": "soup", "obj": "grid.obj"}],
    )


def shared_edges_cube():
    # Box [-9/8, 9/8]^3, 12 x 12 cells of 3/16 per face. Perspective camera at
    # (61/32, 1/32, 25/8), looking down -z, width 2 (pitch 1/32): pixel rays reach the front
    # face z = 9/8 at t = 2, at x = (j-1)/16, y = (24-i)/16. Cells are 3 pixels wide, so pixel
    # rays cross the cell diagonals at 1/3 and 2/3 (barycentrics that round), column 19 runs
    # exactly along the front/right crease x = 9/8, and rows 6 and 42 along the front/top and
    # front/bottom silhouette edges.
    h = 9 / 8
    tris = box_triangles((-h, -h, -h), (h, h, h), 12)
    write_obj("cube12.obj", tris, "A closed cube [-9/8, 9/8]^3, 12 x 12 cells per face, "
              "alternating diagonals, outward normals.")
    write_scene(
        "shared-edges-cube.json",
        {
            "probes": f"a closed cube of {len(tris)} triangles (12 x 12 cells of 3/16 per face) "
            "in perspective, eye at (61/32, 1/32, 25/8) so pixel rays meet the front face at "
            "x = (column - 1)/16, y = (24 - row)/16: rays through vertices (columns 1 mod 3, rows "
            "0 mod 3), along grid lines and across diagonals at 1/3 and 2/3 of a cell (rounded "
            "barycentrics); column 19 runs exactly along the front/right crease (x = 9/8, z = "
            "9/8) between two visible faces, rows 6 and 42 along the silhouette edges",
            "invariant": "no misses inside the silhouette: every pixel of columns 0..25 whose ray "
            "meets the cube hits it (rows 6..42 on the front face, column 19 on the crease "
            "included); the right face appears as a band in columns 19..25",
            "kind": "shared-edges",
        },
        camera([61 / 32, 1 / 32, 25 / 8], 1, 2, 1.5),
        [{"type": "soup", "obj": "cube12.obj"}],
    )


def degenerate():
    # Perspective, eye (0,0,4), pitch 1/64: the ray of pixel (i, j) is
    # (us, vs, -1) with us = (2j-63)/128, vs = (47-2i)/128; at depth z it is at
    # (us (4-z), vs (4-z), z). A segment in the plane of pixel row i is crossed by that row's
    # rays; everything below is placed in such planes.
    def at(i, j, z):
        return ((2 * j - 63) / 128 * (4 - z), (47 - 2 * i) / 128 * (4 - z), z)

    e = 1e-6
    objects = []
    # 0: horizontal needle along row 10, tilting away in depth; apex at column 7.5, base at 55.5.
    a = at(10, 7.5, 0)
    m = at(10, 55.5, -2)
    objects.append(triangle(a, (m[0], m[1] - e, m[2]), (m[0], m[1] + e, m[2])))
    # 1: vertical needle along column 58, from row 39.5 (apex) to row 7.5.
    a = at(39.5, 58, 0)
    m = at(7.5, 58, -1)
    objects.append(triangle(a, (m[0] - e, m[1], m[2]), (m[0] + e, m[1], m[2])))
    # 2: diagonal needle at z = 1/2 over pixels (28+k, 6+k), k = 0..19.
    a = at(27.5, 5.5, 0.5)
    m = at(47.5, 25.5, 0.5)
    objects.append(triangle(a, (m[0] + e, m[1] + e, m[2]), (m[0] - e, m[1] - e, m[2])))
    # 3: repeated vertex (p, p, q), a segment crossed by row 20, columns 16..47.
    p, q = at(20, 15.5, 0), at(20, 47.5, -2)
    objects.append(triangle(p, p, q))
    # 4: collinear, third corner between the first two; row 30, columns 12..47.
    p, r = at(30, 11.5, 0), at(30, 47.5, -1)
    mid = tuple((x + y) / 2 for x, y in zip(p, r))
    objects.append(triangle(p, r, mid))
    # 5: collinear, third corner beyond the second; row 38, columns 28..50.
    p, r = at(38, 28, 0), at(38, 50, -1)
    mid = tuple((x + y) / 2 for x, y in zip(p, r))
    objects.append(triangle(p, mid, r))
    # 6: all three corners at one point, on the ray of pixel (5, 5).
    p = at(5, 5, 0)
    objects.append(triangle(p, p, p))
    # 7: three points on the ray of pixel (44, 20): the triangle lies along the ray.
    objects.append(triangle(at(44, 20, 0), at(44, 20, -1), at(44, 20, -2)))
    for o in objects[3:]:
        a, b, c = o["corners"]
        assert all(is_f32(x) for p in (a, b, c) for x in p)
        u = [b[k] - a[k] for k in range(3)]
        v = [c[k] - a[k] for k in range(3)]
        cross = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
        assert cross == [0, 0, 0], o  # zero area, exactly, in f64 (and f32)
    write_scene(
        "degenerate-needles.json",
        {
            "probes": "needles and zero-area triangles placed where pixel rays meet them exactly "
            "(perspective, every segment in the plane of a pixel row or column): object 0 a needle "
            "(width 2e-6 at its base, length 4.3, aspect 2e6) whose median is crossed by the rays "
            "of row 10, columns 8..55; 1 a needle along column 58, rows 8..39; 2 a needle along "
            "the pixel diagonal (28+k, 6+k), k = 0..19; zero-area: 3 a repeated corner (p, p, q) "
            "crossed by row 20, columns 16..47; 4 collinear corners, the third between the first "
            "two, crossed by row 30, columns 12..47; 5 collinear, the third beyond the second, "
            "row 38, columns 28..50; 6 all corners at one point on the ray of pixel (5, 5); 7 "
            "three corners on the ray of pixel (44, 20) itself. Coordinates are dyadic (the "
            "degenerate ones exactly so in f32), needle widths 1e-6 decimal",
            "invariant": "objects 3..7 are never hit; each needle is hit exactly on the pixels "
            "listed for it (the rays cross its median, at least about 1e-8 inside its edges) and "
            "nowhere else; no NaN or infinite distance or normal anywhere",
            "kind": "degenerate",
        },
        camera([0, 0, 4], 1, 1, 0.75),
        objects,
    )


def grazing():
    write_scene(
        "grazing-plane-height.json",
        {
            "probes": "an eye 1e-3 above the plane y = 0 looking along it (view 0.004 x 0.003 at "
            "focal length 1, so the rays that reach the plane beyond the image plane meet it "
            "at 0.0018 to 0.056 degrees), with a sphere of radius 0.01 resting on the plane 20 "
            "away and one of radius 0.03 60 away: t = 1e-3/|vs| is very sensitive to the ray's slope",
            "invariant": "rows 0..23 (above the horizon) never hit the plane; rows 24..39 hit it "
            "(t = 1e-3/|vs| from 32 down to 1.03) wherever the spheres do not cover it; rows "
            "40..47 would meet it before the image plane (t < 1) and so show only spheres or "
            "nothing; the spheres touch the plane at one point each",
            "kind": "grazing-plane",
        },
        camera([0, 0.001, 0], 1, 0.004, 0.003),
        [plane([0, 0, 0], [0, 1, 0]), sphere([0.015, 0.01, -20], 0.01), sphere([-0.05, 0.03, -60], 0.03)],
    )
    write_scene(
        "grazing-plane-through-eye.json",
        {
            "probes": "the plane 3x + 4y = 0 contains the eye (its point (800000, -600000, -5) is "
            "1e6 away, exactly on it); the horizon 3 us + 4 vs = 0 crosses the view diagonally, "
            "rays near it are almost parallel to the plane; in world coordinates f32 rounds "
            "(p - e).n to about 0.03 instead of 0, giving t = 0.03/(d.n), which is >= 1 near the "
            "horizon; three spheres rest on the plane (two above, one below)",
            "invariant": "the plane is never hit (every ray meets it at t = 0, the eye); the "
            "three spheres are hit, each touching the plane at one point",
            "kind": "grazing-plane",
        },
        camera([0, 0, 0], 1, 1, 0.75),
        [plane([800000, -600000, -5], [3, 4, 0]), sphere([0.6, 0.8, -8], 1),
         sphere([-1.3, 1.6, -5], 0.5), sphere([0.75, -1.5, -6], 0.75)],
    )


def base_scene(t=(0, 0, 0), s=1.0):
    """The dyadic base: 2 spheres, a plane and a closed cube mesh; translated by t, scaled by s.
    Scene values are multiples of 1/4 with small odd parts, so that times 2^-20 they still
    parse exactly; mesh coordinates are multiples of 1/16 (f32-exact after adding 1e6)."""

    def X(p):
        return [s * c + d for c, d in zip(p, t)]

    cam = camera(X([1, 1, 4]), 2 * s, 2 * s, 1.5 * s, look=[-0.25, -0.375, -1])
    objects = [
        plane(X([0, -1, 0]), [0, 1, 0]),
        sphere(X([-1.5, -0.5, -1]), 0.5 * s),
        sphere(X([1.5, 0, -2.5]), 1 * s),
    ]
    return cam, objects


def transformed():
    base_tris = box_triangles((-0.5, -0.9375, 0), (0.5, 0.0625, 1), 4)
    # (name, translation, scale, mesh format): the cube in OBJ, ASCII PLY or binary PLY with
    # double coordinates. Scales below 2^-20 are left to src/tests/extremes.rs, which scales in
    # memory: their shortest decimal forms do not all parse back exactly in serde_json without
    # its float_roundtrip feature, and above 2^56 the scene's numbers exceed 1e18.
    variants = [
        ("dyadic-base", (0, 0, 0), 1.0, "obj"),
        ("translated-1e3", (1000, 1000, 1000), 1.0, "obj"),
        ("translated-1e6", (1e6, 1e6, 1e6), 1.0, "obj"),
        ("translated-1e6-ascii-ply", (1e6, 1e6, 1e6), 1.0, "ply"),
        ("translated-1e6-binary-ply", (1e6, -1e6, 1e6), 1.0, "binary ply"),
        ("scaled-2e-20", (0, 0, 0), 2.0**-20, "obj"),
        ("scaled-2e20", (0, 0, 0), 2.0**20, "obj"),
        ("scaled-2e40", (0, 0, 0), 2.0**40, "obj"),
        ("scaled-2e56", (0, 0, 0), 2.0**56, "ply"),
    ]
    for name, t, s, fmt in variants:
        cam, objects = base_scene(t, s)
        tris = [tuple(tuple(s * c + d for c, d in zip(p, t)) for p in tri) for tri in base_tris]
        header = f"The base cube of dyadic-base.json, scale {s!r}, translation {list(t)!r}."
        if fmt == "obj":
            mesh = f"{name}.cube.obj"
            write_obj(mesh, tris, header)
            objects.append({"type": "soup", "obj": mesh})
        else:
            mesh = f"{name}.cube.ply"
            write_ply(mesh, tris, header, binary=fmt == "binary ply")
            objects.append({"type": "soup", "ply": mesh})
        if name == "dyadic-base":
            comment = {
                "probes": "the untransformed reference of the translated-* and scaled-* scenes: "
                "a floor plane, two spheres and a closed cube of 192 triangles (cells 1/4), every "
                "coordinate dyadic (scene values multiples of 1/4, mesh multiples of 1/16)",
                "invariant": "itself (translation zero): the translated and scaled scenes must "
                "render like this one",
                "kind": "translated",
                "base": "dyadic-base.json",
                "translation": [0, 0, 0],
            }
        elif s == 1.0:
            comment = {
                "probes": f"dyadic-base.json with every point (eye, plane point, centres, mesh "
                f"corners) moved by {list(t)}, exactly (f64 scene values, f32-exact "
                f"mesh corners, the mesh in {fmt.upper()}); world-coordinate arithmetic loses "
                "log2 of the offset in bits",
                "invariant": "the same picture as dyadic-base.json: the same hit/miss and ids on "
                "every pixel, distances equal to about 1e-6 relative (camera-relative rendering "
                "removes the offset exactly)",
                "kind": "translated",
                "base": "dyadic-base.json",
                "translation": list(t),
            }
        else:
            k = int(math.log2(s))
            comment = {
                "probes": f"dyadic-base.json scaled by 2^{k} about the origin (eye, focal length, "
                f"image-plane size, every point and radius, the mesh in {fmt.upper()}), exactly; "
                f"the kernel's products of three coordinates would reach about 2^{3 * k} times "
                "the base's, so they stay in f32's range only through the host's power-of-two "
                "rescale to the camera's size",
                "invariant": f"the same hit/miss and ids as dyadic-base.json on every pixel in "
                f"every mode, distances exactly 2^{k} times the base's, normals identical",
                "kind": "scaled",
                "base": "dyadic-base.json",
                "scale": s,
            }
        write_scene(f"{name}.json", comment, cam, objects)


def fov():
    write_scene(
        "fov-narrow.json",
        {
            "probes": "a field of view of 2e-6 x 1.5e-6 radians (width 2e-6 at focal length 1): "
            "neighbouring pixel rays differ by 3e-8 in direction, about half an f32 ulp of the "
            "unit component; looking at spheres of radius 0.5 and 0.3 a million units away "
            "(overlapping), with a wall behind them at 1.2e6",
            "invariant": "every pixel hits (the wall behind everything); the two spheres appear "
            "as discs of radius about 16 and 10 pixels, the nearer (object 1) in front; "
            "distances about 1e6 on the spheres",
            "kind": "fov",
        },
        camera([0, 0, 0], 1, 2e-6, 1.5e-6),
        [sphere([0.1, 0, -1e6], 0.5), sphere([-0.45, 0.2, -999999.5], 0.3), plane([0, 0, -1.2e6], [0, 0, 1])],
    )
    write_scene(
        "fov-wide.json",
        {
            "probes": "a field of view of 178.9 x 177.7 degrees (image plane 200 x 150 at focal "
            "length 1, pixel pitch 3.125) inside a box room: the four central pixels already "
            "look 57 degrees off axis, corner rays have |d| = 125 and meet the walls at up to "
            "89.4 degrees from their normals; t >= 1 clips everything nearer than the image plane "
            "z = -1; spheres on the floor and a triangle 10 in front of the right wall show as slivers",
            "invariant": "every pixel hits (the room is closed in front of the eye): each ray "
            "meets the nearest of floor y = -100 (t = 100/|vs|), ceiling y = 100, side walls "
            "x = +-150 (t = 150/|us|) and back wall z = -50 (t = 50), all beyond the image plane, "
            "so the walls appear as four wedges meeting at the back wall, which only three of the "
            "2 x 2 central pixels see (a sphere resting on the floor and piercing the back wall "
            "covers the fourth)",
            "kind": "fov",
        },
        camera([0, 0, 0], 1, 200, 150),
        [plane([0, -100, 0], [0, 1, 0]), plane([0, 100, 0], [0, -1, 0]), plane([-150, 0, 0], [1, 0, 0]),
         plane([150, 0, 0], [-1, 0, 0]), plane([0, 0, -50], [0, 0, 1]), sphere([100, -80, -20], 20),
         sphere([-80, -70, -30], 30), triangle([140, -40, -10], [140, 60, -6], [140, 20, -45])],
    )


def up_near_look():
    write_scene(
        "up-near-look.json",
        {
            "probes": "up = look + 1e-7 (2,1,2) with look = (1,2,-2): the angle between them is "
            "1e-7 rad, so u = normalize(look x up) comes from a cross product that cancels seven "
            "digits (in f64, on the host)",
            "invariant": "the frame is that of up = (2,1,2) to about 1e-9 rad: u = (2,-2,-1)/3, "
            "v = (2,1,2)/3; the spheres at 9 look/3 +- 3u, (5,4,-7) and (1,8,-5), appear at the "
            "same image row mirrored about the centre column (right and left), the floor with "
            "normal v below everything",
            "kind": "up",
        },
        camera([0, 0, 0], 1, 1, 0.75, look=[1, 2, -2], up=[1.0000002, 2.0000001, -1.9999998]),
        [sphere([2, 4, -4], 1), sphere([3, 3, -3], 0.5), sphere([5, 4, -7], 0.75), sphere([1, 8, -5], 0.75),
         plane([-1, -0.5, -1], [2, 1, 2])],
    )


def on_surface():
    write_scene(
        "on-surface-plane.json",
        {
            "probes": "the eye lies exactly on the plane y = 0 and looks along it at objects "
            "resting on it, a sphere half sunk into it and a triangle crossing it: every ray meets "
            "the plane at t = 0",
            "invariant": "the plane is never hit; above the horizon (rows 0..23) the resting "
            "spheres, the upper half of the sunk sphere and the triangle; below it only the lower "
            "half of the sunk sphere and the lower part of the triangle",
            "kind": "on-surface",
        },
        camera([0.25, 0, 2.5], 1, 1.2, 0.9, look=[0.125, 0, -1]),
        [plane([5, 0, -9], [0, 1, 0]), sphere([0, 1, -5], 1), sphere([-1.5, 0.5, -3], 0.5),
         sphere([2.5, 0, -7], 0.75), triangle([1, -0.75, -4], [2, -0.75, -4], [1.5, 1, -4])],
    )
    write_scene(
        "on-surface-sphere.json",
        {
            "probes": "the eye (3, 4, 0) lies exactly on the sphere of radius 5 about the origin "
            "(9 + 16 = 25), looking along the tangent (-4, 3, 0): one root of every ray is t = 0 "
            "(c = |e - c|^2 - r^2 = 0 exactly); rays below the tangent plane cross the sphere's "
            "inside, with a small sphere inside it and another outside above",
            "invariant": "no hit at t = 0: rays above the tangent plane (the upper half) miss the "
            "big sphere and see only the outside sphere (object 1); rays below it hit the big "
            "sphere's far side from inside where the chord 10 sin(angle) reaches past the image "
            "plane, and the inside sphere (object 2)",
            "kind": "on-surface",
        },
        camera([3, 4, 0], 1, 2.5, 1.875, look=[-4, 3, 0], up=[3, 4, 0]),
        [sphere([0, 0, 0], 5), sphere([-0.6, 9.2, 0], 1), sphere([-0.9, 3.8, 0], 0.5)],
    )


def far_camera():
    """A centimetre-sized sphere and cube seen from 1e6 away: in f32 the camera-relative centre
    rounds to 1/16, more than the objects' size."""
    d = 1e6
    cube = box_triangles((2**-7, -(2**-8), -(2**-8)), (2**-6, 2**-8, 2**-8), 2)
    write_obj("far-camera-centimetre.cube.obj", cube, "A 7.8 mm cube beside the sphere of far-camera-centimetre.json.")
    write_scene(
        "far-camera-centimetre.json",
        {
            "probes": "a sphere 1 cm across at the origin and a 7.8 mm cube beside it, seen from 1e6 "
            "away along (2,1,2)/3 with a 4e-8 wide image plane at focal length 1 (a 4 cm view): "
            "in f32 the camera-relative centre and corners round to 1/16, six times the objects' "
            "size, so robust f32 cannot place them; f64 places them to about 1e-10",
            "invariant": "f64 (GPU and CPU): a pixel hits the sphere exactly when its ray passes "
            "within 0.005 of the centre (computed independently, pixels within 1e-6 relative of "
            "the silhouette skipped), at distance |c - e| - about 0.005; adaptive precision "
            "equals f64 on every pixel; robust f32 equals f64 wherever the margins allow",
            "kind": "far-camera",
        },
        camera([2 * d / 3, d / 3, 2 * d / 3], 1, 4e-8, 3e-8, look=[-2, -1, -2]),
        [sphere([0, 0, 0], 0.005), {"type": "soup", "obj": "far-camera-centimetre.cube.obj"}],
    )


def range_scenes():
    """Scenes whose arithmetic leaves f32's range even in kernel units (the host keeps kernel
    coordinates within 2^61): where the certainty test must refuse to trust f32."""
    cam = camera([0, 0, 0], 0.001, 0.002, 0.0015)
    write_scene(
        "range-far-triangle.json",
        {
            "probes": "a triangle 1e18 away, 1e18 across, seen by a camera 2e-3 across: the "
            "largest number is 2^60 times the camera, so the host's rescale stops there (kernel "
            "coordinates at most 2^61) and the triangle's t, a product of three coordinates "
            "(about 1e54), overflows f32; a sphere 0.1 away in front of it is an ordinary hit",
            "invariant": "robust f32 loses the triangle's hits (its t is NaN); the certainty test "
            "marks every pixel whose ray meets the overflowing triangle uncertain, so adaptive "
            "precision equals f64 on every pixel; f64 hits the triangle at about 1e18 (distance)",
            "kind": "range",
        },
        cam,
        [triangle([-1e18, -7e17, -1e18], [9e17, -8e17, -1e18], [1e17, 9e17, -1e18]),
         sphere([0.05, 0, -0.1], 0.03)],
    )
    write_scene(
        "range-far-mixed.json",
        {
            "probes": "a sphere, a plane and a triangle, all about 1e18 away, seen by a camera "
            "2e-3 across: kernel coordinates near 2^60, where the sphere's and plane's "
            "arithmetic stays in f32's range and the triangle's t (a product of three "
            "coordinates) overflows; robust f32 sphere normals overflow too (the half-chord "
            "over a tiny direction)",
            "invariant": "adaptive precision equals f64 on every pixel: pixels whose rays meet "
            "the triangle, or whose f32 normal is NaN, are uncertain, the others certain where "
            "the margins allow",
            "kind": "range",
        },
        cam,
        [sphere([0, 0, -1e18], 5e17), plane([0, -1e18, 0], [0, 1, 0]),
         triangle([-1e18, -1e18, -9e17], [1e18, -1e18, -9e17], [0, 1e18, -9e17])],
    )
    write_scene(
        "range-tiny-camera.json",
        {
            "probes": "a camera 2e-21 across in a scene 1e18 large: the rescale keeps kernel "
            "coordinates within 2^61, so the camera stays near 1e-21 in kernel units and the "
            "squared length of every ray direction (about 1e-42) underflows f32's normal range "
            "(or flushes to zero)",
            "invariant": "robust f32 gets most pixels wrong (its ray arithmetic underflows); the "
            "certainty test marks them uncertain, so adaptive precision equals f64 on every "
            "pixel: the big sphere fills the view, the small one covers part of its right half",
            "kind": "range",
        },
        camera([0, 0, 0], 1e-21, 2e-21, 1.5e-21),
        [sphere([0, 0, -1e18], 9e17), sphere([3e-21, 0, -1e-20], 3e-21)],
    )


def main():
    far_spheres()
    big_sphere()
    tangent()
    shared_edges_grid()
    shared_edges_cube()
    degenerate()
    grazing()
    transformed()
    fov()
    up_near_look()
    on_surface()
    far_camera()
    range_scenes()
    print(f"wrote {len(SCENES)} scenes and {len(MESHES)} meshes in {HERE}")


if __name__ == "__main__":
    main()
