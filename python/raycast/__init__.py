"""GPU ray casting on any Vulkan, Metal or DX12 GPU, or on Mesa's lavapipe without one.

``raycast.RaycastingScene`` mirrors Open3D's ``open3d.t.geometry.RaycastingScene``, so that
switching is one import::

    import raycast
    scene = raycast.RaycastingScene()
    mesh_id = scene.add_triangles(vertices, triangles)
    rays = raycast.RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 640, 480)
    ans = scene.cast_rays(rays)          # t_hit, geometry_ids, primitive_ids, ...

Beyond Open3D: spheres and planes (``add_sphere``, ``add_plane``), ``precision="f32" | "f64" |
"adaptive"`` and ``device="gpu" | "cpu"`` on every cast, scene files (``raycast.load``) and
their camera renders (``render``, lit by the course's ray tracer with ``lit=True`` or coloured
by a shade hook file with ``shader=``), and ``raycast.info()`` for the adapter.

Rays are rows of ``origin, direction`` (shape ``(..., 6)``, any float dtype and layout:
float32 and float64 are read as they are when C-contiguous, others converted once to float64);
``t_hit`` is in units of each ray's direction, as Open3D's.
Casts release the GIL.
"""

from __future__ import annotations

import math
import os
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from . import _raycast

__all__ = ["RaycastingScene", "load", "info"]

ArrayLike = Union[np.ndarray, Sequence[Any]]

_PRECISIONS = ("f32", "f64", "adaptive")
_DEVICES = ("gpu", "cpu")


def info() -> Dict[str, Any]:
    """The GPU adapter raycast runs on: name, backend, driver, device type, f64, subgroups."""
    return _raycast.info()


def _float_array(
    value: ArrayLike, name: str, last: Optional[int] = None, keep_float32: bool = False
) -> np.ndarray:
    """`value` as a C-contiguous float64 array (float32 kept with `keep_float32`), its last
    dimension `last` where given."""
    try:
        array = np.asarray(value)
    except Exception as e:  # ragged lists and the like
        raise ValueError(f"{name}: cannot be read as an array ({e})") from None
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)
    ):
        raise TypeError(f"{name}: expected an array of numbers, got dtype {array.dtype}")
    if last is not None and (array.ndim == 0 or array.shape[-1] != last):
        raise ValueError(f"{name}: expected shape (..., {last}), got {array.shape}")
    keep = keep_float32 and array.dtype == np.float32
    return np.ascontiguousarray(array, dtype=np.float32 if keep else np.float64)


def _rays(rays: ArrayLike) -> tuple:
    """The rays as an (n, 6) float32 or float64 array (float32 is read as it is: widening a
    copy of 2M rays took 0.02 s of a 0.35 s cast), the leading shape to give the results, and
    the width of the image they are rows of, if they have two leading dimensions or more (the
    GPU then traces tiles of neighbouring rows together, as it does a camera's)."""
    array = _float_array(rays, "rays", 6, keep_float32=True)
    shape = array.shape[:-1]
    width = shape[-1] if len(shape) >= 2 and shape[-1] > 0 else None
    return array.reshape(-1, 6), shape, width


def _options(precision: str, device: str) -> None:
    if precision not in _PRECISIONS:
        raise ValueError(f"precision: expected one of {', '.join(_PRECISIONS)}, got {precision!r}")
    if device not in _DEVICES:
        raise ValueError(f"device: expected one of {', '.join(_DEVICES)}, got {device!r}")


def _point(value: ArrayLike, name: str) -> list:
    array = _float_array(value, name)
    if array.shape != (3,):
        raise ValueError(f"{name}: expected 3 numbers, got shape {array.shape}")
    return [float(x) for x in array]


