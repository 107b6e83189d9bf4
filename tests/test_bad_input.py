"""Bad input at the library level (issue 9, items 13 and 14).

Item 13: files the package reads (descriptions in TOML / JSON, CSV tables, ``.npz``
results, closure sidecars) that are not UTF-8, nest too deeply, are corrupt or hold ragged
or non-numeric fields raise :class:`FileFormatError` naming the file, the problem and the
line where known; the CLI prints one line and exits 2.

Item 14: numbers given as strings or booleans, complex arrays, NaN thresholds and negative
tolerances or periods are refused with named errors instead of being converted.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from stewart_pin import (
    DescriptionError,
    FileFormatError,
    InputError,
    RobotDescription,
    StewartRobot,
    random_robot,
    simulate,
)
from stewart_pin.cli import main
from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv
from stewart_pin.formats.urdf import read_sidecar
from stewart_pin.motion.simulation import SimulationResult


@pytest.fixture(scope="module")
def good() -> dict:
    return random_robot(5).to_dict()


def line_of(text: str, fragment: str) -> int:
    """The 1-based line of the first occurrence of ``fragment`` in ``text``."""
    return text[: text.index(fragment)].count("\n") + 1


def assert_one_line_exit_2(argv: list[str], capsys, *fragments: str) -> str:
    """``stewart-pin argv`` exits 2 with one line on stderr holding each fragment."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    return err


# ====================================================================== item 13: files
# ---------------------------------------------------------------------- not UTF-8
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_non_utf8_description_is_a_file_format_error_naming_the_line(tmp_path, good, suffix):
    text = RobotDescription.from_dict(good).write(tmp_path / f"r{suffix}").read_text()
    # A name in Latin-1 (as an editor in a Western locale saves it): byte 0xe9 for "é".
    text = text.replace('"random-5"', '"caf\xe9"')
    path = tmp_path / f"latin1{suffix}"
    path.write_bytes(text.encode("latin-1"))
    line = line_of(text, "caf\xe9")
    with pytest.raises(FileFormatError, match=rf"latin1\{suffix}, line {line}: not UTF-8 text"):
        RobotDescription.read(path)


def test_non_utf8_csv_is_a_file_format_error_naming_the_line(tmp_path):
    path = tmp_path / "latin1.csv"
    row = ",".join(["0.0"] * 7 + ["1.0"] + ["0.0"] * 12)
    path.write_bytes(f"{','.join(STATE_COLUMNS)}\n# r\xe9sum\xe9\n{row}\n".encode("latin-1"))
    with pytest.raises(FileFormatError, match=r"latin1\.csv, line 2: not UTF-8 text"):
        read_csv(path, STATE_COLUMNS)


def test_non_utf8_closure_sidecar_is_a_file_format_error(tmp_path):
    path = tmp_path / "x.closures.json"
    path.write_bytes(b'{"format": "caf\xe9"}')
    with pytest.raises(FileFormatError, match=r"x\.closures\.json, line 1: not UTF-8"):
        read_sidecar(path)


# ---------------------------------------------------------------------- nesting, JSON
@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("deep.json", "[" * 100_000 + "]" * 100_000),
        ("deep-dict.json", '{"a":' * 100_000 + "1" + "}" * 100_000),
        ("deep.toml", "base_points = " + "[" * 100_000 + "]" * 100_000),
    ],
)
def test_deeply_nested_description_is_a_file_format_error(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(FileFormatError, match="nested too deeply"):
        RobotDescription.read(path)


def test_deeply_nested_closure_sidecar_is_a_file_format_error(tmp_path):
    path = tmp_path / "x.closures.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(FileFormatError, match="nested too deeply"):
        read_sidecar(path)


def test_huge_json_integer_is_a_file_format_error(tmp_path, good):
    path = tmp_path / "huge.json"
    text = json.dumps(good)
    path.write_text(text.replace('"gravity": [', '"gravity": [' + "9" * 5000 + ", ", 1))
    with pytest.raises(FileFormatError, match=r"malformed robot description .*huge\.json"):
        RobotDescription.read(path)


def test_repeated_json_key_is_a_file_format_error(tmp_path, good):
    # Which of two strokes would be meant? JSON parsers keep the last one silently.
    path = tmp_path / "twice.json"
    text = json.dumps(good)
    path.write_text(text[:-1] + ', "stroke": [0.1, 0.2]}')
    with pytest.raises(FileFormatError, match=r"key 'stroke' is given twice"):
        RobotDescription.read(path)


# ---------------------------------------------------------------------- ragged, non-numeric
@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("stroke", '[0.5, "0.9"]', r"stroke\[1\] is the string '0\.9', not a real number"),
        ("gravity", "[0.0, 0.0, true]", r"gravity\[2\] is the boolean True"),
        ("stroke", "[0.5, [0.9]]", r"stroke\[1\] is a list where a number is expected"),
        (
            "base_points",
            "[[0.5, 0.0, 0.0], [0.1, 0.2], [0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]]",
            r"ragged rows: base_points\[0\] is a row of 3 but base_points\[1\] is a row of 2",
        ),
        (
            "u_joint_limits",
            '[[-1.0, 1.0], [0.1, "x"]]',
            r"u_joint_limits\[1\]\[1\] is the string 'x'",
        ),
        ("platform_inertia", '"heavy"', r"platform_inertia is the string 'heavy'"),
        ("home_pose", "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.7], [0, 0, 0]]", r"ragged"),
    ],
)
def test_ragged_or_non_numeric_field_names_the_key_and_its_line(
    tmp_path, good, key, value, message
):
    text = RobotDescription.from_dict(good).write(tmp_path / "r.toml").read_text()
    lines = text.splitlines()
    k = next((n for n, line in enumerate(lines) if line.startswith(f"{key} = ")), None)
    if k is None:  # an optional key the robot lacks: add it
        lines.append(f"{key} = {value}")
        k = len(lines) - 1
    else:  # replace the (possibly multi-line) value by the bad one on one line
        end = k + 1
        while end < len(lines) and lines[end].startswith((" ", "]")):
            end += 1
        lines[k:end] = [f"{key} = {value}"]
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FileFormatError, match=rf"bad\.toml: line {k + 1}: .*{message}"):
        RobotDescription.read(path)


