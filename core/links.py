"""Links: the form factors from each receiver to the clusters of the tree it sees (core.cluster_tree).

Each receiver (a side of an element, or any surface point) links to a cut through the tree, as Barnes & Hut
traverse an octree: a node is accepted when it is small as seen from the receiver (its bounding box's half
diagonal under ``opening`` times its distance) and its area could not subtend a form factor over
``FORM_FACTOR_LIMIT`` (A / (pi d^2): Hanrahan et al.'s bound, so that no sampled link carries much light), else
opened; leaves (elements) are always accepted; nodes entirely below the receiver's tangent plane, and the
receiver's own element, are skipped. So each receiver holds about a
few hundred links however many elements the scene has (hierarchical radiosity with clustering: Hanrahan, Salzman
& Aupperle 1991; Smits, Arvo & Greenberg 1994), and memory is O(receivers x links), not O(n^2).

A link holds F(receiver -> node) split by the direction class of the node's surfaces it sees
(core.geometry.direction_classes: every surface reflects from both sides, as in Cycles, and each side falls in the
class of its outward normal), and the gather multiplies each by the node's mean radiosity in that class.

- An element of one piece: Lambert's exact point-to-polygon factor (core.formfactor) times the visible share of
  s x s stratified points on it, as for the classic patches.
- Any other node: each part of equal area a of each of its classes (core.cluster_tree) as a square of area a
  at the part's centroid, in the plane of its mean normal; Lambert's exact factor to that square (exact at any
  angle and distance, where Wallace et al.'s disk formula a cos cos / (pi r^2 + a) is exact only on its axis and
  fell 5-10% short off it), or the point kernel a cos cos / (pi r^2) for a square far away; with one shadow ray
  per part.

No receiver's links can cover more of its hemisphere than the solved surfaces do, so a row is capped to sum to
at most its ``covered`` share plus COVERED_MARGIN (the rays' sampling error), and never over one: a cluster of a
carved moulding's facets a few millimetres in front of a receiver, as squares at its parts' centroids, took the
whole hemisphere where rays found 40% of it covered, and the moulding's elements then lit each other to 3.6 times
their direct light. The energy the sampled links may
miss or add is balanced in the solve (core.hierarchical), against each receiver's ``covered`` share, the share of
its hemisphere that solved surfaces cover, measured with ``COVERAGE_SAMPLES^2`` stratified cosine-weighted rays
(what was tried instead: docs/benchmarks.md, History).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cluster_tree import NODE_SAMPLES, ClusterTree
from .clusters import FaceClusters
from .errors import BakeCancelled
from .formfactor import point_to_polygon, triangle_samples, visible_fraction
from .geometry import lengths, tangent_frames, triangle_unit_normals
from .parallel import ordered_map, steps_in_flight
from .progress import Progress, never_cancelled, no_progress
from .raycast import RayCaster
from .sampling import cosine_hemisphere, stratified_square

OPENING = 0.5
FORM_FACTOR_LIMIT = 0.02      # nor is a node accepted whose area could subtend more than this form factor
NEAR_SHARE = 0.02             # a sample square closer than this (a / (pi r^2)) takes Lambert's exact factor
COVERAGE_SAMPLES = 8          # per edge: 64 stratified rays per receiver measure how much of its hemisphere is covered
COVERED_MARGIN = 0.15         # over 2 standard errors of a share measured by 64 independent rays (at most 0.0625)
PAIRS_PER_STEP = 1 << 16      # link candidates evaluated at once (memory: ~ 24 samples x 200 bytes each)
RECEIVERS_PER_STEP = 1024     # receivers traversed at once: blocks small enough that the steps in flight
                              # keep every core busy to the end


@dataclass
class Links:
    """receiver (L,) and node (L,) of every link, int32; factor (L, 6) float32: F(receiver -> the node's surfaces
    of each direction class); unoccluded (L,) float32: the link's form factor without visibility (for its error
    bound); exact (L,): the link's factor is exact (a one-piece element), not sampled; partial (L,): some of the
    link's shadow rays were blocked and some not; covered (R,): the share of each receiver's hemisphere covered
    by solved surfaces, which its row sums to."""

    receiver: np.ndarray
    node: np.ndarray
    factor: np.ndarray
    unoccluded: np.ndarray
    exact: np.ndarray
    partial: np.ndarray
    covered: np.ndarray

    @property
    def count(self) -> int:
        return len(self.receiver)

    @property
    def nbytes(self) -> int:
        return sum(column.nbytes for column in self.columns)

    @property
    def columns(self) -> tuple:
        """The per-link arrays, in the order Links takes them."""
        return self.receiver, self.node, self.factor, self.unoccluded, self.exact, self.partial

    def subset(self, rows: np.ndarray) -> "Links":
        return Links(*(column[rows] for column in self.columns), self.covered)

    def transfer(self, which: np.ndarray) -> "Transfer":
        """The links ``which`` selects as a sparse transfer from node radiosity to receiver irradiance."""
        link, direction = np.nonzero(self.factor[which])
        chosen = np.flatnonzero(which)[link]
        return Transfer(self.receiver[chosen], (self.node[chosen] * 6 + direction).astype(np.int64),
                        self.factor[chosen, direction])


@dataclass
class Transfer:
    """Links as sparse entries: receiver (E,), source (E,) = node x 6 + direction class, factor (E,)."""

    receiver: np.ndarray
    source: np.ndarray
    factor: np.ndarray

    def gather(self, node_radiosity: np.ndarray, receiver_count: int) -> np.ndarray:
        """(R, 3) irradiance, W m^-2: sum over each receiver's entries of F B, with ``node_radiosity`` (N, 6, 3)
        the mean radiosity of every node's surfaces in each direction class."""
        radiosity = node_radiosity.reshape(-1, 3)[self.source]
        return np.stack([np.bincount(self.receiver, weights=self.factor * radiosity[:, c], minlength=receiver_count)
                         for c in range(3)], axis=1)


