"""The Warp backend of core.raycast: NVIDIA Warp's BVH on the CPU (warp-lang: wheels for Linux, Windows and
macOS arm64, one for every Python), for platforms where embreex has no wheel.

Warp compiles its kernels the first time they run on a machine (about 10-20 s) and keeps them in its kernel
cache; ``first_use_message`` says so before that happens. A kernel launch is a foreign call that releases the
GIL, so core.raycast's thread pool over chunks of rays runs them side by side.
"""
from __future__ import annotations

import numpy as np
import warp as wp

wp.config.log_level = wp.LOG_ERROR  # no banner, no CUDA warning: this backend runs on the CPU only
_state = {"loaded": False}


@wp.kernel
def _closest_kernel(mesh: wp.uint64, origins: wp.array(dtype=wp.vec3), directions: wp.array(dtype=wp.vec3),
                    distances: wp.array(dtype=wp.float32), face: wp.array(dtype=wp.int32),
                    u: wp.array(dtype=wp.float32), v: wp.array(dtype=wp.float32)):
    i = wp.tid()
    query = wp.mesh_query_ray(mesh, origins[i], directions[i], distances[i])
    face[i] = -1
    if query.result:
        face[i] = query.face
        u[i] = query.u
        v[i] = query.v


@wp.kernel
def _occluded_kernel(mesh: wp.uint64, origins: wp.array(dtype=wp.vec3), directions: wp.array(dtype=wp.vec3),
                     distances: wp.array(dtype=wp.float32), hit: wp.array(dtype=wp.int32)):
    i = wp.tid()
    hit[i] = 0
    if wp.mesh_query_ray_anyhit(mesh, origins[i], directions[i], distances[i]):
        hit[i] = 1


def first_use_message() -> str | None:
    """What to tell the user before the kernels load (None once they have, in this process)."""
    return None if _state["loaded"] else "Loading the Warp ray kernels (compiled on a machine's first bake)"


def _load() -> None:
    if not _state["loaded"]:
        wp.init()
        wp.load_module(device="cpu")
        _state["loaded"] = True


class Scene:
    """Warp's BVH over (T, 3, 3) float32 triangles (a vertex per corner: no welding needed)."""

    def __init__(self, triangles: np.ndarray):
        _load()
        points = np.ascontiguousarray(triangles.reshape(-1, 3), dtype=np.float32)
        indices = np.arange(len(points), dtype=np.int32)
        self._points = wp.array(points, dtype=wp.vec3, device="cpu")
        self._indices = wp.array(indices, dtype=wp.int32, device="cpu")
        self._mesh = wp.Mesh(points=self._points, indices=self._indices)

    def occluded(self, origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
        """(m,) True where a triangle lies along the ray before ``distances`` (float32 arrays)."""
        hit = wp.zeros(len(origins), dtype=wp.int32, device="cpu")
        wp.launch(_occluded_kernel, dim=len(origins), device="cpu",
                  inputs=[self._mesh.id, *_rays(origins, directions, distances), hit])
        return hit.numpy() > 0

    def closest(self, origins: np.ndarray, directions: np.ndarray,
                distances: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m,) first triangle hit (-1 for none) and its (u, v) in Embree's convention, the hit at
        (1 - u - v) v0 + u v1 + v v2 (Warp's own u and v weigh v0 and v1)."""
        count = len(origins)
        face = wp.empty(count, dtype=wp.int32, device="cpu")
        u = wp.zeros(count, dtype=wp.float32, device="cpu")
        v = wp.zeros(count, dtype=wp.float32, device="cpu")
        wp.launch(_closest_kernel, dim=count, device="cpu",
                  inputs=[self._mesh.id, *_rays(origins, directions, distances), face, u, v])
        weight0, weight1 = u.numpy().astype(np.float64), v.numpy().astype(np.float64)
        return face.numpy().astype(np.int64), weight1, 1.0 - weight0 - weight1


def _rays(origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> list:
    return [wp.array(origins, dtype=wp.vec3, device="cpu"), wp.array(directions, dtype=wp.vec3, device="cpu"),
            wp.array(distances, dtype=wp.float32, device="cpu")]