# ---------------------------------------------------------------------- corrupt .npz
FIELDS = ("t", "poses", "twists", "accels", "gammas", "lengths")


def result_arrays(n: int = 4) -> dict[str, np.ndarray]:
    """A small valid result: identity rotations, distinct finite values."""
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, 3] = np.arange(3 * n).reshape(n, 3) * 0.01
    return {
        "t": np.arange(n) * 0.1,
        "poses": poses,
        "twists": np.full((n, 6), 0.25),
        "accels": np.full((n, 6), -0.5),
        "gammas": np.full((n, 6), 10.0),
        "lengths": np.full((n, 6), 0.123456789),
    }


def _save(path, **changes) -> bytes:
    arrays = {**result_arrays(), **changes}
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path.read_bytes()


def _flip_data_byte(path) -> None:
    data = bytearray(_save(path))
    k = data.index(np.float64(0.123456789).tobytes())  # inside the stored 'lengths' array
    data[k] ^= 0xFF
    path.write_bytes(bytes(data))


def _rotated_pose(path) -> None:
    poses = result_arrays()["poses"]
    poses[2, :3, :3] *= 1.01
    _save(path, poses=poses)


NPZ_CASES = {
    "not a zip": (lambda p: p.write_bytes(b"garbage, not an archive"), r"not a readable \.npz"),
    "truncated": (lambda p: p.write_bytes(_save(p)[:300]), r"not a readable \.npz"),
    "bad checksum": (_flip_data_byte, r"not a readable \.npz .*CRC"),
    "pickled": (
        lambda p: _save(p, t=np.array([0.0, "x", None, 1], dtype=object)),
        r"not a readable \.npz .*allow_pickle",
    ),
    "missing array": (lambda p: _save(p, lengths=None), r"missing array 'lengths'"),
    "wrong shape": (lambda p: _save(p, poses=np.zeros((4, 3))), r"'poses' has shape \(4, 3\)"),
    "sample count": (
        lambda p: _save(p, twists=np.zeros((3, 6))),
        r"'twists' holds 3 samples but 't' holds 4",
    ),
    "no samples": (
        lambda p: np.savez(p, **{k: v[:0] for k, v in result_arrays().items()}),
        "no samples",
    ),
    "nan": (lambda p: _save(p, accels=np.full((4, 6), np.nan)), r"'accels' holds nan"),
    "complex": (
        lambda p: _save(p, gammas=np.full((4, 6), 1 + 2j)),
        r"'gammas' holds complex128 values, expected real numbers",
    ),
    "bool": (lambda p: _save(p, gammas=np.ones((4, 6), bool)), r"'gammas' holds bool values"),
    "strings": (lambda p: _save(p, t=np.array(["0", "1", "2", "3"])), r"'t' holds <U1 values"),
    "not rigid": (_rotated_pose, r"poses\[2\] is not a rigid transform"),
    "time": (lambda p: _save(p, t=np.array([0.0, 0.2, 0.1, 0.3])), r"t\[2\] = 0\.1 s does"),
}