@dataclass
class LinkSources:
    """What links point at: the tree, the elements' polygons, and the shadow rays' targets (n x 2 x SAMPLES, 3),
    float32: each element sample lifted ``offset_m`` off its face on each side, in the tree's flat sample order
    ((element x 2 + side) x SAMPLES + k)."""

    tree: ClusterTree
    polygon: np.ndarray
    side_point: np.ndarray

    @classmethod
    def of(cls, tree: ClusterTree, clusters: FaceClusters, offset_m: float) -> "LinkSources":
        lift = offset_m * np.array([1.0, -1.0])[None, :, None, None] * clusters.sample_normal[:, None]
        side_point = clusters.sample_point[:, None] + lift                              # (n, 2, SAMPLES, 3)
        return cls(tree, clusters.polygon, side_point.reshape(-1, 3).astype(np.float32))


def build_links(sources: LinkSources, points: np.ndarray, normals: np.ndarray, own_element: np.ndarray,
                caster: RayCaster, opening: float, samples_per_edge: int, offset_m: float, covered: np.ndarray,
                progress: Progress = no_progress, cancelled=never_cancelled) -> Links:
    """Links of receivers at (R, 3) points with unit (R, 3) normals (``own_element`` (R,): the element each lies
    on, -1 for none), with their form factors and visibility; ``covered`` (R,) is each one's covered share
    (``covered_share``)."""
    def block_links(rows: np.ndarray) -> list:
        receiver, node = accepted_nodes(sources.tree, points[rows], normals[rows], own_element[rows], opening,
                                        offset_m)
        return [_links_part(sources, caster, points, normals, rows[receiver[start:start + PAIRS_PER_STEP]],
                            node[start:start + PAIRS_PER_STEP], samples_per_edge, offset_m)
                for start in range(0, len(receiver), PAIRS_PER_STEP)]

    blocks = [np.arange(first, min(first + RECEIVERS_PER_STEP, len(points)))
              for first in range(0, len(points), RECEIVERS_PER_STEP)]
    parts = []
    for rows, block in zip(blocks, ordered_map(block_links, blocks, steps_in_flight(caster.threads))):
        if cancelled():
            raise BakeCancelled("Bake cancelled while linking elements.")
        parts += block
        progress(rows[-1] / max(1, len(points) - 1), f"Linking: {rows[-1] + 1} of {len(points)} receivers")
    parts.append(_links_part(sources, caster, points, normals, np.zeros(0, int), np.zeros(0, int), 1, offset_m))
    links = Links(*(np.concatenate(column) for column in zip(*parts)), covered)
    _cap_rows(links)
    return links


