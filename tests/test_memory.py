"""The memory guard (core.memory): estimates before the heavy work, coarser elements when they help, and a one-line
refusal when nothing does."""
import numpy as np
import pytest

from core.memory import (BYTES_PER_LINKED_SIDE, BYTES_PER_SOLVED_SIDE, GIB, MemoryLimitError, element_count,
                         estimate_bake, fit_to_memory, memory_guard, physical_memory_bytes, resident_bytes)


def subdivided_plane(size_m: float, quads: int) -> np.ndarray:
    """(2 quads^2, 3, 3) triangles of a size x size plane at z = 0."""
    ticks = np.linspace(0.0, size_m, quads + 1)
    x, y = np.meshgrid(ticks[:-1], ticks[:-1], indexing="ij")
    step = size_m / quads
    corner = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    a, b = corner, corner + [step, 0, 0]
    c, d = corner + [step, step, 0], corner + [0, step, 0]
    return np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])


PLANE = subdivided_plane(20.0, 320)  # 204,800 triangles


def test_a_bake_over_the_limit_is_refused_in_one_line_naming_the_setting():
    with pytest.raises(MemoryLimitError) as error:
        fit_to_memory(PLANE, 0.5, limit_gb=0.1)
    message = str(error.value)
    assert "\n" not in message and "--max-memory-gb" in message and "0.1 GiB" in message


def test_coarser_elements_make_a_bake_fit_when_they_can():
    asked = 0.05  # 160,000 pieces of 5 cm on 20 m: the per-piece and per-element terms dominate
    needed = estimate_bake(PLANE, asked).peak_bytes
    coarse = estimate_bake(PLANE, 2 * asked).peak_bytes
    assert coarse < needed
    limit_gb = (coarse + needed) / 2 / GIB
    size, estimate = fit_to_memory(PLANE, asked, limit_gb)
    assert asked < size <= 2 * asked and estimate.peak_bytes <= limit_gb * GIB
    assert fit_to_memory(PLANE, asked, 2 * needed / GIB)[0] == asked  # room enough: nothing changes


def test_lightmap_pages_count_towards_the_estimate():
    without = estimate_bake(PLANE, 0.5)
    with_pages = estimate_bake(PLANE, 0.5, covered_texels=4096 ** 2, image_texels=3 * 4096 ** 2)
    assert with_pages.peak_bytes > without.peak_bytes + 3 * 4096 ** 2 * 12  # at least the float32 RGB images


def test_texels_planned_alongside_the_solve_count_towards_the_estimate():
    """Each planned texel keeps at least its 9 footprint points and their barycentrics (2 x 9 x 3 float64) through
    the solve."""
    texels = 1_000_000
    without = estimate_bake(PLANE, 0.5).peak_bytes
    assert estimate_bake(PLANE, 0.5, planned_texels=texels).peak_bytes >= without + 2 * 9 * 3 * 8 * texels


def test_the_machine_memory_is_known():
    assert physical_memory_bytes() > 2 ** 30


def test_adaptive_passes_count_towards_the_estimate():
    """Each adaptive pass may double the elements (core.adaptive_elements.ADAPTIVE_GROWTH): after two, the
    estimate holds at least three times more element sides' memory (solution and links) than without."""
    sides = 2 * element_count(PLANE, 0.05)
    added = estimate_bake(PLANE, 0.05, adaptive_passes=2).peak_bytes - estimate_bake(PLANE, 0.05).peak_bytes
    assert added >= 3 * sides * (BYTES_PER_SOLVED_SIDE + BYTES_PER_LINKED_SIDE)


def test_resident_memory_counts_what_the_process_touches():
    """256 MiB of ones raise the resident memory by their size (within 10%), and freeing them lowers it again."""
    before = resident_bytes()
    block = np.ones(32 * 2 ** 20)  # 256 MiB of float64, every page written
    grown = resident_bytes() - before
    del block
    assert grown == pytest.approx(256 * 2 ** 20, rel=0.1)
    assert resident_bytes() < before + 128 * 2 ** 20


def test_the_guard_stops_a_bake_once_resident_memory_exceeds_the_limit():
    """Over the limit, the guard raises MemoryLimitError in one line naming the limit and the setting, from
    inside a bake too (its first poll); under it, it answers as the ``cancelled`` it wraps."""
    from core import BakeSettings, Material, Scene, SunLight, bake
    below = (resident_bytes() - 2 ** 26) / GIB
    with pytest.raises(MemoryLimitError) as error:
        memory_guard(below, lambda: False, estimate_gb=0.5)()
    message = str(error.value)
    assert "\n" not in message and f"Memory Limit of {below:g} GiB" in message and "--max-memory-gb" in message
    assert memory_guard(1e6, lambda: True)() is True and memory_guard(1e6, lambda: False)() is False
    scene = Scene(PLANE[:2000], np.zeros(2000, int), [Material("grey")], lights=[SunLight("sun", (0, 0, -1), 1.0)])
    with pytest.raises(MemoryLimitError):
        bake(scene, BakeSettings(patch_size_m=2.0, element_size_m=1.0), cancelled=memory_guard(below, lambda: False))
