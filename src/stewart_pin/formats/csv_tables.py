"""CSV tables of platform states, forces and leg lengths (the project's one CSV format).

A table is a header line naming its columns (any order on reading) and one row per
sample, SI units, numbers written with Python's ``repr`` so that reading them back gives
the same floats. Lines starting with ``#`` and blank lines are skipped. The file is UTF-8
(a byte-order mark is allowed) and every line, the last one included, ends with a line
break: a file whose last line has none may have been cut while it was written, and is
refused (if it is complete, add the line break). A line longer than
:data:`MAX_LINE_LENGTH` characters, or a NUL byte (a binary file), is refused before the
rest is read. A number is what CSV tools write: ASCII decimal or scientific notation
(``-1.5``, ``2e-3``, ``.5``, ``1E+06``), optionally between ASCII spaces; no digit
separators (``1_000``, ``1,000``), no other scripts' digits, no other white space (a tab,
a non-breaking space); ``nan`` and ``inf`` are read as numbers and refused as non-finite
(:func:`parse_number`). Files are written atomically (a
temporary file in the folder, renamed into place). The columns:

- :data:`STATE_COLUMNS`: ``t`` [s]; ``x y z``, the position of O_p in F0 [m];
  ``qx qy qz qw``, the unit quaternion of 0Rp; ``vx vy vz wx wy wz``, the twist [v, w] in
  F0 [m/s, rad/s]; ``ax ay az alphax alphay alphaz``, the classical acceleration in F0
  [m/s^2, rad/s^2];
- :data:`FORCE_COLUMNS`: ``gamma1 .. gamma6``, the actuator forces [N];
- :data:`LENGTH_COLUMNS`: ``l1 .. l6``, the actuated joint positions: leg lengths [m] for
  6-UPS, crank angles [rad] for 6-RUS, slide positions [m] for 6-PUS.
"""

from __future__ import annotations

import csv
import math
import re
import zipfile
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

from stewart_pin._checks import check_increasing_times
from stewart_pin._io import atomic_open
from stewart_pin._so3 import quaternions_xyzw_from_rotations, rotations_from_quaternions_xyzw
from stewart_pin.exceptions import FileFormatError

STATE_COLUMNS: tuple[str, ...] = (
    "t",
    *("x", "y", "z"),
    *("qx", "qy", "qz", "qw"),
    *("vx", "vy", "vz", "wx", "wy", "wz"),
    *("ax", "ay", "az", "alphax", "alphay", "alphaz"),
)
FORCE_COLUMNS: tuple[str, ...] = tuple(f"gamma{i}" for i in range(1, 7))
LENGTH_COLUMNS: tuple[str, ...] = tuple(f"l{i}" for i in range(1, 7))


def _span(columns: tuple[str, ...], first: str, last: str) -> slice:
    return slice(columns.index(first), columns.index(last) + 1)


#: Where each quantity sits in a row of a table read in the column order
#: ``STATE_COLUMNS + FORCE_COLUMNS (+ LENGTH_COLUMNS)`` (the one definition of the layout).
TIME_COLUMN = STATE_COLUMNS.index("t")
POSITION_SLICE = _span(STATE_COLUMNS, "x", "z")
QUATERNION_SLICE = _span(STATE_COLUMNS, "qx", "qw")
TWIST_SLICE = _span(STATE_COLUMNS, "vx", "wz")
ACCEL_SLICE = _span(STATE_COLUMNS, "ax", "alphaz")
FORCE_SLICE = slice(len(STATE_COLUMNS), len(STATE_COLUMNS) + len(FORCE_COLUMNS))
LENGTH_SLICE = slice(FORCE_SLICE.stop, FORCE_SLICE.stop + len(LENGTH_COLUMNS))

#: Tolerance on ``|q| - 1`` of a quaternion read from a file (renormalised within it).
QUATERNION_TOLERANCE = 1e-6

#: The largest magnitude of a measured value (a position, velocity, acceleration [SI], an
#: effort [N or N m]) in a log or a measurement CSV: far past any hexapod's, and far
#: enough inside double precision that the regressor's products and squares stay exact in
#: their relative precision (unchecked, an effort of 1e200 N made the regressor lose rank
#: and 1e308 N made its SVD fail).
MAX_MAGNITUDE = 1e9

