"""Writing files safely: a temporary file in the same folder, then a rename,
so a failed run never leaves a half-written output behind.

Every writer of the project goes through `atomic_output` (clips, C3D,
OptiTrack CSV, checkpoints, reports, Meshcat HTML, model files).
"""

from __future__ import annotations

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
    `folder` a folder to write into): not the wrong kind of thing, and the
    nearest existing folder above it writable. `InputError` naming the path
    otherwise."""
    path = Path(path)
    if path.exists() and path.is_dir() != folder:
        problem = "is a folder; give a file name" if path.is_dir() else "is a file; give a folder"
        raise InputError(problem, path)
    existing = path if folder and path.exists() else path.parent
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise InputError(f"cannot write here ({existing} is not a folder)", path)
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"cannot write here ({existing} is not writable)", path)
    return path


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` all at once (creating the parent folder)."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` all at once (creating the parent folder)."""
    return write_bytes_atomic(path, text.encode("utf-8"))
