"""Index arithmetic for groups: ragged runs (a flat array cut into consecutive runs of given sizes) and rows that
share a key."""
from __future__ import annotations

import numpy as np


def concatenated_ranges(sizes: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s) for each s in ``sizes``: each item's position within its run."""
    ends = np.cumsum(sizes)
    return np.arange(ends[-1] if len(ends) else 0) - np.repeat(ends - sizes, sizes)


def even_ranges(count: int, size: int) -> list[slice]:
    """Slices of ``size`` consecutive items (the last one shorter) covering ``count`` items."""
    return [slice(start, min(start + size, count)) for start in range(0, count, size)]


def budget_ranges(counts: np.ndarray, budget: int):
    """(start, stop) ranges of consecutive items whose ``counts`` sum to at most ``budget`` (an item over the
    budget gets a range of its own): for processing ragged work in bounded memory."""
    ends = np.cumsum(counts)
    start = 0
    while start < len(counts):
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + budget, side="right")))
        yield start, stop
        start = stop


def row_groups(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(m,) the group of each row of the (m, k) integer ``keys``, groups numbered in the rows' lexicographic order,
    and (g,) the first row of each group: what np.unique(keys, axis=0, return_index=True, return_inverse=True)
    gives, by a stable sort per column instead of a sort of whole rows, which is about six times slower."""
    order = np.lexsort(keys.T[::-1])
    ordered = keys[order]
    new = np.ones(len(keys), dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    group = np.empty(len(keys), dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    return group, order[new]
