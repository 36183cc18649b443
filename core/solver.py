"""Radiosity solvers over patches (shooters) and elements (receivers), RGB throughout.

Discretisation (Cohen et al. 1986, substructuring): patch j carries the area-weighted mean radiosity of its
elements; an element's irradiance is H_e = H_direct,e + sum_j F(e -> j) B_j and its radiosity
B_e = E_e + rho_e H_e. The patch-to-patch coupling is the area-weighted mean of element rows,
F(i -> j) = sum_{e in i} A_e F(e -> j) / A_i. Both solvers converge to the same answer:

- ``solve_direct``: the matrix of the radiosity equation at patch level, (I - rho F) B = E (radiosity paper,
  section 4), solved by Gaussian elimination (numpy.linalg.solve). It is the reference for small scenes and
  refuses large ones.
- ``solve_progressive``: progressive refinement (Cohen et al. 1988): repeatedly shoot the patch with the most
  unshot power. Shooting patch j adds rho_i F(i -> j) dB_j to every patch's unshot radiosity; a patch's column of
  F is computed the first time it shoots (blocks of the strongest unshot patches at once, on all cores) and then
  kept, so later shots cost O(P). Element irradiance is gathered from the shot totals whenever it is needed.
  Memory: O(n + P^2) plus an optional element-row matrix under a byte budget that saves recomputing rows.
  It stops when unshot power / injected power falls below a threshold.

The invariant ``unshot_j = mean_j(B) - shot_j`` (what patch j holds minus what it already sent) holds after adaptive
refinement changes the elements too, so a solve resumes on a refined mesh.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import BakeCancelled, SceneError
from .mesh import Elements
from .progress import Progress, never_cancelled, no_progress
from .formfactor_rows import FormFactorCache, Patches, exposed_area, patch_mean


@dataclass
class ConvergenceStep:
    """One entry of a solve's history: shots so far, residual (unshot / injected power), seconds, rays cast."""

    shots: int
    residual: float
    seconds: float
    rays: int


@dataclass
class RadiosityState:
    """Per-element direct and total irradiance (W m^-2, (n, 3)) and per-patch shot radiosity ((P, 3))."""

    elements: Elements
    patches: Patches
    direct_irradiance: np.ndarray
    irradiance: np.ndarray
    shot: np.ndarray
    injected_power_w: float
    history: list[ConvergenceStep] = field(default_factory=list)

    @classmethod
    def start(cls, elements: Elements, patches: Patches, direct_irradiance: np.ndarray) -> "RadiosityState":
        state = cls(elements, patches, direct_irradiance, direct_irradiance.copy(),
                    np.zeros((len(patches.area_m2), 3)), 0.0)
        state.injected_power_w = float((state.radiosity * elements.exposed_m2[:, None]).sum())
        return state

    @property
    def patch_area_m2(self) -> np.ndarray:
        """(P,) exposed area of each patch (buried elements left out)."""
        return exposed_area(self.elements, self.patches)

    @property
    def radiosity(self) -> np.ndarray:
        return self.elements.emitted_exitance + self.elements.reflectance * self.irradiance

    @property
    def unshot(self) -> np.ndarray:
        """(P, 3) radiosity each patch still has to send."""
        return patch_mean(self.radiosity, self.elements, self.patches) - self.shot

    @property
    def residual(self) -> float:
        """Unshot power over injected power (emission plus first reflection of direct light)."""
        return _residual(self.unshot, self.patch_area_m2, self.injected_power_w)

    def ambient(self, enclosure: float = 1.0) -> np.ndarray:
        """(3,) ambient radiosity (Cohen et al. 1988, section 4.2): the light the unshot radiosity will still
        bring, spread evenly, R sum_j dB_j A_j / sum_j A_j with R = 1 / (1 - rho_avg); show B_e + rho_e ambient.

        ``enclosure`` (the share of light leaving a surface that lands on the scene: 1 in a closed room, less where
        light escapes) generalises it to open scenes: f unshot_mean / (1 - rho_avg f); the paper's term is f = 1."""
        area, patch_area = self.elements.exposed_m2[:, None], self.patch_area_m2[:, None]
        rho_avg = (self.elements.reflectance * area).sum(axis=0) / area.sum()
        unshot_mean = (self.unshot * patch_area).sum(axis=0) / patch_area.sum()
        return enclosure * unshot_mean / (1.0 - rho_avg * enclosure)


