"""Form-factor rows for the solvers: F(e -> j) from every receiving element e to one shooting patch j.

Two interchangeable methods (``FormFactorMethod``):
- ``RayCastRows``: Lambert's exact unoccluded point-to-polygon factor at the element centroid times the visible
  share of stratified points on the patch (Wallace et al. 1989 style visibility). The accurate default.
- ``HemicubeRows``: a hemicube at the patch centroid (Cohen & Greenberg 1985) whose pixels are found by casting
  one Embree ray each; F(j -> e) sums the delta form factors of the pixels that see element e, and reciprocity
  gives F(e -> j) = F(j -> e) A_j / A_e (Cohen et al. 1988 shoot with it).

By reciprocity, shooting patch j's radiosity B_j adds F(e -> j) B_j to the irradiance of every element e.
``FormFactorCache`` keeps the rows and the patch-to-patch coupling F(i -> j) (their area-weighted means over each
patch, ``patch_mean``) once computed, for the solvers (core.solver).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import BakeCancelled
from .formfactor import hemicube_item_buffer, point_to_triangle_with_visibility, triangle_samples
from .mesh import ElementMesh, Elements
from .parallel import ordered_map
from .progress import never_cancelled
from .raycast import RayCaster
from .scene import MAX_REFLECTANCE
from .geometry import triangle_areas, triangle_unit_normals


@dataclass
class Patches:
    """Shooting patches: (P, 3, 3) corners, (P, 3) centroids and unit normals, (P,) areas in m^2."""

    corners: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    area_m2: np.ndarray

    @classmethod
    def of(cls, mesh: ElementMesh) -> "Patches":
        corners = mesh.corners(np.arange(mesh.patch_count))
        return cls(corners, corners.mean(axis=1), triangle_unit_normals(corners), triangle_areas(corners))


PAIRS_PER_BLOCK = 1 << 17


class RayCastRows:
    """F(e -> j) = F_Lambert(centroid_e -> patch_j) x visible share of s x s stratified points on patch j."""

    def __init__(self, caster: RayCaster, patches: Patches, samples_per_edge: int, offset_m: float):
        self.caster, self.patches = caster, patches
        self.samples_per_edge, self.offset_m = samples_per_edge, offset_m
        self._samples = triangle_samples(patches.corners, samples_per_edge)

    def block(self, patches: np.ndarray, receivers: Elements, lift=None) -> np.ndarray:
        """(n, b) form factors from every receiver to each of the b given patches; only the pairs where the
        receiver lies in front of the patch are ever gathered into flat arrays. ``lift`` (core.terminator.ShadowLift
        per receiver, optional) starts grazing shadow rays from smooth-shaded receivers on their smooth surface."""
        patch_normal = self.patches.normal[patches]
        height = receivers.centroid @ patch_normal.T - np.einsum("bk,bk->b", self.patches.centroid[patches],
                                                                   patch_normal)
        receiver, column = np.nonzero((height > 0) & (receivers.patch[:, None] != patches[None, :]))
        patch = patches[column]
        values = point_to_triangle_with_visibility(
            self.caster, receivers.centroid[receiver], receivers.normal[receiver], self.patches.corners[patch],
            self._samples[patch], self.patches.normal[patch], self.offset_m,
            None if lift is None else lift[receiver])
        factors = np.zeros((len(receivers.node), len(patches)))
        factors[receiver, column] = values
        return factors


class HemicubeRows:
    """F(e -> j) from one hemicube of ``resolution`` pixels across its top face, at patch j's centroid."""

    def __init__(self, caster: RayCaster, patches: Patches, mesh: ElementMesh, resolution: int, offset_m: float,
                 scene_to_mesh_triangle: np.ndarray):
        self.caster, self.patches, self.mesh = caster, patches, mesh
        self.resolution, self.offset_m = resolution, offset_m
        self.scene_to_mesh_triangle = scene_to_mesh_triangle

    def block(self, patches: np.ndarray, receivers: Elements) -> np.ndarray:
        """(n, b) form factors; each patch's hemicube is turned by a golden-ratio angle against aliasing."""
        hit, bary, weights = hemicube_item_buffer(
            self.caster, self.patches.centroid[patches], self.patches.normal[patches], self.resolution,
            self.offset_m, rotation=(0.618034 * patches % 1.0) * 2 * np.pi)
        column = np.broadcast_to(np.arange(len(patches))[:, None], hit.shape).ravel()
        weight = np.broadcast_to(weights, hit.shape).ravel()
        hit, bary = hit.ravel(), bary.reshape(-1, 3)
        mesh_triangle = np.where(hit >= 0, self.scene_to_mesh_triangle[np.maximum(hit, 0)], -1)
        seen = np.flatnonzero(mesh_triangle >= 0)
        node, _ = self.mesh.locate(mesh_triangle[seen], bary[seen])
        position = np.full(len(self.mesh.node_bary), -1)
        position[receivers.node] = np.arange(len(receivers.node))
        receiver = position[node]
        kept = receiver >= 0
        n, b = len(receivers.node), len(patches)
        patch_to_element = np.bincount(receiver[kept] * b + column[seen][kept], weights=weight[seen][kept],
                                       minlength=n * b).reshape(n, b)
        return patch_to_element * self.patches.area_m2[patches][None, :] / receivers.area_m2[:, None]


