"""Text from a user (a robot name, a path) on its way into markup and file names.

A description's ``name`` is checked when the description is built
(:func:`stewart_pin.description.check_robot_name`). The writers do not rely on that alone:
they build XML with ElementTree (which escapes attribute text), never put user text in a
comment, write YAML and JSON strings with full escaping, and derive file names through
:func:`file_in_folder`; a name that bypassed the check is escaped or refused, never pasted.
"""

from __future__ import annotations

import functools
import os
import re
from pathlib import Path

from stewart_pin.exceptions import InputError

__all__ = ["check_xml_text", "file_in_folder", "toml_quoted", "yaml_quoted"]


@functools.cache
def _not_xml() -> re.Pattern[str]:
    """The characters XML 1.0 cannot hold at all, not even as a character reference
    (compiled on first use: about 10 ms, out of every process's start-up)."""
    return re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def check_xml_text(text: str, what: str) -> str:
    """``text`` if XML 1.0 can hold it (ElementTree escapes ``& < > "`` and line breaks in
    attributes), else :class:`InputError` (control characters, lone surrogates)."""
    if not isinstance(text, str):
        raise InputError(f"{what} must be a string to be written into XML, got {text!r}")
    bad = _not_xml().search(text)
    if bad is not None:
        raise InputError(
            f"{what} {text!r} holds the character {bad.group()!r} at index {bad.start()}, "
            "which XML cannot represent; remove it"
        )
    return text


def _quoted(text: str, byte_escape: str, surrogate: str | None) -> str:
    """``text`` double-quoted: printable ASCII as is (but ``"`` and ``\\``), every other
    character escaped: ``byte_escape`` (a format of the code) up to U+00FF, ``\\uXXXX``,
    ``\\UXXXXXXXX`` above; lone surrogates as ``surrogate`` when given."""
    out = []
    for ch in text:
        code = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif 0x20 <= code < 0x7F:
            out.append(ch)
        elif surrogate is not None and 0xD800 <= code <= 0xDFFF:
            out.append(surrogate)
        elif code <= 0xFF:
            out.append(byte_escape.format(code))
        elif code <= 0xFFFF:
            out.append(f"\\u{code:04x}")
        else:
            out.append(f"\\U{code:08x}")
    return '"' + "".join(out) + '"'


def yaml_quoted(text: str) -> str:
    """``text`` as a YAML double-quoted scalar: printable ASCII as is (but ``"`` and ``\\``),
    everything else as an escape (``\\xXX``, ``\\uXXXX``, ``\\UXXXXXXXX``), so no character
    of ``text`` can end the scalar, break the line or be folded by the reader."""
    return _quoted(text, "\\x{:02x}", None)


def toml_quoted(text: str) -> str:
    """``text`` as a TOML basic string: printable ASCII as is (but ``"`` and ``\\``), every
    other character escaped (``\\uXXXX``, ``\\UXXXXXXXX``: TOML has no ``\\x``), so no
    text from a file can end the string or the line. Lone surrogates, which no TOML string
    can hold, become U+FFFD."""
    return _quoted(text, "\\u{:04x}", "\\ufffd")


def file_in_folder(folder: str | os.PathLike[str], file_name: str) -> Path:
    """``folder / file_name``, checked to be a file directly inside ``folder``.

    ``file_name`` (typically derived from a robot name, e.g. ``"<name>.urdf"``) must be one
    plain path component: no separator, not ``.`` or ``..``, no NUL; and the resolved path
    must have the resolved ``folder`` as its parent. Raises :class:`InputError` otherwise.
    """
    folder = Path(folder)
    parts = re.split(r"[/\\]", file_name)
    if len(parts) != 1 or file_name in ("", ".", "..") or "\0" in file_name:
        raise InputError(
            f"file name {file_name!r} (derived from the robot name) is not a plain file name: "
            f"it would be written outside the folder {str(folder)!r}; rename the robot"
        )
    path = folder / file_name
    if Path(os.path.realpath(path)).parent != Path(os.path.realpath(folder)):
        raise InputError(
            f"file name {file_name!r} resolves outside the folder {str(folder)!r}; rename "
            "the robot"
        )
    return path