def _links_part(sources, caster, points, normals, receiver, node, samples_per_edge, offset_m,
                keep_hidden=True) -> tuple:
    """Columns of Links (receiver, node, factor, unoccluded, exact) for (receiver, node) pairs, in their storage
    types: those with some factor, and, where ``keep_hidden`` (a bool or one per pair), those to clusters whose
    samples are all hidden but that are not out of sight (refinement may still find a visible bright part in
    them)."""
    factor, unoccluded, partial = link_factors(sources, caster, points[receiver], normals[receiver], node,
                                               samples_per_edge, offset_m)
    keep = (np.einsum("lc->l", factor) > 0) | ((unoccluded > 0) & (sources.tree.left[node] >= 0) & keep_hidden)
    return (receiver[keep].astype(np.int32), node[keep].astype(np.int32), factor[keep].astype(np.float32),
            unoccluded[keep].astype(np.float32), _exact(sources, node[keep]), partial[keep])


def refine_links(links: Links, sources: LinkSources, caster: RayCaster, points: np.ndarray, normals: np.ndarray,
                 deviation: np.ndarray, radiosity: np.ndarray, irradiance: np.ndarray, tolerance: float,
                 samples_per_edge: int, offset_m: float, cancelled=never_cancelled) -> Links:
    """Links whose error bound is too large replaced by links to the node's children, until none is (Hanrahan,
    Salzman & Aupperle 1991's BF refinement, with their refinement of partly visible links). The bound is the
    visible factor per class times the node's ``deviation`` (N, 6), the largest difference between one of its
    surfaces' radiosity and its class mean, plus the hidden part of the unoccluded factor times its largest
    deviation (four samples may all miss the bright part of a cluster); for a partly visible link, whose few
    shadow rays tell its visible share only in steps, the unoccluded factor times the node's mean radiosity
    ``radiosity`` (N,) is its bound. Too large is over ``tolerance`` times the receiver's ``irradiance`` (R,). A
    link to a cluster holding a lamp's panel or a sunlit patch, or half hidden by a block, seen from nearby, thus
    becomes links to its parts. A link whose shadow rays were all blocked is refined once: its children's parts
    are new samples, twice as many rays looking for a visible bright part; children hidden as well are dropped
    (descending further tests every element behind every wall: docs/benchmarks.md, History). Links left with no
    visible factor are dropped, and rows capped again. Receivers are refined ``RECEIVERS_PER_STEP`` at a time,
    so the links being split stay few however many levels open."""
    refined = lambda first: _refined(
        links.subset((links.receiver >= first) & (links.receiver < first + RECEIVERS_PER_STEP)), sources, caster,
        points, normals, deviation, radiosity, irradiance, tolerance, samples_per_edge, offset_m, cancelled)
    steps = list(ordered_map(refined, range(0, len(links.covered), RECEIVERS_PER_STEP),
                             steps_in_flight(caster.threads)))
    links = Links(*(np.concatenate(column) for column in zip(*[step.columns for step in steps])), links.covered)
    _cap_rows(links)
    return links


