"""The Embree backend of core.raycast (embreex: Linux and Windows wheels).

Every scene shares one Embree device per process: a device per scene (embreex's default) starts threads of its
own, and a process holding a thousand scenes (a farm worker, a fuzzer) then fails to start more and crashes.
embreex releases the GIL inside ``run``, so core.raycast's thread pool over chunks of rays uses every core.
"""
from __future__ import annotations

import numpy as np
from embreex import rtcore, rtcore_scene
from embreex.mesh_construction import TriangleMesh

_shared = {}


def _device():
    """The process's one Embree device, made on first use."""
    if "device" not in _shared:
        _shared["device"] = rtcore.EmbreeDevice()
    return _shared["device"]


def first_use_message() -> str | None:
    """Embree needs no preparation."""
    return None


class Scene:
    """Embree's BVH over (T, 3, 3) float32 triangles."""

    def __init__(self, triangles: np.ndarray):
        self._scene = rtcore_scene.EmbreeScene(_device())
        TriangleMesh(self._scene, triangles)
        # Build the BVH now, not inside the first worker thread.
        self._scene.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))

    def occluded(self, origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
        """(m,) True where a triangle lies along the ray before ``distances`` (float32 arrays)."""
        return self._scene.run(origins, directions, dists=distances.copy(), query="OCCLUDED") >= 0

    def closest(self, origins: np.ndarray, directions: np.ndarray,
                distances: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m,) first triangle hit (-1 for none) and its (u, v): the hit is (1 - u - v) v0 + u v1 + v v2."""
        info = self._scene.run(origins, directions, dists=distances.copy(), output=1)
        return info["primID"].astype(np.int64), info["u"].astype(np.float64), info["v"].astype(np.float64)
