"""Quality presets and the mapping from user settings to core.BakeSettings (no bpy: testable anywhere)."""
from __future__ import annotations

from dataclasses import dataclass

# name: (elements across the scene's diagonal, patches across it, adaptive passes, residual threshold,
#        light samples per edge). Sizes follow the scene, so a 0.5 m model and a 50 m level bake alike; the work
#        grows with elements x patches, so the patch count grows slowly.
# The residual thresholds are low because shooting is cheap next to the form factors: on the Cornell box Medium at
# 0.001 takes the same time as at 0.01 and is 0.6 points closer to Cycles (the ambient term covers most, not all,
# of what an early stop leaves). Light samples: a lightmap texel's 3 x 3 points each get ceil(s / 3)^2 shadow rays,
# so 7 gives them 3 x 3 (the room's penumbrae measured 2.25% -> 2.0% from Cycles, at the same time: less noise
# also means fewer adaptive splits) and 10 gives 4 x 4. High's second adaptive pass and a final gather measured no
# closer to Cycles on the sample scenes, at 1.5 to 3 times the time (docs/benchmarks.md).
PRESETS = {
    "DRAFT": (16, 6, 0, 0.02, 2),
    "MEDIUM": (32, 8, 1, 0.001, 7),
    "HIGH": (48, 8, 1, 0.0005, 10),
}
ADAPTIVE_THRESHOLD = 0.3
# Lightmap texels across the scene's diagonal per preset. Presets light texels with the automatic indirect method
# (core.gather.gather_pays): rooms interpolate from the element corners, which on both sample scenes measured
# closer to Cycles than a final gather (its rays pick up the hot elements on the rim of a light's opening and leave
# noise per texel); scenes whose surfaces lie closer than 3 elements apart gather (docs/benchmarks.md).
LIGHTMAP_TEXELS_ACROSS = {"DRAFT": 128, "MEDIUM": 256, "HIGH": 512}


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
    lightmap_indirect: str = "auto"
    max_memory_gb: float = 0.0  # 0: core.memory.default_limit_gb(), a share of the machine's memory


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
                        adaptive_threshold=ADAPTIVE_THRESHOLD, min_element_size_m=element / 4, seed=user.seed,
                        max_memory_gb=user.max_memory_gb)


def lightmap_settings(user: UserSettings, scene_size_m: float):
    """(core.LightmapSettings, default texels per metre) for the user's choice: a preset's density with the
    automatic indirect method, or CUSTOM's indirect method and gather samples at the user's density (or the
    Medium density when it is 0)."""
    from ..core.lightmap import LightmapSettings
    density = LIGHTMAP_TEXELS_ACROSS.get(user.quality, LIGHTMAP_TEXELS_ACROSS["MEDIUM"]) / scene_size_m
    if user.quality in LIGHTMAP_TEXELS_ACROSS:
        return LightmapSettings(indirect="auto", seed=user.seed), density
    return LightmapSettings(indirect=user.lightmap_indirect, gather_samples_per_edge=user.gather_samples_per_edge,
                            seed=user.seed), user.texels_per_metre or density