def _refined(links, sources, caster, points, normals, deviation, radiosity, irradiance, tolerance,
             samples_per_edge, offset_m, cancelled) -> Links:
    """``refine_links`` for some receivers' links: those left with a visible factor, refined as far as needed."""
    tree = sources.tree
    settled, pending = [], links
    while True:
        if cancelled():
            raise BakeCancelled("Bake cancelled while refining links.")
        spread = deviation[pending.node]
        hidden = np.maximum(pending.unoccluded - np.einsum("lc->l", pending.factor), 0.0)
        bound = np.einsum("ls,ls->l", pending.factor, spread) + hidden * spread.max(axis=1)
        bound = np.maximum(bound, pending.partial * pending.unoccluded * radiosity[pending.node])
        refine = (tree.left[pending.node] >= 0) & (bound > tolerance * irradiance[pending.receiver])
        settled.append(pending.subset(~refine & (np.einsum("lc->l", pending.factor) > 0)))
        if not refine.any():
            break
        receiver = np.repeat(pending.receiver[refine], 2)
        node = np.stack([tree.left[pending.node[refine]], tree.right[pending.node[refine]]], axis=1).ravel()
        seen = np.repeat(np.einsum("lc->l", pending.factor[refine]) > 0, 2)
        parts = [_links_part(sources, caster, points, normals, receiver[start:start + PAIRS_PER_STEP],
                             node[start:start + PAIRS_PER_STEP], samples_per_edge, offset_m,
                             seen[start:start + PAIRS_PER_STEP])
                 for start in range(0, len(node), PAIRS_PER_STEP)]
        pending = Links(*(np.concatenate(column) for column in zip(*parts)), links.covered)
    return Links(*(np.concatenate(column) for column in zip(*[part.columns for part in settled])), links.covered)


