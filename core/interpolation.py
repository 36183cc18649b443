"""Smooth light between elements, at any surface point, without leaking through walls.

The solve knows the irradiance at each element's receiver point. At a surface point x with normal n, it is fitted
to the receivers around x by moving least squares with a linear basis in x's tangent plane (Lancaster &
Salkauskas 1981): H(x) = b_0 of the fit H_e ~ b_0 + b_1 u_e + b_2 v_e that minimises sum_e w_e (...)^2, with
(u_e, v_e) receiver e's offset in the tangent plane and

    w_e = (1 - (d_e / r_e)^2)^2 x s(n . n_e) x V(x, p_e),

d_e the distance to receiver e, r_e its reach (a few element sizes), s a smoothstep from 30 to 70 degrees between
the normals (creases over 70 degrees stay sharp) and V a shadow ray between the two points, each lifted off its
surface by a fifth of their distance (so the ray clears the curve of a column between neighbouring elements,
while a wall standing between them still stops it). A linear field is reproduced exactly, as by linear
interpolation on a mesh; the result is kept within the values fitted, so it never overshoots. Scattered-data
interpolation needs no mesh connectivity, so it works on meshes that are not manifold, not welded and made of
many objects. Only the ``NEIGHBOURS`` heaviest receivers are tested for visibility. A point that sees none takes
the value of the element it lies on.
"""
from __future__ import annotations

import numpy as np

from .geometry import lengths, tangent_frames
from .ragged import concatenated_ranges
from .raycast import RayCaster

NEIGHBOURS = 8
LIFT_FRACTION = 0.2
COS_SHARP, COS_SMOOTH = np.cos(np.radians(70.0)), np.cos(np.radians(30.0))
PAIRS_PER_STEP = 1 << 21  # candidate (point, receiver) pairs weighed at once
BLOCK = 1 << 16           # points whose candidates are counted at once
RIDGE = 0.01  # damps the fitted gradient where the receivers around a point do not span its tangent plane
_CELL_OFFSETS = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 3)


