"""Denoising the final gather's indirect light over a lightmap page, guided by the gather's own noise.

A cross-bilateral filter whose range term is the difference of two texels' gathered values measured in their
estimated noise, the per-pixel distance of non-local means filtering for Monte Carlo images (Rousselle, Knaus &
Zwicker 2012, "Adaptive Rendering with Non-Local Means Filtering", section 4.1):

    d^2(p, q) = [(u_p - u_q)^2 - (Var_p + min(Var_p, Var_q))] / [eps + k^2 (Var_p + Var_q)],
    w(p, q)   = exp(-max(0, d^2))      (d^2 averaged over the colour channels),

where u is a texel's gathered light and Var the variance of that mean (the rays' sample variance over their
count; stratified directions make it an overestimate, which errs on the side of smoothing). Two texels whose values
differ by no more than their noise are averaged; a real change of the indirect light, a contact shadow or a bright
wall's bounce, differs by more and is kept.

The filter runs in passes over ever wider windows (the a-trous scheme: Dammertz et al. 2010, "Edge-Avoiding
A-Trous Wavelet Transform for fast Global Illumination Filtering"): a 3 x 3 window of neighbours PASS_STEPS[i]
texels apart. Each pass hands the next the variance of its weighted means, sum(w^2 Var) / (sum w)^2 (the
neighbours' rays are independent), so a later pass averages only what is still noise at its lower level (Schied
et al. 2017, "Spatiotemporal Variance-Guided Filtering", section 4.4).

A second range term of the same form keeps apart texels whose gather rays met nearby surfaces in different shares
(a guide feature, as in Rousselle, Manzi & Zwicker 2013, "Robust Denoising using Feature and Color Information"):
the share p of a texel's N rays that land within a few texels, with the binomial variance p (1 - p) / N (at least
1 / N^2). A soffit's corner, where most rays meet the next arch a few centimetres away, is darker than the open
span beside it by about the span's noise: the light alone let the span's texels in, and the corner came out at
over twice Cycles' light; its share of close hits, 0.75 to 0.86 against 0 to 0.5 beside it, tells them apart.

Neighbours count only on the same surface: normals within NORMAL_COSINE of each other, the neighbour within
PLANE_TEXELS of the texel's plane, and no farther away in the world than its place in the grid allows (texels of
another chart that sit beside it in the atlas are not its neighbours). Direct light, exact per texel, is not
filtered.
"""
from __future__ import annotations

import numpy as np

from .geometry import lengths

# Steps of the passes' windows and k of the range term: measured on the courtyard (docs/benchmarks.md,
# "Denoising the gather" and "The denoiser in passes").
PASS_STEPS = (1, 2)
NOISE_MULTIPLE = 2.0
NORMAL_COSINE = 0.9
PLANE_TEXELS = 0.5
GRID_SLACK_TEXELS = 1.5


def denoise_gathered(pixel: np.ndarray, width: int, height: int, points: np.ndarray, normals: np.ndarray,
                     texel_m: np.ndarray, light: np.ndarray, variance: np.ndarray,
                     parts: np.ndarray | None = None, guide: tuple[np.ndarray, int] | None = None) -> np.ndarray:
    """(m, 3) filtered ``light`` of m texels at flat ``pixel`` indices (y * width + x) of a page, with their (m, 3)
    world ``points``, unit ``normals``, (m,) edge length ``texel_m`` and the (m, 3) ``variance`` of each mean.
    With ``parts`` (G, m, 3), parts of the light that sum to it (light groups), the parts are filtered instead, with
    the weights ``light`` gives: a linear filter, so that they still sum to the filtered light. With ``guide``
    ((m,) share of each texel's rays that landed close by, rays per texel), the shares' range term too."""
    texel_at = np.full(width * height, -1, dtype=np.int64)
    texel_at[pixel] = np.arange(len(pixel))
    filtered = light if parts is None else parts
    share, rays = guide if guide is not None else (np.zeros(len(pixel)), 1)
    share_variance = np.maximum(share * (1.0 - share), 1.0 / rays) / rays
    for step in PASS_STEPS:
        neighbours = [_neighbours(pixel, width, height, texel_at, points, normals, texel_m, dx * step, dy * step)
                      for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dx or dy]
        neighbours = [(texel, neighbour, _noise_weight(share[texel, None], share_variance[texel, None],
                                                       share[neighbour, None], share_variance[neighbour, None]))
                      for texel, neighbour in neighbours]
        filtered, variance = _filter_pass(neighbours, light, variance, filtered)
        light = filtered if parts is None else filtered.sum(axis=0)
    return filtered


def _neighbours(pixel, width, height, texel_at, points, normals, texel_m, dx, dy) -> tuple[np.ndarray, np.ndarray]:
    """(texels, their neighbours): the pairs of texels dx, dy apart on the page that lie on one surface."""
    x, y = pixel % width, pixel // width
    on_page = np.flatnonzero((x + dx >= 0) & (x + dx < width) & (y + dy >= 0) & (y + dy < height))
    neighbour = texel_at[pixel[on_page] + dy * width + dx]
    texel, neighbour = on_page[neighbour >= 0], neighbour[neighbour >= 0]
    same = _same_surface(points[texel], normals[texel], points[neighbour], normals[neighbour],
                         texel_m[texel] * (np.hypot(dx, dy) + GRID_SLACK_TEXELS), texel_m[texel])
    return texel[same], neighbour[same]


def _filter_pass(neighbours, light, variance, filtered) -> tuple[np.ndarray, np.ndarray]:
    """One pass: ``filtered`` (m, 3) or (G, m, 3) averaged over each texel and its ``neighbours`` (texels,
    neighbours, the guide's weights), weighted by those and by ``_noise_weight`` of ``light``; and the (m, 3)
    variance of the averages."""
    total, weight, weighted_variance = filtered.copy(), np.ones(len(light)), variance.copy()
    for texel, neighbour, guide_weight in neighbours:
        w = guide_weight * _noise_weight(light[texel], variance[texel], light[neighbour], variance[neighbour])
        total[..., texel, :] += w[:, None] * filtered[..., neighbour, :]
        weight[texel] += w
        weighted_variance[texel] += (w ** 2)[:, None] * variance[neighbour]
    return total / weight[:, None], weighted_variance / weight[:, None] ** 2


def _same_surface(points, normals, other_points, other_normals, reach_m, texel_m) -> np.ndarray:
    """Whether each neighbour lies on the texel's surface: facing the same way, on its plane, within reach."""
    offset = other_points - points
    return ((np.einsum("mk,mk->m", normals, other_normals) > NORMAL_COSINE)
            & (np.abs(np.einsum("mk,mk->m", offset, normals)) < PLANE_TEXELS * texel_m)
            & (lengths(offset) < reach_m))


def _noise_weight(light, variance, other_light, other_variance) -> np.ndarray:
    """Rousselle et al.'s weight exp(-max(0, d^2)) of each neighbour (module docstring)."""
    excess = (light - other_light) ** 2 - (variance + np.minimum(variance, other_variance))
    scale = NOISE_MULTIPLE ** 2 * (variance + other_variance)
    distance = np.divide(excess, scale, out=np.where(excess > 0, np.inf, 0.0), where=scale > 0).mean(axis=1)
    return np.exp(-np.maximum(distance, 0.0))
