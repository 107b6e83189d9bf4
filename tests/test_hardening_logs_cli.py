"""Hardening of the log and CSV readers and the command line (issue 25, items 13-18 and
the physical fit's credibility of item 20).

References are independent of the code under test: hand-written file texts (numbers as
CSV tools write them, and the spellings Python's ``float`` also accepts), the sizes of
the machine (``os.sysconf``), signals sent to a child process, and an effort log whose
sign was flipped (a fit no physical robot can make).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from stewart_pin.exceptions import FileFormatError, LogError, LogValueError
from stewart_pin.formats.csv_tables import MAX_LINE_LENGTH, STATE_COLUMNS, read_csv
from stewart_pin.parameters.logs import MAX_MAGNITUDE, read_log

HEADER = "t,l1,l2,l3,l4,l5,l6,gamma1,gamma2,gamma3,gamma4,gamma5,gamma6\n"


def _log_text(n: int = 12, field: str | None = None, row: int = 5, column: int = 8) -> str:
    """A plain log of ``n`` samples at 100 Hz (positions 0.5 m, efforts 10 N plus a ramp);
    ``field`` replaces column ``column`` of sample ``row`` (line ``row + 2``)."""
    lines = [HEADER]
    for k in range(n):
        values = [repr(k / 100.0)] + ["0.5"] * 6 + [repr(10.0 + 0.1 * k + j) for j in range(6)]
        if field is not None and k == row:
            values[column] = field
        lines.append(",".join(values) + "\n")
    return "".join(lines)


# ====================================================================== item 13: numbers

ACCEPTED = ["12.5", " 12.5 ", "+12.5", "1.25e1", "1.25E+01", "125e-1", ".125e2", "0012.50"]
REFUSED = {
    "digit separator": "1_2.5",
    "Arabic-Indic digits": "\u0661\u0662.\u0665",
    "non-breaking space": "\u00a012.5",
    "tab": "\t12.5",
    "full-width digits": "\uff11\uff12",
    "hex": "0x12",
}


@pytest.mark.parametrize("text", ACCEPTED)
def test_log_reads_numbers_as_csv_tools_write_them(tmp_path, text):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field=text), encoding="utf-8")
    assert read_log(path).efforts[5, 1] == 12.5


@pytest.mark.parametrize("case", list(REFUSED))
def test_log_refuses_what_python_float_alone_would_take(tmp_path, case):
    text = _log_text(field=REFUSED[case])
    path = tmp_path / "log.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(LogValueError, match=r"log\.csv, line 7: column 'gamma2': .* is not a num"):
        read_log(path)


@pytest.mark.parametrize("case", list(REFUSED))
def test_trajectory_csv_refuses_what_python_float_alone_would_take(tmp_path, case):
    value = REFUSED[case]
    row = ["0.0", "0", "0", "1", "0", "0", "0", "1"] + ["0"] * 12
    good = tmp_path / "good.csv"
    good.write_text(",".join(STATE_COLUMNS) + "\n" + ",".join(row) + "\n", encoding="utf-8")
    assert read_csv(good, STATE_COLUMNS)[0, 3] == 1.0
    row[3] = value
    path = tmp_path / "traj.csv"
    path.write_text(",".join(STATE_COLUMNS) + "\n" + ",".join(row) + "\n", encoding="utf-8")
    with pytest.raises(FileFormatError, match=r"traj\.csv, line 2, column 'z': .* is not a num"):
        read_csv(path, STATE_COLUMNS)


def test_nan_in_a_log_is_read_as_a_number_and_refused_as_non_finite(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field="NaN"), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 7: column 'gamma2': non-finite value nan"):
        read_log(path)


# ====================================================================== item 14: magnitudes


@pytest.mark.parametrize("value", ["1e308", "-1e200", "1.0000001e9"])
def test_log_effort_beyond_the_bound_names_its_value_and_line(tmp_path, value):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field=value), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 7: column 'gamma2': effort .* beyond 1e\+09"):
        read_log(path)
    assert MAX_MAGNITUDE == 1e9
    path.write_text(_log_text(field="1e9"), encoding="utf-8")  # the bound itself: accepted
    assert read_log(path, clip_run=0).efforts[5, 1] == 1e9


def test_log_position_beyond_the_bound_names_its_value_and_line(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text(_log_text(field="-3e15", row=9, column=4), encoding="utf-8")
    with pytest.raises(LogValueError, match=r"line 11: column 'l4': position -3e\+15") as info:
        read_log(path)
    assert info.value.line == 11 and info.value.value == -3e15


def test_cli_identify_log_with_a_huge_effort_is_one_line_exit_2(tmp_path, capsys):
    from stewart_pin.cli import main

    path = tmp_path / "log.csv"
    path.write_text(_log_text(n=40, field="1e308", row=30), encoding="utf-8")
    code = main(["identify", "--preset", "random-2", "--log", str(path), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "line 32" in err and "1e+308" in err


# ====================================================================== item 15: lines


@pytest.mark.parametrize("reader", ["log", "table"])
def test_a_file_without_line_breaks_is_refused_at_line_1(tmp_path, reader):
    path = tmp_path / "long.csv"
    path.write_bytes(b"1" * (4 * MAX_LINE_LENGTH))
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=rf"line 1: a line longer than {MAX_LINE_LENGTH}"):
        read(path)


@pytest.mark.parametrize("reader", ["log", "table"])
def test_a_binary_file_is_refused_at_its_first_nul(tmp_path, reader):
    path = tmp_path / "bin.csv"
    path.write_bytes(HEADER.encode() + b"0,1\x00\x00,2\n" + b"\x00" * 100)
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=r"line 2: a NUL byte: a binary file"):
        read(path)


@pytest.mark.parametrize("reader", ["log", "table"])
def test_dev_zero_is_refused_not_read_forever(reader):
    from pathlib import Path

    if not Path("/dev/zero").exists():
        pytest.skip("no /dev/zero")
    read = (lambda p: read_log(p)) if reader == "log" else (lambda p: read_csv(p, STATE_COLUMNS))
    with pytest.raises(FileFormatError, match=r"/dev/zero, line 1: a line longer"):
        read(Path("/dev/zero"))


def test_the_bound_leaves_long_comment_and_data_lines_alone(tmp_path):
    path = tmp_path / "log.csv"
    text = _log_text()
    path.write_text("#" + "x" * (MAX_LINE_LENGTH - 2) + "\n" + text, encoding="utf-8")
    assert len(read_log(path)) == 12
    assert isinstance(LogError("x"), FileFormatError) and math.isfinite(MAX_MAGNITUDE)
    np.testing.assert_array_equal(read_log(path).positions, 0.5)
