"""GPU ray casting on any Vulkan, Metal or DX12 GPU, or on Mesa's lavapipe without one.

``raycast.RaycastingScene`` runs code written for Open3D 0.20's
``open3d.t.geometry.RaycastingScene`` unchanged but for the constructor::

    import raycast
    scene = raycast.RaycastingScene()    # instead of o3d.t.geometry.RaycastingScene()
    mesh_id = scene.add_triangles(mesh)  # or add_triangles(vertices, triangles)
    rays = raycast.RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 640, 480)
    ans = scene.cast_rays(rays)          # t_hit, geometry_ids, primitive_ids, ...
    depth = ans["t_hit"].numpy()         # results are NumPy arrays with Open3D's .numpy()

Open3D's queries: ``cast_rays``, ``test_occlusions``, ``count_intersections``,
``list_intersections``, ``compute_closest_points``, ``compute_distance``,
``compute_signed_distance``, ``compute_occupancy`` and ``create_rays_pinhole``, with Open3D's
keywords and defaults (``nthreads`` is accepted and ignored).

Beyond Open3D: spheres and planes (``add_sphere``, ``add_plane``), ``precision="f32" | "f64" |
"adaptive"`` and ``device="gpu" | "cpu"`` on every query, ``sign="parity" | "winding"`` for the
inside tests, ``compute_winding_number``, scene files (``raycast.load``) and their camera
renders (``render``, lit by the course's ray tracer with ``lit=True`` or coloured by a shade
hook file with ``shader=``; ``render_views`` for other cameras or an orbit), ``raycast.info()``
for the adapter, ``raycast.trimesh``, a drop-in for trimesh's ``mesh.ray`` (imported on its
own: ``from raycast.trimesh import RayMeshIntersector``), and ``raycast.distributed``, datasets
of many scenes and views rendered to files on a Ray cluster (with Ray Data: ``pip install
"ray[data]>=2.9"``).

Inputs: arrays are NumPy arrays of any int or float dtype and layout, lists, Open3D tensors,
or anything with ``__array__`` or ``__dlpack__`` (torch, JAX, CuPy...), on the CPU (a GPU
tensor is refused: move it to the CPU first). Meshes are Open3D tensor or legacy triangle
meshes, ``trimesh.Trimesh`` or any object with ``vertices`` and ``faces`` or ``triangles``.
Rays are rows of ``origin, direction`` (shape ``(..., 6)``: float32 and float64 are read as
they are when C-contiguous, others converted once to float64); ``t_hit`` is in units of each
ray's direction, as Open3D's. Query points are shape ``(..., 3)``. Results keep the leading
dimensions of the rays or points (``list_intersections`` flattens them, as Open3D does); float
results are float32 for f32 and adaptive, float64 for f64. Bad input raises ValueError or
TypeError naming the argument. Queries release the GIL. Rays with NaN or infinite coordinates
or a zero direction, and points with NaN or infinite coordinates, get Open3D's answers (a
miss; a nan or inf distance, occupancy 0), as a depth image's invalid pixels need.
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Any, Callable, Dict, Iterator, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import _raycast

__all__ = ["Array", "RaycastingScene", "load", "info"]

# The package's version: python/Cargo.toml's, which maturin gives the wheel too.
__version__: str = _raycast.__version__

# Submodules imported on first use (`__getattr__`).
_SUBMODULES = ("trimesh", "distributed")

# What the array arguments accept: NumPy arrays, lists, Open3D tensors, anything with
# `__array__` or `__dlpack__` (see `_as_numpy`).
ArrayLike = Union[np.ndarray, Sequence[Any], Any]

_PRECISIONS = ("f32", "f64", "adaptive")
_DEVICES = ("gpu", "cpu")
_SIGNS = ("parity", "winding")

# DLPack's device types (dlpack.h) whose memory the CPU reads: kDLCPU and kDLCUDAHost.
_DLPACK_CPU = (1, 3)
_DLPACK_DEVICES = {
    2: "CUDA", 4: "OpenCL", 7: "Vulkan", 8: "Metal", 10: "ROCm", 13: "CUDA managed", 14: "oneAPI"
}


class Array(np.ndarray):
    """A result: a NumPy array that also has Open3D's ``Tensor.numpy()``, so that code written
    for Open3D (``ans["t_hit"].numpy()``) runs unchanged."""

    def numpy(self) -> np.ndarray:
        """The same data as a plain ``np.ndarray`` (a view, not a copy)."""
        return self.view(np.ndarray)


def _result(array: np.ndarray, shape: Tuple[int, ...]) -> Array:
    """A native result reshaped to `shape`, as an `Array`."""
    return np.asarray(array).reshape(shape).view(Array)


def _results(
    out: Dict[str, np.ndarray], shape: Tuple[int, ...], fields: Dict[str, tuple]
) -> Dict[str, Array]:
    """The native results named in `fields`, each shaped `shape` plus its trailing dimensions."""
    return {key: _result(out[key], shape + tail) for key, tail in fields.items()}


# The trailing dimensions of the results of a cast, a closest-point query and a list of hits.
_IDS = {"geometry_ids": (), "primitive_ids": (), "primitive_uvs": (2,)}
_HIT_FIELDS = {"t_hit": (), **_IDS, "primitive_normals": (3,)}
_CLOSEST_FIELDS = {"points": (3,), **_IDS, "primitive_normals": (3,)}
_LIST_FIELDS = {"ray_ids": (), "t_hit": (), **_IDS}

_INVALID_ID = 4294967295

# What Open3D 0.20 answers for a ray with a NaN or infinite coordinate or a zero direction,
# which the library refuses: a miss (python/tests/data/make_open3d_invalid.py records it).
_MISS = {
    "t_hit": math.inf,
    "geometry_ids": _INVALID_ID,
    "primitive_ids": _INVALID_ID,
    "primitive_uvs": 0.0,
    "primitive_normals": 0.0,
}
# A closest-point query's answer at a NaN or infinite point: Open3D's ids and distance (nan,
# or inf where no coordinate is NaN: set by `_closest`); its point, uvs and normal are
# whatever memory held, so raycast gives a NaN point and a miss's zeros.
_NO_SURFACE = {
    "points": math.nan,
    "distance": math.nan,
    "geometry_ids": _INVALID_ID,
    "primitive_ids": _INVALID_ID,
    "primitive_uvs": 0.0,
    "primitive_normals": 0.0,
}


# The numbers a row of each result has.
_ROW_SIZES = {key: math.prod(tail) for key, tail in {**_HIT_FIELDS, **_CLOSEST_FIELDS}.items()}


class _Rows(NamedTuple):
    """Rays or query points as the library takes them: `flat`, (n, 6) or (n, 3), the leading
    `shape` they were given in (the results'), the argument's `name`, and `valid`, the
    indices of the rows the library is asked about (None: all of them). The others hold NaN
    or infinity (or a zero direction), which the library refuses and Open3D answers without
    a surface (a miss, a nan distance...)."""

    flat: np.ndarray
    shape: Tuple[int, ...]
    name: str
    valid: Optional[np.ndarray]

    def query(self, query: Any, *args: Any) -> Any:
        """``query(rows, *args)`` of the valid rows. The library's error naming one of them
        (``points[k]: ...``) names it as it was given (``query_points[i, j]: ...``)."""
        try:
            return query(self.flat if self.valid is None else self.flat[self.valid], *args)
        except ValueError as e:
            row = re.match(r"\w+\[(\d+)\]", str(e))
            if row is None:
                raise
            k = int(row.group(1)) if self.valid is None else int(self.valid[int(row.group(1))])
            index = ", ".join(str(int(i)) for i in np.unravel_index(k, self.shape))
            name = f"{self.name}[{index}]" if self.shape else self.name
            raise ValueError(name + str(e)[row.end() :]) from None

    def spread(self, values: Any, fill: Any, key: str = "") -> Any:
        """The flat results `values` of the valid rows as those of every row (`values`
        itself where all are valid), each other row's numbers `fill` (`_ROW_SIZES[key]`
        numbers a row, 1 for other keys)."""
        if self.valid is None:
            return values
        values = np.asarray(values)
        size = _ROW_SIZES.get(key, 1)
        whole = np.full((len(self.flat), size), fill, dtype=values.dtype)
        whole[self.valid] = values.reshape(len(self.valid), size)
        return whole.reshape(-1)

    def spread_each(self, results: Mapping[str, Any], fills: Mapping[str, Any]) -> Mapping:
        """`spread` of each of the native `results` named in `fills`, with its fill."""
        if self.valid is None:
            return results
        return {key: self.spread(results[key], fill, key) for key, fill in fills.items()}


def __getattr__(name: str) -> Any:
    """``raycast.trimesh`` and ``raycast.distributed`` imported on first use, so that ``import
    raycast`` needs neither trimesh nor Ray and costs nothing for those who do not use them."""
    if name in _SUBMODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> List[str]:
    """The package's public names, its submodules and its dunders (``__version__``...): not
    the modules and typing names its code imports (``np``, ``os``, ``Any``...), which ``from
    raycast import *`` leaves out too (``__all__``)."""
    dunders = [name for name in globals() if name.startswith("__") and name.endswith("__")]
    return sorted({*__all__, *_SUBMODULES, *dunders})


def info() -> Dict[str, Any]:
    """The GPU adapter raycast runs on: name, backend, driver, device type, f64, subgroups."""
    return _raycast.info()


def _device_of(value: Any) -> Optional[str]:
    """The device whose memory holds `value`, if it is not the CPU's: from DLPack's
    ``__dlpack_device__``, or an Open3D-like tensor's ``device`` ("CPU:0", "CUDA:0")."""
    dlpack_device = getattr(value, "__dlpack_device__", None)
    if callable(dlpack_device):
        kind = dlpack_device()[0]
        try:
            code = int(kind)
        except (TypeError, ValueError):  # an enum without __int__: go by its name
            return None if "cpu" in str(kind).lower() else str(kind)
        if code in _DLPACK_CPU:
            return None
        return _DLPACK_DEVICES.get(code, f"DLPack device type {code}")
    device = getattr(value, "device", None)
    if callable(getattr(value, "numpy", None)) and device is not None and not callable(device):
        return None if str(device).lower().startswith("cpu") else str(device)
    return None


