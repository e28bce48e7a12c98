"""The files `raycast render` writes for other tools, read by their own readers: render.exr by
the OpenEXR package, render.npz by numpy, checked against the npy files of the same render.
Runs the command-line binary that `cargo test` built (RAYCAST_BIN to use another)."""
import json
import os
import pathlib
import subprocess

import numpy as np
import OpenEXR

ROOT = pathlib.Path(__file__).resolve().parents[2]
BINARY = os.environ.get("RAYCAST_BIN", str(ROOT / "target" / "debug" / "raycast"))


def render(out, *args):
    subprocess.run([BINARY, "render", *args, "-o", str(out)], check=True, capture_output=True)
    return out


def test_exr_read_by_openexr_equals_the_npy_arrays(tmp_path):
    scene = str(ROOT / "scenes" / "course" / "bunny.json")
    out = render(tmp_path, scene, "--size", "64x36", "--format", "npy,exr", "--spp", "4",
                 "--depth", "z", "--precision", "f32")
    with OpenEXR.File(str(out / "render.exr")) as exr:
        channels = {name: c.pixels for name, c in exr.channels().items()}
    assert sorted(channels) == ["A", "N.X", "N.Y", "N.Z", "Z", "id"]
    ids = np.load(out / "id.npy")
    assert channels["id"].dtype == np.uint32
    assert np.array_equal(channels["id"], ids.astype(np.uint32))
    assert np.array_equal(channels["id"][ids == -1], np.full((ids == -1).sum(), 0xFFFFFFFF))
    assert np.array_equal(channels["Z"], np.load(out / "z.npy"))
    normal = np.load(out / "normal.npy")
    for k, axis in enumerate("XYZ"):
        assert np.array_equal(channels["N." + axis], normal[..., k])
    assert np.array_equal(channels["A"], np.load(out / "alpha.npy"))


def test_npz_loads_as_the_npy_arrays(tmp_path):
    scene = str(ROOT / "scenes" / "course" / "sphere-and-plane.json")
    out = render(tmp_path, scene, "--size", "48x27", "--format", "npy,npz")
    with np.load(out / "render.npz") as npz:
        assert sorted(npz.files) == ["distance", "id", "normal"]
        for name in npz.files:
            assert np.array_equal(npz[name], np.load(out / f"{name}.npy"))
    camera = json.loads((out / "camera.json").read_text())
    assert (camera["width"], camera["height"]) == (48, 27)
    assert camera["depth"] == "distance"
