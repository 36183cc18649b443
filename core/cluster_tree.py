"""A binary tree of clusters over the elements: the source side of hierarchical radiosity with clustering
(Hanrahan, Salzman & Aupperle 1991; Smits, Arvo & Greenberg 1994; Sillion 1995).

Built top-down by median splits of the elements' centroids along each node's longest axis, so that every node holds
a contiguous range ``order[start:end]`` of the elements: sums over a node (its exposed area, its radiated power) are
taken from the leaves up, one step per tree level, vectorised over the nodes of a level. A node's surfaces are split
by the direction class of their outward normals (core.geometry.direction_classes: six classes, one per axis and
sign), and its radiosity is kept per class: a receiver under a sunlit slab gets the mean of the slab's underside,
not of its top. A node stands for its elements when seen from far enough away (core.links); each of its classes is
then cut, in tree order, into ``NODE_SAMPLES`` parts of equal exposed area, each seen from the receiver at its
area-weighted centroid and mean normal (a midpoint rule, second-order accurate, where one element's point in each
part would be first-order) and tested for visibility with one shadow ray to the element sample at its middle: a node
of a hundred elements costs as few shadow rays as one element.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .clusters import SAMPLES
from .geometry import direction_classes
from .ragged import concatenated_ranges

NODE_SAMPLES = 4


@dataclass
class ClusterTree:
    """Nodes of the tree (root 0): element range ``order[start:end]``, children ``left`` / ``right`` (-1 for
    leaves), bounding box ``low`` / ``high`` (N, 3), m; ``depth`` (N,) below the root; ``element`` (N,) the element
    of a leaf (-1 for internal nodes); ``leaf_of`` (n,) the leaf node of each element; ``side_class`` (n, 2) the
    direction class of each element side; ``class_exposed`` (N, 6) each node's exposed area per class, m^2; per
    node, class and part of equal area (N, 6, NODE_SAMPLES): ``sample`` the flat index (element x 2 + side) x
    SAMPLES + k of the element sample at the part's middle, ``centroid`` and ``normal`` (..., 3) the part's
    area-weighted centroid and unit mean normal (float32)."""

    order: np.ndarray
    start: np.ndarray
    end: np.ndarray
    left: np.ndarray
    right: np.ndarray
    low: np.ndarray
    high: np.ndarray
    depth: np.ndarray
    element: np.ndarray
    leaf_of: np.ndarray
    side_class: np.ndarray
    class_exposed: np.ndarray
    sample: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray

    @property
    def node_count(self) -> int:
        return len(self.start)

    @cached_property
    def inner_levels(self) -> list[np.ndarray]:
        """The inner nodes of each depth, deepest first: what a pass from the leaves up takes, one step per level."""
        depths = range(int(self.depth.max(initial=0)) - 1, -1, -1)
        return [np.flatnonzero((self.depth == depth) & (self.left >= 0)) for depth in depths]

    def node_sums(self, values: np.ndarray) -> np.ndarray:
        """(N, ...) sums over each node's elements of per-element ``values`` (n, ...), leaves up. (Differences of
        a running sum leave a sliver's node the round-off of everything summed before it: a mean over it, this
        sum over its area, then comes out of any size.)"""
        sums = np.zeros((self.node_count,) + values.shape[1:])
        leaves = np.flatnonzero(self.left < 0)
        sums[leaves] = values[self.element[leaves]]
        for inner in self.inner_levels:
            sums[inner] = sums[self.left[inner]] + sums[self.right[inner]]
        return sums

    def class_range(self, side_values: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 6) smallest and largest per-element-side value (n, 2) of every node's live sides in each direction
        class (+inf and -inf where a node has none), leaves up, one step per level."""
        low = np.full((self.node_count, 6), np.inf)
        high = np.full((self.node_count, 6), -np.inf)
        leaves = self.leaf_of
        for side in range(2):
            live = np.flatnonzero(alive[:, side])
            low[leaves[live], self.side_class[live, side]] = side_values[live, side]
            high[leaves[live], self.side_class[live, side]] = side_values[live, side]
        for inner in self.inner_levels:
            low[inner] = np.minimum(low[self.left[inner]], low[self.right[inner]])
            high[inner] = np.maximum(high[self.left[inner]], high[self.right[inner]])
        return low, high

    def by_class(self, side_values: np.ndarray) -> np.ndarray:
        """(n, 6, ...) per-element-side values (n, 2, ...) moved to their sides' direction classes."""
        out = np.zeros((len(side_values), 6) + side_values.shape[2:])
        rows = np.arange(len(side_values))
        for side in range(2):
            out[rows, self.side_class[:, side]] += side_values[:, side]
        return out