@pytest.mark.parametrize("case", list(NPZ_CASES))
def test_corrupt_npz_result_is_a_file_format_error(tmp_path, case):
    make, message = NPZ_CASES[case]
    path = tmp_path / "result.npz"
    make(path)
    with pytest.raises(FileFormatError, match=message) as info:
        SimulationResult.load(path)
    assert "result.npz" in str(info.value)


def test_valid_npz_result_loads_exactly(tmp_path):
    path = tmp_path / "ok.npz"
    _save(path)
    result = SimulationResult.load(path)
    for key, value in result_arrays().items():
        np.testing.assert_array_equal(getattr(result, key), value)


# ---------------------------------------------------------------------- the CLI
def test_cli_non_utf8_description_exits_2(tmp_path, good, capsys):
    path = tmp_path / "latin1.toml"
    text = RobotDescription.from_dict(good).write(tmp_path / "r.toml").read_text()
    path.write_bytes(text.replace('"random-5"', '"caf\xe9"').encode("latin-1"))
    assert_one_line_exit_2(["ik", "--description", str(path)], capsys, "latin1.toml", "UTF-8")


def test_cli_deeply_nested_description_exits_2(tmp_path, capsys):
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    assert_one_line_exit_2(["ik", "--description", str(path)], capsys, "deep.json", "nested")


def test_cli_non_numeric_description_field_exits_2(tmp_path, good, capsys):
    path = tmp_path / "strings.json"
    path.write_text(json.dumps({**good, "stroke": ["0.5", "0.9"]}, indent=1))
    err = assert_one_line_exit_2(["ik", "--description", str(path)], capsys, "strings.json")
    assert re.search(r"line \d+: .*stroke\[0\] is the string '0\.5'", err)


def test_cli_non_utf8_trajectory_exits_2(tmp_path, capsys):
    path = tmp_path / "latin1.csv"
    path.write_bytes(f"{','.join(STATE_COLUMNS)}\n# r\xe9sum\xe9\n".encode("latin-1"))
    argv = ["idm", "--preset", "desktop", "--trajectory", str(path), "-o", str(tmp_path / "f.csv")]
    assert_one_line_exit_2(argv, capsys, "latin1.csv, line 2", "UTF-8")


def test_cli_corrupt_npz_result_exits_2(tmp_path, capsys):
    path = tmp_path / "bad.npz"
    _flip_data_byte(path)
    out = tmp_path / "a.html"
    argv = ["animate", "--preset", "desktop", "--result", str(path), "-o", str(out)]
    assert_one_line_exit_2(argv, capsys, "bad.npz", "not a readable .npz")
    assert not out.exists()


# ====================================================================== item 14: lenient
@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("stroke", ["0.5", "0.9"], r"stroke\[0\] is the string '0\.5'"),
        ("gravity", [0.0, 0.0, True], r"gravity\[2\] is the boolean True"),
        ("gravity", [0.0, 0.0, -9.81 + 0.5j], r"gravity\[2\] is the complex number"),
        ("base_points", np.zeros((6, 3), bool), r"base_points holds booleans"),
        ("platform_inertia", np.full(10, "1"), r"platform_inertia holds strings"),
        ("leg_inertia", np.zeros((6, 3, 10), complex), r"leg_inertia holds complex numbers"),
        ("u_joint_limits", [[-1.0, 1.0], [False, 2.0]], r"u_joint_limits\[1\]\[0\] is the bool"),
        ("home_pose", "object", r"home_pose\[2\]\[3\] is the string '0\.7'"),
    ],
)
def test_description_numbers_as_strings_booleans_or_complex_are_refused(good, key, value, message):
    if isinstance(value, str):  # an object array holding one string
        value = np.array(good[key], dtype=object)
        value[2, 3] = "0.7"
    with pytest.raises(DescriptionError, match=message):
        RobotDescription.from_dict({**good, key: value})


@pytest.fixture(scope="module")
def robot() -> StewartRobot:
    return StewartRobot.from_preset("desktop")


def _state(robot):
    return robot.home_pose, np.full(6, 0.01), np.full(6, 0.02)


