"""Adaptive meshing (radiosity paper, section 6; Cohen et al. 1986): split elements where light changes fast.

An element is split into four when, relative to the local light level plus a floor of ``floor_fraction`` times
the scene's mean irradiance,
- the direct irradiance sampled at its three (slightly inset) corners and its centroid varies by more than
  ``threshold`` (a shadow boundary or a light's falloff crosses it: visibility changes across the element), or
- its irradiance differs from an edge neighbour's by more than ``threshold`` (a steep gradient);
and its edges are still longer than the minimum element size. New elements get their own direct light and gather
every patch's shot radiosity, so no patch needs to shoot again for them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import longest_edges
from .mesh import ElementMesh, Elements, elements_of, weld_vertices

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
CORNER_INSET = 0.15


@dataclass(frozen=True)
class RefinementCriteria:
    threshold: float
    min_edge_m: float
    floor_fraction: float = 0.05


def corner_sample_points(elements: Elements) -> np.ndarray:
    """(n, 3, 3) points just inside each element's corners (inset towards the centroid)."""
    return (1.0 - CORNER_INSET) * elements.corners + CORNER_INSET * elements.centroid[:, None, :]


def edge_neighbours(mesh: ElementMesh, nodes: np.ndarray, weld_tolerance_m: float) -> np.ndarray:
    """(k, 2) positions (into ``nodes``) of element pairs that share an edge."""
    _, corner_vertex = weld_vertices(mesh, nodes, weld_tolerance_m)
    edges = np.sort(np.stack([corner_vertex, np.roll(corner_vertex, -1, axis=1)], axis=2), axis=2).reshape(-1, 2)
    owner = np.repeat(np.arange(len(nodes)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    same = (edges[1:] == edges[:-1]).all(axis=1)
    return np.stack([owner[:-1][same], owner[1:][same]], axis=1)


def elements_to_split(mesh: ElementMesh, elements: Elements, irradiance: np.ndarray, corner_direct: np.ndarray,
                      centroid_direct: np.ndarray, criteria: RefinementCriteria, weld_tolerance_m: float) -> np.ndarray:
    """Positions (into ``elements``) of the elements the criteria above ask to split.

    corner_direct: (n, 3, 3) direct irradiance at the inset corners; centroid_direct, irradiance: (n, 3).
    """
    level = irradiance @ LUMINANCE
    floor = criteria.floor_fraction * float((level * elements.area_m2).sum() / elements.area_m2.sum())
    direct = np.concatenate([corner_direct @ LUMINANCE, (centroid_direct @ LUMINANCE)[:, None]], axis=1)
    wants = (direct.max(axis=1) - direct.min(axis=1)) > criteria.threshold * (direct.mean(axis=1) + floor)
    pairs = edge_neighbours(mesh, elements.node, weld_tolerance_m)
    jump = np.abs(level[pairs[:, 0]] - level[pairs[:, 1]])
    steep = jump > criteria.threshold * (0.5 * (level[pairs[:, 0]] + level[pairs[:, 1]]) + floor)
    wants[pairs[steep].ravel()] = True
    longest_edge = longest_edges(elements.corners)
    return np.flatnonzero(wants & (longest_edge / 2.0 >= criteria.min_edge_m))


def split_elements(mesh: ElementMesh, scene, elements: Elements, positions: np.ndarray) -> tuple[Elements, np.ndarray]:
    """Split the given elements; returns the new full element set and, for each of its elements, the position
    of the same element in the old set (-1 for the new children)."""
    old_position = np.full(len(mesh.node_bary), -1)
    old_position[elements.node] = np.arange(len(elements.node))
    mesh.split(elements.node[positions])
    refined = elements_of(mesh, scene)
    grown = np.full(len(mesh.node_bary), -1)
    grown[: len(old_position)] = old_position
    return refined, grown[refined.node]
