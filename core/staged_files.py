"""Outputs that appear whole or not at all.

Each file is written under a hidden temporary name in its target's folder, flushed to disk (fsync) and checked
(read back by the caller's check), and only when every file of the bake is staged are they all renamed over their
targets. A rename within one folder is atomic on POSIX and on NTFS (os.replace), so a full disk, a failing check,
an error or an interrupt before the commit leaves every earlier file as it was and no temporary behind.

A bake claims its main output for as long as it runs (``claimed``), so that two bakes started at once into the
same file cannot mix their files: the second one stops at once, naming the file and the process that holds it.
"""
from __future__ import annotations

import contextlib
import importlib
import itertools
import os
import signal
from typing import Callable, Iterator

from .errors import OutputError

locking = importlib.import_module("msvcrt" if os.name == "nt" else "fcntl")  # the platform's file locks

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


@contextlib.contextmanager
def claimed(target: str) -> Iterator[None]:
    """Hold the claim on writing ``target`` while the block runs; raises OutputError naming ``target`` and the
    holder's process id if another process holds it. The claim is an advisory lock (flock, or msvcrt's byte lock
    on Windows) on a hidden file ``.NAME.claim`` beside the target, removed on release. The operating system
    drops the lock of a process that dies, so a file left by a killed bake claims nothing."""
    folder, name = os.path.split(os.path.abspath(target))
    path = os.path.join(folder, f".{name}.claim")
    descriptor = _lock(path, target)
    try:
        os.ftruncate(descriptor, 0)
        os.write(descriptor, str(os.getpid()).encode())
        yield
    finally:
        if os.name == "nt":  # an open file cannot be removed there; a bake claiming it between the two is harmless
            os.close(descriptor)
            with contextlib.suppress(OSError):
                os.remove(path)
        else:  # removed while locked, so that no one locks the removed file (see _lock)
            os.remove(path)
            os.close(descriptor)


def _lock(path: str, target: str) -> int:
    """An open descriptor of ``path`` holding its exclusive lock, which is the file ``path`` names now (a holder
    may remove it between our open and our lock)."""
    while True:
        try:
            descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise OutputError(f"Cannot write '{target}': {error.strerror or error}.") from error
        try:
            if os.name == "nt":
                locking.locking(descriptor, locking.LK_NBLCK, 1)
            else:
                locking.flock(descriptor, locking.LOCK_EX | locking.LOCK_NB)
        except OSError:
            holder = _holder(descriptor)
            os.close(descriptor)
            raise OutputError(f"Another bake (process {holder}) is writing '{target}': wait for it to finish, or "
                              "choose another output.") from None
        if os.name == "nt" or _same_file(descriptor, path):
            return descriptor
        os.close(descriptor)


def _holder(descriptor: int) -> str:
    """The process id a claim's holder wrote into it (Windows refuses to read a locked byte)."""
    try:
        return os.read(descriptor, 32).decode(errors="replace").strip() or "unknown"
    except OSError:
        return "unknown"


def _same_file(descriptor: int, path: str) -> bool:
    try:
        return os.path.samestat(os.fstat(descriptor), os.stat(path))
    except FileNotFoundError:
        return False


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
