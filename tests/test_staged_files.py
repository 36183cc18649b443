"""core.staged_files.claimed: one bake at a time writes a file; the claim leaves nothing behind."""
import os

import pytest

from core import OutputError
from core.staged_files import claimed


def test_a_claimed_output_is_refused_to_a_second_claim_until_released(tmp_path):
    target = tmp_path / "level.blend"
    with claimed(str(target)):
        assert (tmp_path / ".level.blend.claim").read_text() == str(os.getpid())
        with pytest.raises(OutputError, match=f"process {os.getpid()}.*level.blend"):
            with claimed(str(target)):
                pass
    assert list(tmp_path.iterdir()) == []
    with claimed(str(target)):
        pass
    assert list(tmp_path.iterdir()) == []


def test_a_claim_left_by_a_killed_bake_claims_nothing(tmp_path):
    """A claim file nobody holds a lock on (its bake was killed) is taken over, and removed after."""
    (tmp_path / ".level.blend.claim").write_text("12345")
    with claimed(str(tmp_path / "level.blend")):
        assert (tmp_path / ".level.blend.claim").read_text() == str(os.getpid())
    assert list(tmp_path.iterdir()) == []


def test_a_folder_that_cannot_hold_the_claim_names_the_output(tmp_path):
    with pytest.raises(OutputError, match="Cannot write .*missing.*level.blend"):
        with claimed(str(tmp_path / "missing" / "level.blend")):
            pass
