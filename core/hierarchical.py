"""Hierarchical radiosity with clustering over face clusters, two-sided: the default solver, for any scene size.

1. Elements (core.clusters) have two sides. A side whose sample points all lie inside closed geometry (the inside
   of a closed prop, a floor under a box: core.surface_probes.inside_closed_geometry along that side's normal) or repeat
   another face's side (a two-sided sheet made of two copies of a face: core.geometry.duplicate_sides), or whose
   hemisphere meets no live side (core.links.covered_share: the bottom of a box resting on a floor), sends no
   light (the first two are dead: they neither receive nor send). Every other side reflects, with the element's
   reflectance, as Cycles shades the back of a single-sided wall or drape.
2. Each live side receives at one point (its exposed sample nearest the element's centroid) through links to the
   cluster tree (core.links), with form factors and visibility; its direct light is the mean over its exposed
   samples.
3. Radiosity is found by Jacobi iteration of B = E + rho (H_direct + sum_links F B_node) (Cohen & Wallace 1993,
   ch. 5), where B_node is a node's mean radiosity per side over its exposed area, summed from the leaves up
   (core.cluster_tree). It stops when the change in radiated power falls below the residual threshold, and the
   receivers' own irradiance has settled to that threshold over most of the lit area; the light the remaining
   iterations would add is the ambient term (Cohen et al. 1988), a geometric series whose ratio is the decay of that
   change from one iteration to the next.

Memory: the links (16 bytes each, a few hundred per live side), the tree (O(n)) and per-element arrays: nothing is
O(n^2), and nothing depends on the input triangle count beyond the pieces.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .cluster_tree import ClusterTree
from .clusters import SAMPLES, FaceClusters
from .errors import BakeCancelled
from .geometry import duplicate_sides, triangle_unit_normals
from .analytic_lights import direct_irradiance
from .links import Links, Transfer
from .mesh import ElementMesh
from .progress import Progress, never_cancelled, no_progress
from .raycast import RayCaster
from .scene import Scene
from .solver import ConvergenceStep
from .surface_probes import inside_closed_geometry

SIDES = np.array([1.0, -1.0])  # front, back: the side's normal is SIDES[side] x the element's normal
# The solve runs until the receivers making up this share of the lit area changed their irradiance by at most the
# residual threshold in the last iteration. The radiated power's change is the bright surfaces': light that settles
# slowly between dim ones (an arcade's floor lit off its ceiling) stopped 13-24% off (docs/benchmarks.md,
# "Settled receivers").
SETTLED_AREA_SHARE = 0.95
SETTLED_MIN_LIGHT = 1e-3  # of the receivers' mean irradiance: dimmer ones do not count as lit there
EMITTED, REFLECTED = 0, 1  # the parts of the light the links transfer, each with its energy balance


def sample_exposure(clusters: FaceClusters, mesh: ElementMesh, caster: RayCaster, scene: Scene,
                    offset_m: float, seed: int) -> np.ndarray:
    """(n, 2, SAMPLES) exposed area each element sample stands for on each side, m^2: area / SAMPLES, or 0 where
    the sample lies inside closed geometry as seen along that side's normal and no lamp or sky lights it there
    (a room whose normals were flipped outwards is closed geometry too, but lit inside), or where its face's side
    is a duplicate."""
    points = np.broadcast_to(clusters.sample_point[:, None], (clusters.count, 2, SAMPLES, 3)).reshape(-1, 3)
    normals = (clusters.sample_normal[:, None] * SIDES[None, :, None, None]).reshape(-1, 3)
    inside = inside_closed_geometry(caster, scene.triangles, points, normals, offset_m)
    enclosed = np.flatnonzero(inside)
    lit = direct_irradiance(scene, caster, points[enclosed], normals[enclosed], offset_m, 1, seed).max(axis=1) > 0
    inside[enclosed[lit]] = False
    duplicate = duplicate_sides(mesh.triangles, offset_m / 10)
    piece_triangle = mesh.node_triangle[clusters.piece_node[clusters.sample_piece]]        # (n, SAMPLES)
    repeated = duplicate[piece_triangle].transpose(0, 2, 1).reshape(-1)                     # (n, 2, SAMPLES)
    share = np.repeat(clusters.area_m2 / SAMPLES, 2 * SAMPLES)
    return np.where(inside | repeated, 0.0, share).reshape(clusters.count, 2, SAMPLES)


def sample_direct_irradiance(scene: Scene, clusters: FaceClusters, caster: RayCaster, element: np.ndarray,
                             side: np.ndarray, offset_m: float, samples_per_edge: int, seed: int) -> np.ndarray:
    """(R, SAMPLES, 3) direct irradiance, W m^-2, at the samples of the given element sides, each sample with
    ceil(s / sqrt(SAMPLES)) of the s light samples per edge."""
    points = clusters.sample_point[element].reshape(-1, 3)
    normals = (clusters.sample_normal[element] * SIDES[side][:, None, None]).reshape(-1, 3)
    per_sample = -(-samples_per_edge // int(np.sqrt(SAMPLES)))
    irradiance = direct_irradiance(scene, caster, points, normals, offset_m, per_sample, seed)
    return irradiance.reshape(len(element), SAMPLES, 3)


def side_mean(exposed_samples: np.ndarray, element: np.ndarray, side: np.ndarray, per_sample: np.ndarray):
    """(R, 3) the mean of ``per_sample`` (R, SAMPLES, 3) over each side's exposed samples, weighted by the area
    they stand for. (At one receiver point, an element the sun crosses, a coarse gallery floor half in sunlight,
    was all sunlit or all in shade: on the courtyard's galleries that point came out 0.4 to 1.9 times the
    element's mean.)"""
    weight = exposed_samples[element, side]
    return np.einsum("rs,rsk->rk", weight, per_sample) / np.maximum(weight.sum(axis=1), 1e-300)[:, None]


def side_direct_irradiance(scene: Scene, clusters: FaceClusters, caster: RayCaster, exposed_samples: np.ndarray,
                           element: np.ndarray, side: np.ndarray, offset_m: float, samples_per_edge: int,
                           seed: int) -> np.ndarray:
    """(R, 3) direct irradiance, W m^-2, of the given element sides: the mean over each side's exposed samples."""
    per_sample = sample_direct_irradiance(scene, clusters, caster, element, side, offset_m, samples_per_edge, seed)
    return side_mean(exposed_samples, element, side, per_sample)


def live_side_test(scene: Scene, mesh: ElementMesh, node_element: np.ndarray, alive: np.ndarray):
    """``receives(triangle, barycentric, direction)`` for core.links.covered_share: whether rays along
    ``direction`` that hit scene triangles at those barycentrics land on a live side (``alive`` (n, 2)) of the
    element there (``node_element``: the element of each leaf of ``mesh``)."""
    to_mesh = mesh.scene_to_mesh(len(scene.triangles))

    def receives(triangle: np.ndarray, barycentric: np.ndarray, direction: np.ndarray) -> np.ndarray:
        out = np.zeros(len(triangle), dtype=bool)
        solved = np.flatnonzero(to_mesh[triangle] >= 0)
        node, _ = mesh.locate(to_mesh[triangle[solved]], barycentric[solved])
        element = node_element[node]
        back = np.einsum("mk,mk->m", triangle_unit_normals(scene.triangles[triangle[solved]]), direction[solved]) > 0
        out[solved] = (element >= 0) & alive[np.maximum(element, 0), back.astype(np.int64)]
        return out

    return receives


@dataclass
class Receivers:
    """The live element sides: element (R,) and side (R,) (0 front, 1 back), point (R, 3) and unit normal (R, 3)."""

    element: np.ndarray
    side: np.ndarray
    point: np.ndarray
    normal: np.ndarray

    @classmethod
    def of(cls, clusters: FaceClusters, exposed_samples: np.ndarray) -> "Receivers":
        """Every side with an exposed sample; it receives at the exposed sample nearest the element's centroid."""
        element, side = np.nonzero(exposed_samples.sum(axis=2) > 0)
        distance = np.linalg.norm(clusters.sample_point - clusters.centroid[:, None, :], axis=2)  # (n, SAMPLES)
        distance = np.where(exposed_samples[element, side] > 0, distance[element], np.inf)
        nearest = np.argmin(distance, axis=1)
        point = clusters.sample_point[element, nearest]
        normal = clusters.normal[element] * SIDES[side][:, None]
        return cls(element, side, point, normal)


@dataclass
class HierarchicalState:
    """Per element side (n, 2, 3): direct irradiance and total irradiance (W m^-2); per element reflectance
    (n, 3); per side (n, 2) the exposed area and the area that sends light into the scene (0 for isolated sides);
    the solve's history, the enclosure (the share of the light leaving the receivers that lands on the scene, from
    the links' covered shares), the irradiance each receiver last gathered from reflected light and what the last
    iteration added to it (R, 3), the change in radiated power (3,) W of the last iteration and its ratio to the
    one before (the iteration's decay per channel); per side (n, 2, SAMPLES) the area each element sample stands
    for (sample_exposure), where the direct light of another lighting of the same elements is measured; the
    energy balance's scales of the sampled links' transfer (2, 3), of the emitted and of the reflected light, as
    last measured (_BalancedTransfer)."""

    clusters: FaceClusters
    tree: ClusterTree
    receivers: Receivers
    links: Links
    exposed_m2: np.ndarray
    sending_m2: np.ndarray
    reflectance: np.ndarray
    direct_irradiance: np.ndarray
    irradiance: np.ndarray
    history: list[ConvergenceStep] = field(default_factory=list)
    enclosure: float = 0.0
    gathered: np.ndarray | None = None
    increment: np.ndarray | None = None
    power_change_w: np.ndarray | None = None
    decay: np.ndarray | None = None
    exposed_samples: np.ndarray | None = None
    sampled_scale: np.ndarray | None = None

    @property
    def emission(self) -> np.ndarray:
        """(n, 2, 3) emitted exitance per side: materials emit from the front of their faces."""
        out = np.zeros_like(self.irradiance)
        out[:, 0] = self.clusters.emitted_exitance
        return out

    @property
    def radiosity(self) -> np.ndarray:
        """(n, 2, 3) B = E + rho H per side, W m^-2."""
        return self.emission + self.reflectance[:, None, :] * self.irradiance

    @property
    def residual(self) -> float:
        return self.history[-1].residual if self.history else 0.0

    def reflected_irradiance(self) -> np.ndarray:
        """(n, 2, 3) the irradiance each side gathers from reflected light (its indirect light), W m^-2."""
        out = np.zeros_like(self.irradiance)
        if self.gathered is not None:
            out[self.receivers.element, self.receivers.side] = self.gathered
        return out

    def ambient(self) -> np.ndarray:
        """(n, 2, 3) irradiance the unfinished iterations would still add: each side's last increment continued as
        a geometric series of ratio r per channel (Cohen et al. 1988's ambient term, with the light spread where it
        was last arriving rather than evenly, since the outside of a room's walls never gets any). r is the decay
        of the radiated power's change over the last two iterations: Jacobi's error shrinks by the spectral radius
        of rho F each iteration (Cohen & Wallace 1993, ch. 5), at most the largest reflectance (F's rows sum to 1
        at most), which bounds a ratio measured across a change of links. After a single iteration, r = rho_eff f
        instead: the reflectance and the enclosure, both weighted by the power the sides radiate."""
        if self.increment is None:
            return np.zeros_like(self.irradiance)
        receivers = self.receivers
        if self.decay is not None:
            ratio = np.clip(self.decay, 0.0, self.reflectance[receivers.element].max(axis=0))
        else:
            power = self.radiosity[receivers.element, receivers.side] * \
                self.exposed_m2[receivers.element, receivers.side][:, None]
            rho = (self.reflectance[receivers.element] * power).sum(axis=0) / np.maximum(power.sum(axis=0), 1e-300)
            ratio = np.clip(rho * self.enclosure, 0.0, 0.99)
        tail = np.zeros_like(self.irradiance)
        tail[receivers.element, receivers.side] = self.increment * ratio / (1.0 - ratio)
        return tail


def settled_change(state: HierarchicalState, area_m2: np.ndarray) -> float:
    """The last iteration's change of a receiver's irradiance over that irradiance (summed over RGB) that the
    receivers making up SETTLED_AREA_SHARE of the lit area (``area_m2`` (R,) per receiver) stay within. Lit: at
    least SETTLED_MIN_LIGHT of the receivers' mean irradiance, so that a crack's trickle of light holds no solve."""
    total = state.irradiance[state.receivers.element, state.receivers.side].sum(axis=1)
    lit = total > SETTLED_MIN_LIGHT * np.average(total, weights=area_m2)
    if not lit.any():
        return 0.0
    change = np.abs(state.increment[lit]).sum(axis=1) / total[lit]
    order = np.argsort(change, kind="stable")
    covered = np.cumsum(area_m2[lit][order])
    return float(change[order][min(np.searchsorted(covered, SETTLED_AREA_SHARE * covered[-1]), len(order) - 1)])


def node_radiosity(tree: ClusterTree, radiosity: np.ndarray, exposed_m2: np.ndarray) -> np.ndarray:
    """(N, 6, 3) mean radiosity of every node's surfaces per direction class, weighted by exposed area (0 where
    nothing is exposed); ``radiosity`` (n, 2, 3) and ``exposed_m2`` (n, 2) per element side."""
    sums = tree.node_sums(tree.by_class(radiosity * exposed_m2[..., None]))
    return sums / np.maximum(tree.class_exposed[..., None], 1e-300)


def node_deviation(tree: ClusterTree, radiosity: np.ndarray, exposed_m2: np.ndarray) -> np.ndarray:
    """(N, 6) largest difference, summed over RGB, between the radiosity of a node's live surfaces in each
    direction class and their mean (0 for leaves and empty classes)."""
    total = radiosity.sum(axis=2)
    low, high = tree.class_range(total, exposed_m2 > 0)
    mean = node_radiosity(tree, radiosity, exposed_m2).sum(axis=2)
    deviation = np.maximum(high - mean, mean - low)
    return np.where(np.isfinite(deviation) & (tree.left[:, None] >= 0), deviation, 0.0)


def solve(state: HierarchicalState, residual_threshold: float, max_iterations: int,
          rays=lambda: 0, progress: Progress = no_progress, cancelled=never_cancelled,
          sampled_scale: np.ndarray | None = None, min_iterations: int = 1) -> HierarchicalState:
    """Jacobi iterations, from the state's irradiance, until the change in radiated power is below
    ``residual_threshold`` of the injected power (emission plus first reflection of direct light) and the lit
    area's receivers have settled to it (``settled_change``), and at least ``min_iterations`` of them (a light
    group's solve as many as the solve of the whole, so that the ambient term, measured from the last two, is
    measured alike: ``HierarchicalState.ambient``). Emitted and
    reflected radiosity are gathered apart (_BalancedTransfer): the light straight from emissive surfaces once,
    the reflected light (``gathered``: the indirect light outputs interpolate) in every iteration. With
    ``sampled_scale`` (another solve's, on the same links) the balance keeps that scale: the transfer is then one
    linear operator, and the solves of light groups sum to the solve of their sum."""
    started = time.perf_counter()
    receivers, links = state.receivers, state.links
    area = state.exposed_m2[receivers.element, receivers.side][:, None]
    injected = float(((state.emission + state.reflectance[:, None, :] * state.direct_irradiance) *
                      state.exposed_m2[..., None]).sum())
    first = state.history[-1].shots + 1 if state.history else 1
    fixed = sampled_scale is not None
    state.sampled_scale = np.array(sampled_scale, dtype=np.float64) if fixed else np.ones((2, 3))
    transfer = _BalancedTransfer(state, links.transfer(links.exact), links.transfer(~links.exact), area, fixed)
    emitted = transfer.gather(state.emission, EMITTED)  # the same in every iteration: light straight from emitters
    radiosity = state.radiosity
    for iteration in range(first, first + max_iterations):
        if cancelled():
            raise BakeCancelled("Bake cancelled during the radiosity solve.")
        reflected = transfer.gather(radiosity - state.emission, REFLECTED)
        state.irradiance = state.direct_irradiance.copy()
        state.irradiance[receivers.element, receivers.side] += emitted + reflected
        state.increment = reflected - (0.0 if state.gathered is None else state.gathered)
        state.gathered = reflected
        updated = state.radiosity
        change = updated - radiosity
        radiosity = updated
        power_change = (np.abs(change) * state.exposed_m2[..., None]).sum(axis=(0, 1))
        if state.power_change_w is not None:
            state.decay = power_change / np.maximum(state.power_change_w, 1e-300)
        state.power_change_w = power_change
        residual = float(power_change.sum() / injected) if injected else 0.0
        state.history.append(ConvergenceStep(iteration, residual, time.perf_counter() - started, rays()))
        unsettled = max(residual, settled_change(state, area[:, 0]))
        progress(min(1.0, np.log(max(unsettled, 1e-12)) / np.log(max(residual_threshold, 1e-12))),
                 f"Solving: iteration {iteration}, residual {residual:.4f}")
        if unsettled <= residual_threshold and iteration - first + 1 >= min_iterations:
            break
    # The enclosure: the share of the power the receivers radiate that lands on the scene.
    power = (radiosity[receivers.element, receivers.side] * area).sum(axis=1)
    state.enclosure = float(links.covered @ power / max(power.sum(), 1e-300))
    return state


class _BalancedTransfer:
    """The links' transfer of a radiosity (n, 2, 3) to the receivers' irradiance (R, 3), with the part that comes
    through sampled (cluster) links scaled, per channel, so that the power the live sides receive equals the power
    the links take from them, sum A_j B_j F_j with F_j the sum of side j's own link factors (the share of its
    hemisphere its links cover: by the definition of the form factor, the share of what it radiates that lands on
    what they link to): the energy balance every exact solve satisfies (Cohen & Wallace 1993, ch. 4). A cluster's
    mean radiosity times its form factor misses the correlation between the two (a lamp's pool of light is also
    the part of a wall nearest to most receivers), which left a closed room lit by a point light 4.5% short of its
    closed-form indirect light; exact links (to one-piece elements) are left as they are. Why the balance is
    against the links' own factors and not a ray-measured covered share: docs/benchmarks.md, History."""

    def __init__(self, state: HierarchicalState, exact: Transfer, sampled: Transfer, area: np.ndarray,
                 fixed: bool):
        self.state, self.exact, self.sampled, self.area, self.fixed = state, exact, sampled, area, fixed
        links = state.links
        self.linked = np.bincount(links.receiver, weights=np.einsum("lc->l", links.factor),
                                  minlength=len(links.covered))

    def gather(self, radiosity: np.ndarray, part: int) -> np.ndarray:
        """The receivers' irradiance (R, 3) from ``radiosity``: emitted (``part`` 0) or reflected (1)."""
        state, receivers = self.state, self.state.receivers
        count = len(receivers.element)
        means = node_radiosity(state.tree, radiosity, state.sending_m2)
        exact, sampled = self.exact.gather(means, count), self.sampled.gather(means, count)
        if self.fixed:
            return exact + sampled * state.sampled_scale[part]
        sent = (radiosity[receivers.element, receivers.side] * self.area * self.linked[:, None]).sum(axis=0)
        received = (sampled * self.area).sum(axis=0)
        scale = np.clip((sent - (exact * self.area).sum(axis=0)) / np.maximum(received, 1e-300), 0.5, 2.0)
        state.sampled_scale[part] = np.where(received > 0, scale, 1.0)
        return exact + sampled * state.sampled_scale[part]