def _as_numpy(value: Any, name: str) -> np.ndarray:
    """`value` as a NumPy array, without a copy where it can be read in place: NumPy arrays,
    lists, anything with ``__array__`` (torch, trimesh), Open3D tensors (``.numpy()``) and
    anything else with ``__dlpack__``. Tensors on a GPU are refused (ValueError)."""
    if isinstance(value, np.ndarray):
        return value
    device = _device_of(value)
    if device is not None:
        # NumPy cannot read it, and copying it here would hide a costly transfer.
        raise ValueError(f"{name}: is on a {device} device; move it to the CPU first (.cpu())")
    try:
        if hasattr(value, "__array__"):
            return np.asarray(value)
        to_numpy = getattr(value, "numpy", None)
        if callable(to_numpy):  # Open3D tensors, which have no __array__
            return np.asarray(to_numpy())
        if hasattr(value, "__dlpack__"):
            return np.from_dlpack(value)
        return np.asarray(value)
    except Exception as e:  # ragged lists, tensors that need grad, unreadable DLPack capsules
        raise ValueError(f"{name}: cannot be read as an array ({e})") from None


def _numeric(array: np.ndarray, name: str) -> None:
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)
    ):
        raise TypeError(f"{name}: expected an array of numbers, got dtype {array.dtype}")