#: The longest line a CSV reader accepts [characters]: a row of 32 numbers written with
#: ``repr`` takes under 800; a file with no line break (a binary file, ``/dev/zero``)
#: would otherwise be read as one endless line.
MAX_LINE_LENGTH = 65536

#: A number as CSV tools write it (ASCII only, optional surrounding ASCII spaces): decimal
#: or scientific notation, or ``nan`` / ``inf`` / ``infinity`` with an optional sign (read,
#: then refused as non-finite by the readers).
NUMBER = re.compile(
    r" *[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf|infinity) *",
    re.ASCII | re.IGNORECASE,
)


def parse_number(text: str) -> float | None:
    """The float of one CSV field, ``None`` unless it is a :data:`NUMBER` (Python's
    ``float`` alone would also take ``1_000``, Arabic-Indic digits and non-breaking
    spaces)."""
    return float(text) if NUMBER.fullmatch(text) is not None else None


def iter_lines(path: Path, error: Callable[[str, int], Exception]) -> Iterator[tuple[int, str]]:
    """``(line number, line)`` of a UTF-8 text file (optional byte-order mark), line breaks
    kept (``\\n``, ``\\r\\n`` or ``\\r``), streamed: a line longer than
    :data:`MAX_LINE_LENGTH` characters (no line break: a binary file, ``/dev/zero``), a
    NUL byte (a binary file) or bytes that are not UTF-8 raise ``error(message, line)`` at
    that line, before the rest of the file is read."""
    with open(path, encoding="utf-8-sig", errors="surrogateescape", newline="") as f:
        k = 0
        while True:
            line = f.readline(MAX_LINE_LENGTH + 1)
            if not line:
                return
            k += 1
            if len(line) > MAX_LINE_LENGTH:
                raise error(
                    f"{path}, line {k}: a line longer than {MAX_LINE_LENGTH} characters (no "
                    "line break): not a CSV text file (a binary file?)",
                    k,
                )
            if "\0" in line:
                raise error(f"{path}, line {k}: a NUL byte: a binary file, not CSV text", k)
            try:
                line.encode("utf-8")  # bytes that were not UTF-8 are lone surrogates here
            except UnicodeEncodeError as e:
                raise error(
                    f"{path}, line {k}: not UTF-8 text (byte "
                    f"{ord(line[e.start]) - 0xDC00:#04x} at character {e.start}); save the "
                    "file as UTF-8",
                    k,
                ) from None
            yield k, line


#: Conversions between 0Rp and the ``qx qy qz qw`` columns (re-exported names).
quaternions_from_rotations = quaternions_xyzw_from_rotations
rotations_from_quaternions = rotations_from_quaternions_xyzw


def state_table(
    times: np.ndarray, poses: np.ndarray, twists: np.ndarray, accels: np.ndarray
) -> np.ndarray:
    """The :data:`STATE_COLUMNS` block (N, 20) of a motion."""
    quat = quaternions_xyzw_from_rotations(poses[:, :3, :3])
    return np.column_stack([times, poses[:, :3, 3], quat, twists, accels])


