"""Batched ray queries through Embree (embreex), spread over the machine's cores.

embreex releases the GIL inside ``run``, so a thread pool over chunks of rays uses every core.
All arrays are numpy; there is never a Python loop per ray. Every scene shares one Embree device per process:
a device per scene (embreex's default) starts threads of its own, and a process holding a thousand scenes (a
farm worker, a fuzzer) then fails to start more and crashes.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from embreex import rtcore, rtcore_scene
from embreex.mesh_construction import TriangleMesh

CHUNK_RAYS = 65536
_shared = {}


def _device():
    """The process's one Embree device, made on first use."""
    if "device" not in _shared:
        _shared["device"] = rtcore.EmbreeDevice()
    return _shared["device"]


class RayCaster:
    """Embree scene over (T, 3, 3) triangles; counts the rays it casts in ``rays_cast``. Pickles as its triangles
    and rebuilds the scene when unpickled, with the threads of the machine that loads it."""

    def __init__(self, triangles: np.ndarray, threads: int | None = None):
        self._triangles = np.ascontiguousarray(triangles, dtype=np.float32)
        self._scene = rtcore_scene.EmbreeScene(_device())
        TriangleMesh(self._scene, self._triangles)
        self._threads = max(1, threads or os.cpu_count() or 1)
        self._pool = ThreadPoolExecutor(self._threads) if self._threads > 1 else None
        self.rays_cast = 0
        # Build the BVH now, not inside the first worker thread.
        self._scene.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))

    def __getstate__(self) -> dict:
        return {"triangles": self._triangles, "rays_cast": self.rays_cast}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["triangles"])
        self.rays_cast = state["rays_cast"]

    def occluded(self, origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
        """True where something lies along origin + t direction for 0 < t < distance (unit directions)."""
        hits = self._run(origins, directions, distances, "OCCLUDED")
        return hits >= 0

    def first_hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """First triangle hit along unit directions: (m,) index (-1 for none) and (m, 3) barycentrics.

        Embree's (u, v) put the hit at (1 - u - v) v0 + u v1 + v v2.
        """
        result = self._run(origins, directions, np.full(len(origins), np.inf), "INTERSECT")
        u, v = result[:, 1], result[:, 2]
        return result[:, 0].astype(np.int64), np.stack([1.0 - u - v, u, v], axis=1)

    def hit_distance(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(m,) distance to the first surface along each unit direction (inf where the ray escapes)."""
        hit, bary = self.first_hit(origins, directions)
        points = np.einsum("mc,mck->mk", bary, self._triangles[np.maximum(hit, 0)])
        return np.where(hit >= 0, np.linalg.norm(points - origins, axis=1), np.inf)

    def _run(self, origins, directions, distances, query):
        count = len(origins)
        self.rays_cast += count
        origins = np.ascontiguousarray(origins, dtype=np.float32)
        directions = np.ascontiguousarray(directions, dtype=np.float32)
        distances = np.ascontiguousarray(np.minimum(distances, np.finfo(np.float32).max), dtype=np.float32)
        bounds = [(start, min(start + CHUNK_RAYS, count)) for start in range(0, count, CHUNK_RAYS)]
        work = lambda b: self._query(origins[b[0]:b[1]], directions[b[0]:b[1]], distances[b[0]:b[1]], query)
        parts = list(self._pool.map(work, bounds)) if self._pool and len(bounds) > 1 else [work(b) for b in bounds]
        if not parts:
            return np.zeros((0, 3) if query == "INTERSECT" else 0)
        return np.concatenate(parts)

    def _query(self, origins, directions, distances, query):
        if query == "OCCLUDED":
            return self._scene.run(origins, directions, dists=distances.copy(), query="OCCLUDED")
        info = self._scene.run(origins, directions, dists=distances.copy(), output=1)
        return np.stack([info["primID"], info["u"], info["v"]], axis=1).astype(np.float64)

    def close(self) -> None:
        if self._pool:
            self._pool.shutdown()
