"""Independent steps side by side: chunks of texels, blocks of receivers, rows of form factors.

A step is numpy work on large arrays and batched ray queries. The ray backends spread one query over every core,
but the numpy between queries runs on one, so steps taken one after the other leave the other cores idle for about
half of the time. numpy and the backends release the GIL on large arrays, so steps on a few threads overlap one
step's numpy with another's (measured: docs/benchmarks.md, "Steps side by side").

Each step's memory is held once per step in flight, so their number is bounded (``MAX_STEPS_IN_FLIGHT``, and the
memory estimate counts it: core.memory). Results come back in the steps' order, to the calling thread, which is
the one that reports progress and checks for cancellation: the outcome is the same as one step at a time.
"""
from __future__ import annotations

import os
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, Iterator, TypeVar

MAX_STEPS_IN_FLIGHT = 4

Item = TypeVar("Item")
Result = TypeVar("Result")


def steps_in_flight(threads: int | None = None) -> int:
    """How many steps run at once on a machine with ``threads`` cores (all of this machine's when None)."""
    return max(1, min(MAX_STEPS_IN_FLIGHT, threads or os.cpu_count() or 1))


def ordered_map(step: Callable[[Item], Result], items: Iterable[Item], workers: int) -> Iterator[Result]:
    """``step(item)`` for each item, yielded in order, with up to ``workers`` steps computed at once ahead of the
    caller. When the caller stops early (an exception, a cancelled bake), the steps not started are dropped and
    the running ones finish before this returns."""
    if workers <= 1:
        yield from map(step, items)
        return
    with ThreadPoolExecutor(workers) as pool:
        pending = deque()
        try:
            for item in items:
                pending.append(pool.submit(step, item))
                if len(pending) >= workers:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for future in pending:
                future.cancel()
