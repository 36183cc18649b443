"""How much memory a bake may use, and what it will need, estimated before the heavy work starts.

The limit defaults to ``DEFAULT_SHARE`` of the machine's physical memory (or of the container's limit, when one
is set, on Linux). ``estimate_bake`` adds up what each step holds at its peak from quantities known before any
large allocation: the triangles, the pieces they are cut into, the elements the pieces group into (counted the
way core.clusters groups them, without its visibility test) and the lightmap texels. Its per-item sizes are the
arrays the steps keep (docs/benchmarks.md shows them against measured peaks). ``fit_to_memory`` coarsens the
elements until the estimate fits, and refuses the bake in one line when even that does not help. Since an
estimate can be short, ``memory_guard`` makes the limit hold while the bake runs: wrapped around the bake's
``cancelled`` (which the core polls between steps, chunks and solver iterations), it stops the bake with
MemoryLimitError once the process's resident memory exceeds the limit, before anything is written.
"""
from __future__ import annotations

import ctypes
import importlib
import os
import sys
from dataclasses import dataclass

import numpy as np

from .adaptive_elements import ADAPTIVE_GROWTH, COVER_GROWTH
from .clusters import normal_bins, stands_alone
from .errors import SceneError
from .geometry import longest_edges, triangle_areas, triangle_unit_normals
from .links import PAIRS_PER_STEP
from .parallel import steps_in_flight
from .ragged import row_groups

resource = None if sys.platform == "win32" else importlib.import_module("resource")  # POSIX only

DEFAULT_SHARE = 0.75
GIB = 2 ** 30
# Bytes each item costs at a step's peak, from peak resident memory measured on the procedural courtyard at 250k
# to 1M triangles (docs/benchmarks.md), rounded up.
FIXED_BYTES = 500 * 2 ** 20     # interpreter, Blender or numpy, Embree
BYTES_PER_TRIANGLE = 1_500      # the exported scene, the Embree BVH, per-triangle tests
BYTES_PER_PIECE = 700           # the element mesh's nodes and the clustering's per-piece arrays
BYTES_PER_SOLVED_SIDE = 2_000   # what the solution keeps per element side (points, light, interpolation)
LINK_WORKSPACE = 256 * 2 ** 20  # candidate links weighed by one step (core.links.PAIRS_PER_STEP pairs): its numpy
                                # arrays peak at 55-85 MiB (traced), plus the ray queries' buffers and the
                                # allocator's slack (fitted: docs/benchmarks.md, "Memory")
CANDIDATES_PER_SIDE = 470       # Medium: about 235 links per side, twice while they are refined
BYTES_PER_LINKED_SIDE = 30_000  # those links and their sparse transfer in the solve
BYTES_PER_GATHERED_SIDE = 3_000 # core.gather.gather_at_receivers' transport, beside the links: a pair per side
                                # its 144 rays land on (20 bytes: int32 receiver and side, float32 RGB weight; 24
                                # more of float64 light while it is iterated); measured: the courtyard's 250k
                                # Medium peak rose 0.12-0.15 GiB at 68,604 sides, about 2 kB a side
BYTES_PER_TEXEL = 3_000         # a page's covered texels while lit: points, footprints, rays, interpolation
BYTES_PER_PLANNED_TEXEL = 2_000 # every page's texels planned alongside the solve: the plan kept until the page
                                # is lit (core.lightmap.TexelPlan, 9 footprint points a texel: 600 bytes) and the
                                # planning's arrays at the solve's peak
BYTES_PER_IMAGE_TEXEL = 16      # every page's float32 light and masks, kept until written
COARSENING = 1.25               # each adaptation makes elements this much larger
MOST_COARSENING = 4.0           # ... up to this factor, else the bake is refused


class MemoryLimitError(SceneError):
    """The bake would need more memory than the limit allows, even with coarser elements."""


def physical_memory_bytes() -> int:
    """The machine's physical memory, or a Linux container's limit when that is lower (0 if unknown)."""
    total = 0
    if sys.platform == "win32":
        class Status(ctypes.Structure):
            _fields_ = [("length", ctypes.c_ulong), ("load", ctypes.c_ulong), ("total", ctypes.c_ulonglong),
                        ("available", ctypes.c_ulonglong), ("page_total", ctypes.c_ulonglong),
                        ("page_available", ctypes.c_ulonglong), ("virtual_total", ctypes.c_ulonglong),
                        ("virtual_available", ctypes.c_ulonglong), ("extended", ctypes.c_ulonglong)]
        status = Status(length=ctypes.sizeof(Status))
        if ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(status)):
            total = int(status.total)
    elif hasattr(os, "sysconf") and "SC_PHYS_PAGES" in os.sysconf_names:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path, encoding="ascii") as handle:
                text = handle.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < (total or 1 << 62):
            total = int(text)
    return total


