"""Quality presets and the mapping from user settings to core.BakeSettings (no bpy: testable anywhere)."""
from __future__ import annotations

from dataclasses import dataclass

# name: (elements across the scene's diagonal, patches across it, adaptive passes, residual threshold,
#        light samples per edge). Sizes follow the scene, so a 0.5 m model and a 50 m level bake alike; the work
#        grows with elements x patches, so the patch count grows slowly.
# The residual thresholds are low because shooting is cheap next to the form factors: on the Cornell box Medium at
# 0.001 takes the same time as at 0.01 and is 0.6 points closer to Cycles (the ambient term covers most, not all,
# of what an early stop leaves).
PRESETS = {
    "DRAFT": (16, 6, 0, 0.02, 2),
    "MEDIUM": (32, 8, 1, 0.001, 4),
    "HIGH": (64, 10, 2, 0.0005, 6),
}
ADAPTIVE_THRESHOLD = 0.3
# Lightmaps per preset: (texels across the scene's diagonal, indirect light method, gather rays per texel edge).
# Medium interpolates the indirect light: on the Cornell box it measured closer to Cycles than an 8 x 8 gather
# (docs/benchmarks.md), whose rays pick up the hot elements on the rim of the light's opening.
LIGHTMAP_PRESETS = {
    "DRAFT": (128, "interpolate", 1),
    "MEDIUM": (256, "interpolate", 1),
    "HIGH": (512, "gather", 16),
}


@dataclass(frozen=True)
class UserSettings:
    """What the panel and the command line let a user choose; ``quality`` CUSTOM uses the explicit fields."""

    quality: str = "MEDIUM"
    element_size_m: float = 0.25
    patch_size_m: float = 1.0
    adaptive_passes: int = 1
    residual_threshold: float = 0.01
    light_samples_per_edge: int = 4
    form_factors: str = "raycast"
    seed: int = 0
    gather_samples_per_edge: int = 8
    texels_per_metre: float = 0.0


def bake_settings(user: UserSettings, scene_size_m: float):
    """core.BakeSettings for the user's choice: a preset scaled to the scene's diagonal, or the CUSTOM values."""
    from ..core import BakeSettings
    if user.quality in PRESETS:
        across, patches_across, passes, residual, samples = PRESETS[user.quality]
        element, patch = scene_size_m / across, scene_size_m / patches_across
    else:
        element, patch, passes, residual, samples = (user.element_size_m, user.patch_size_m, user.adaptive_passes,
                                                     user.residual_threshold, user.light_samples_per_edge)
    return BakeSettings(element_size_m=element, patch_size_m=max(patch, element), adaptive_passes=passes,
                        residual_threshold=residual, light_samples_per_edge=samples, form_factors=user.form_factors,
                        adaptive_threshold=ADAPTIVE_THRESHOLD, min_element_size_m=element / 4, seed=user.seed)


def lightmap_settings(user: UserSettings, scene_size_m: float):
    """(core.LightmapSettings, default texels per metre) for the user's choice; CUSTOM gathers with the user's
    sample count at the user's density (or the Medium density when it is 0)."""
    from ..core.lightmap import LightmapSettings
    across, method, samples = LIGHTMAP_PRESETS.get(user.quality, LIGHTMAP_PRESETS["MEDIUM"])
    density = across / scene_size_m
    if user.quality not in LIGHTMAP_PRESETS:
        method, samples = "gather", user.gather_samples_per_edge
        density = user.texels_per_metre or density
    return LightmapSettings(indirect=method, gather_samples_per_edge=samples, seed=user.seed), density