class ReceiverField:
    """Receivers at (k, 3) points with unit (k, 3) normals and (k,) reaches, m; ``alive`` (k,) those whose values
    count. Finds, for surface points, the receivers to interpolate from and their normalised weights."""

    def __init__(self, points: np.ndarray, normals: np.ndarray, reach_m: np.ndarray, alive: np.ndarray,
                 caster: RayCaster, offset_m: float):
        self.points, self.normals, self.caster, self.offset_m = points, normals, caster, offset_m
        self.reach = np.asarray(reach_m, dtype=np.float64)
        self.entries = np.flatnonzero(alive)
        # How far above each receiver its side stays open: a visibility ray ends no higher above a receiver than
        # half of that, so a receiver under a surface close above it (a decal's back under the wall) is not
        # lifted through that surface and seen from the other side.
        self.clearance = np.full(len(points), np.inf)
        start = points[self.entries] + offset_m * normals[self.entries]
        self.clearance[self.entries] = caster.hit_distance(start, normals[self.entries]) + offset_m
        self.cell_m = max(float(self.reach[self.entries].max(initial=0.0)), 1e-9)
        keys = self._keys(np.floor(points[self.entries] / self.cell_m).astype(np.int64))
        order = np.argsort(keys, kind="stable")
        self.sorted_keys, self.sorted_entries = keys[order], self.entries[order]

    @staticmethod
    def _keys(cells: np.ndarray) -> np.ndarray:
        """One int64 per grid cell (cells within +-2^20 of the origin get distinct keys)."""
        cells = cells + (1 << 20)
        return (cells[..., 0] << 42) | (cells[..., 1] << 21) | cells[..., 2]

    def _cell_ranges(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(m, 27) first and end positions, in the sorted receivers, of the 27 grid cells around each point."""
        cells = np.floor(points / self.cell_m).astype(np.int64)
        keys = self._keys(cells[:, None, :] + _CELL_OFFSETS[None])
        return (np.searchsorted(self.sorted_keys, keys, side="left"),
                np.searchsorted(self.sorted_keys, keys, side="right"))

    def _steps(self, points) -> list[slice]:
        """Consecutive runs of points whose candidate receivers add up to about ``PAIRS_PER_STEP`` (memory
        stays bounded however densely the receivers crowd the cells)."""
        counts = np.zeros(len(points), dtype=np.int64)
        for start in range(0, len(points), BLOCK):
            low, high = self._cell_ranges(points[start:start + BLOCK])
            counts[start:start + BLOCK] = (high - low).sum(axis=1)
        total = np.cumsum(counts)
        steps = int(total[-1]) // PAIRS_PER_STEP if len(total) else 0
        cuts = np.searchsorted(total, PAIRS_PER_STEP * np.arange(1, steps + 1))
        edges = np.unique(np.concatenate([[0], cuts, [len(points)]]))
        return [slice(start, stop) for start, stop in zip(edges[:-1], edges[1:])]

    def _neighbours(self, points, normals, visibility):
        """(row, receiver, weight) of the receivers each point interpolates from (weights not normalised); points
        that see none in reach have no row."""
        low, high = self._cell_ranges(points)
        count = (high - low).ravel()
        row = np.repeat(np.repeat(np.arange(len(points)), 27), count)
        receiver = self.sorted_entries[np.repeat(low.ravel(), count) + concatenated_ranges(count)]
        offset = self.points[receiver] - points[row]
        distance2 = np.einsum("mk,mk->m", offset, offset)
        agree = np.einsum("mk,mk->m", self.normals[receiver], normals[row])
        t = np.clip((agree - COS_SHARP) / (COS_SMOOTH - COS_SHARP), 0.0, 1.0)
        kernel = np.maximum(1.0 - distance2 / self.reach[receiver] ** 2, 0.0) ** 2
        weight = kernel * t * t * (3.0 - 2.0 * t)
        keep = np.flatnonzero(weight > 0)
        row, receiver, weight, distance2 = row[keep], receiver[keep], weight[keep], distance2[keep]
        order = np.lexsort((-weight, row))
        row, receiver, weight, distance2 = row[order], receiver[order], weight[order], distance2[order]
        first = np.flatnonzero(np.r_[True, row[1:] != row[:-1]]) if len(row) else np.zeros(0, dtype=np.int64)
        rank = np.arange(len(row)) - np.repeat(first, np.diff(np.r_[first, len(row)]))
        top = np.flatnonzero(rank < NEIGHBOURS)
        row, receiver, weight, distance2 = row[top], receiver[top], weight[top], distance2[top]
        if visibility and len(row):
            lift = np.maximum(LIFT_FRACTION * np.sqrt(distance2), self.offset_m)[:, None]
            start = points[row] + lift * normals[row]
            end = self.points[receiver] + np.minimum(lift, 0.5 * self.clearance[receiver, None]) * \
                self.normals[receiver]
            ray = end - start
            length = lengths(ray)
            moving = length > 1e-9
            seen = np.ones(len(row), dtype=bool)
            seen[moving] = ~self.caster.occluded(start[moving], ray[moving] / length[moving, None], length[moving])
            row, receiver, weight = row[seen], receiver[seen], weight[seen]
        return row, receiver, weight

    def interpolate(self, values: np.ndarray, points: np.ndarray, normals: np.ndarray, fallback: np.ndarray,
                    visibility: bool = True) -> np.ndarray:
        """(m, c) values (k, c) fitted at surface points; ``fallback`` (m,) the receiver whose value a point takes
        when it sees none in reach."""
        out = values[fallback].astype(np.float64)
        for rows in self._steps(points):
            row, receiver, weight = self._neighbours(points[rows], normals[rows], visibility)
            if len(row):
                found = np.unique(row)
                out[rows.start + found] = self._fit(values, points[rows], normals[rows], row, receiver, weight)[found]
        return out

    def _fit(self, values, points, normals, row, receiver, weight) -> np.ndarray:
        """(m, c) moving-least-squares value at each point (rows without neighbours: 0)."""
        count, channels = len(points), values.shape[1]
        frame = tangent_frames(normals)
        offset = self.points[receiver] - points[row]
        basis = np.stack([np.ones(len(row)), np.einsum("mk,mk->m", offset, frame[row, 0]),
                          np.einsum("mk,mk->m", offset, frame[row, 1])], axis=1)          # (pairs, 3)
        gram = np.zeros((count, 3, 3))
        np.add.at(gram, row, weight[:, None, None] * basis[:, :, None] * basis[:, None, :])
        total = np.bincount(row, weights=weight, minlength=count)
        ridge = RIDGE * np.bincount(row, weights=weight * self.reach[receiver] ** 2, minlength=count)
        gram[:, 1, 1] += ridge
        gram[:, 2, 2] += ridge
        unused = total <= 0  # rows without neighbours: an identity system, ignored by the caller
        gram[unused] = np.eye(3)
        moments = np.zeros((count, 3, channels))
        np.add.at(moments, row, weight[:, None, None] * basis[:, :, None] * values[receiver][:, None, :])
        fitted = np.linalg.solve(gram, moments)[:, 0, :]
        low = np.full((count, channels), np.inf)
        high = np.full((count, channels), -np.inf)
        np.minimum.at(low, row, values[receiver])
        np.maximum.at(high, row, values[receiver])
        return np.clip(fitted, low, high)