def resident_bytes() -> int:
    """The process's resident memory now (its peak on macOS, where only that is at hand; 0 if unknown)."""
    if sys.platform == "win32":
        class Counters(ctypes.Structure):
            _fields_ = [("size", ctypes.c_ulong), ("faults", ctypes.c_ulong)] + [
                (name, ctypes.c_size_t) for name in ("peak_working_set", "working_set", "peak_paged_pool",
                                                      "paged_pool", "peak_nonpaged_pool", "nonpaged_pool",
                                                      "page_file", "peak_page_file")]
        counters = Counters(size=ctypes.sizeof(Counters))
        process = ctypes.windll.kernel32.GetCurrentProcess()
        ok = ctypes.windll.psapi.GetProcessMemoryInfo(process, ctypes.byref(counters), counters.size)
        return int(counters.working_set) if ok else 0
    try:
        with open("/proc/self/statm", encoding="ascii") as handle:
            return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        pass
    if resource is None:
        return 0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak) if sys.platform == "darwin" else int(peak) * 1024


def memory_guard(limit_gb: float, cancelled, estimate_gb: float | None = None):
    """A ``cancelled`` for the core that is ``cancelled()``, but raises MemoryLimitError (naming the resident
    memory, the limit and the estimate) once the process's resident memory exceeds ``limit_gb`` GiB."""
    def guarded() -> bool:
        resident = resident_bytes()
        if resident > limit_gb * GIB:
            estimated = f"; the bake estimated {estimate_gb:.3g} GiB" if estimate_gb is not None else ""
            raise MemoryLimitError(
                f"The bake stopped at {resident / GIB:.3g} GiB resident, over the Memory Limit of {limit_gb:g} GiB"
                f"{estimated}: nothing was written. Raise the Memory Limit (--max-memory-gb), lower the quality "
                "or the lightmap's texel density, or set objects to 'Shadow Only'.")
        return cancelled()
    return guarded


def default_limit_gb() -> float:
    """``DEFAULT_SHARE`` of the physical memory, in GiB (8 GiB when it cannot be read)."""
    total = physical_memory_bytes()
    return round(DEFAULT_SHARE * total / GIB, 1) if total else 8.0


@dataclass(frozen=True)
class MemoryEstimate:
    """Bytes each step needs at its peak: ``steps`` name -> bytes; the bake needs their largest plus what lives
    through every step (``persistent``)."""

    steps: dict
    persistent: int

    @property
    def peak_bytes(self) -> int:
        return self.persistent + max(self.steps.values(), default=0)

    def describe(self) -> str:
        return ", ".join(f"{name} {size / GIB:.1f} GiB" for name, size in self.steps.items())


def piece_counts(triangles_m: np.ndarray, element_size_m: float) -> np.ndarray:
    """(T,) pieces each triangle is cut into at the element size (core.mesh.build_mesh: k x k)."""
    edges = longest_edges(triangles_m)
    return np.clip(np.ceil(edges / element_size_m - 1e-9), 1, 1e9).astype(np.int64) ** 2


def element_count(triangles_m: np.ndarray, element_size_m: float) -> int:
    """About how many elements core.clusters makes: pieces long enough stand alone, smaller ones group by grid
    cell and normal bin (the visibility split is left out: it adds a few percent, and more where surfaces hang
    close in front of others, at least 11% on the 250k courtyard at Draft; the peaks measured stay under the
    estimate, docs/benchmarks.md)."""
    pieces = piece_counts(triangles_m, element_size_m)
    alone = stands_alone(longest_edges(triangles_m) / np.sqrt(pieces), triangle_areas(triangles_m) / pieces,
                         element_size_m)
    small = ~alone
    centroid = triangles_m[small].mean(axis=1)
    origin = centroid.min(axis=0) if len(centroid) else np.zeros(3)
    keys = np.concatenate([np.floor((centroid - origin) / element_size_m).astype(np.int64),
                           normal_bins(triangle_unit_normals(triangles_m[small]))[:, None]], axis=1)
    grouped = len(row_groups(keys)[1])
    return int(pieces[alone].sum()) + grouped


