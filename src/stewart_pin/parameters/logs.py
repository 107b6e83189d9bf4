"""Actuator logs: what a robot measures, in the CSV format identification reads.

A real hexapod logs its six actuator positions (encoders) and efforts (motor currents
times a torque constant, or load cells) at its controller's rate; a motion tracker may
add the platform pose. :class:`ActuatorLog` holds such a log; :func:`read_log` reads its
CSV file (format below and in ``docs/identification.md``) and checks it
(:func:`check_log`), raising a named :class:`~stewart_pin.exceptions.LogError` with the
line for what would make identification silently wrong:

- :class:`~stewart_pin.exceptions.LogValueError`: a field that is not a number as CSV
  tools write it (ASCII decimal or scientific notation between optional ASCII spaces:
  no ``1_000``, no other scripts' digits, no non-breaking space), or not finite (``nan``,
  ``inf``); a position, effort or tracker position beyond :data:`MAX_MAGNITUDE` (1e9 in
  SI units); a tracker quaternion that is not unit;
- :class:`~stewart_pin.exceptions.LogTimeError`: a time that does not increase, or a
  step below ``min_step`` (0.5) times the median step: the filters take the samples as
  uniformly spaced at the median step;
- :class:`~stewart_pin.exceptions.LogGapError`: a step above ``max_gap`` (1.5) times the
  median: lost samples (split the log there);
- :class:`~stewart_pin.exceptions.LogSaturationError`: an effort at or past the
  actuator's effort limit (``effort_limits`` of the description, or given), or stuck at
  its extreme value for ``clip_run`` (10) samples or more (a drive or sensor that
  clipped);
- :class:`~stewart_pin.exceptions.LogLimitError`: a position outside the actuated
  joint's stroke or limits (revolute joints compared modulo 2 pi).

The CSV format: a header line, then one line per sample; comma-separated (no quoting),
SI units, columns in any order, blank lines and lines starting with ``#`` skipped, UTF-8,
every line ending with a line break, none longer than
:data:`~stewart_pin.formats.csv_tables.MAX_LINE_LENGTH` characters and no NUL byte (a binary
file is refused at its first line, not read whole):

- ``t`` [s], strictly increasing, uniformly sampled;
- ``l1 .. l6``: the actuated joint positions [m or rad] (leg lengths for UPS, crank
  angles for RUS, slide positions for PUS), as ``robot.actuator_positions`` gives them;
- ``gamma1 .. gamma6``: the actuated joints' efforts [N or N m, joint side], positive
  along the joint's positive direction (extending a UPS leg);
- optional, all seven or none: ``x y z qx qy qz qw``, the platform pose 0Tp from a
  tracker (O_p in F0 [m], unit quaternion of 0Rp, scalar last);
- ignored: the twist and acceleration columns of a simulation or measurement CSV (``vx
  .. alphaz``), so that ``stewart-pin simulate`` output reads as a log.

How an effort relates to its time stamp: by default ``gamma_k`` is the effort at
``t_k`` (a sample of a continuous signal, e.g. a load cell). A digital controller that
holds its command from ``t_k`` to ``t_(k+1)`` (zero-order hold) and logs the command
says so with the comment line ``# efforts: hold`` before the header: each held value
acts, on average, half a sample after its time stamp, and identification shifts the
sequence back by half a sample (:func:`hold_shift`, a windowed-sinc interpolator;
taking the held value as the sample would put the efforts half a sample ahead of the
motion: a bias of ``step / 2`` times the efforts' rate of change, 3 % of them for 5 Hz
content at 500 Hz).

The reader streams the file: memory grows with the samples kept, not with the text. The
log keeps 13 floats and the line number per sample (112 bytes; the tracker adds 16
floats for its 4x4 pose); reading peaks at about 1.25 times that (the arrays grow in
place by a quarter) plus column-sized temporaries: 136 bytes per sample measured by
``scripts/bench_log_memory.py`` (200 000 samples, ``tracemalloc``; 340 before the
arrays were grown in place).
"""

from __future__ import annotations

