"""Atomic file output: every writer of the package goes through :func:`atomic_open`.

A file is written to a temporary file in its destination folder, flushed to disk, then
renamed over the destination (``os.replace``, atomic on POSIX). A full disk, a size limit
or an interrupted process leaves the destination as it was (absent or its previous
content), never a truncated file.

A destination that exists and is not a regular file (a symbolic link, a FIFO, a device
node, a socket) is refused (:func:`check_destination`): renaming over it would replace
the special file (as root, ``/dev/full`` by a regular file) instead of writing through it.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from stewart_pin.exceptions import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_destination(path: str | os.PathLike[str], what: str = "output") -> Path:
    """``path`` as a :class:`Path` when it is absent or a regular file (not followed if a
    symbolic link: ``os.lstat``); else :class:`InputError` naming its kind.

    Args:
        path: the destination file. what: how the message names it (``"-o"``...).
    """
    dest = Path(path)
    try:
        mode = os.lstat(dest).st_mode
    except (FileNotFoundError, NotADirectoryError):  # absent (the write says why, if it fails)
        return dest
    except OSError as e:
        raise InputError(f"{what} {dest}: cannot inspect the destination: {e}") from e
    if stat.S_ISREG(mode):
        return dest
    kinds = (
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    kind = next((name for test, name in kinds if test(mode)), "not a regular file")
    raise InputError(
        f"{what} {dest} is {kind}: files are written to a temporary file renamed over the "
        "destination, which would replace it; give the path of a regular file (or a new one)"
    )


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w") -> Iterator[IO[Any]]:
    """Open ``path`` for writing through a temporary file renamed into place on success.

    Args:
        path: destination file; its folder must exist.
        mode: ``"w"`` (text, UTF-8, ``\\n`` line ends) or ``"wb"`` (bytes).

    On any exception inside the ``with`` block the temporary file is removed and the
    destination is left untouched. The new file gets the permissions ``open`` would give
    (0666 less the umask).

    Raises:
        InputError: ``path`` exists and is not a regular file (:func:`check_destination`),
            checked before and again just before the rename.
    """
    if mode not in ("w", "wb"):
        raise InputError(f"atomic_open mode must be 'w' or 'wb', got {mode!r}")
    dest = check_destination(path)
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
        check_destination(dest)  # made special while the file was written
        os.replace(tmp, dest)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_open`)."""
    with atomic_open(path, "w") as handle:
        handle.write(text)
