"""Steps side by side (core.parallel): the caller sees what one step at a time gives, in the same order."""
import time

import pytest

from core.parallel import ordered_map


def test_results_come_in_order_when_later_steps_finish_first():
    """The first steps are the slowest, so on two threads later ones finish first; results still come in order."""
    slow_first = lambda item: time.sleep(0.02 * (5 - item)) or item * item
    assert list(ordered_map(slow_first, range(6), workers=2)) == [item * item for item in range(6)]


def test_a_failing_step_reaches_the_caller_and_no_step_runs_after_it_stops():
    """A step's exception is raised where its result is taken; when the caller stops there, steps not started
    are dropped and the running ones have finished by the time the exception arrives."""
    started = []

    def step(item):
        started.append(item)
        if item == 2:
            raise ValueError("step 2")
        time.sleep(0.05)
        return item

    with pytest.raises(ValueError, match="step 2"):
        for _ in ordered_map(step, range(100), workers=2):
            pass
    count = len(started)
    time.sleep(0.2)
    assert len(started) == count <= 5