class RaycastingScene:
    """Objects to cast rays at: triangle meshes, spheres and planes (Open3D's
    ``RaycastingScene``, plus spheres, planes, precision and device)."""

    INVALID_ID: int = 4294967295

    def __init__(self) -> None:
        self._scene = _raycast.Scene()

    @classmethod
    def _wrap(cls, native: "_raycast.Scene") -> "RaycastingScene":
        scene = cls.__new__(cls)
        scene._scene = native
        return scene

    def add_triangles(self, vertices: ArrayLike, triangles: ArrayLike) -> int:
        """Adds a triangle mesh: ``vertices`` (N, 3) positions, ``triangles`` (M, 3) vertex
        indices. Returns the geometry id. Raises ValueError on NaN or infinite positions and
        out-of-range indices."""
        v = _float_array(vertices, "vertices", 3)
        if v.ndim != 2:
            raise ValueError(f"vertices: expected shape (N, 3), got {v.shape}")
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"triangles: expected shape (M, 3), got {t.shape}")
        if t.size and not np.issubdtype(t.dtype, np.integer):
            if not np.issubdtype(t.dtype, np.floating) or not np.all(t == np.floor(t)):
                raise TypeError(f"triangles: expected integer indices, got dtype {t.dtype}")
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            bad = int(t.min()) if t.min() < 0 else int(t.max())
            raise ValueError(f"triangles: index {bad} is out of range ({len(v)} vertices)")
        t = np.ascontiguousarray(t, dtype=np.uint32)
        return self._scene.add_triangles(v, t)

    def add_sphere(self, center: ArrayLike, radius: float) -> int:
        """Adds a sphere; returns its geometry id (not in Open3D)."""
        return self._scene.add_sphere(_point(center, "center"), float(radius))

    def add_plane(self, point: ArrayLike, normal: ArrayLike) -> int:
        """Adds an infinite plane through ``point`` facing ``normal``; returns its geometry id
        (not in Open3D)."""
        return self._scene.add_plane(_point(point, "point"), _point(normal, "normal"))

    def cast_rays(
        self, rays: ArrayLike, precision: str = "f32", device: str = "gpu"
    ) -> Dict[str, np.ndarray]:
        """The nearest hit of each ray (``t >= 0``): a dict of ``t_hit`` (inf on a miss),
        ``geometry_ids`` and ``primitive_ids`` (uint32, ``INVALID_ID`` on a miss),
        ``primitive_uvs`` (..., 2) and ``primitive_normals`` (..., 3), with the rays'
        leading dimensions. float32 for f32 and adaptive, float64 for f64."""
        _options(precision, device)
        flat, shape, width = _rays(rays)
        out = self._scene.cast(flat, width, precision, device)
        return {
            "t_hit": out["t_hit"].reshape(shape),
            "geometry_ids": out["geometry_ids"].reshape(shape),
            "primitive_ids": out["primitive_ids"].reshape(shape),
            "primitive_uvs": out["primitive_uvs"].reshape(shape + (2,)),
            "primitive_normals": out["primitive_normals"].reshape(shape + (3,)),
        }

    def test_occlusions(
        self,
        rays: ArrayLike,
        tnear: float = 0.0,
        tfar: float = math.inf,
        nthreads: int = 0,
        precision: str = "f32",
        device: str = "gpu",
    ) -> np.ndarray:
        """Whether each ray hits anything with ``tnear <= t <= tfar`` (bool, the rays' leading
        shape). ``nthreads`` is accepted for Open3D compatibility and ignored."""
        _options(precision, device)
        flat, shape, width = _rays(rays)
        hit = self._scene.occluded(flat, width, (float(tnear), float(tfar)), precision, device)
        return hit.reshape(shape)

    def count_intersections(
        self, rays: ArrayLike, nthreads: int = 0, precision: str = "f32", device: str = "gpu"
    ) -> np.ndarray:
        """How many surfaces each ray crosses (``t >= 0``; int32, the rays' leading shape):
        a mesh's triangles once each, a sphere twice from outside and once from inside."""
        _options(precision, device)
        flat, shape, _ = _rays(rays)
        counts = self._scene.count(flat, precision, device)
        return counts.view(np.int32).reshape(shape)

    def render(
        self,
        precision: str = "f32",
        device: str = "gpu",
        lit: bool = False,
        shader: Optional[Union[str, os.PathLike]] = None,
    ) -> Dict[str, Any]:
        """The scene file's camera rendered (scenes from ``raycast.load``): ``id`` (int32,
        -1 on a miss), ``distance`` (inf on a miss) and ``normal`` (..., 3) images, rows from
        the top, as the command line's npy files hold them.

        With ``lit=True`` (the course's ray tracer from the scene's materials and lights, the
        hook shaders/examples/raytrace.wgsl on the GPU, its mirror on the CPU) or a shade hook
        file ``shader`` (GPU), also ``color`` (uint8 RGBA, (..., 4)) and ``hook_rays``, the
        rays the hook cast (None where it casts none)."""
        _options(precision, device)
        out = self._scene.render(
            precision, device, lit, None if shader is None else os.fspath(shader)
        )
        shape = (out["height"], out["width"])
        images = {
            "id": out["id"].reshape(shape),
            "distance": out["distance"].reshape(shape),
            "normal": out["normal"].reshape(shape + (3,)),
        }
        if "color" in out:
            images["color"] = out["color"].reshape(shape + (4,))
            images["hook_rays"] = out["hook_rays"]
        return images

    @staticmethod
    def create_rays_pinhole(*args: Any, **kwargs: Any) -> np.ndarray:
        """Rays of a pinhole camera, shape (height_px, width_px, 6) float32, as Open3D makes
        them: ``create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px)`` (fov
        horizontal, looking from ``eye`` at ``center``) or ``create_rays_pinhole(
        intrinsic_matrix, extrinsic_matrix, width_px, height_px)`` (3x3 pixel intrinsics, 4x4
        world-to-camera). Directions are not normalised: t_hit is the camera's z depth."""
        names_fov = ("fov_deg", "center", "eye", "up", "width_px", "height_px")
        names_k = ("intrinsic_matrix", "extrinsic_matrix", "width_px", "height_px")
        if "intrinsic_matrix" in kwargs or (len(args) + len(kwargs) == 4):
            values = _bind(names_k, args, kwargs)
            return _pinhole(*values)
        values = _bind(names_fov, args, kwargs)
        fov, center, eye, up, width, height = values
        fov = float(fov)
        if not 0.0 < fov < 180.0:
            raise ValueError(f"fov_deg: expected 0 < fov_deg < 180, got {fov}")
        width, height = _size(width, height)
        focal = 0.5 * width / math.tan(math.radians(fov) / 2.0)
        intrinsic = np.array([[focal, 0, 0.5 * width], [0, focal, 0.5 * height], [0, 0, 1]])
        return _pinhole(intrinsic, _look_at(center, eye, up), width, height)