def estimate_bake(triangles_m: np.ndarray, element_size_m: float, covered_texels: int = 0,
                  image_texels: int = 0, threads: int = 0, planned_texels: int = 0,
                  adaptive_passes: int = 0) -> MemoryEstimate:
    """What a hierarchical bake of these (T, 3, 3) receiving triangles needs on ``threads`` threads (0: every
    core), with lightmap pages lit one at a time (``covered_texels``: the largest page's texels that charts
    cover) whose images (``image_texels`` in all) are kept until they are written, and whose texels
    (``planned_texels``: every page's covered texels) are planned alongside the solve; each adaptive pass may
    make up to ADAPTIVE_GROWTH times the pieces and elements, after the cover passes' COVER_GROWTH."""
    growth = COVER_GROWTH * ADAPTIVE_GROWTH ** adaptive_passes
    pieces = int(growth * piece_counts(triangles_m, element_size_m).sum())
    sides = int(2 * growth * element_count(triangles_m, element_size_m))
    persistent = (FIXED_BYTES + BYTES_PER_TRIANGLE * len(triangles_m) + BYTES_PER_PIECE * pieces +
                  BYTES_PER_SOLVED_SIDE * sides + BYTES_PER_IMAGE_TEXEL * image_texels +
                  BYTES_PER_PLANNED_TEXEL * planned_texels)
    linked = (BYTES_PER_LINKED_SIDE + BYTES_PER_GATHERED_SIDE) * sides
    return MemoryEstimate({"solve": link_workspace_bytes(sides, threads) + linked,
                           "lightmap texels": BYTES_PER_TEXEL * covered_texels}, persistent)


def link_workspace_bytes(sides: int, threads: int = 0) -> int:
    """The candidate links weighed at once: a step of core.links.PAIRS_PER_STEP pairs (LINK_WORKSPACE) per step
    in flight (core.parallel), or all the candidates where there are fewer (a side has at most
    CANDIDATES_PER_SIDE, and no more than there are tree nodes, about twice the sides)."""
    candidates = sides * min(CANDIDATES_PER_SIDE, 2 * sides)
    return int(LINK_WORKSPACE * min(candidates / PAIRS_PER_STEP, steps_in_flight(threads)))


def fit_to_memory(triangles_m: np.ndarray, element_size_m: float, limit_gb: float, covered_texels: int = 0,
                  image_texels: int = 0, threads: int = 0, planned_texels: int = 0,
                  adaptive_passes: int = 0) -> tuple[float, MemoryEstimate]:
    """The element size (the one asked for, or up to MOST_COARSENING times larger) at which the estimate fits in
    ``limit_gb``; raises MemoryLimitError naming the figures and the settings to change when none does."""
    size = element_size_m
    while True:
        estimate = estimate_bake(triangles_m, size, covered_texels, image_texels, threads, planned_texels,
                                 adaptive_passes)
        if estimate.peak_bytes <= limit_gb * GIB:
            return size, estimate
        if size * COARSENING > MOST_COARSENING * element_size_m:
            raise MemoryLimitError(
                f"The bake needs about {estimate.peak_bytes / GIB:.1f} GiB ({estimate.describe()}, and "
                f"{estimate.persistent / GIB:.1f} GiB for {len(triangles_m)} triangles) but the memory limit is "
                f"{limit_gb:g} GiB, even with elements {MOST_COARSENING:g} times larger: raise the memory limit "
                "(--max-memory-gb), lower the quality or the lightmap's texel density, or set objects to "
                "'Shadow Only'.")
        size *= COARSENING


def check_bake_memory(receivers_m: np.ndarray, emitters_m: np.ndarray, element_size_m: float,
                      patch_size_m: float, limit_gb: float, threads: int = 0,
                      adaptive_passes: int = 0) -> MemoryEstimate:
    """The estimate of a core bake of these receiving and emitting (T, 3, 3) triangles; MemoryLimitError naming
    the setting to change when it is over ``limit_gb`` (a core caller that did not fit its settings first)."""
    estimate = estimate_bake(receivers_m, element_size_m, threads=threads, adaptive_passes=adaptive_passes)
    emitter_pieces = int(piece_counts(emitters_m, patch_size_m).sum())
    estimate = MemoryEstimate(estimate.steps, estimate.persistent + BYTES_PER_PIECE * emitter_pieces)
    if estimate.peak_bytes > limit_gb * GIB:
        raise MemoryLimitError(
            f"The bake needs about {estimate.peak_bytes / GIB:.3g} GiB ({estimate.describe()}) but the memory limit "
            f"is {limit_gb:g} GiB: raise 'element_size_m' (now {element_size_m:g} m) or 'patch_size_m' (now "
            f"{patch_size_m:g} m), or 'max_memory_gb'.")
    return estimate
