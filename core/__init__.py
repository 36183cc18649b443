"""Radiosity core: pure Python (numpy + embreex), no Blender. See README.md for the architecture."""
from .bake import BakeSettings, bake
from .errors import BakeCancelled, BakeError, OutputError, SceneError, SettingsError
from .scene import AreaLight, Material, PointLight, Scene, SpotLight, SunLight, World
from .solution import Solution

__all__ = ["AreaLight", "BakeCancelled", "BakeError", "BakeSettings", "Material", "OutputError", "PointLight", "Scene",
           "SceneError", "SettingsError", "Solution", "SpotLight", "SunLight", "World", "bake"]
