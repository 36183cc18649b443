"""Quality presets, and the mapping from a user's settings to the core's (no bpy: testable anywhere).

Sizes follow the scene's diagonal, so a 0.5 m model and a 50 m level bake alike. Why each number is what it is
(residuals, light samples, the indirect method): docs/benchmarks.md, "Presets".
"""
from __future__ import annotations

from dataclasses import dataclass

from ..core.atlas import AtlasSize, atlas_size
from ..core.bake import BakeSettings
from ..core.lightmap import LightmapSettings

ADAPTIVE_THRESHOLD = 0.3  # relative change of light across an element that splits it (Custom's adaptive passes)
MIN_ELEMENT_SHARE = 0.25  # adaptive meshing splits elements down to this share of the element size


@dataclass(frozen=True)
class Preset:
    """elements_across / patches_across: element and patch edges per scene diagonal (no adaptive pass:
    docs/benchmarks.md, "Presets"); residual: the solve stops at this unshot share of the injected power;
    light_samples: s, so s^2 shadow rays per element and soft light; lightmap_texels_across: lightmap texels per
    scene diagonal; gather_samples: s, so s^2 final-gather rays per texel where the automatic indirect method
    gathers; corner_gather_samples: s, so s^2 final-gather rays per vertex-colour corner (no denoiser follows
    them, so more than per texel)."""

    elements_across: int
    patches_across: int
    residual: float
    light_samples: int
    lightmap_texels_across: int
    gather_samples: int
    corner_gather_samples: int

    def summary(self) -> str:
        return (f"{self.elements_across} elements and {self.lightmap_texels_across} lightmap texels across the "
                f"scene, {self.light_samples} x {self.light_samples} shadow rays")


PRESETS = {
    "DRAFT": Preset(16, 6, 0.02, 2, 128, 6, 8),
    "MEDIUM": Preset(32, 8, 0.001, 7, 256, 8, 24),
    "HIGH": Preset(48, 8, 0.0005, 10, 512, 8, 32),
}


def bake_settings(user, scene_size_m: float) -> BakeSettings:
    """core.BakeSettings for ``user`` (settings.UserSettings): a preset scaled to the scene's diagonal, or the
    Custom values; the elements' indirect light solved again by rays where outputs gather (core.gather
    .gather_at_receivers)."""
    preset = PRESETS.get(user.quality)
    if preset is not None:
        element, patch = scene_size_m / preset.elements_across, scene_size_m / preset.patches_across
        passes, residual, samples = 0, preset.residual, preset.light_samples
    else:
        element, patch = user.element_size, user.patch_size
        passes, residual, samples = user.adaptive_passes, user.residual, user.light_samples
    return BakeSettings(element_size_m=element, patch_size_m=max(patch, element), adaptive_passes=passes,
                        residual_threshold=residual, light_samples_per_edge=samples,
                        adaptive_threshold=ADAPTIVE_THRESHOLD, min_element_size_m=element * MIN_ELEMENT_SHARE,
                        seed=user.seed, max_memory_gb=user.max_memory_gb, receiver_gather=True)


def lightmap_settings(user, scene_size_m: float) -> tuple[LightmapSettings, AtlasSize]:
    """(core.LightmapSettings, the atlas size) for ``user``: a preset's density with the automatic indirect
    method, or Custom's indirect method and gather samples; the user's density or resolution wins over the
    preset's density (Custom without either takes Medium's). Dilation fills the padding."""
    preset = PRESETS.get(user.quality, PRESETS["MEDIUM"])
    size = atlas_size(user.texels_per_metre, user.lightmap_resolution, preset.lightmap_texels_across / scene_size_m,
                      user.lightmap_padding, user.lightmap_max_size)
    custom = user.quality not in PRESETS
    return LightmapSettings(indirect=user.lightmap_indirect if custom else "auto",
                            gather_samples_per_edge=user.gather_samples if custom else preset.gather_samples,
                            dilation_texels=user.lightmap_padding, seed=user.seed), size


def corner_gather_samples(user) -> int:
    """s, so s^2 final-gather rays per vertex-colour corner: the preset's, or Custom's Corner Gather Samples."""
    preset = PRESETS.get(user.quality)
    return preset.corner_gather_samples if preset is not None else user.vertex_gather_samples
