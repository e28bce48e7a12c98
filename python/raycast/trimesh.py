"""A drop-in for trimesh's ``mesh.ray``, casting with raycast::

    import trimesh
    from raycast.trimesh import RayMeshIntersector

    mesh = trimesh.load("bunny.stl")
    mesh.ray = RayMeshIntersector(mesh)
    mesh.contains(points)                       # and trimesh.proximity, mesh.voxelized(...)
    index_tri, index_ray, locations = mesh.ray.intersects_id(
        origins, directions, return_locations=True)

``RayMeshIntersector`` has the methods and return conventions of trimesh's own intersectors
(``trimesh.ray.ray_triangle`` and ``trimesh.ray.ray_pyembree``): triangle and ray indices as
int64, locations as float64, a miss as -1. It casts on a ``raycast.RaycastingScene`` holding
the mesh (primitive ids are face indices), rebuilt when the mesh's vertices or faces change.

Where it differs from trimesh's:

- ``contains_points`` uses the generalized winding number, not the parity of ray hits: right
  for meshes with holes, doubled faces or overlapping parts, where parity is wrong, and it
  never depends on which way a ray happens to go past an edge. A mesh whose normals point
  inwards has winding number -1 inside, so it contains nothing (trimesh's parity test does
  not look at normals).
- Multiple hits are every crossing with ``t >= 0``, in order along each ray, found in one
  query rather than by restarting rays past each hit (trimesh's embree intersector) or by
  tolerances (its pure-Python one, which also counts hits up to 1e-6 behind the origin).
- A ray that passes through an edge or a vertex crosses the surface once there:
  ``intersects_id`` lists one of the faces that meet there (trimesh's ``ray_triangle`` lists
  each), and a ray that only touches the surface there enters and leaves, two hits at one point;
  ``intersects_location`` (and ``intersects_id`` with ``return_locations``) give each point
  once, as both of trimesh's do.
- A ray whose direction is zero or not finite, or whose origin is not finite, hits nothing,
  as in raycast's own queries (and Open3D's).

This module needs neither trimesh nor Open3D: only the mesh object it is given, with
``vertices`` and ``faces``.
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import RaycastingScene

__all__ = ["RayMeshIntersector"]

# The hits of each ray that trimesh's embree intersector reports at most, by default.
_MAX_HITS = 100


class RayMeshIntersector:
    """Ray queries on a trimesh mesh (any object with ``vertices`` (n, 3) and ``faces``
    (m, 3)), for ``mesh.ray = RayMeshIntersector(mesh)``. ``precision`` ("f32", "f64",
    "adaptive") and ``device`` ("gpu", "cpu") are those of ``raycast.RaycastingScene``."""

    def __init__(self, mesh: Any, precision: str = "f32", device: str = "gpu") -> None:
        self.mesh = mesh
        self.precision = precision
        self.device = device
        self._scene: Optional[RaycastingScene] = None
        self._scene_key: Any = None
        # The largest coordinate of the mesh: hit points on it are computed to a few ulps of it.
        self._magnitude = 0.0

    @property
    def scene(self) -> RaycastingScene:
        """The ``raycast.RaycastingScene`` holding the mesh (empty where the mesh has no
        faces), built on first use and again once the mesh has changed."""
        key = _mesh_key(self.mesh)
        if self._scene is None or key != self._scene_key:
            scene = RaycastingScene()
            vertices = np.asarray(self.mesh.vertices, dtype=np.float64)
            if len(self.mesh.faces) > 0:
                scene.add_triangles(vertices, self.mesh.faces)
            self._magnitude = float(np.abs(vertices).max(initial=0.0))
            self._scene, self._scene_key = scene, key
        return self._scene

    def intersects_id(
        self,
        ray_origins: Any,
        ray_directions: Any,
        multiple_hits: bool = True,
        max_hits: int = _MAX_HITS,
        return_locations: bool = False,
    ) -> Union[Tuple[np.ndarray, np.ndarray], Tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The faces the rays hit: ``index_tri`` (int64, face indices) and ``index_ray``
        (int64, which ray hit it), and with ``return_locations`` also ``locations`` (k, 3)
        float64. With ``multiple_hits`` every hit of each ray, nearest first, at most
        ``max_hits`` of them; otherwise the nearest. Hits of a ray at the same distance (on
        an edge two faces share) are counted once with ``return_locations``, twice without,
        as trimesh's ``ray_triangle`` counts them."""
        rays, valid = _rays(ray_origins, ray_directions)
        if multiple_hits:
            ray_ids, tri_ids, t = self._all_hits(rays[valid], max_hits)
            if return_locations:
                ray_ids, tri_ids, t = self._drop_repeated(rays[valid], ray_ids, tri_ids, t)
        else:
            ray_ids, tri_ids, t = self._first_hits(rays[valid])
        # Back from the rays that were cast to the rays as given.
        index_ray = np.flatnonzero(valid)[ray_ids]
        if not return_locations:
            return tri_ids, index_ray
        return tri_ids, index_ray, _locations(rays, index_ray, t)

    def intersects_location(
        self, ray_origins: Any, ray_directions: Any, multiple_hits: bool = True
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where the rays hit the mesh: ``locations`` (k, 3) float64, ``index_ray`` and
        ``index_tri`` (int64), each hit point once (see ``intersects_id``)."""
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins, ray_directions, multiple_hits=multiple_hits, return_locations=True
        )
        return locations, index_ray, index_tri

    def intersects_first(self, ray_origins: Any, ray_directions: Any) -> np.ndarray:
        """The face each ray hits first (int64, one per ray), -1 where it misses."""
        rays, valid = _rays(ray_origins, ray_directions)
        first = np.full(len(rays), -1, dtype=np.int64)
        ray_ids, tri_ids, _ = self._first_hits(rays[valid])
        first[np.flatnonzero(valid)[ray_ids]] = tri_ids
        return first

    def intersects_any(self, ray_origins: Any, ray_directions: Any) -> np.ndarray:
        """Whether each ray hits the mesh (bool, one per ray)."""
        rays, valid = _rays(ray_origins, ray_directions)
        hit = np.zeros(len(rays), dtype=bool)
        hit[valid] = self.scene.test_occlusions(
            rays[valid], precision=self.precision, device=self.device
        )
        return hit

    def contains_points(self, points: Any) -> np.ndarray:
        """Whether each point (n, 3) is inside the mesh (bool), where its generalized winding
        number is over 1/2; see the module's documentation for how that differs from
        trimesh's parity test. Points on the surface may go either way."""
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points: expected shape (n, 3), got {points.shape}")
        occupied = self.scene.compute_occupancy(
            points, sign="winding", precision=self.precision, device=self.device
        )
        return occupied.numpy() > 0.5

    def _first_hits(self, rays: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The nearest hit of each ray: which rays hit, their faces (int64), and t."""
        ans = self.scene.cast_rays(rays, precision=self.precision, device=self.device)
        hit = ans["geometry_ids"].numpy() != RaycastingScene.INVALID_ID
        ray_ids = np.flatnonzero(hit)
        tri_ids = ans["primitive_ids"].numpy()[hit].astype(np.int64)
        return ray_ids, tri_ids, ans["t_hit"].numpy()[hit]

    def _all_hits(
        self, rays: np.ndarray, max_hits: int
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every hit of each ray, nearest first, the first `max_hits` of each: ray indices,
        faces (int64), and t."""
        ans = self.scene.list_intersections(rays, precision=self.precision, device=self.device)
        ray_ids = ans["ray_ids"].numpy().astype(np.int64)
        # Each hit's rank along its ray: its place after the ray's first hit.
        rank = np.arange(len(ray_ids)) - ans["ray_splits"].numpy()[ray_ids].astype(np.int64)
        keep = rank < max_hits
        tri_ids = ans["primitive_ids"].numpy()[keep].astype(np.int64)
        return ray_ids[keep], tri_ids, ans["t_hit"].numpy()[keep]

    def _drop_repeated(
        self, rays: np.ndarray, ray_ids: np.ndarray, tri_ids: np.ndarray, t: np.ndarray
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The hits without those at the point of the ray's previous hit, as trimesh keeps
        one hit per location: a ray through an edge or a vertex may hit each face there, at
        t that differ by rounding. Points closer than 64 ulps of the mesh's largest
        coordinate are the same point (where the rounding of t can put them)."""
        tolerance = 64 * np.finfo(t.dtype).eps * self._magnitude
        step = np.abs(np.diff(t.astype(np.float64)))
        length = np.linalg.norm(rays[ray_ids[1:], 3:], axis=1)
        repeated = np.zeros(len(t), dtype=bool)
        repeated[1:] = (ray_ids[1:] == ray_ids[:-1]) & (step * length <= tolerance)
        return ray_ids[~repeated], tri_ids[~repeated], t[~repeated]

    # trimesh copies and pickles meshes with their `ray`; the native scene is rebuilt.
    def __getstate__(self) -> Dict[str, Any]:
        return {"mesh": self.mesh, "precision": self.precision, "device": self.device}

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(state["mesh"], state["precision"], state["device"])  # type: ignore[misc]

    def __copy__(self) -> "RayMeshIntersector":
        return RayMeshIntersector(self.mesh, self.precision, self.device)

    def __deepcopy__(self, memo: Dict[int, Any]) -> "RayMeshIntersector":
        return self.__copy__()


def _mesh_key(mesh: Any) -> Any:
    """What changes when the mesh does: trimesh's hash of a mesh is of its vertices and faces
    (and cached until they change); other objects hash by identity, or not at all."""
    try:
        return hash(mesh)
    except TypeError:
        return None


def _rays(origins: Any, directions: Any) -> Tuple[np.ndarray, np.ndarray]:
    """The rays as (n, 6) float64 rows of origin and direction, and which of them can hit
    anything (a zero or non-finite direction, or a non-finite origin, cannot)."""
    origins = np.asarray(origins, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    if origins.shape != directions.shape:
        raise ValueError(
            f"ray_origins, ray_directions: shapes differ, {origins.shape} and {directions.shape}"
        )
    if origins.ndim != 2 or origins.shape[1] != 3:
        raise ValueError(f"ray_origins: expected shape (n, 3), got {origins.shape}")
    rays = np.concatenate([origins, directions], axis=1)
    valid = np.isfinite(rays).all(axis=1) & (directions != 0).any(axis=1)
    return rays, valid


def _locations(rays: np.ndarray, index_ray: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The hit points ``origin + t * direction`` (float64)."""
    hit_rays = rays[index_ray]
    return hit_rays[:, :3] + t.astype(np.float64)[:, None] * hit_rays[:, 3:]
