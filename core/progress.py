"""Progress reporting and cancellation, passed into the core as plain callables.

``progress(fraction, message)`` receives a fraction in [0, 1] of the current phase and a short status line;
``cancelled()`` returns True when the user asked to stop. The same core serves the modal operator, the command
line and the tests.
"""
from __future__ import annotations

import time
from typing import Callable

Progress = Callable[[float, str], None]


def no_progress(fraction: float, message: str) -> None:
    """Default progress callback: report nothing."""


def never_cancelled() -> bool:
    """Default cancel callback: never cancel."""
    return False


class Timer:
    """Seconds per named phase: ``lap(name)`` adds the time since the previous lap (or the start) to that phase,
    so a phase run in parts (chunk after chunk) sums its parts."""

    def __init__(self):
        self.laps: dict[str, float] = {}
        self._last = time.perf_counter()

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        self.laps[name] = self.laps.get(name, 0.0) + now - self._last
        self._last = now

    def share(self, seconds: dict[str, float]) -> None:
        """Add the time since the previous lap to the phases of ``seconds`` in proportion to their seconds there:
        for phases timed on steps side by side (core.parallel), whose seconds overlap."""
        now = time.perf_counter()
        total = sum(seconds.values())
        for name, part in seconds.items():
            self.laps[name] = self.laps.get(name, 0.0) + (now - self._last) * part / max(total, 1e-300)
        self._last = now
