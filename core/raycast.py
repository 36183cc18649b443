"""Batched ray queries over a triangle scene, spread over the machine's cores, through one of two backends:

- Embree (embreex, core.raycast_embree): the default wherever it has a wheel (Linux, Windows);
- Warp (warp-lang, core.raycast_warp): NVIDIA Warp's BVH on the CPU, with wheels for macOS arm64 too.

The environment variable RADIOSITY_RAY_BACKEND (embree or warp) forces one; the test suites run with each.
A backend is a module with a ``Scene(triangles)`` class answering ``occluded`` and ``closest`` for float32 arrays
of rays, and ``first_use_message()``; it is imported by name, as an optional dependency, when first needed. All
arrays are numpy; there is never a Python loop per ray.
"""
from __future__ import annotations

import copy
import importlib
import importlib.util
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .errors import SettingsError

CHUNK_RAYS = 65536
BACKENDS = {"embree": ("embreex", ".raycast_embree"), "warp": ("warp", ".raycast_warp")}
BACKEND_VARIABLE = "RADIOSITY_RAY_BACKEND"


def backend_name() -> str:
    """The backend this process uses: the one RADIOSITY_RAY_BACKEND names, else the first one installed."""
    forced = os.environ.get(BACKEND_VARIABLE, "")
    if forced:
        if forced not in BACKENDS:
            raise SettingsError(f"{BACKEND_VARIABLE} must be one of {', '.join(BACKENDS)}, got '{forced}'.")
        return forced
    for name, (package, _) in BACKENDS.items():
        if importlib.util.find_spec(package) is not None:
            return name
    raise SettingsError("No ray-casting library is installed: the extension needs embreex or warp-lang.")


def _backend():
    return importlib.import_module(BACKENDS[backend_name()][1], __package__)


def first_use_message() -> str | None:
    """A message to show before the first scene is built when the backend needs time then (Warp compiles its
    kernels once per machine); None otherwise."""
    return _backend().first_use_message()


class RayCaster:
    """A ray-casting scene over (T, 3, 3) triangles, for queries from any thread (core.parallel's steps); counts
    the rays it casts in ``rays_cast``. Its state (``__getstate__``, as a data file or a pickle stores it) is its
    triangles; restored, it rebuilds the scene with the threads of the machine that loads it."""

    def __init__(self, triangles: np.ndarray, threads: int | None = None):
        self._triangles = np.ascontiguousarray(triangles, dtype=np.float32)
        self._scene = _backend().Scene(self._triangles)
        self._threads = max(1, threads or os.cpu_count() or 1)
        self._pool = ThreadPoolExecutor(self._threads) if self._threads > 1 else None
        self._counting = threading.Lock()
        self.rays_cast = 0

    @property
    def threads(self) -> int:
        """The threads its queries run on."""
        return self._threads

    def with_own_count(self) -> "RayCaster":
        """The same scene and threads, counting its rays apart: for work beside another's on one scene (lightmap
        texels planned during the solve) whose rays the other's count must not include."""
        other = copy.copy(self)
        other._counting, other.rays_cast = threading.Lock(), 0
        return other

    def __getstate__(self) -> dict:
        return {"triangles": self._triangles, "rays_cast": self.rays_cast}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["triangles"])
        self.rays_cast = state["rays_cast"]

    def occluded(self, origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
        """True where something lies along origin + t direction for 0 < t < distance (unit directions)."""
        return self._run(self._scene.occluded, origins, directions, distances)

    def first_hit(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """First triangle hit along unit directions: (m,) index (-1 for none) and (m, 3) barycentrics, the hit
        at (1 - u - v) v0 + u v1 + v v2."""
        hit, u, v = self._run(self._scene.closest, origins, directions, np.full(len(origins), np.inf))
        return hit, np.stack([1.0 - u - v, u, v], axis=1)

    def hit_distance(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(m,) distance to the first surface along each unit direction (inf where the ray escapes)."""
        hit, bary = self.first_hit(origins, directions)
        points = np.einsum("mc,mck->mk", bary, self._triangles[np.maximum(hit, 0)])
        return np.where(hit >= 0, np.linalg.norm(points - origins, axis=1), np.inf)

    def _run(self, query, origins, directions, distances):
        """``query`` over chunks of CHUNK_RAYS rays on the thread pool; its results concatenated."""
        count = len(origins)
        with self._counting:
            self.rays_cast += count
        origins = np.ascontiguousarray(origins, dtype=np.float32).reshape(-1, 3)
        directions = np.ascontiguousarray(directions, dtype=np.float32).reshape(-1, 3)
        distances = np.ascontiguousarray(np.minimum(distances, np.finfo(np.float32).max), dtype=np.float32)
        if count == 0:  # the backends' answer to one ray, emptied: the same types and shapes for none
            result = query(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32), np.ones(1, np.float32))
            return tuple(column[:0] for column in result) if isinstance(result, tuple) else result[:0]
        bounds = [(start, min(start + CHUNK_RAYS, count)) for start in range(0, count, CHUNK_RAYS)]
        work = lambda b: query(origins[b[0]:b[1]], directions[b[0]:b[1]], distances[b[0]:b[1]])
        parts = list(self._pool.map(work, bounds)) if self._pool and len(bounds) > 1 else [work(b) for b in bounds]
        if isinstance(parts[0], tuple):
            return tuple(np.concatenate(column) for column in zip(*parts))
        return np.concatenate(parts)

    def close(self) -> None:
        if self._pool:
            self._pool.shutdown()
