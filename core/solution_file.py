"""A solved scene on disk, so that the output stages (lightmap texel chunks, vertex colours) can run later, in
another process or on another machine, over the same solution.

The file holds what outputs read: the scene, the element mesh, the solved elements, the direct lighting (its
emitter clusters) and the triangles of the ray-casting scene, which is rebuilt on load. It leaves out the solver's
working state (links, shooting queues), which no output reads and which is the largest part of a solve. It is a
data-only file (core.data_file): reading one runs nothing it holds, whoever wrote it.
"""
from __future__ import annotations

import copy

from .cluster_tree import ClusterTree
from .data_file import data_writer, read_data
from .direct_light import DirectLighting
from .links import LinkSources
from .mesh import ElementMesh, Elements
from .raycast import RayCaster
from .scene import AreaLight, Material, PointLight, Scene, Source, SpotLight, SunLight, World
from .solution import SolvedElements, Solution
from .solver import ConvergenceStep
from .staged_files import StagedFiles
from .texture import ReflectanceTexture

FORMAT = "radiosity-solution"
VERSION = 3
CLASSES = (Solution, SolvedElements, Scene, Material, ReflectanceTexture, PointLight, SpotLight, SunLight,
           AreaLight, World, Source, ElementMesh, Elements, DirectLighting, LinkSources, ClusterTree,
           ConvergenceStep, RayCaster)


def save_solution(solution: Solution, path: str) -> None:
    """Write ``solution`` to ``path`` atomically (core.staged_files): a file written in full replaces the old one,
    or nothing changes and OutputError names the file."""
    saved = copy.copy(solution)
    saved.state, saved._overlap_test = None, None  # the solver's working state; a test rebuilt on use
    with StagedFiles() as staged:
        staged.stage(path, data_writer({"format": FORMAT, "version": VERSION}, saved, CLASSES))
        staged.commit()


def load_solution(path: str) -> Solution:
    """The solution saved at ``path``; SceneError names the file if it is missing, unreadable, or not a solution
    of this version."""
    return read_data(path, FORMAT, VERSION, "saved radiosity solution", CLASSES)[1]
