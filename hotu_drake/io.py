"""Writing files safely: a temporary file in the same folder, then a rename,
so a failed run never leaves a half-written output behind.

Every writer of the project goes through `atomic_output` (clips, C3D,
OptiTrack CSV, checkpoints, reports, Meshcat HTML, model files).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from hotu_drake.errors import InputError


@contextmanager
def atomic_output(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary path beside `path` to write to; renamed to `path` when the
    block ends without an error, removed otherwise. `suffix` is for writers
    that insist on a file ending (`np.savez` adds `.npz` to any other).

    The parent folder is created; an unwritable destination raises an
    `OSError` that names `path`, not the temporary file."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    except OSError as error:
        raise OSError(error.errno, f"cannot write here ({error.strerror})", str(path)) from None
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual mode
        try:
            os.replace(tmp, path)
        except OSError as error:  # name the destination, not the temporary file
            raise OSError(error.errno, f"cannot write here ({error.strerror})", str(path)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def check_output_path(path: str | Path, folder: bool = False) -> Path:
    """Check, before any work, that `path` can be written (a file, or with
    `folder` a folder to write into), so a run does not fail on its last
    output after writing the others. `InputError` naming the path otherwise.

    Refused: the wrong kind of thing (a folder for a file, a file for a
    folder), a file or a broken link where a folder must be, and a nearest
    existing folder that is not writable or marked read-only (no write
    permission bit: refused for root too, who could write there). Then the
    writing is tried, as `atomic_output` does it: the missing folders and a
    temporary file are made and removed again, which finds what permission
    bits do not show (a special file system such as /sys, no space left)."""
    path = Path(path)
    if path.exists() and path.is_dir() != folder:
        problem = "is a folder; give a file name" if path.is_dir() else "is a file; give a folder"
        raise InputError(problem, path)
    target = path if folder else path.parent
    existing = target
    while not existing.exists() and existing != existing.parent:
        if existing.is_symlink():
            raise InputError(f"cannot write here ({existing} is a broken link)", path)
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"cannot write here ({existing} is not a folder)", path)
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"cannot write here ({existing} is not writable)", path)
    if not existing.stat().st_mode & 0o222:
        raise InputError(f"cannot write here ({existing} is read-only)", path)
    _try_writing(target, existing, path)
    return path


def _try_writing(folder: Path, existing: Path, path: Path) -> None:
    """Make `folder` (the folders from `existing` down to it) and a temporary
    file in it, then remove them all; `InputError` naming `path` if that fails."""
    missing = []
    while folder != existing:
        missing.append(folder)
        folder = folder.parent
    made: list[Path] = []
    try:
        for step in reversed(missing):
            step.mkdir()
            made.append(step)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".check", dir=missing[0] if missing else existing)
        os.close(fd)
        os.unlink(name)
    except OSError as error:
        raise InputError(f"cannot write here ({error.strerror or error})", path) from None
    finally:
        for step in reversed(made):
            with contextlib.suppress(OSError):
                step.rmdir()


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` all at once (creating the parent folder)."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` all at once (creating the parent folder)."""
    return write_bytes_atomic(path, text.encode("utf-8"))