import math
import re
from array import array
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, freeze_fields
from stewart_pin._io import atomic_open
from stewart_pin.description.actuator_convention import actuator_convention_of
from stewart_pin.exceptions import (
    LogError,
    LogGapError,
    LogLimitError,
    LogSaturationError,
    LogTimeError,
    LogValueError,
)
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    LENGTH_COLUMNS,
    MAX_MAGNITUDE,
    NUMBER,
    QUATERNION_TOLERANCE,
    STATE_COLUMNS,
    iter_lines,
    parse_number,
    quaternions_from_rotations,
    rotations_from_quaternions,
)
from stewart_pin.protocols import RobotLike

#: The time column [s].
TIME_COLUMN = "t"
#: The actuated joint positions [m or rad].
POSITION_COLUMNS: tuple[str, ...] = LENGTH_COLUMNS
#: The actuated joints' efforts [N or N m].
EFFORT_COLUMNS: tuple[str, ...] = FORCE_COLUMNS
#: The optional tracker pose: O_p in F0 [m] and the unit quaternion of 0Rp (scalar last).
TRACKER_COLUMNS: tuple[str, ...] = ("x", "y", "z", "qx", "qy", "qz", "qw")
#: Columns a log may hold and the reader skips (a simulation's twists and accelerations).
IGNORED_COLUMNS: tuple[str, ...] = STATE_COLUMNS[STATE_COLUMNS.index("vx") :]
#: The columns of a log without tracker, in the order :func:`write_log` writes them.
LOG_COLUMNS: tuple[str, ...] = (TIME_COLUMN, *POSITION_COLUMNS, *EFFORT_COLUMNS)

#: A step longer than this multiple of the median step is a gap (:class:`LogGapError`).
MAX_GAP = 1.5
#: A step shorter than this multiple of the median is irregular sampling (:class:`LogTimeError`).
MIN_STEP = 0.5
#: An effort stuck at its column's extreme value for this many consecutive samples is
#: clipped (:class:`LogSaturationError`); 0 turns the check off.
CLIP_RUN = 10

_CUT_HINT = ": the file ends inside this line, it was probably cut short while being written"


