"""Index arithmetic for ragged groups (a flat array cut into consecutive runs of given sizes)."""
from __future__ import annotations

import numpy as np


def concatenated_ranges(sizes: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s) for each s in ``sizes``: each item's position within its run."""
    ends = np.cumsum(sizes)
    return np.arange(ends[-1] if len(ends) else 0) - np.repeat(ends - sizes, sizes)


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
