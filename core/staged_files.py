"""Outputs that appear whole or not at all.

Each file is written under a hidden temporary name in its target's folder, flushed to disk (fsync) and checked
(read back by the caller's check), and only when every file of the bake is staged are they all renamed over their
targets. A rename within one folder is atomic on POSIX and on NTFS (os.replace), so a full disk, a failing check,
an error or an interrupt before the commit leaves every earlier file as it was and no temporary behind.
"""
from __future__ import annotations

import itertools
import os
import signal
from typing import Callable

from .errors import OutputError

_numbers = itertools.count()


class StagedFiles:
    """A set of output files written now and moved into place together by ``commit``; use as a context manager,
    which discards the staged files unless they were committed."""

    def __init__(self):
        self._staged: list[tuple[str, str]] = []  # (temporary, target)

    def stage(self, target: str, write: Callable[[str], None], check: Callable[[str], None] | None = None) -> str:
        """Call ``write(temporary_path)``, flush the file to disk and ``check(temporary_path)``; returns the
        temporary path. An OSError on the way becomes an OutputError naming ``target``, and the temporary is
        removed."""
        target = os.path.abspath(target)
        folder, name = os.path.split(target)
        stem, extension = os.path.splitext(name)  # kept: writers choose the format by the extension
        temporary = os.path.join(folder, f".{stem}.partial-{os.getpid()}-{next(_numbers)}{extension}")
        self._staged.append((temporary, target))
        try:
            write(temporary)
            _flush_to_disk(temporary)
            if check is not None:
                check(temporary)
        except OutputError as error:  # a writer's own message, about the file it was given
            self._remove(temporary)
            raise OutputError(str(error).replace(temporary, target)) from error
        except OSError as error:
            self._remove(temporary)
            raise OutputError(f"Cannot write '{target}': {error.strerror or error}; the earlier file, if any, "
                              "is unchanged.") from error
        except BaseException:
            self._remove(temporary)
            raise
        return temporary

    def commit(self) -> None:
        """Rename every staged file over its target, with interrupts held back until all are in place."""
        blocked = {signal.SIGINT, signal.SIGTERM} if hasattr(signal, "pthread_sigmask") else set()
        if blocked:
            signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
        try:
            for temporary, target in self._staged:
                os.replace(temporary, target)
            for folder in {os.path.dirname(target) for _, target in self._staged}:
                _flush_folder(folder)
            self._staged = []
        except OSError as error:
            raise OutputError(f"Cannot move the bake's files into place: {error.strerror or error}.") from error
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, blocked)

    def discard(self) -> None:
        """Remove every staged file that was not committed."""
        for temporary, _ in self._staged:
            self._remove(temporary)
        self._staged = []

    def __enter__(self) -> StagedFiles:
        return self

    def __exit__(self, *exc) -> None:
        self.discard()

    @staticmethod
    def _remove(path: str) -> None:
        try:
            os.remove(path)
        except FileNotFoundError:
            pass


def _flush_to_disk(path: str) -> None:
    with open(path, "rb+") as file:
        os.fsync(file.fileno())


def _flush_folder(folder: str) -> None:
    """Make the renames themselves durable (POSIX; Windows has no folder handles to flush)."""
    if os.name != "posix":
        return
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