@dataclass(frozen=True, eq=False)
class ActuatorLog:
    """A log of actuator positions and efforts (and optionally tracker poses).

    Attributes:
        times: shape (N,) [s], strictly increasing.
        positions: shape (N, 6), the actuated joint positions [m or rad].
        efforts: shape (N, 6), the actuated joints' efforts [N or N m, joint side].
        tracker_poses: shape (N, 4, 4), 0Tp from a tracker, or ``None``.
        lines: shape (N,), the file line of each sample (``None``: a log built in memory,
            whose sample k is reported as line k + 2, as if written with a header).
        source: where it came from (the path, or a description), for messages.
        effort_hold: whether ``efforts[k]`` was held from ``times[k]`` to ``times[k+1]``
            (a zero-order hold: ``# efforts: hold`` in the file) rather than sampled at
            ``times[k]``.
    """

    times: np.ndarray
    positions: np.ndarray
    efforts: np.ndarray
    tracker_poses: np.ndarray | None = None
    lines: np.ndarray | None = None
    source: str = "log"
    effort_hold: bool = False

    def __post_init__(self) -> None:
        times = check_array(self.times, (None,), "times")
        n = times.shape[0]
        values: dict[str, Any] = {
            "times": times,
            "positions": check_array(self.positions, (n, 6), "positions"),
            "efforts": check_array(self.efforts, (n, 6), "efforts"),
        }
        if self.tracker_poses is not None:
            values["tracker_poses"] = check_array(self.tracker_poses, (n, 4, 4), "tracker_poses")
        if self.lines is not None:
            values["lines"] = np.asarray(self.lines, dtype=np.int64).reshape(n)
        freeze_fields(self, values)

    @classmethod
    def _of_checked_arrays(
        cls,
        times: np.ndarray,
        positions: np.ndarray,
        efforts: np.ndarray,
        tracker_poses: np.ndarray | None,
        lines: np.ndarray,
        source: str,
        effort_hold: bool,
    ) -> ActuatorLog:
        """A log of arrays :func:`read_log` built and checked (float64, finite, of the
        right shapes), kept as they are (made read-only, not copied: a long log's
        numbers are held once)."""
        log = cls.__new__(cls)
        fields = {
            "times": times,
            "positions": positions,
            "efforts": efforts,
            "tracker_poses": tracker_poses,
            "lines": lines,
            "source": source,
            "effort_hold": bool(effort_hold),
        }
        for key, value in fields.items():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
            object.__setattr__(log, key, value)
        return log

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def line(self, k: int) -> int:
        """The file line of sample ``k`` (``k + 2`` for a log built in memory)."""
        return int(self.lines[k]) if self.lines is not None else int(k) + 2

    @property
    def step(self) -> float:
        """The median time step [s] (the filters' sampling period)."""
        if len(self) < 2:
            raise LogTimeError(f"{self.source}: {len(self)} sample(s): no time step")
        return float(np.median(np.diff(self.times)))

    @property
    def sample_rate(self) -> float:
        """``1 / step`` [Hz]."""
        return 1.0 / self.step

    def segment(self, start: int, stop: int) -> ActuatorLog:
        """Samples ``start:stop`` (line numbers kept)."""
        sl = slice(start, stop)
        lines = np.arange(len(self)) + 2 if self.lines is None else self.lines
        return ActuatorLog(
            self.times[sl],
            self.positions[sl],
            self.efforts[sl],
            None if self.tracker_poses is None else self.tracker_poses[sl],
            lines[sl],
            self.source,
            self.effort_hold,
        )

    def effort_samples(self, start: int, stop: int) -> np.ndarray:
        """The efforts acting at samples ``start:stop`` (m, 6): ``efforts[start:stop]``, or
        with :attr:`effort_hold` the held values shifted by half a sample
        (:func:`hold_shift`, :data:`HOLD_TAPS`; the log's ends padded with its first and
        last values)."""
        if not self.effort_hold:
            return np.asarray(self.efforts[start:stop])
        h = HOLD_TAPS
        M = len(h) // 2  # taps j = -M+1 .. M: efforts[k - j]
        lo, hi = start - M, stop + M - 1
        idx = np.clip(np.arange(lo, hi), 0, len(self) - 1)
        e = self.efforts[idx]  # e[i] = efforts[lo + i]
        out = np.zeros((stop - start, 6))
        for t, j in enumerate(range(-M + 1, M + 1)):
            # efforts[k - j] for k = start..stop-1 is e[k - j - lo]
            a = start - j - lo
            out += h[t] * e[a : a + stop - start]
        return out

    @classmethod
    def from_simulation(
        cls,
        result: Any,
        position_resolution: float | Any = 0.0,
        effort_noise: float | Any = 0.0,
        seed: int | None = None,
        tracker: bool = False,
        effort_hold: bool = True,
    ) -> ActuatorLog:
        """What a lab would log of a simulated run: quantised positions, noisy efforts.

        Args:
            result: a :class:`~stewart_pin.motion.simulation.SimulationResult` (``t``,
                ``lengths`` the actuated positions, ``gammas`` the applied efforts).
            position_resolution: the encoders' resolution [m or rad], one or (6,): each
                position is rounded to the nearest multiple (e.g. 1e-6 m, 2**-16 rad);
                0 keeps the exact values.
            effort_noise: standard deviation of zero-mean Gaussian noise added to the
                efforts [N or N m], one or (6,), independent across samples.
            seed: seeds the noise.
            tracker: keep the simulated poses as tracker poses.
            effort_hold: the efforts were held over each step (:func:`simulate` with
                ``control_period`` equal to the output step: each ``gammas[k]`` acts from
                ``t[k]`` to ``t[k+1]``); ``False`` for forces continuous in time.
        """
        res = np.broadcast_to(np.asarray(position_resolution, dtype=float), (6,))
        std = np.broadcast_to(np.asarray(effort_noise, dtype=float), (6,))
        if np.any(~np.isfinite(res)) or np.any(res < 0):
            raise LogValueError(f"position_resolution must be >= 0, got {position_resolution}")
        if np.any(~np.isfinite(std)) or np.any(std < 0):
            raise LogValueError(f"effort_noise must be >= 0, got {effort_noise}")
        q = np.asarray(result.lengths, dtype=float)
        q = np.where(res > 0, np.round(q / np.where(res > 0, res, 1.0)) * res, q)
        rng = np.random.default_rng(seed)
        efforts = np.asarray(result.gammas, dtype=float) + rng.normal(size=q.shape) * std
        poses = np.asarray(result.poses) if tracker else None
        return cls(result.t, q, efforts, poses, None, "simulation", bool(effort_hold))


# ====================================================================== reading