def _residual(unshot: np.ndarray, patch_area: np.ndarray, injected_power_w: float) -> float:
    return float((np.abs(unshot) * patch_area[:, None]).sum() / injected_power_w) if injected_power_w > 0 else 0.0


def solve_progressive(state: RadiosityState, factors: FormFactorCache, residual_threshold: float, max_shots: int,
                      rays: Callable[[], int] = lambda: 0, progress: Progress = no_progress,
                      cancelled: Callable[[], bool] = never_cancelled) -> RadiosityState:
    """Shoot the patch with the most unshot power until the residual is below ``residual_threshold``."""
    started = time.perf_counter()
    patch_area = state.patch_area_m2
    reflectance = patch_mean(state.elements.reflectance, state.elements, state.patches)
    unshot = state.unshot
    residual = _residual(unshot, patch_area, state.injected_power_w)
    shots = state.history[-1].shots if state.history else 0
    state.history.append(ConvergenceStep(shots, residual, 0.0, rays()))
    batch = max(1, factors.threads) * max(1, (1 << 17) // max(1, len(state.elements.node)))
    while residual > residual_threshold and shots < max_shots:
        if cancelled():
            raise BakeCancelled("Bake cancelled during the radiosity solve.")
        power = np.abs(unshot).sum(axis=1) * patch_area
        patch = int(np.argmax(power))
        if not factors.known[patch]:
            strongest = np.argsort(-np.where(factors.known, -1.0, power), kind="stable")[:batch]
            factors.compute(strongest[~factors.known[strongest]], state.elements, state.patches, cancelled)
        delta = unshot[patch].copy()
        state.shot[patch] += delta
        unshot += reflectance * factors.coupling[:, patch:patch + 1] * delta
        unshot[patch] -= delta
        residual = _residual(unshot, patch_area, state.injected_power_w)
        shots += 1
        state.history.append(ConvergenceStep(shots, residual, time.perf_counter() - started, rays()))
        if shots % 64 == 0:
            progress(min(1.0, np.log(max(residual, 1e-12)) / np.log(max(residual_threshold, 1e-12))),
                     f"Shooting: {shots} shots, residual {residual:.4f}")
    progress(1.0, f"Gathering light on {len(state.elements.node)} elements")
    state.irradiance = state.direct_irradiance + factors.gather(state.shot, state.elements, cancelled)
    return state


def solve_direct(state: RadiosityState, factors: FormFactorCache, max_patches: int = 6000,
                 cancelled: Callable[[], bool] = never_cancelled) -> RadiosityState:
    """Gaussian elimination of (I - rho F) B = E + rho H_direct at patch level; then every element gathers."""
    elements, patches = state.elements, state.patches
    count = len(patches.area_m2)
    if count > max_patches:
        raise SceneError(f"The direct solver is limited to {max_patches} patches (this scene has {count}): "
                         "use the progressive solver or larger patches.")
    factors.compute(np.flatnonzero(~factors.known), elements, patches, cancelled)
    reflectance = patch_mean(elements.reflectance, elements, patches)
    source = patch_mean(elements.emitted_exitance + elements.reflectance * state.direct_irradiance, elements, patches)
    coupling = factors.coupling.astype(np.float64)
    radiosity = np.stack([np.linalg.solve(np.eye(count) - reflectance[:, c:c + 1] * coupling, source[:, c])
                          for c in range(3)], axis=1)
    state.shot = radiosity
    state.irradiance = state.direct_irradiance + factors.gather(radiosity, elements, cancelled)
    state.history.append(ConvergenceStep(count, state.residual, 0.0, 0))
    return state