def _bind(names: tuple, args: tuple, kwargs: dict) -> list:
    if len(args) > len(names):
        raise TypeError(f"create_rays_pinhole: expected at most {len(names)} arguments")
    values = dict(zip(names, args))
    for key, value in kwargs.items():
        if key not in names or key in values:
            raise TypeError(f"create_rays_pinhole: unexpected argument {key!r}")
        values[key] = value
    missing = [n for n in names if n not in values]
    if missing:
        raise TypeError(f"create_rays_pinhole: missing {', '.join(missing)}")
    return [values[n] for n in names]


def _size(width: Any, height: Any) -> tuple:
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"width_px, height_px: expected positive integers, got {width}, {height}")
    return int(width), int(height)


def _look_at(center: ArrayLike, eye: ArrayLike, up: ArrayLike) -> np.ndarray:
    """Open3D's world-to-camera matrix for a camera at ``eye`` looking at ``center``: rows
    ``x = up x z``, ``y = z x x``, ``z`` towards the centre (checked against Open3D 0.20)."""
    c, e, u = (np.array(_point(p, n)) for p, n in ((center, "center"), (eye, "eye"), (up, "up")))
    z = c - e
    if not np.linalg.norm(z) > 0:
        raise ValueError("center, eye: the camera must look somewhere (center == eye)")
    z = z / np.linalg.norm(z)
    x = np.cross(u, z)
    if not np.linalg.norm(x) > 0:
        raise ValueError("up: must not be parallel to the viewing direction")
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = np.stack([x, y, z])
    extrinsic[:3, 3] = -extrinsic[:3, :3] @ e
    return extrinsic


def _pinhole(intrinsic: ArrayLike, extrinsic: ArrayLike, width: Any, height: Any) -> np.ndarray:
    k = _float_array(intrinsic, "intrinsic_matrix")
    if k.shape != (3, 3):
        raise ValueError(f"intrinsic_matrix: expected shape (3, 3), got {k.shape}")
    e = _float_array(extrinsic, "extrinsic_matrix")
    if e.shape != (4, 4):
        raise ValueError(f"extrinsic_matrix: expected shape (4, 4), got {e.shape}")
    width, height = _size(width, height)
    try:
        k_inv = np.linalg.inv(k)
        e_inv = np.linalg.inv(e)
    except np.linalg.LinAlgError:
        raise ValueError("intrinsic_matrix, extrinsic_matrix: must be invertible") from None
    # Pixel (column x, row y) is sampled at its centre (x + 0.5, y + 0.5).
    xs, ys = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    pixels = np.stack([xs, ys, np.ones_like(xs)], axis=-1)
    directions = pixels @ k_inv.T @ e_inv[:3, :3].T
    rays = np.empty((height, width, 6), dtype=np.float32)
    rays[..., :3] = e_inv[:3, 3]
    rays[..., 3:] = directions
    return rays


def load(path: Union[str, "os.PathLike[str]"]) -> RaycastingScene:
    """A scene file (the course's JSON format, meshes beside it) as a RaycastingScene, with its
    camera for ``render``."""
    return RaycastingScene._wrap(_raycast.Scene.load(path))