def states_from_table(
    rows: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(times, poses (N, 4, 4), twists, accels)`` from rows whose first 20 columns are
    :data:`STATE_COLUMNS` (quaternions already checked to be unit within tolerance)."""
    quat = rows[:, QUATERNION_SLICE]
    poses = np.tile(np.eye(4), (rows.shape[0], 1, 1))
    poses[:, :3, 3] = rows[:, POSITION_SLICE]
    poses[:, :3, :3] = rotations_from_quaternions_xyzw(
        quat / np.linalg.norm(quat, axis=1)[:, None]
    )
    return rows[:, TIME_COLUMN], poses, rows[:, TWIST_SLICE], rows[:, ACCEL_SLICE]


def write_csv(path: str | Path, columns: Sequence[str], table: np.ndarray) -> Path:
    """Write ``table`` (N, len(columns)) under a header of ``columns``, atomically (a
    temporary file in the folder, renamed into place: an error leaves the previous file)."""
    path = Path(path)
    with atomic_open(path, "w") as f:
        f.write(",".join(columns) + "\n")
        for row in np.asarray(table, dtype=float):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    return path


def read_csv(
    path: str | Path,
    columns: Sequence[str],
    min_rows: int = 1,
    max_magnitude: float | None = None,
) -> np.ndarray:
    """Read a table holding exactly ``columns`` (any order): rows (N, len(columns)) in the
    order of ``columns``; with ``max_magnitude``, every value but the time ``t`` at most
    that in magnitude (measurements: :data:`MAX_MAGNITUDE`).

    Raises:
        FileFormatError: text that is not UTF-8, a last line without its line break (a
            file cut short), a missing, unknown or repeated column, a row with the wrong
            number of fields, a non-numeric or non-finite value, a value beyond
            ``max_magnitude``, a non-unit quaternion
            (when the table has ``qx..qw``), a time ``t`` that does not increase, or fewer
            than ``min_rows`` rows; the message names the line.
        OSError: the file cannot be read.
    """
    path = Path(path)
    columns = tuple(columns)
    lines = [(k, line) for k, line in _read_lines(path) if line.strip() and line[0] != "#"]
    # A last line without its line break: the file may have been cut while written.
    cut = bool(lines) and not lines[-1][1].endswith(("\n", "\r"))
    if not lines:
        raise FileFormatError(f"{path}: no header line; expected {','.join(columns)}")
    header_line, header = lines[0][0], next(csv.reader([lines[0][1]]))
    header = [h.strip() for h in header]
    missing = [c for c in columns if c not in header]
    unknown = [c for c in header if c not in columns]
    repeated = sorted({c for c in header if header.count(c) > 1})
    if missing or unknown or repeated:
        problems = [
            f"{label} column{'s' if len(cols) > 1 else ''} {', '.join(map(repr, cols))}"
            for label, cols in (("missing", missing), ("unknown", unknown), ("repeated", repeated))
            if cols
        ]
        raise FileFormatError(
            f"{path}, line {header_line}: {'; '.join(problems)}; the header must name "
            f"each of {','.join(columns)} once"
        )
    order = [header.index(c) for c in columns]
    rows = np.empty((len(lines) - 1, len(columns)))
    line_numbers = [k for k, _ in lines[1:]]
    for r, (k, line) in enumerate(lines[1:]):
        fields = next(csv.reader([line]))
        if len(fields) != len(header):
            hint = _CUT_HINT if cut and r == len(lines) - 2 else ""
            raise FileFormatError(
                f"{path}, line {k}: {len(fields)} fields, expected {len(header)} (one per "
                f"header column){hint}"
            )
        for c, j in enumerate(order):
            text = fields[j].strip(" ")
            value = parse_number(text)
            if value is None:
                raise FileFormatError(
                    f"{path}, line {k}, column '{columns[c]}': {text!r} is not a number "
                    "(ASCII decimal or scientific notation, e.g. -1.5 or 2e-3, nothing else)"
                )
            if not math.isfinite(value):
                raise FileFormatError(
                    f"{path}, line {k}, column '{columns[c]}': non-finite value {text!r}"
                )
            if max_magnitude is not None and abs(value) > max_magnitude and columns[c] != "t":
                raise FileFormatError(
                    f"{path}, line {k}, column '{columns[c]}': {value:.6g} is beyond "
                    f"{max_magnitude:g} (SI units): no robot measures that; a corrupt sample "
                    "or a wrong unit (drop or repair the sample)"
                )
            rows[r, c] = value
    if cut:
        k, line = lines[-1]
        shown = line if len(line) <= 60 else line[:60] + "..."
        raise FileFormatError(
            f"{path}, line {k}: no line break after the last line ({shown!r}){_CUT_HINT}; "
            "every line must end with a line break (add one if the file is complete)"
        )
    if "qx" in columns:
        q0 = columns.index("qx")
        quat = rows[:, q0 : q0 + 4]
        norms = np.linalg.norm(quat, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
        if bad.size:
            r = int(bad[0])
            raise FileFormatError(
                f"{path}, line {line_numbers[r]}: the quaternion (qx, qy, qz, qw) = "
                f"{tuple(float(v) for v in quat[r])} has norm {norms[r]:.9g}, expected 1 "
                f"within {QUATERNION_TOLERANCE:g}; write unit quaternions"
            )
    if "t" in columns:
        check_increasing_times(
            rows[:, columns.index("t")],
            label=lambda k: f"line {line_numbers[k]}: time t",
            prefix=f"{path}, ",
            error=FileFormatError,
        )
    if rows.shape[0] < max(int(min_rows), 1):
        raise FileFormatError(
            f"{path}: {rows.shape[0]} data rows (after the header on line {header_line}), "
            f"at least {max(int(min_rows), 1)} needed"
        )
    return rows


_CUT_HINT = ": the file ends inside this line, it was probably cut short while being written"


def _read_lines(path: Path) -> list[tuple[int, str]]:
    """``(line number, line)`` of a table's file (:func:`iter_lines`)."""
    return list(iter_lines(path, lambda message, line: FileFormatError(message)))


#: Tolerance on ``max |R^T R - I|`` and on the last row of a pose read from an ``.npz``.
POSE_TOLERANCE = 1e-6


def read_npz(path: str | Path, shapes: Mapping[str, tuple[int | None, ...]]) -> dict:
    """Read the arrays named in ``shapes`` from an ``.npz`` written by ``np.savez``.

    Each array must be present and hold finite real numbers (no booleans, complex numbers,
    strings or pickled objects) of its shape, where ``None`` is one sample count shared
    by every array (at least one sample). A ``t`` array must strictly increase; a
    ``poses`` array (K, 4, 4) must hold rigid transforms (last row ``[0, 0, 0, 1]``,
    rotation blocks orthonormal within :data:`POSE_TOLERANCE`).

    Returns:
        the float64 arrays by name.

    Raises:
        FileFormatError: the file is not a readable ``.npz`` (corrupt, truncated, not a
            zip archive, pickled data) or an array is missing or invalid, naming it.
        OSError: the file cannot be opened.
    """
    path = Path(path)
    with path.open("rb") as f:  # OSError (missing, unreadable) as for CSV files
        try:
            with np.load(f, allow_pickle=False) as data:
                missing = [k for k in shapes if k not in data.files]
                if missing:
                    raise FileFormatError(
                        f"{path}: missing array{'s' if len(missing) > 1 else ''} "
                        f"{', '.join(map(repr, missing))}; expected {', '.join(shapes)}"
                    )
                raw = {k: data[k] for k in shapes}
        except FileFormatError:
            raise
        except (
            OSError,
            ValueError,
            EOFError,
            KeyError,
            MemoryError,
            zipfile.BadZipFile,
            zlib.error,
        ) as e:
            raise FileFormatError(f"{path}: not a readable .npz file ({e})") from e
    out: dict[str, np.ndarray] = {}
    count: tuple[int, str] | None = None
    for key, shape in shapes.items():
        a = raw[key]
        if a.dtype.kind not in "iuf":
            raise FileFormatError(
                f"{path}: array '{key}' holds {a.dtype} values, expected real numbers"
            )
        fits = a.ndim == len(shape) and all(
            s is None or s == n for s, n in zip(shape, a.shape, strict=True)
        )
        if not fits:
            want = "(" + ", ".join("K" if s is None else str(s) for s in shape) + ")"
            raise FileFormatError(f"{path}: array '{key}' has shape {a.shape}, expected {want}")
        for s, n in zip(shape, a.shape, strict=True):
            if s is None:
                count = count or (n, key)
                if n != count[0]:
                    raise FileFormatError(
                        f"{path}: array '{key}' holds {n} samples but '{count[1]}' holds "
                        f"{count[0]}"
                    )
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            where = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
            raise FileFormatError(f"{path}: array '{key}' holds {a[where]} at index {where}")
        out[key] = a
    if count is not None and count[0] < 1:
        raise FileFormatError(f"{path}: no samples (at least one needed)")
    if "t" in out:
        check_increasing_times(
            out["t"], label=lambda k: f"time t[{k}]", prefix=f"{path}: ", error=FileFormatError
        )
    if "poses" in out and out["poses"].shape[1:] == (4, 4):
        T = out["poses"]
        R = T[:, :3, :3]
        err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        err = np.maximum(err, np.abs(T[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(axis=1))
        bad = np.flatnonzero((err > POSE_TOLERANCE) | (np.linalg.det(R) <= 0))
        if bad.size:
            k = int(bad[0])
            raise FileFormatError(
                f"{path}: poses[{k}] is not a rigid transform (max |R^T R - I| or last-row "
                f"error {err[k]:.3g} > {POSE_TOLERANCE:g}, or det R <= 0)"
            )
    return out