FormFactorMethod = RayCastRows | HemicubeRows


def row_blocks(method: FormFactorMethod, patches: np.ndarray, receivers: Elements, threads: int):
    """Yield (patch indices, (n, b) form factors) for all given patches, blocks computed side by side on
    ``threads`` threads (core.parallel)."""
    size = max(1, PAIRS_PER_BLOCK // max(1, len(receivers.node)))
    if isinstance(method, HemicubeRows):
        size = max(1, PAIRS_PER_BLOCK // (3 * method.resolution ** 2))
    blocks = [patches[start:start + size] for start in range(0, len(patches), size)]
    yield from zip(blocks, ordered_map(lambda block: method.block(block, receivers), blocks, threads))


class FormFactorCache:
    """Form factors known so far: the patch coupling F(i -> j) as (P, P) float32 columns, filled as patches
    shoot, and, while n P float32 fit in ``row_budget_bytes``, the element rows F(e -> j) as an (n, P) matrix."""

    def __init__(self, method: FormFactorMethod, patch_count: int, row_budget_bytes: int, threads: int):
        self.method, self.threads, self.row_budget_bytes = method, threads, row_budget_bytes
        self.coupling = np.zeros((patch_count, patch_count), dtype=np.float32)
        self.known = np.zeros(patch_count, dtype=bool)
        self.rows: np.ndarray | None = None
        self.rows_known = np.zeros(patch_count, dtype=bool)

    def compute(self, patches: np.ndarray, elements: Elements, patch_table: "Patches",
                cancelled: Callable[[], bool] = never_cancelled) -> None:
        """Compute element rows of the given patches (all cores); keep their coupling columns and rows."""
        self._allocate_rows(len(elements.node))
        for block, rows in row_blocks(self.method, patches, elements, self.threads):
            if cancelled():
                raise BakeCancelled("Bake cancelled while computing form factors.")
            rows = conserving(rows, block, elements, patch_table)
            self.coupling[:, block] = patch_mean(rows, elements, patch_table)
            self.known[block] = True
            if self.rows is not None:
                self.rows[:, block] = rows
                self.rows_known[block] = True

    def enclosure(self, area: np.ndarray) -> float:
        """Area-weighted mean, over the patches that have shot, of the share of their light landing on the scene:
        sum_i F(i -> j) A_i / A_j by reciprocity from patch j's coupling column (1 if none has shot); ``area``
        (P,) are the patches' exposed areas."""
        if not self.known.any():
            return 1.0
        column_sums = (self.coupling[:, self.known].astype(np.float64) * area[:, None]).sum(axis=0)
        share = np.clip(column_sums / np.maximum(area[self.known], 1e-300), 0.0, 1.0)
        return float((share * area[self.known]).sum() / area[self.known].sum())

    def gather(self, weights: np.ndarray, elements: Elements, cancelled: Callable[[], bool] = never_cancelled,
               store: bool = True):
        """(n, 3) sum_j F(e -> j) weights_j over patches with non-zero weight, from stored or fresh rows.

        With ``store`` False the elements are a subset (not the current set) and rows are neither read nor kept.
        """
        store = store and self.rows is not None
        active = np.flatnonzero(np.abs(weights).sum(axis=1) > 0)
        stored = active[self.rows_known[active]] if store else active[:0]
        total = self.rows[:, stored] @ weights[stored] if len(stored) else np.zeros((len(elements.node), 3))
        for block, rows in row_blocks(self.method, np.setdiff1d(active, stored), elements, self.threads):
            if cancelled():
                raise BakeCancelled("Bake cancelled while gathering light.")
            total += rows @ weights[block]
            if store:
                self.rows[:, block] = rows
                self.rows_known[block] = True
        return total

    def refine(self, old_position: np.ndarray, refined: Elements, cancelled: Callable[[], bool] = never_cancelled):
        """Carry stored rows over to a refined element set; ``old_position`` is each refined element's position
        in the old set, -1 for new ones, whose stored rows are computed here."""
        if self.rows is None:
            return
        kept, new = old_position >= 0, np.flatnonzero(old_position < 0)
        rows = np.zeros((len(old_position), self.rows.shape[1]), dtype=np.float32)
        rows[kept] = self.rows[old_position[kept]]
        self.rows = rows
        subset = _subset(refined, new)
        for block, block_rows in row_blocks(self.method, np.flatnonzero(self.rows_known), subset, self.threads):
            if cancelled():
                raise BakeCancelled("Bake cancelled during adaptive meshing.")
            self.rows[np.ix_(new, block)] = block_rows

    def _allocate_rows(self, count: int) -> None:
        size = count * len(self.known) * 4
        if self.rows is None and size <= self.row_budget_bytes:
            self.rows = np.zeros((count, len(self.known)), dtype=np.float32)


def _subset(elements: Elements, positions: np.ndarray) -> Elements:
    return Elements(**{name: value[positions] for name, value in vars(elements).items()})


def conserving(rows: np.ndarray, block: np.ndarray, elements: Elements, patches: Patches) -> np.ndarray:
    """(n, b) rows F(e -> j) of the ``block`` patches, each patch's column scaled down where the elements would
    reflect back more than MAX_REFLECTANCE of the light it shoots. By reciprocity they receive
    sum_e F(e -> j) A_e / A_j of it, at most 1 (the form factors leaving a patch sum to 1 in a closed scene,
    radiosity paper section 3), and reflect at most MAX_REFLECTANCE of that. A factor estimated at an element's
    centroid overshoots where surfaces touch or cut through each other (2.6 between intersecting triangles), and
    a patch that gets back more than it shoots makes the solvers diverge; the few percent over 1 that centroid
    estimates reach in a closed room (1.024 in the furnace box) come back at the reflectance's share and stay."""
    reflected = (elements.exposed_m2[:, None] * elements.reflectance).T @ rows  # (3, b) W per W/m^2 shot
    returned = reflected.max(axis=0) / np.maximum(exposed_area(elements, patches)[block], 1e-300)
    return rows / np.maximum(returned / MAX_REFLECTANCE, 1.0)[None, :]


def patch_mean(values: np.ndarray, elements: Elements, patches: Patches) -> np.ndarray:
    """Mean of per-element values (n, c) over each patch, weighted by exposed area: (P, c) (0 where nothing of
    the patch is exposed)."""
    order = np.argsort(elements.patch, kind="stable")
    patch_of = elements.patch[order]
    starts = np.flatnonzero(np.r_[True, patch_of[1:] != patch_of[:-1]])
    sums = np.add.reduceat(values[order] * elements.exposed_m2[order, None], starts, axis=0)
    out = np.zeros((len(patches.area_m2), values.shape[1]), dtype=np.result_type(values, np.float64))
    out[patch_of[starts]] = sums
    return out / np.maximum(exposed_area(elements, patches), 1e-300)[:, None]


def exposed_area(elements: Elements, patches: Patches) -> np.ndarray:
    """(P,) sum of the exposed areas of each patch's elements."""
    return np.bincount(elements.patch, weights=elements.exposed_m2, minlength=len(patches.area_m2))
