"""Radiosity core: pure Python (numpy + embreex), no Blender. See README.md for the architecture."""
from .bake import BakeSettings, bake
from .progress import BakeCancelled
from .scene import (AreaLight, Material, PointLight, Scene, SceneError, SpotLight, SunLight, World)
from .solution import Solution

__all__ = ["AreaLight", "BakeCancelled", "BakeSettings", "Material", "PointLight", "Scene", "SceneError",
           "Solution", "SpotLight", "SunLight", "World", "bake"]
