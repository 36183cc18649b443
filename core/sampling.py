"""Deterministic stratified samples: jittered grids with a seeded per-point shift (Cranley-Patterson rotation).

Shirley & Chiu 1997 give the concentric square-to-disk map; Malley's method lifts the disk to a cosine-weighted
hemisphere (Pharr, Jakob & Humphreys, PBRT 4th ed., 13.6).
"""
from __future__ import annotations

import numpy as np


def stratified_square(count: int, samples_per_edge: int, seed: int) -> np.ndarray:
    """(count, s^2, 2) points in [0, 1)^2: an s x s grid of cell centres shifted per point by a seeded offset."""
    cells = (np.stack(np.meshgrid(np.arange(samples_per_edge), np.arange(samples_per_edge), indexing="ij"), -1)
             .reshape(-1, 2) + 0.5) / samples_per_edge
    shift = np.random.default_rng(seed).random((count, 1, 2))
    return (cells[None] + shift) % 1.0


def concentric_disk(square: np.ndarray) -> np.ndarray:
    """Map points of [0, 1)^2 to the unit disk, preserving stratification (Shirley & Chiu 1997)."""
    a, b = 2.0 * square[..., 0] - 1.0, 2.0 * square[..., 1] - 1.0
    use_a = np.abs(a) > np.abs(b)
    radius = np.where(use_a, a, b)
    safe_a = np.where(a == 0, 1.0, a)
    safe_b = np.where(b == 0, 1.0, b)
    angle = np.where(use_a, np.pi / 4 * (b / safe_a), np.pi / 2 - np.pi / 4 * (a / safe_b))
    angle = np.where((a == 0) & (b == 0), 0.0, angle)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1)


def cosine_hemisphere(square: np.ndarray) -> np.ndarray:
    """Cosine-weighted directions (local frame, z up) from points of [0, 1)^2 (Malley's method)."""
    disk = concentric_disk(square)
    z = np.sqrt(np.maximum(0.0, 1.0 - (disk ** 2).sum(axis=-1)))
    return np.concatenate([disk, z[..., None]], axis=-1)