def _float_array(
    value: ArrayLike, name: str, last: Optional[int] = None, keep_float32: bool = False
) -> np.ndarray:
    """`value` as a C-contiguous float64 array (float32 kept with `keep_float32`), its last
    dimension `last` where given."""
    array = _as_numpy(value, name)
    _numeric(array, name)
    if last is not None and (array.ndim == 0 or array.shape[-1] != last):
        raise ValueError(f"{name}: expected shape (..., {last}), got {array.shape}")
    keep = keep_float32 and array.dtype == np.float32
    return np.ascontiguousarray(array, dtype=np.float32 if keep else np.float64)


def _ray_rows(rays: ArrayLike) -> _Rows:
    """The rays as `_Rows` of an (n, 6) float32 or float64 array (float32 is read as it is:
    widening a copy of 2M rays took 0.02 s of a 0.35 s cast), not yet scanned for invalid
    ones (`valid` None)."""
    array = _float_array(rays, "rays", 6, keep_float32=True)
    return _Rows(array.reshape(-1, 6), array.shape[:-1], "rays", None)


def _rays(rays: ArrayLike) -> _Rows:
    """The rays as `_Rows`, valid where finite with a direction not zero."""
    rows = _ray_rows(rays)
    return rows._replace(valid=_valid(_raycast.invalid_rays(rows.flat)))


def _each_ray(rays: ArrayLike, query: Callable[[_Rows, Optional[int]], Any]) -> Tuple[_Rows, Any]:
    """`query(rows, width)` of the rays, asked first of every ray with no scan for invalid ones
    (a valid array, the common case, then costs none) and the width of the image they are rows
    of where they have two leading dimensions or more (the GPU then traces tiles of
    neighbouring rows together, as it does a camera's); where the library refuses a ray that
    Open3D answers as a miss, asked again of the valid rays alone, as a list."""
    rows = _ray_rows(rays)
    shape = rows.shape
    try:
        return rows, query(rows, shape[-1] if len(shape) >= 2 and shape[-1] > 0 else None)
    except ValueError:
        valid = _valid(_raycast.invalid_rays(rows.flat))
        if valid is None:
            raise
        rows = rows._replace(valid=valid)
        return rows, query(rows, None)


def _query_points(query_points: ArrayLike) -> _Rows:
    """The points as `_Rows` of a C-contiguous (n, 3) float64 array, valid where finite."""
    array = _float_array(query_points, "query_points", 3)
    flat = array.reshape(-1, 3)
    return _Rows(flat, array.shape[:-1], "query_points", _valid(_raycast.invalid_points(flat)))


def _valid(invalid: Optional[np.ndarray]) -> Optional[np.ndarray]:
    """The indices of the rows not `invalid` (a mask from `_raycast.invalid_rays` or
    `invalid_points`, None where no row is)."""
    return None if invalid is None else np.flatnonzero(~invalid)


def _options(precision: Optional[str], device: str, render: bool = False) -> None:
    # A render may leave the precision to the command line's default (None).
    if not (render and precision is None) and precision not in _PRECISIONS:
        raise ValueError(f"precision: expected one of {', '.join(_PRECISIONS)}, got {precision!r}")
    if device not in _DEVICES:
        raise ValueError(f"device: expected one of {', '.join(_DEVICES)}, got {device!r}")


def _inside_options(nsamples: Any, sign: str) -> int:
    """`nsamples` checked by Open3D's rule (a positive odd count of rays, so that a majority
    vote has no ties) and `sign` one of the inside tests."""
    if (
        isinstance(nsamples, bool)
        or not isinstance(nsamples, (int, np.integer))
        or nsamples < 1
        or nsamples % 2 == 0
    ):
        raise ValueError(f"nsamples: expected a positive odd integer, got {nsamples!r}")
    if sign not in _SIGNS:
        raise ValueError(f"sign: expected one of {', '.join(_SIGNS)}, got {sign!r}")
    return int(nsamples)


def _float_dtype(precision: str) -> type:
    return np.float64 if precision == "f64" else np.float32


def _point(value: ArrayLike, name: str) -> list:
    array = _float_array(value, name)
    if array.shape != (3,):
        raise ValueError(f"{name}: expected 3 numbers, got shape {array.shape}")
    return [float(x) for x in array]


