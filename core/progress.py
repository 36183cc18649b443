"""Progress reporting and cancellation, passed into the core as plain callables.

``progress(fraction, message)`` receives a fraction in [0, 1] of the current phase and a short status line;
``cancelled()`` returns True when the user asked to stop. The same core serves the modal operator, the command
line and the tests.
"""
from __future__ import annotations

from typing import Callable

Progress = Callable[[float, str], None]


class BakeCancelled(Exception):
    """Raised inside the core when ``cancelled()`` returned True; nothing has been written anywhere."""


def no_progress(fraction: float, message: str) -> None:
    """Default progress callback: report nothing."""


def never_cancelled() -> bool:
    """Default cancel callback: never cancel."""
    return False
