"""How much light a Principled BSDF sends back into the room: its hemispherical reflectance, the albedo a
diffuse radiosity surface needs.

Radiosity keeps only how much of the received light a surface reflects, not where it goes. For Blender's
Principled BSDF (a GGX specular layer over a diffuse base, or a GGX metal), averaged over directions weighted by
their cosine, rho = 2 int_0^1 R(mu) mu dmu:

- dielectric: rho = S + (1 - S) base. The specular layer reflects S, the single-scattering albedo of a GGX
  microfacet surface (Walter et al. 2007; alpha = roughness^2, Smith height-correlated shadowing, Heitz 2014) with
  the unpolarised Fresnel reflectance of the interface (Born & Wolf): 0.092 when smooth at index 1.5, 0.059 at
  roughness 0.5, 0.021 at roughness 1. The diffuse base gets what the layer lets through (Cycles scales its
  diffuse layer by one minus the specular albedo). Specular IOR Level l scales the normal-incidence reflectance
  to 2 l F0. Measured in Cycles 5.2 (a plane under a white sky, 8 view angles): 0.060 and 0.022 at roughness
  0.5 and 1, with the diffuse part scaled by 1 - S (docs/units.md).
- metal: its base colour. Cycles' metal keeps nearly all the energy a single-scattering GGX loses when rough
  (measured at roughness 0.5: 0.48 and 0.78 for base colours 0.5 and 0.8).
- transmission: the transmitted share leaves through the surface, which radiosity does not follow; only the
  layer's reflection S stays.

Every case is affine in the base colour, rho = offset + scale x base, which maps a base colour texture texel by
texel. The integrals use fixed quadrature (Gauss-Legendre in mu, a stratified grid of visible normals, Heitz
2018), so they are deterministic.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

VIEW_POINTS = 16
NORMAL_GRID = 32


def fresnel_dielectric(cos_incidence: np.ndarray, ior: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a dielectric interface seen from the outside (index ratio ``ior``)."""
    c = np.asarray(cos_incidence, dtype=np.float64)
    g = np.sqrt(ior * ior - 1.0 + c * c)
    return 0.5 * ((g - c) / (g + c)) ** 2 * (1.0 + ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)) ** 2)


@lru_cache(maxsize=32)
def _ggx_samples(roughness: float) -> tuple[np.ndarray, np.ndarray]:
    """(cos between view and microfacet normal, weight) over views and visible normals, such that the
    hemispherical albedo of GGX with Fresnel F is sum(weight x F(cos))."""
    alpha = max(roughness, 1e-3) ** 2
    nodes, node_weights = np.polynomial.legendre.leggauss(VIEW_POINTS)
    mu = 0.5 * (nodes + 1.0)
    view = np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=1)
    cells = (np.arange(NORMAL_GRID) + 0.5) / NORMAL_GRID
    u1, u2 = (grid.ravel() for grid in np.meshgrid(cells, cells, indexing="ij"))
    normal = _visible_normals(view, alpha, u1, u2)
    cos_h = np.einsum("vk,vsk->vs", view, normal)
    light_z = 2.0 * cos_h * normal[..., 2] - view[:, None, 2]
    lo, li = _smith_lambda(mu, alpha)[:, None], _smith_lambda(np.clip(light_z, 1e-9, 1.0), alpha)
    shadowing = np.where(light_z > 0, (1.0 + lo) / (1.0 + lo + li), 0.0)
    weight = (0.5 * node_weights * 2.0 * mu)[:, None] * shadowing / len(u1)
    return np.clip(cos_h, 0.0, 1.0), weight


def _visible_normals(view: np.ndarray, alpha: float, u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """(v, s, 3) GGX microfacet normals distributed as seen from each view (Heitz 2018, sampling the VNDF)."""
    stretched = view * [alpha, alpha, 1.0]
    stretched /= np.linalg.norm(stretched, axis=1, keepdims=True)
    length = np.hypot(stretched[:, 0], stretched[:, 1])
    t1 = np.where(length[:, None] > 1e-9, np.stack([-stretched[:, 1], stretched[:, 0], 0 * length], 1)
                  / np.maximum(length, 1e-9)[:, None], [[1.0, 0.0, 0.0]])
    t2 = np.cross(stretched, t1)
    radius, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = radius * np.cos(phi), radius * np.sin(phi)
    s = 0.5 * (1.0 + stretched[:, 2:3])
    p2 = (1.0 - s) * np.sqrt(1.0 - p1 * p1) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    normal = p1[..., None] * t1[:, None] + p2[..., None] * t2[:, None] + p3[..., None] * stretched[:, None]
    normal = normal * [alpha, alpha, 1.0]
    normal[..., 2] = np.maximum(normal[..., 2], 1e-9)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def _smith_lambda(mu: np.ndarray, alpha: float) -> np.ndarray:
    tan2 = (1.0 - mu * mu) / np.maximum(mu * mu, 1e-18)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * tan2) - 1.0)


@lru_cache(maxsize=64)
def dielectric_albedo(ior: float, roughness: float) -> float:
    """S: hemispherical albedo of a GGX dielectric interface (0 for an index of 1: no interface)."""
    if ior <= 1.0:
        return 0.0
    cos_h, weight = _ggx_samples(roughness)
    return float((weight * fresnel_dielectric(cos_h, ior)).sum())


def adjusted_ior(ior: float, specular_ior_level: float) -> float:
    """The index whose normal-incidence reflectance is 2 l F0(ior) (Specular IOR Level l; 0.5 leaves it)."""
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    root = np.sqrt(np.clip(2.0 * specular_ior_level * f0, 0.0, 0.99))
    return float((1.0 + root) / (1.0 - root))


def principled_reflectance(roughness: float, metallic: float, ior: float, specular_ior_level: float,
                           transmission: float) -> tuple[float, float]:
    """(offset, scale) with hemispherical reflectance = offset + scale x base colour."""
    roughness = round(float(np.clip(roughness, 0.0, 1.0)), 3)
    metallic, transmission = float(np.clip(metallic, 0, 1)), float(np.clip(transmission, 0, 1))
    specular = dielectric_albedo(round(adjusted_ior(max(ior, 1.0), specular_ior_level), 4), roughness)
    offset = (1.0 - metallic) * specular
    scale = (1.0 - metallic) * (1.0 - transmission) * (1.0 - specular) + metallic
    return offset, scale