def _mesh_arrays(mesh: Any) -> Tuple[Any, Any]:
    """A mesh object's vertex positions and triangle indices: an Open3D tensor mesh
    (``vertex["positions"]``, ``triangle["indices"]``), a legacy Open3D mesh or any object
    with ``vertices`` and ``triangles``, or a ``trimesh.Trimesh`` (``vertices``, ``faces``;
    its ``triangles`` are corner positions, so ``faces`` is asked first)."""
    if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):
        try:
            return mesh.vertex["positions"], mesh.triangle["indices"]
        except (KeyError, IndexError, TypeError):
            # An Open3D mesh without triangles has no "indices" at all.
            raise ValueError("mesh triangles: the mesh has no triangles") from None
    for indices in ("faces", "triangles"):
        if hasattr(mesh, "vertices") and hasattr(mesh, indices):
            return mesh.vertices, getattr(mesh, indices)
    raise TypeError(
        "mesh: expected an Open3D or trimesh triangle mesh, or vertices and triangles arrays, "
        f"got {type(mesh).__name__}"
    )


def _geometry_id(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name}: expected a geometry id (an integer), got {type(value).__name__}")
    if not 0 <= int(value) < _INVALID_ID:
        raise ValueError(f"{name}: {int(value)} is not a geometry id")
    return int(value)


def _transforms(value: ArrayLike, name: str, count: Optional[int]) -> np.ndarray:
    """4x4 or 3x4 row-major affine matrices (one, where `count` is 1) as an (n, 16) float64
    array, 3x4 ones completed by the row [0, 0, 0, 1]."""
    m = _float_array(value, name)
    shape = m.shape[1:] if count is None else m.shape
    if m.ndim != (3 if count is None else 2) or shape not in ((4, 4), (3, 4)):
        expected = "(4, 4) or (3, 4)" if count == 1 else "(n, 4, 4) or (n, 3, 4)"
        raise ValueError(f"{name}: expected shape {expected}, got {m.shape}")
    m = m.reshape((-1,) + shape)
    if shape == (3, 4):
        last = np.broadcast_to(np.array([0.0, 0.0, 0.0, 1.0]), (len(m), 1, 4))
        m = np.concatenate([m, last], axis=1)
    return np.ascontiguousarray(m.reshape(len(m), 16))


def _triangle_indices(triangles: ArrayLike, vertex_count: int, name: str) -> np.ndarray:
    """`triangles` as a C-contiguous (M, 3) uint32 array of indices below `vertex_count`."""
    t = _as_numpy(triangles, name)
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (M, 3), got {t.shape}")
    if len(t) == 0:
        raise ValueError(f"{name}: the mesh has no triangles")
    if not np.issubdtype(t.dtype, np.integer):
        if not np.issubdtype(t.dtype, np.floating) or not np.all(t == np.floor(t)):
            raise TypeError(f"{name}: expected integer indices, got dtype {t.dtype}")
    if t.min() < 0 or t.max() >= vertex_count:
        bad = int(t.min()) if t.min() < 0 else int(t.max())
        raise ValueError(f"{name}: index {bad} is out of range ({vertex_count} vertices)")
    return np.ascontiguousarray(t, dtype=np.uint32)