API_CASES = {
    "bool twist": (lambda r, T, V, A: r.inverse_dynamics(T, V > 0, A), r"twist holds booleans"),
    "bool in list": (
        lambda r, T, V, A: r.inverse_dynamics(T, [*V[:5], True], A),
        r"twist\[5\] is the boolean True",
    ),
    "string twist": (
        lambda r, T, V, A: r.inverse_dynamics(T, [str(v) for v in V], A),
        r"twist\[0\] is the string '0\.01'",
    ),
    "complex accel": (
        lambda r, T, V, A: r.inverse_dynamics(T, V, A + 1e-3j),
        r"accel holds complex numbers \(a float conversion would drop the imaginary part\)",
    ),
    "real complex accel": (
        lambda r, T, V, A: r.inverse_dynamics(T, V, A.astype(complex)),
        r"accel holds complex numbers",
    ),
    "object forces": (
        lambda r, T, V, A: r.direct_dynamics(T, V, np.array([1.0] * 5 + ["2"], dtype=object)),
        r"\[5\] is the string '2'",
    ),
    "complex pose": (lambda r, T, V, A: r.inverse_geometry(T + 0j), r"pose holds complex"),
    "string pose": (lambda r, T, V, A: r.inverse_geometry(T.astype(str)), r"pose holds strings"),
    "bool pose batch": (
        lambda r, T, V, A: r.leg_lengths([T, np.eye(4, dtype=bool)]),
        r"pose\[1\] holds booleans",
    ),
    "string lengths": (
        lambda r, T, V, A: r.forward_geometry([repr(x) for x in r.leg_lengths(T)]),
        r"lengths\[0\] is the string",
    ),
    "ragged batch": (
        lambda r, T, V, A: r.inverse_dynamics(np.stack([T, T]), [V, V[:4]], np.stack([A, A])),
        r"ragged rows: twist\[0\] is a row of 6 but twist\[1\] is a row of 4",
    ),
}


@pytest.mark.parametrize("case", list(API_CASES))
def test_api_arrays_refuse_booleans_strings_and_complex(robot, case):
    call, message = API_CASES[case]
    with pytest.raises(InputError, match=message):
        call(robot, *_state(robot))


def test_api_arrays_accept_every_real_number_type(robot):
    # NumPy integer and float scalars, Python ints and object arrays of real numbers are
    # numbers: the same forces as the float64 arrays (bit for bit).
    T, V, A = _state(robot)
    reference = robot.inverse_dynamics(T, V, A)
    mixed = [np.float32(0.25).item() * 0 + v for v in V]  # Python floats
    objects = np.array(list(A), dtype=object)
    np.testing.assert_array_equal(robot.inverse_dynamics(T, mixed, objects), reference)
    ints = robot.inverse_dynamics(T, np.zeros(6, np.int64), [0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(ints, robot.inverse_dynamics(T, np.zeros(6), np.zeros(6)))


THRESHOLD_CASES = {
    "max_condition nan": (
        lambda r: StewartRobot(r.description, max_condition=float("nan")),
        r"max_condition must be finite, got nan",
    ),
    "max_condition negative": (
        lambda r: StewartRobot(r.description, max_condition=-1.0),
        r"max_condition must be positive",
    ),
    "max_condition string": (
        lambda r: StewartRobot(r.description, max_condition="1e6"),
        r"max_condition must be a real number, got the string '1e6'",
    ),
    "max_condition bool": (
        lambda r: StewartRobot(r.description, max_condition=True),
        r"max_condition must be a real number, got the boolean True",
    ),
    "forward tol nan": (
        lambda r: r.forward_geometry(r.leg_lengths(r.home_pose), tol=float("nan")),
        r"tol must be finite",
    ),
    "forward tol negative": (
        lambda r: r.forward_geometry(r.leg_lengths(r.home_pose), tol=-1e-12),
        r"tol must be positive, got -1e-12 m",
    ),
    "forward iterations": (
        lambda r: r.forward_geometry(r.leg_lengths(r.home_pose), max_iterations=2.5),
        r"max_iterations must be an integer",
    ),
    "rtol negative": (
        lambda r: simulate(r, 0.01, method="adaptive", rtol=-1e-6),
        r"rtol must be positive",
    ),
    "atol nan": (
        lambda r: simulate(r, 0.01, method="adaptive", atol=float("nan")),
        r"atol must be finite",
    ),
    "control period negative": (
        lambda r: simulate(r, 0.01, method="adaptive", control_period=-1e-3),
        r"control_period must be positive, got -0\.001 s",
    ),
    "control period nan": (
        lambda r: simulate(r, 0.01, control_period=float("nan")),
        r"control_period must be finite",
    ),
    "control period string": (
        lambda r: simulate(r, 0.01, control_period="0.001"),
        r"control_period must be a real number",
    ),
    "output_dt negative": (
        lambda r: simulate(r, 0.01, output_dt=-0.001),
        r"output_dt must be positive",
    ),
}


@pytest.mark.parametrize("case", list(THRESHOLD_CASES))
def test_nan_thresholds_and_negative_tolerances_or_periods_are_refused(robot, case):
    call, message = THRESHOLD_CASES[case]
    with pytest.raises(InputError, match=message):
        call(robot)