def build_tree(centroid: np.ndarray, low: np.ndarray, high: np.ndarray, normal: np.ndarray,
               sample_exposed_m2: np.ndarray, sample_point: np.ndarray, sample_normal: np.ndarray) -> ClusterTree:
    """The tree over elements with (n, 3) centroids, bounding boxes and unit normals; ``sample_exposed_m2``
    (n, 2, SAMPLES) is the exposed area each element sample stands for on each side (0 where the sample is
    buried), at ``sample_point`` (n, SAMPLES, 3) with the front's ``sample_normal``."""
    count = len(centroid)
    order = np.arange(count)
    start, end = np.array([0]), np.array([count])
    left, right, depth = np.array([-1]), np.array([-1]), np.array([0])
    frontier = np.flatnonzero(end - start > 1)
    while len(frontier):  # one step per level of the tree
        s, e = start[frontier], end[frontier]
        block = np.concatenate([[0], np.cumsum(e - s)[:-1]])
        local = np.repeat(np.arange(len(frontier)), e - s)
        position = np.repeat(s, e - s) + concatenated_ranges(e - s)
        points = centroid[order[position]]
        axis = np.argmax(np.maximum.reduceat(points, block) - np.minimum.reduceat(points, block), axis=1)
        coordinate = points[np.arange(len(points)), axis[local]]
        order[position] = order[position][np.lexsort((coordinate, local))]
        middle = (s + e) // 2
        first = len(start)
        start = np.concatenate([start, np.stack([s, middle], 1).ravel()])
        end = np.concatenate([end, np.stack([middle, e], 1).ravel()])
        left = np.concatenate([left, np.full(2 * len(frontier), -1)])
        right = np.concatenate([right, np.full(2 * len(frontier), -1)])
        left[frontier] = first + 2 * np.arange(len(frontier))
        right[frontier] = left[frontier] + 1
        depth = np.concatenate([depth, np.repeat(depth[frontier] + 1, 2)])
        frontier = first + np.flatnonzero(end[first:] - start[first:] > 1)
    element = np.where(left < 0, order[np.minimum(start, count - 1)], -1) if count else np.zeros(0, dtype=np.int64)
    leaf_of = np.zeros(count, dtype=np.int64)
    leaf_of[element[left < 0]] = np.flatnonzero(left < 0)
    tree = ClusterTree(order, start, end, left, right, _range_reduce(np.minimum, low[order], start, end),
                       _range_reduce(np.maximum, high[order], start, end), depth, element, leaf_of,
                       direction_classes(np.stack([normal, -normal], axis=1)), np.zeros((len(start), 6)),
                       np.zeros((len(start), 6, NODE_SAMPLES), dtype=np.int64),
                       np.zeros((len(start), 6, NODE_SAMPLES, 3), dtype=np.float32),
                       np.zeros((len(start), 6, NODE_SAMPLES, 3), dtype=np.float32))
    tree.class_exposed = tree.node_sums(tree.by_class(sample_exposed_m2.sum(axis=2)))
    _sample_parts(tree, sample_exposed_m2, sample_point, sample_normal)
    return tree


def _range_reduce(function, values: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """function.reduce of values[start:end] for every range, by a sparse table over powers of two."""
    table = [values]
    while (1 << len(table)) <= len(values):
        previous, step = table[-1], 1 << (len(table) - 1)
        table.append(function(previous[:-step], previous[step:]))
    length = np.maximum(end - start, 1)
    level = np.floor(np.log2(length)).astype(np.int64)
    out = np.empty((len(start),) + values.shape[1:])
    for k in np.unique(level):
        rows = np.flatnonzero(level == k)
        out[rows] = function(table[k][start[rows]], table[k][end[rows] - (1 << k)])
    return out


def _sample_parts(tree: ClusterTree, sample_exposed_m2: np.ndarray, sample_point: np.ndarray,
                  sample_normal: np.ndarray) -> None:
    """Per node and direction class, the NODE_SAMPLES parts of equal exposed area (consecutive in tree order):
    their middle samples, area-weighted centroids and mean normals, from prefix sums of area, area x position and
    area x normal over the element samples (each an atom of area at its point)."""
    per_element = 2 * SAMPLES
    sides = np.array([1.0, -1.0])[None, :, None, None]
    points = np.broadcast_to(sample_point[:, None], (len(sample_point), 2, SAMPLES, 3))[tree.order].reshape(-1, 3)
    normals = (sample_normal[:, None] * sides)[tree.order].reshape(-1, 3)
    bounds = (np.arange(NODE_SAMPLES + 1) / NODE_SAMPLES)[None, :]
    for direction in range(6):
        in_class = (tree.side_class == direction)[:, :, None]
        weights = np.where(in_class, sample_exposed_m2, 0.0)[tree.order].ravel()
        area = np.concatenate([[0.0], np.cumsum(weights)])
        first, last = area[tree.start * per_element], area[tree.end * per_element]
        cuts = first[:, None] + (last - first)[:, None] * bounds                        # (N, K + 1)
        position = _prefix_at(area, weights, points, cuts)
        direction_sum = _prefix_at(area, weights, normals, cuts)
        share = np.maximum(np.diff(cuts, axis=1), 1e-300)[..., None]
        tree.centroid[:, direction] = np.diff(position, axis=1) / share
        summed = np.diff(direction_sum, axis=1)
        tree.normal[:, direction] = summed / np.maximum(np.linalg.norm(summed, axis=2, keepdims=True), 1e-300)
        middle = 0.5 * (cuts[:, :-1] + cuts[:, 1:])
        flat = np.clip(np.searchsorted(area, middle, side="right") - 1, 0, len(weights) - 1)
        tree.sample[:, direction, :] = tree.order[flat // per_element] * per_element + flat % per_element


def _prefix_at(area: np.ndarray, weights: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(..., 3) sum of weights x values over the atoms up to cumulative area ``at`` (...), the atom it falls in
    counted in part; ``area`` is the prefix sum of ``weights`` (with a leading 0)."""
    moment = np.concatenate([np.zeros((1, 3)), np.cumsum(weights[:, None] * values, axis=0)])
    atom = np.clip(np.searchsorted(area, at, side="right") - 1, 0, len(weights) - 1)
    return moment[atom] + (at - area[atom])[..., None] * values[atom]
