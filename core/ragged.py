"""Index arithmetic for ragged groups (a flat array cut into consecutive runs of given sizes)."""
from __future__ import annotations

import numpy as np


def concatenated_ranges(sizes: np.ndarray) -> np.ndarray:
    """Concatenation of arange(s) for each s in ``sizes``: each item's position within its run."""
    ends = np.cumsum(sizes)
    return np.arange(ends[-1] if len(ends) else 0) - np.repeat(ends - sizes, sizes)
