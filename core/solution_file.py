"""A solved scene on disk, so that the output stages (lightmap texel chunks, vertex colours) can run later, in
another process or on another machine, over the same solution.

The file holds what outputs read: the scene, the element mesh, the solved elements, the direct lighting (its
emitter clusters) and the triangles of the ray-casting scene, which is rebuilt on load. It leaves out the solver's
working state (links, shooting queues), which no output reads and which is the largest part of a solve. The
format is a versioned pickle: load only files you or your farm wrote.
"""
from __future__ import annotations

import copy
import pickle

from .errors import SceneError
from .solution import Solution
from .staged_files import StagedFiles

FORMAT = "radiosity-solution"
VERSION = 2


def save_solution(solution: Solution, path: str) -> None:
    """Write ``solution`` to ``path`` atomically (core.staged_files): a file written in full replaces the old one,
    or nothing changes and OutputError names the file."""
    saved = copy.copy(solution)
    saved.state, saved._overlap_test = None, None  # the solver's working state; a test rebuilt on use
    with StagedFiles() as staged:
        staged.stage(path, pickle_writer({"format": FORMAT, "version": VERSION, "solution": saved}))
        staged.commit()


def load_solution(path: str) -> Solution:
    """The solution saved at ``path``; SceneError names the file if it is missing, unreadable, or not a solution
    of this version."""
    return read_pickle(path, FORMAT, VERSION, "saved radiosity solution")["solution"]


def pickle_writer(content: dict):
    """A writer of ``content`` as a pickle, for core.staged_files.StagedFiles.stage."""
    def write(temporary: str) -> None:
        with open(temporary, "wb") as file:
            pickle.dump(content, file, protocol=pickle.HIGHEST_PROTOCOL)
    return write


def read_pickle(path: str, format_name: str, version: int, what: str) -> dict:
    """The dict pickled at ``path`` with the given "format" and "version"; SceneError names the file (and
    ``what`` it should be) if it is missing, unreadable, truncated, or of another format or version."""
    try:
        with open(path, "rb") as file:
            saved = pickle.load(file)
    except OSError as error:
        raise SceneError(f"Cannot read the {what} '{path}': {error.strerror or error}.") from error
    except (pickle.UnpicklingError, EOFError, AttributeError, ImportError, IndexError, TypeError) as error:
        raise SceneError(f"'{path}' is not a {what} (or it is truncated).") from error
    if not isinstance(saved, dict) or saved.get("format") != format_name:
        raise SceneError(f"'{path}' is not a {what}.")
    if saved.get("version") != version:
        raise SceneError(f"'{path}' is a {what} of format version {saved.get('version')}; this baker reads "
                         f"version {version}. Bake the scene again.")
    return saved