def covered_share(caster: RayCaster, points: np.ndarray, normals: np.ndarray, offset_m: float, receives,
                  seed: int) -> np.ndarray:
    """(R,) share of each point's cosine-weighted hemisphere covered by surfaces that receive light (stratified,
    seeded): ``receives(triangle, barycentric, direction)`` tells, for rays that hit, whether the side they land
    on is a live element side. Light landing on a dead side (the inside of an attic that no lamp or sky lights)
    leaves the solve, and no link reaches it, so it must not count here either."""
    share = np.zeros(len(points))
    rays = COVERAGE_SAMPLES ** 2
    step = max(1, (1 << 20) // rays)
    for start in range(0, len(points), step):
        rows = slice(start, start + step)
        local = cosine_hemisphere(stratified_square(len(points[rows]), COVERAGE_SAMPLES, seed + start))
        directions = np.einsum("msi,mik->msk", local, tangent_frames(normals[rows])).reshape(-1, 3)
        origins = np.repeat(points[rows] + offset_m * normals[rows], rays, axis=0)
        hit, barycentric = caster.first_hit(origins, directions)
        landed = np.flatnonzero(hit >= 0)
        received = np.zeros(len(hit), dtype=bool)
        received[landed] = receives(hit[landed], barycentric[landed], directions[landed])
        share[rows] = received.reshape(-1, rays).mean(axis=1)
    return share


def _cap_rows(links: Links) -> None:
    """Scale down the rows that sum to more than their receiver's covered share plus COVERED_MARGIN, or than one:
    no receiver's links cover more of its hemisphere than solved surfaces do, and a row over that makes light out
    of nothing."""
    row = np.bincount(links.receiver, weights=np.einsum("lc->l", links.factor), minlength=len(links.covered))
    most = np.minimum(links.covered + COVERED_MARGIN, 1.0)
    links.factor *= (most / np.maximum(row, most))[links.receiver, None].astype(np.float32)


def _exact(sources: LinkSources, node: np.ndarray) -> np.ndarray:
    """(q,) True for nodes that are one-piece elements (their links use the exact polygon factor)."""
    element = sources.tree.element[node]
    exact = np.zeros(len(node), dtype=bool)
    exact[element >= 0] = np.isfinite(sources.polygon[element[element >= 0], 0, 0])
    return exact


def accepted_nodes(tree: ClusterTree, points: np.ndarray, normals: np.ndarray, own_element: np.ndarray,
                   opening: float, offset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(receiver, node) pairs of the tree cut each receiver sees (see the module docstring), one step per level."""
    receiver, node = np.arange(len(points)), np.zeros(len(points), dtype=np.int64)
    accepted_receivers, accepted = [], []
    while len(receiver):
        low, high = tree.low[node], tree.high[node]
        centre, half = 0.5 * (low + high), 0.5 * (high - low)
        relative = centre - points[receiver]
        normal = normals[receiver]
        # The highest point of the node's box above the receiver's tangent plane.
        height = np.einsum("mk,mk->m", relative, normal) + np.einsum("mk,mk->m", np.abs(normal), half)
        leaf = tree.left[node] < 0
        keep = (height > offset_m) & ~(leaf & (tree.element[node] == own_element[receiver]))
        distance2 = np.einsum("mk,mk->m", relative, relative)
        far = (np.einsum("mk,mk->m", half, half) < (opening ** 2) * distance2) & \
            (np.einsum("mc->m", tree.class_exposed[node]) < FORM_FACTOR_LIMIT * np.pi * distance2)
        accept = keep & (leaf | far)
        accepted_receivers.append(receiver[accept])
        accepted.append(node[accept])
        split = keep & ~accept
        receiver = np.repeat(receiver[split], 2)
        node = np.stack([tree.left[node[split]], tree.right[node[split]]], axis=1).ravel()
    return np.concatenate(accepted_receivers), np.concatenate(accepted)


def link_factors(sources: LinkSources, caster: RayCaster, points: np.ndarray, normals: np.ndarray,
                 node: np.ndarray, samples_per_edge: int, offset_m: float,
                 lift=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, 6) F(point -> node's surfaces of each direction class) with visibility, (q,) the same without
    visibility, summed over classes, and (q,) whether some of the shadow rays were blocked and some not, for q
    (point, node) pairs. ``lift`` (core.terminator.ShadowLift per point, optional) starts the shadow rays of
    smooth-shaded points on their smooth surface."""
    factor, unoccluded, partial = np.zeros((len(node), 6)), np.zeros(len(node)), np.zeros(len(node), dtype=bool)
    element = sources.tree.element[node]
    exact = _exact(sources, node)
    rows = np.flatnonzero(exact)
    if len(rows):
        factor[rows], unoccluded[rows] = _polygon_factors(
            caster, points[rows], normals[rows], sources.polygon[element[rows]], sources.tree.side_class[element[rows]],
            samples_per_edge, offset_m, _rows(lift, rows))
    rows = np.flatnonzero(~exact)
    if len(rows):
        factor[rows], unoccluded[rows], partial[rows] = _sampled_factors(sources, caster, points[rows],
                                                                         normals[rows], node[rows], offset_m,
                                                                         _rows(lift, rows))
    return factor, unoccluded, partial


def sample_squares(points: np.ndarray, normals: np.ndarray, area_m2: np.ndarray) -> np.ndarray:
    """(m, 4, 3) squares of the given areas centred on the points, in the planes the unit normals give, wound so
    that their normals are those normals."""
    frame = tangent_frames(normals)
    half = 0.5 * np.sqrt(area_m2)[:, None, None]
    corners = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    return points[:, None, :] + half * np.einsum("vc,mck->mvk", corners, frame[:, :2])


def _rows(lift, rows):
    return None if lift is None else lift[rows]


def _polygon_factors(caster, points, normals, polygon, side_class, samples_per_edge, offset_m, lift):
    """(q, 6): Lambert's factor to each one-piece element times its visible share, in the class (``side_class``
    (q, 2) per side) of the side that faces the point; and (q,) Lambert's factor alone."""
    factor = np.zeros((len(points), 6))
    polygon_normal = triangle_unit_normals(polygon)
    back = (np.einsum("mk,mk->m", points - polygon[:, 0], polygon_normal) < 0).astype(np.int64)
    side = side_class[np.arange(len(points)), back]
    unoccluded = point_to_polygon(points, normals, polygon)
    seen = np.flatnonzero(unoccluded > 0)
    visible = visible_fraction(caster, points[seen], normals[seen], triangle_samples(polygon[seen], samples_per_edge),
                               polygon_normal[seen], offset_m, offset_m, _rows(lift, seen))
    factor[seen, side[seen]] = unoccluded[seen] * visible
    return factor, unoccluded


def _sampled_factors(sources: LinkSources, caster, points, normals, node, offset_m, lift):
    """(q, 6): per direction class, the factor to the node's sample squares of that class that face the point,
    each seen or not by one shadow ray; (q,) the factor to all of them, seen or not; and (q,) whether some were
    seen and some not. A square of area a whose
    a / (pi r^2) is below ``NEAR_SHARE`` takes the point kernel a cos cos / (pi r^2) (within 2% of Lambert's
    exact factor to it); nearer ones take the exact factor. The geometry is float32, as the tree's parts are:
    these arrays are the largest of the solve."""
    tree = sources.tree
    per_part = tree.sample.shape[-1]
    pair, direction = np.nonzero(tree.class_exposed[node] > 0)          # only the classes a node has
    part = node[pair] * 6 + direction                                   # (m,): flat (node, class) of each
    delta = tree.centroid.reshape(-1, per_part, 3)[part] - points.astype(np.float32)[pair, None, :]   # (m, K, 3)
    receiver_side = np.einsum("mki,mi->mk", delta, normals.astype(np.float32)[pair]).ravel()   # r cos(receiver)
    source_side = -np.einsum("mki,mki->mk", delta, tree.normal.reshape(-1, per_part, 3)[part]).ravel()
    facing = np.flatnonzero((receiver_side > 0) & (source_side > 0))    # (f,) of the m K squares
    facing_pair = facing // per_part
    square = part[facing_pair] * per_part + facing % per_part           # (f,): flat (node, class, part)
    delta = delta.reshape(-1, 3)[facing]
    distance2 = np.einsum("fi,fi->f", delta, delta).astype(np.float64)
    square_area = tree.class_exposed.ravel()[part[facing_pair]] / NODE_SAMPLES
    weight = square_area * receiver_side[facing] * source_side[facing] / (np.pi * distance2 ** 2)
    close = np.flatnonzero(square_area > NEAR_SHARE * np.pi * distance2)
    if len(close):
        polygon = sample_squares(tree.centroid.reshape(-1, 3)[square[close]].astype(np.float64),
                                 tree.normal.reshape(-1, 3)[square[close]].astype(np.float64), square_area[close])
        receiver = pair[facing_pair[close]]
        weight[close] = point_to_polygon(points[receiver], normals[receiver], polygon)
    owner = pair[facing_pair]
    unoccluded = np.bincount(owner, weights=weight, minlength=len(node))
    origin = (points + offset_m * normals).astype(np.float32)[owner]
    if lift is not None:
        origin = lift[owner].origins(origin[:, None, :], (delta / lengths(delta)[:, None])[:, None, :])[:, 0]
    ray = sources.side_point[tree.sample.ravel()[square]] - origin
    length = lengths(ray)
    seen = ~caster.occluded(origin, ray / np.maximum(length, 1e-30)[:, None], length)
    factor = np.bincount(owner[seen] * 6 + direction[facing_pair[seen]], weights=weight[seen],
                         minlength=6 * len(node)).reshape(-1, 6)
    shown = np.bincount(owner, weights=seen, minlength=len(node))
    partial = (shown > 0) & (shown < np.bincount(owner, minlength=len(node)))
    return factor, unoccluded, partial