def _error_at(path: Any, line: int, message: str) -> str:
    return f"{path}, line {line}: {message}"


def _sample_error(
    cls: type[LogError], log: ActuatorLog, k: int, message: str, column: str, value: float
) -> LogError:
    """A ``cls`` naming sample ``k`` of ``log``: its file and line, the column and value."""
    return cls(
        _error_at(log.source, log.line(k), message), line=log.line(k), column=column, value=value
    )


class _Samples:
    """The numbers of the rows read so far, kept in the log's own arrays: ``times`` (n,),
    ``positions`` and ``efforts`` (n, 6), the tracker's seven columns (n, 7) if any and
    the line numbers (n,), grown in place (``ndarray.resize``, a ``realloc``) by a
    quarter when full, from a buffer of :data:`BLOCK` rows: the file's numbers are held
    once (13 floats and a line number per sample), never copied into a second table."""

    #: Rows parsed into the buffer before they are moved into the arrays.
    BLOCK = 4096

    def __init__(self, tracker: bool) -> None:
        self.width = len(LOG_COLUMNS) + (len(TRACKER_COLUMNS) if tracker else 0)
        self.n = 0
        self.buffer = array("d")
        self.buffer_lines = array("q")
        cap = self.BLOCK
        self.times = np.empty(cap)
        self.positions = np.empty((cap, 6))
        self.efforts = np.empty((cap, 6))
        self.track = np.empty((cap, len(TRACKER_COLUMNS))) if tracker else None
        self.lines = np.empty(cap, dtype=np.int64)

    def append(self, row: list[float], line: int) -> None:
        self.buffer.extend(row)
        self.buffer_lines.append(line)
        if len(self.buffer_lines) == self.BLOCK:
            self._flush()

    def _resize(self, cap: int) -> None:
        for a in (self.times, self.positions, self.efforts, self.track, self.lines):
            if a is not None:
                a.resize((cap, *a.shape[1:]), refcheck=False)

    def _flush(self) -> None:
        m = len(self.buffer_lines)
        if m == 0:
            return
        if self.n + m > len(self.times):
            self._resize(max(self.n + m, len(self.times) + len(self.times) // 4))
        block = np.frombuffer(self.buffer, dtype=float).reshape(m, self.width)
        rows = slice(self.n, self.n + m)
        self.times[rows] = block[:, 0]
        self.positions[rows] = block[:, 1:7]
        self.efforts[rows] = block[:, 7:13]
        if self.track is not None:
            self.track[rows] = block[:, 13:20]
        self.lines[rows] = np.frombuffer(self.buffer_lines, dtype=np.int64)
        del block
        self.n += m
        self.buffer = array("d")
        self.buffer_lines = array("q")

    def arrays(
        self,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """``(times, positions, efforts, tracker columns or None, lines)``, n rows each
        (the arrays shrunk in place to the rows read)."""
        self._flush()
        self._resize(self.n)
        return self.times, self.positions, self.efforts, self.track, self.lines


def read_log(
    path: str | Path,
    robot: RobotLike | None = None,
    *,
    effort_limits: Any = None,
    max_gap: float = MAX_GAP,
    min_step: float = MIN_STEP,
    clip_run: int = CLIP_RUN,
    min_rows: int = 2,
) -> ActuatorLog:
    """Read an actuator log (CSV, module docstring) and check it (:func:`check_log`).

    Args:
        path: the CSV file.
        robot: the robot the log is of; with it the positions are checked against its
            actuated joints' limits and the efforts against its ``effort_limits``.
        effort_limits: the actuators' effort limits [N or N m], one or (6,) (default the
            description's, if any).
        max_gap, min_step: the allowed time step, as multiples of the median step.
        clip_run: consecutive samples at a column's extreme value that count as clipped
            (0: no such check).
        min_rows: fewest samples accepted.

    Raises:
        LogError: a missing, unknown or repeated column; a row with the wrong number of
            fields; a file cut inside its last line; fewer than ``min_rows`` samples;
            text that is not UTF-8; and the named subclasses (module docstring).
        OSError: the file cannot be read.
    """
    path = Path(path)
    header: list[str] | None = None
    columns: list[int] = []
    n_fields = 0
    tracker = False
    store: _Samples | None = None
    last_line, last_text, last_break = 0, "", True
    hold = False
    for k, text in iter_lines(path, lambda message, line: LogError(message, line=line)):
        if not text.strip() or text[0] == "#":
            if header is None and _directive(text) is not None:
                hold = _directive(text) == "hold"
            continue
        last_line, last_text = k, text
        last_break = text.endswith(("\n", "\r"))
        fields = text.rstrip("\r\n").split(",")
        if header is None:
            header = [h.strip() for h in fields]
            columns, tracker = _header(path, k, header)
            n_fields = len(header)
            store = _Samples(tracker)
            continue
        if len(fields) != n_fields:
            hint = "" if last_break else _CUT_HINT
            raise LogError(
                _error_at(
                    path,
                    k,
                    f"{len(fields)} fields, expected {n_fields} (one per header column)" + hint,
                ),
                line=k,
            )
        if _PLAIN_ROW.fullmatch(text) is None:  # letters, other scripts, other spaces
            _check_fields(path, k, fields, columns, header)
        try:
            row = [float(fields[c]) for c in columns]
        except ValueError:
            _raise_bad_field(path, k, fields, columns, header)
        assert store is not None  # set with the header
        store.append(row, k)
    if header is None:
        raise LogError(f"{path}: no header line; expected {','.join(LOG_COLUMNS)}")
    if not last_break:
        shown = last_text if len(last_text) <= 60 else last_text[:60] + "..."
        raise LogError(
            f"{path}, line {last_line}: no line break after the last line ({shown!r})"
            f"{_CUT_HINT}; every line must end with a line break (add one if the file is "
            "complete)",
            line=last_line,
        )
    assert store is not None  # set with the header
    times, positions, efforts, track, line_numbers = store.arrays()
    names = [header[c] for c in columns]
    blocks = [(times[:, None], names[:1]), (positions, names[1:7]), (efforts, names[7:13])]
    if track is not None:
        blocks.append((track, names[13:20]))
    for values, block_names in blocks:  # column by column: a small temporary
        for c in range(values.shape[1]):
            finite = np.isfinite(values[:, c])
            if finite.all():
                continue
            r = int(np.argmin(finite))
            raise LogValueError(
                _error_at(
                    path,
                    int(line_numbers[r]),
                    f"column '{block_names[c]}': non-finite value {float(values[r, c])!r}; "
                    "a log holds finite numbers (drop or repair the sample)",
                ),
                line=int(line_numbers[r]),
                column=block_names[c],
                value=float(values[r, c]),
            )
    if len(times) < min_rows:
        raise LogError(
            f"{path}: {len(times)} sample(s), at least {min_rows} needed",
            line=last_line or None,
        )
    poses = None
    if track is not None:
        quat = track[:, 3:7]
        norms = np.linalg.norm(quat, axis=1)
        off = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
        if off.size:
            r = int(off[0])
            raise LogValueError(
                _error_at(
                    path,
                    int(line_numbers[r]),
                    f"the tracker quaternion (qx, qy, qz, qw) = "
                    f"{tuple(float(v) for v in quat[r])} has norm {norms[r]:.9g}, expected 1 "
                    f"within {QUATERNION_TOLERANCE:g}",
                ),
                line=int(line_numbers[r]),
                column="qw",
                value=float(norms[r]),
            )
        poses = np.tile(np.eye(4), (len(times), 1, 1))
        poses[:, :3, 3] = track[:, 0:3]
        poses[:, :3, :3] = rotations_from_quaternions(quat / norms[:, None])
    log = ActuatorLog._of_checked_arrays(
        times, positions, efforts, poses, line_numbers, str(path), hold
    )
    check_log(
        log,
        robot,
        effort_limits=effort_limits,
        max_gap=max_gap,
        min_step=min_step,
        clip_run=clip_run,
    )
    return log


def hold_shift(half_width: int = 16) -> np.ndarray:
    """The taps ``h_j`` (j = -M+1 .. M, M = ``half_width``) of a half-sample delay:
    ``g_k = sum_j h_j efforts[k - j]`` is the held sequence (whose value ``efforts[m]``
    acts, on average, at ``t_m + step / 2``) evaluated at ``t_k``: a Hann-windowed
    ``sinc(j - 1/2)``, normalised to unit DC gain: phase exact (a symmetric filter about
    the half sample), gain within 1e-4 of 1 up to a fifth of the sample rate (the two-tap
    average ``(e_(k-1) + e_k) / 2`` would be off by ``(2 pi f step)^2 / 8``, 3e-3 at 6 Hz
    for 250 Hz)."""
    M = int(half_width)
    j = np.arange(-M + 1, M + 1)
    x = j - 0.5
    h = np.sinc(x) * 0.5 * (1.0 + np.cos(np.pi * x / M))
    return np.asarray(h / h.sum(), dtype=float)


#: :func:`hold_shift` with 32 taps.
HOLD_TAPS = hold_shift()

#: The comment line saying how efforts relate to their time stamps.
EFFORT_DIRECTIVE = "# efforts:"


def _directive(text: str) -> str | None:
    """``"hold"`` or ``"sample"`` for a ``# efforts: hold|sample`` line, else ``None``."""
    words = text.split()
    if len(words) == 3 and words[0] == "#" and words[1] == "efforts:":
        if words[2] in ("hold", "sample"):
            return words[2]
    return None


def _header(path: Path, line: int, header: list[str]) -> tuple[list[int], bool]:
    """Field indices of t, l1..l6, gamma1..gamma6 (and the tracker's seven), and whether
    the tracker columns are there."""
    known = (TIME_COLUMN, *POSITION_COLUMNS, *EFFORT_COLUMNS, *TRACKER_COLUMNS, *IGNORED_COLUMNS)
    required = LOG_COLUMNS
    missing = [c for c in required if c not in header]
    unknown = [c for c in header if c not in known]
    repeated = sorted({c for c in header if header.count(c) > 1})
    present = [c for c in TRACKER_COLUMNS if c in header]
    problems = [
        f"{label} column{'s' if len(cols) > 1 else ''} {', '.join(map(repr, cols))}"
        for label, cols in (("missing", missing), ("unknown", unknown), ("repeated", repeated))
        if cols
    ]
    if present and len(present) != len(TRACKER_COLUMNS):
        absent = [c for c in TRACKER_COLUMNS if c not in header]
        problems.append(f"tracker columns {present} without {absent} (all seven or none)")
    if problems:
        raise LogError(
            f"{path}, line {line}: {'; '.join(problems)}; a log's header names "
            f"{','.join(required)} (and optionally {','.join(TRACKER_COLUMNS)}) once each",
            line=line,
        )
    tracker = bool(present)
    order = list(required) + (list(TRACKER_COLUMNS) if tracker else [])
    return [header.index(c) for c in order], tracker


#: A data row of plain numbers: ASCII digits, signs, points, exponents, commas and
#: spaces only, and its line break (anything else is checked field by field,
#: :func:`~stewart_pin.formats.csv_tables.parse_number`).
_PLAIN_ROW = re.compile(r"[0-9eE+\-., ]*\r?\n?", re.ASCII)


def _check_fields(
    path: Path, line: int, fields: list[str], columns: list[int], header: list[str]
) -> None:
    """Raise :class:`LogValueError` for the first read field that is not a number as CSV
    tools write it (:data:`~stewart_pin.formats.csv_tables.NUMBER`)."""
    for c in columns:
        if NUMBER.fullmatch(fields[c]) is None:
            _raise_bad_field(path, line, fields, [c], header)


def _raise_bad_field(
    path: Path, line: int, fields: list[str], columns: list[int], header: list[str]
) -> None:
    for c in columns:
        if parse_number(fields[c]) is None:
            raise LogValueError(
                _error_at(
                    path,
                    line,
                    f"column '{header[c]}': {fields[c].strip(' ')!r} is not a number (ASCII "
                    "decimal or scientific notation, e.g. -1.5 or 2e-3, nothing else)",
                ),
                line=line,
                column=header[c],
                value=fields[c].strip(" "),
            )
    raise AssertionError("unreachable")  # pragma: no cover


def write_log(path: str | Path, log: ActuatorLog) -> Path:
    """Write ``log`` as CSV: the ``# efforts: hold|sample`` line, then :data:`LOG_COLUMNS`
    (and the tracker's seven columns when it has tracker poses), atomically, numbers as
    ``repr`` so they read back exactly."""
    columns = LOG_COLUMNS
    parts = [log.times[:, None], log.positions, log.efforts]
    if log.tracker_poses is not None:
        columns = columns + TRACKER_COLUMNS
        parts += [
            log.tracker_poses[:, :3, 3],
            quaternions_from_rotations(log.tracker_poses[:, :3, :3]),
        ]
    path = Path(path)
    with atomic_open(path, "w") as f:
        f.write(f"{EFFORT_DIRECTIVE} {'hold' if log.effort_hold else 'sample'}\n")
        f.write(",".join(columns) + "\n")
        for row in np.hstack(parts):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    return path


# ====================================================================== checks


def _limits_of(robot: RobotLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(lower, upper, revolute)`` (6,) each of the six actuated joints, in the robot's
    actuator convention (a log holds the robot's values: an imported robot's file's)."""
    desc = robot.description
    lower, upper, revolute = np.empty(6), np.empty(6), np.zeros(6, dtype=bool)
    for i, leg in enumerate(desc.leg_architectures):
        joint = leg.joints[leg.actuated - 1]
        lower[i], upper[i], revolute[i] = joint.lower, joint.upper, joint.revolute
    lim = actuator_convention_of(robot).limits_from_description(np.c_[lower, upper])
    return lim[:, 0], lim[:, 1], revolute


def check_log(
    log: ActuatorLog,
    robot: RobotLike | None = None,
    *,
    effort_limits: Any = None,
    max_gap: float = MAX_GAP,
    min_step: float = MIN_STEP,
    clip_run: int = CLIP_RUN,
) -> None:
    """Check a log's time stamps, and with ``robot`` its positions and efforts (see the
    module docstring for what each named error means).

    Raises:
        LogTimeError, LogGapError, LogLimitError, LogSaturationError: naming the first
            offending line.
    """
    src = log.source
    t = log.times
    if len(log) < 2:
        raise LogTimeError(f"{src}: {len(log)} sample(s), at least 2 needed for a time step")
    _check_magnitudes(log)
    dt = np.diff(t)
    bad = np.flatnonzero(~(dt > 0))
    if bad.size:
        k = int(bad[0]) + 1
        raise _sample_error(
            LogTimeError,
            log,
            k,
            f"t = {float(t[k])!r} s does not increase (previous sample, line "
            f"{log.line(k - 1)}: {float(t[k - 1])!r} s); time stamps must be strictly "
            "increasing",
            column=TIME_COLUMN,
            value=float(t[k]),
        )
    step = float(np.median(dt))
    gaps = np.flatnonzero(dt > max_gap * step)
    short = np.flatnonzero(dt < min_step * step)
    if gaps.size and not (short.size and short[0] < gaps[0]):  # the first offence
        k = int(gaps[0]) + 1
        raise _sample_error(
            LogGapError,
            log,
            k,
            f"a gap of {float(dt[k - 1]):.6g} s before t = {float(t[k])!r} s, more than "
            f"{max_gap:g} times the median step {step:.6g} s: samples are missing "
            f"(about {round(float(dt[k - 1]) / step) - 1}); split the log at the gap and "
            "identify from the pieces",
            column=TIME_COLUMN,
            value=float(dt[k - 1]),
        )
    if short.size:
        k = int(short[0]) + 1
        raise _sample_error(
            LogTimeError,
            log,
            k,
            f"a step of {float(dt[k - 1]):.6g} s before t = {float(t[k])!r} s, less than "
            f"{min_step:g} times the median step {step:.6g} s: irregular sampling (the "
            "filters take the samples as uniformly spaced); resample the log uniformly",
            column=TIME_COLUMN,
            value=float(dt[k - 1]),
        )
    if robot is not None:
        _check_positions(log, robot)
        if effort_limits is None:
            effort_limits = robot.description.effort_limits
    if effort_limits is not None:
        _check_effort_limits(log, effort_limits)
    if clip_run:
        _check_clipping(log, int(clip_run))


def _check_magnitudes(log: ActuatorLog) -> None:
    """Positions, efforts and tracker positions within :data:`MAX_MAGNITUDE` (a value far
    past any actuator's is a corrupt sample or a wrong unit: unchecked, 1e200 N made the
    regressor lose rank and 1e308 N made its SVD fail)."""
    blocks = [
        (log.positions, POSITION_COLUMNS, "position"),
        (log.efforts, EFFORT_COLUMNS, "effort"),
    ]
    if log.tracker_poses is not None:
        blocks.append((log.tracker_poses[:, :3, 3], TRACKER_COLUMNS[:3], "tracker position"))
    found = []
    for values, names, what in blocks:
        for i in range(values.shape[1]):  # column by column: a small temporary
            within = np.abs(values[:, i]) <= MAX_MAGNITUDE
            if not within.all():
                found.append((int(np.argmin(within)), i, values, names, what))
    if found:
        k, i, values, names, what = min(found, key=lambda f: (f[0], f[1]))
        raise _sample_error(
            LogValueError,
            log,
            k,
            f"column '{names[i]}': {what} {float(values[k, i]):.6g} is beyond "
            f"{MAX_MAGNITUDE:g} (SI units: m, rad, N, N m): no actuator reads that; a "
            "corrupt sample or a wrong unit (drop or repair the sample)",
            column=names[i],
            value=float(values[k, i]),
        )


def _check_positions(log: ActuatorLog, robot: RobotLike) -> None:
    lower, upper, revolute = _limits_of(robot)
    q = log.positions
    found = []
    for i in range(6):  # column by column: small temporaries
        qi = q[:, i]
        if revolute[i] and math.isfinite(lower[i]):
            qi = lower[i] + np.mod(qi - lower[i], 2 * math.pi)
        with np.errstate(invalid="ignore"):
            inside = (qi >= lower[i]) & (qi <= upper[i])
        if not inside.all():
            found.append((int(np.argmin(inside)), i))
    if found:
        k, i = min(found)
        unit = "rad" if revolute[i] else "m"
        what = robot.description.limits_name
        raise _sample_error(
            LogLimitError,
            log,
            k,
            f"actuator {i + 1} position l{i + 1} = {float(q[k, i])!r} {unit} is outside "
            f"its {what} [{lower[i]:.9g}, {upper[i]:.9g}] {unit}: check the encoder "
            "offset, the units and the column order, or the robot description",
            column=POSITION_COLUMNS[i],
            value=float(q[k, i]),
        )


def _check_effort_limits(log: ActuatorLog, effort_limits: Any) -> None:
    if isinstance(effort_limits, (int, float)) and not isinstance(effort_limits, bool):
        effort_limits = [float(effort_limits)] * 6
    limits = check_array(effort_limits, (6,), "effort_limits")
    found = []
    for i in range(6):  # column by column: a small temporary
        below = np.abs(log.efforts[:, i]) < limits[i]
        if not below.all():
            found.append((int(np.argmin(below)), i))
    if found:
        k, i = min(found)
        raise _sample_error(
            LogSaturationError,
            log,
            k,
            f"actuator {i + 1} effort gamma{i + 1} = {float(log.efforts[k, i])!r} is at "
            f"its limit {limits[i]:.6g}: the drive saturated, so the logged effort is "
            "not the one the dynamics needed; cut the saturated part or use a gentler "
            "trajectory",
            column=EFFORT_COLUMNS[i],
            value=float(log.efforts[k, i]),
        )


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """``(start, length)`` of the longest run of True in ``mask`` (length 0 if none)."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    if edges.size == 0:
        return 0, 0
    starts, stops = edges[0::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k] - starts[k])


def _check_clipping(log: ActuatorLog, run: int) -> None:
    e = log.efforts
    for i in range(6):
        for extreme in (e[:, i].max(), e[:, i].min()):
            start, length = _longest_run(e[:, i] == extreme)
            if length >= run:
                raise _sample_error(
                    LogSaturationError,
                    log,
                    start,
                    f"actuator {i + 1} effort gamma{i + 1} stays at its extreme value "
                    f"{float(extreme)!r} for {length} consecutive samples (lines "
                    f"{log.line(start)}-{log.line(start + length - 1)}): clipped by a "
                    "saturated drive or sensor; cut that part, or pass clip_run=0 if "
                    "the plateau is real",
                    column=EFFORT_COLUMNS[i],
                    value=float(extreme),
                )


__all__ = [
    "CLIP_RUN",
    "EFFORT_COLUMNS",
    "LOG_COLUMNS",
    "MAX_GAP",
    "MAX_MAGNITUDE",
    "MIN_STEP",
    "POSITION_COLUMNS",
    "TRACKER_COLUMNS",
    "ActuatorLog",
    "check_log",
    "hold_shift",
    "read_log",
    "write_log",
]
