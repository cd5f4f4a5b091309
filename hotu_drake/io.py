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
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` all at once (creating the parent folder)."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` all at once (creating the parent folder)."""
    return write_bytes_atomic(path, text.encode("utf-8"))
