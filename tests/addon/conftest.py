"""Add-on tests run on the bpy module: the extension is registered once, and each test starts from factory
settings with an empty scene."""
import os
import sys

import pytest

bpy = pytest.importorskip("bpy", reason="the bpy module is installed by scripts/test.sh")

from blender_setup import empty_black_scene, load_extension  # noqa: E402


@pytest.fixture(scope="session")
def extension():
    package = load_extension()
    package.register()
    yield package
    package.unregister()


@pytest.fixture
def empty_scene(extension):
    return empty_black_scene()


_exit_status = {"code": 0}


def pytest_sessionfinish(session, exitstatus):
    _exit_status["code"] = int(exitstatus)


def pytest_unconfigure(config):
    """The bpy 4.2 module segfaults while the interpreter tears down (after every test passed and the summary was
    printed); leave with pytest's own exit status instead of crashing."""
    if tuple(bpy.app.version[:2]) == (4, 2):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_exit_status["code"])
