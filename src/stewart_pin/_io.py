"""Atomic file output: every writer of the package goes through :func:`atomic_open`.

A file is written to a temporary file in its destination folder, flushed to disk, then
renamed over the destination (``os.replace``, atomic on POSIX). A full disk, a size limit
or an interrupted process leaves the destination as it was (absent or its previous
content), never a truncated file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from stewart_pin.exceptions import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w") -> Iterator[IO[Any]]:
    """Open ``path`` for writing through a temporary file renamed into place on success.

    Args:
        path: destination file; its folder must exist.
        mode: ``"w"`` (text, UTF-8, ``\\n`` line ends) or ``"wb"`` (bytes).

    On any exception inside the ``with`` block the temporary file is removed and the
    destination is left untouched. The new file gets the permissions ``open`` would give
    (0666 less the umask).
    """
    if mode not in ("w", "wb"):
        raise InputError(f"atomic_open mode must be 'w' or 'wb', got {mode!r}")
    dest = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent or ".")
    try:
        if mode == "w":
            handle: IO[Any] = os.fdopen(fd, "w", encoding="utf-8", newline="\n")
        else:
            handle = os.fdopen(fd, "wb")
        with handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_open`)."""
    with atomic_open(path, "w") as handle:
        handle.write(text)