class RaycastingScene:
    """Objects to cast rays at and measure distances to: triangle meshes, spheres and planes
    (Open3D's ``RaycastingScene``, plus spheres, planes, precision and device)."""

    INVALID_ID: int = _INVALID_ID

    def __init__(self) -> None:
        self._scene = _raycast.Scene()

    @classmethod
    def _wrap(cls, native: "_raycast.Scene") -> "RaycastingScene":
        scene = cls.__new__(cls)
        scene._scene = native
        return scene

    def add_triangles(
        self,
        vertices: Any = None,
        triangles: Optional[ArrayLike] = None,
        *,
        mesh: Any = None,
        vertex_positions: Optional[ArrayLike] = None,
        triangle_indices: Optional[ArrayLike] = None,
    ) -> int:
        """Adds a triangle mesh; returns its geometry id (its triangles' indices are the
        primitive ids). Either ``add_triangles(vertices, triangles)`` (``vertices`` (N, 3)
        positions, ``triangles`` (M, 3) vertex indices; Open3D's keywords ``vertex_positions``
        and ``triangle_indices`` too) or ``add_triangles(mesh)``: an Open3D tensor or legacy
        ``TriangleMesh``, a ``trimesh.Trimesh``, or any object with ``vertices`` and ``faces``
        or ``triangles``. Raises ValueError on NaN or infinite positions, out-of-range
        indices and a mesh without triangles, TypeError on indices that are not integers."""
        if vertex_positions is not None or triangle_indices is not None:
            if vertices is not None or triangles is not None or mesh is not None:
                raise TypeError("add_triangles: give vertex_positions and triangle_indices alone")
            vertices, triangles = vertex_positions, triangle_indices
        if mesh is not None and (vertices is not None or triangles is not None):
            raise TypeError("add_triangles: give a mesh or vertices and triangles, not both")
        if triangles is None:
            mesh = vertices if mesh is None else mesh
            if mesh is None:
                raise TypeError("add_triangles: missing the mesh, or vertices and triangles")
            vertices, triangles = _mesh_arrays(mesh)
            names = ("mesh vertices", "mesh triangles")
        else:
            names = ("vertices", "triangles")
        v = _float_array(vertices, names[0], 3)
        if v.ndim != 2:
            raise ValueError(f"{names[0]}: expected shape (N, 3), got {v.shape}")
        t = _triangle_indices(triangles, len(v), names[1])
        return self._scene.add_mesh(v, t)

    def add_sphere(self, center: ArrayLike, radius: float) -> int:
        """Adds a sphere; returns its geometry id (not in Open3D)."""
        return self._scene.add_sphere(_point(center, "center"), float(radius))

    def add_plane(self, point: ArrayLike, normal: ArrayLike) -> int:
        """Adds an infinite plane through ``point`` facing ``normal``; returns its geometry id
        (not in Open3D)."""
        return self._scene.add_plane(_point(point, "point"), _point(normal, "normal"))

    def add_instance(self, mesh: int, transform: ArrayLike) -> int:
        """Places another copy of mesh ``mesh`` (a geometry id ``add_triangles`` returned, or a
        loaded scene's mesh or instance) by ``transform``, a 4x4 (or 3x4) matrix, row-major,
        from the mesh's own coordinates to the world's; returns its geometry id. The copies
        share the mesh's one tree, built once however many place it and however often they
        move (not in Open3D). Raises ValueError on a singular or non-finite transform, or a
        ``mesh`` that is not a triangle mesh."""
        return self._scene.add_instance(_geometry_id(mesh, "mesh"), _transforms(transform, "transform", 1))

    def set_transforms(self, ids: ArrayLike, transforms: ArrayLike) -> None:
        """Moves the instances ``ids`` (ids ``add_instance`` returned, or a loaded scene's
        instances) to ``transforms``, (n, 4, 4) or (n, 3, 4), one each, each from its mesh's
        own coordinates; the next cast or render uses them without building the meshes' trees
        again. A loaded scene's ``render`` shows its own instances where they are moved to
        (objects added after loading are cast at, not rendered). Nothing moves if any is
        refused (ValueError)."""
        id_array = _as_numpy(ids, "ids")
        if id_array.ndim != 1:
            raise ValueError(f"ids: expected shape (n,), got {id_array.shape}")
        if len(id_array) and not np.issubdtype(id_array.dtype, np.integer):
            raise TypeError(f"ids: expected integer ids, got dtype {id_array.dtype}")
        if len(id_array) and (id_array.min() < 0 or id_array.max() > 2**32 - 2):
            raise ValueError(f"ids: {int(id_array.min())} is not a geometry id")
        m = _transforms(transforms, "transforms", None)
        if len(m) != len(id_array):
            raise ValueError(f"transforms: gives {len(m)} transforms for {len(id_array)} ids: one each")
        self._scene.set_transforms([int(i) for i in id_array], m)

    def cast_rays(
        self, rays: ArrayLike, nthreads: int = 0, precision: str = "f32", device: str = "gpu"
    ) -> Dict[str, Array]:
        """The nearest hit of each ray (``t >= 0``): a dict of ``t_hit`` (inf on a miss),
        ``geometry_ids`` and ``primitive_ids`` (uint32, ``INVALID_ID`` on a miss),
        ``primitive_uvs`` (..., 2) and ``primitive_normals`` (..., 3), with the rays'
        leading dimensions. float32 for f32 and adaptive, float64 for f64. ``nthreads`` is
        accepted for Open3D compatibility and ignored. A ray with a NaN or infinite
        coordinate or a zero direction misses, as in Open3D (uvs and normals 0)."""
        _options(precision, device)
        rows, out = _each_ray(rays, lambda r, w: r.query(self._scene.intersect, w, precision, device))
        return _results(rows.spread_each(out, _MISS), rows.shape, _HIT_FIELDS)

    def test_occlusions(
        self,
        rays: ArrayLike,
        tnear: float = 0.0,
        tfar: float = math.inf,
        nthreads: int = 0,
        precision: str = "f32",
        device: str = "gpu",
    ) -> Array:
        """Whether each ray hits anything with ``tnear <= t <= tfar`` (bool, the rays' leading
        shape; False for the rays ``cast_rays`` misses as invalid). ``nthreads`` is accepted
        for Open3D compatibility and ignored."""
        _options(precision, device)
        t_range = (float(tnear), float(tfar))
        occluded = self._scene.occluded
        rows, hit = _each_ray(rays, lambda r, w: r.query(occluded, w, t_range, precision, device))
        return _result(rows.spread(hit, False), rows.shape)

    def count_intersections(
        self, rays: ArrayLike, nthreads: int = 0, precision: str = "f32", device: str = "gpu"
    ) -> Array:
        """How many surfaces each ray crosses (``t >= 0``; int32, the rays' leading shape),
        as Open3D counts them: a mesh's triangles once each, a crossing through an edge or
        corner that triangles of one mesh share once (so that an odd count means the ray
        started inside a closed mesh), a sphere twice from outside and once from inside.
        Counted by the CPU reference, from ``list_intersections``'s hits; 0 for the rays
        ``cast_rays`` misses as invalid."""
        _options(precision, device)
        rows = _rays(rays)
        splits = self._list_intersections(rows, precision, device)["ray_splits"]
        return _result(np.diff(splits.astype(np.int64)).astype(np.int32), rows.shape)

    def list_intersections(
        self, rays: ArrayLike, nthreads: int = 0, precision: str = "f32", device: str = "gpu"
    ) -> Dict[str, Array]:
        """Every hit of every ray (``t >= 0``), as Open3D lists them: the rays are flattened
        (ray ``i`` is row ``i`` of ``rays.reshape(-1, 6)``) and the hits of ray ``i`` are
        entries ``ray_splits[i]:ray_splits[i + 1]`` of ``ray_ids``, ``t_hit``,
        ``geometry_ids``, ``primitive_ids`` (uint32) and ``primitive_uvs`` (k, 2), nearest
        first. ``ray_splits`` (uint32) has one entry more than there are rays. The rays
        ``cast_rays`` misses as invalid have no hits."""
        _options(precision, device)
        rows = _rays(rays)
        out = self._list_intersections(rows, precision, device)
        results = {"ray_splits": _result(out["ray_splits"], (-1,))}
        results.update(_results(out, (-1,), _LIST_FIELDS))
        return results

    def _list_intersections(self, rows: _Rows, precision: str, device: str) -> Mapping:
        """The native ``list_intersections`` of the valid rays, as those of every ray: the
        others have no hits."""
        out = rows.query(self._scene.every_hit, precision, device)
        if rows.valid is None:
            return out
        counts = rows.spread(np.diff(out["ray_splits"].astype(np.int64)), 0)
        splits = np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)
        ray_ids = rows.valid[out["ray_ids"]].astype(np.uint32)
        return {**out, "ray_splits": splits, "ray_ids": ray_ids}

    def compute_closest_points(
        self,
        query_points: ArrayLike,
        nthreads: int = 0,
        precision: str = "f32",
        device: str = "gpu",
    ) -> Dict[str, Array]:
        """The closest point on the scene's surfaces to each query point (shape (..., 3)): a
        dict of ``points`` (..., 3), ``geometry_ids`` and ``primitive_ids`` (uint32;
        ``INVALID_ID`` where the scene is empty), ``primitive_uvs`` (..., 2, the point's
        barycentric coordinates in its triangle) and ``primitive_normals`` (..., 3), with the
        points' leading dimensions. float32 for f32 and adaptive, float64 for f64. At a point
        with a NaN or infinite coordinate the ids are ``INVALID_ID``, as in Open3D, the point
        NaN, uvs and normal 0 (Open3D's are undefined there)."""
        _options(precision, device)
        rows = _query_points(query_points)
        return _results(self._closest(rows, precision, device), rows.shape, _CLOSEST_FIELDS)

    def compute_distance(
        self,
        query_points: ArrayLike,
        nthreads: int = 0,
        precision: str = "f32",
        device: str = "gpu",
    ) -> Array:
        """The distance from each query point (shape (..., 3)) to the nearest surface, with
        the points' leading dimensions: as in Open3D, nan at a point with a NaN coordinate,
        inf at one with an infinite coordinate and no NaN."""
        _options(precision, device)
        rows = _query_points(query_points)
        return _result(self._closest(rows, precision, device)["distance"], rows.shape)

    def _closest(self, rows: _Rows, precision: str, device: str) -> Mapping:
        """The native closest-point query at the valid points, with Open3D's answers
        (`_NO_SURFACE`) at the others."""
        out = rows.query(self._scene.closest, precision, device)
        if rows.valid is None:
            return out
        out = rows.spread_each(out, _NO_SURFACE)
        # Open3D's distance from the point to a finite one: inf, unless a coordinate is NaN.
        far = np.ones(len(rows.flat), dtype=bool)
        far[rows.valid] = False
        out["distance"][far & ~np.isnan(rows.flat).any(axis=1)] = math.inf
        return out

    def compute_signed_distance(
        self,
        query_points: ArrayLike,
        nthreads: int = 0,
        nsamples: int = 1,
        sign: str = "parity",
        precision: str = "f32",
        device: str = "gpu",
    ) -> Array:
        """The distance from each query point to the nearest surface, negative inside (see
        ``compute_occupancy`` for ``nsamples`` and ``sign``), with the points' leading
        dimensions; at a point with a NaN or infinite coordinate, ``compute_distance``'s
        nan or inf, as in Open3D."""
        rows, inside = self._inside(query_points, nsamples, sign, precision, device)
        distance = self._closest(rows, precision, device)["distance"]
        return _result(np.where(inside, -distance, distance), rows.shape)

    def compute_occupancy(
        self,
        query_points: ArrayLike,
        nthreads: int = 0,
        nsamples: int = 1,
        sign: str = "parity",
        precision: str = "f32",
        device: str = "gpu",
    ) -> Array:
        """1.0 where a query point is inside the scene's closed surfaces, 0.0 outside (float32
        as Open3D's, float64 for f64), with the points' leading dimensions.

        ``sign="parity"`` (Open3D's test, along Open3D 0.20's directions, each within 0.001
        of (1, 1, 1)) counts the surfaces a ray from the point crosses: odd is inside.
        ``nsamples`` (a positive odd number) rays in different directions vote, for points
        whose ray passes within rounding of an edge. It assumes closed meshes that do not
        intersect each other. ``sign="winding"`` (not in Open3D) is inside where the
        generalized winding number (``compute_winding_number``) is over 0.5: right for
        meshes with holes, overlapping parts or doubled faces where parity fails; it ignores
        ``nsamples``. A point with a NaN or infinite coordinate is outside (0.0), as in
        Open3D."""
        rows, inside = self._inside(query_points, nsamples, sign, precision, device)
        return _result(inside.astype(_float_dtype(precision)), rows.shape)

    def _inside(
        self, query_points: ArrayLike, nsamples: Any, sign: str, precision: str, device: str
    ) -> Tuple[_Rows, np.ndarray]:
        """The query points and whether each is inside (``compute_occupancy``'s rules; a
        point that is not valid is not), every argument checked first."""
        _options(precision, device)
        nsamples = _inside_options(nsamples, sign)
        rows = _query_points(query_points)
        inside = rows.query(self._scene.inside, sign, nsamples, precision, device)
        return rows, rows.spread(inside, False)

    def compute_winding_number(
        self,
        query_points: ArrayLike,
        nthreads: int = 0,
        precision: str = "f32",
        device: str = "gpu",
    ) -> Array:
        """The generalized winding number of the scene at each query point (not in Open3D;
        float64, the points' leading dimensions): the solid angle the triangles subtend seen
        from the point over 4 pi, positive where a triangle's normal (by its corner order)
        faces away. 1 inside and 0 outside a closed mesh whose normals face out, and in
        between near holes, so that a threshold at 0.5 tells the sides of meshes that are
        not closed apart (Jacobson et al., "Robust Inside-Outside Segmentation using
        Generalized Winding Numbers", 2013). A sphere counts 1 inside, a plane 1 behind its
        normal. Computed on the CPU in f64 whatever ``precision`` and ``device`` say:
        exactly for the triangles near the point, by the dipoles of far groups of them
        (Barill et al. 2018). NaN at a point with a NaN or infinite coordinate."""
        _options(precision, device)
        rows = _query_points(query_points)
        winding = rows.query(self._scene.winding_numbers, precision, device)
        return _result(rows.spread(winding, math.nan), rows.shape)

    def render(
        self,
        precision: Optional[str] = None,
        device: str = "gpu",
        lit: bool = False,
        shader: Optional[Union[str, os.PathLike]] = None,
        size: Optional[Sequence[int]] = None,
    ) -> Dict[str, Any]:
        """The scene file's camera rendered (scenes from ``raycast.load``): ``id`` (int32,
        -1 on a miss), ``distance`` (inf on a miss) and ``normal`` (..., 3) images, rows from
        the top, as the command line's npy files hold them. ``size`` ``(width, height)`` in
        pixels replaces the camera's resolution, as the command line's ``--size`` does.

        With ``lit=True`` (the course's ray tracer from the scene's materials and lights, the
        hook shaders/examples/raytrace.wgsl on the GPU, its mirror on the CPU) or a shade hook
        file ``shader`` (GPU), also ``color`` (uint8 RGBA, (..., 4)) and ``hook_rays``, the
        rays the hook cast (None where it casts none).

        ``precision`` None renders as the command line does by default: on the GPU adaptive
        (f32 with a hook), on the CPU f64."""
        _options(precision, device, render=True)
        return self._render(precision, device, lit, shader, None, _image_size(size))

    def render_views(
        self,
        cameras: Union[int, Sequence[Mapping[str, Any]]],
        precision: Optional[str] = None,
        device: str = "gpu",
        lit: bool = False,
        shader: Optional[Union[str, os.PathLike]] = None,
        *,
        orbit_radius: Optional[float] = None,
        orbit_elevation: Optional[float] = None,
    ) -> Iterator[Dict[str, Any]]:
        """The scene (from ``raycast.load``) rendered from each of ``cameras``, one view at a
        time: an iterator of dicts as ``render`` returns them, each with the view's ``name``.

        ``cameras`` is a list of cameras in the scene format's forms (docs/scene-format.md:
        ``eye``, ``look`` or ``look_at``, ``up``, then ``focal_length``, ``width`` and
        ``height``, or ``fov``, or ``intrinsics``; ``resolution``, ``near``, ``type``), each
        with an optional ``name`` (default ``view-000``, ``view-001``, ...), as a views file
        lists them; numbers may be NumPy values or arrays. Or a number N: N views around the
        scene (``orbit-000``, ...), as ``raycast render --orbit N`` renders them, the eye
        ``orbit_radius`` from the centre and ``orbit_elevation`` degrees above the turntable
        where given (``--orbit-radius``, ``--orbit-elevation``; docs/datasets.md#orbits). A view
        renders what ``render`` renders for a scene file with that camera. Every camera is
        checked before the first view renders: a bad one raises ValueError (or TypeError)
        naming it (``cameras[2]: camera.fov: ...``). A thread renders the next view while the
        caller takes the last (one view ahead, no more); a view whose render fails raises
        when the iteration reaches it, and ends the views."""
        _options(precision, device, render=True)
        # here, not at the first view: bad cameras raise now
        views = self._views(cameras, orbit_radius, orbit_elevation)
        return self._render_each(views, precision, device, lit, shader)

    def _render_each(
        self,
        views: List[Tuple[str, Any]],
        precision: Optional[str],
        device: str,
        lit: bool,
        shader: Optional[Union[str, os.PathLike]],
    ) -> Iterator[Dict[str, Any]]:
        # a thread renders the next view while this one is taken
        cameras = [camera for _, camera in views]
        shader = None if shader is None else os.fspath(shader)
        stream = self._scene.render_each(precision, device, cameras, lit, shader)
        for (name, _), out in zip(views, stream):
            images = self._images(out)
            images["name"] = name
            yield images

    def _views(
        self,
        cameras: Any,
        orbit_radius: Optional[float] = None,
        orbit_elevation: Optional[float] = None,
    ) -> List[Tuple[str, Any]]:
        """The named native cameras of `cameras`, every one checked here, before anything
        renders: an orbit's, or those of a list of camera dicts as a views file lists them."""
        orbit = {"orbit_radius": orbit_radius, "orbit_elevation": orbit_elevation}
        for name, value in orbit.items():
            number = isinstance(value, (int, float, np.integer, np.floating))
            if value is not None and (isinstance(value, (bool, np.bool_)) or not number):
                raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
        if isinstance(cameras, (int, np.integer)) and not isinstance(cameras, (bool, np.bool_)):
            n = int(cameras)
            if not 1 <= n < 2**32:
                raise ValueError(f"cameras: expected at least 1 orbit view, got {n}")
            numbers = {k: None if v is None else float(v) for k, v in orbit.items()}
            return self._scene.views(orbit=n, **numbers)
        given = [name for name, value in orbit.items() if value is not None]
        if given:
            raise ValueError(f"{given[0]}: sets an orbit's views; give cameras as a number of views")
        if isinstance(cameras, (str, bytes, Mapping)) or not isinstance(cameras, Sequence):
            raise TypeError(
                "cameras: expected a list of camera dicts or a number of orbit views, got "
                f"{type(cameras).__name__}"
            )
        named = []
        for k, camera in enumerate(cameras):
            label = f"cameras[{k}]"
            if not isinstance(camera, Mapping):
                raise TypeError(f"{label}: expected a dict of camera fields, got {type(camera).__name__}")
            fields = dict(camera)
            fields.setdefault("name", f"view-{k:03d}")
            if not isinstance(fields["name"], str):
                raise TypeError(f"{label}.name: expected a string, got {type(fields['name']).__name__}")
            try:
                named.append(json.dumps(fields, default=_json_value, allow_nan=False))
            except ValueError:  # NaN or infinity, which JSON cannot hold
                raise ValueError(f"{label}: expected finite numbers") from None
            except TypeError as e:
                raise TypeError(f"{label}: {e}") from None
        return self._scene.views(cameras="[" + ",".join(named) + "]")

    def _render(
        self,
        precision: Optional[str],
        device: str,
        lit: bool,
        shader: Optional[Union[str, os.PathLike]],
        camera: Any,
        size: Optional[List[int]] = None,
    ) -> Dict[str, Any]:
        out = self._scene.render(
            precision, device, lit, None if shader is None else os.fspath(shader), camera, size
        )
        return self._images(out)

    @staticmethod
    def _images(out: Dict[str, Any]) -> Dict[str, Any]:
        """A native render's flat arrays shaped as images."""
        shape = (out["height"], out["width"])
        fields = {"id": (), "distance": (), "normal": (3,), "color": (4,)}
        images: Dict[str, Any] = _results(out, shape, {k: fields[k] for k in fields if k in out})
        if "hook_rays" in out:
            images["hook_rays"] = out["hook_rays"]
        return images

    @staticmethod
    def create_rays_pinhole(*args: Any, **kwargs: Any) -> Array:
        """Rays of a pinhole camera, shape (height_px, width_px, 6) float32, as Open3D makes
        them: ``create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px)`` (fov
        horizontal, looking from ``eye`` at ``center``) or ``create_rays_pinhole(
        intrinsic_matrix, extrinsic_matrix, width_px, height_px)`` (3x3 pixel intrinsics, 4x4
        world-to-camera). Directions are not normalised: t_hit is the camera's z depth."""
        names_fov = ("fov_deg", "center", "eye", "up", "width_px", "height_px")
        names_k = ("intrinsic_matrix", "extrinsic_matrix", "width_px", "height_px")
        if "intrinsic_matrix" in kwargs or (len(args) + len(kwargs) == 4):
            values = _bind(names_k, args, kwargs)
            return _pinhole(*values).view(Array)
        values = _bind(names_fov, args, kwargs)
        fov, center, eye, up, width, height = values
        fov = float(fov)
        if not 0.0 < fov < 180.0:
            raise ValueError(f"fov_deg: expected 0 < fov_deg < 180, got {fov}")
        width, height = _size(width, height)
        focal = 0.5 * width / math.tan(math.radians(fov) / 2.0)
        intrinsic = np.array([[focal, 0, 0.5 * width], [0, focal, 0.5 * height], [0, 0, 1]])
        return _pinhole(intrinsic, _look_at(center, eye, up), width, height).view(Array)


def _json_value(value: Any) -> Any:
    """NumPy arrays and numbers in a camera dict as the lists and numbers JSON writes."""
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    raise TypeError(f"expected numbers and lists, got {type(value).__name__}")


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


def _image_size(size: Any) -> Optional[List[int]]:
    """`size` as the command line's ``--size WxH`` takes it: None, or ``(width, height)``,
    two integers of at least 1 (a u32 each)."""
    if size is None:
        return None
    if isinstance(size, (str, bytes, Mapping)) or not isinstance(size, (Sequence, np.ndarray)):
        raise TypeError(f"size: expected (width, height), got {type(size).__name__}")
    if len(size) != 2:
        raise ValueError(f"size: expected (width, height), got {len(size)} numbers")
    for n in size:
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
            raise TypeError(f"size: expected integers (width, height), got {n!r}")
    width, height = (int(n) for n in size)
    if not (1 <= width < 2**32 and 1 <= height < 2**32):
        got = f"({width}, {height})"
        raise ValueError(f"size: expected (width, height) of at least 1 each, got {got}")
    return [width, height]


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
