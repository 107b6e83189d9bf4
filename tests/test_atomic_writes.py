"""No half-written file (issue 9, item 8).

Every writer goes through :func:`stewart_pin._io.atomic_open` (a temporary file in the
destination folder, renamed over the destination on success): a disk that fills up in the
middle of a write leaves the previous file as it was and no temporary file behind. The CSV
reader refuses a file cut short (its last line without a line break), naming the line.
"""

from __future__ import annotations

import ast
import builtins
import contextlib
import errno
import io
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import random_motion_states

import stewart_pin
from stewart_pin import preset
from stewart_pin.exceptions import FileFormatError
from stewart_pin.formats.csv_tables import (
    FORCE_COLUMNS,
    STATE_COLUMNS,
    read_csv,
    state_table,
    write_csv,
)
from stewart_pin.formats.mjcf import write_mjcf
from stewart_pin.formats.robot_files import write_robot_files
from stewart_pin.formats.urdf import write_urdf
from stewart_pin.formats.xacro import write_xacro_args
from stewart_pin.motion.simulation import SimulationResult
from stewart_pin.parameters.identification import Measurements, write_measurements_csv

SRC = Path(stewart_pin.__file__).resolve().parent


# ---------------------------------------------------------------------- a disk that fills up
class _FullDisk:
    """A writable file that takes ``room`` bytes, then writes what fits of the next chunk
    and raises ``error`` (ENOSPC by default), as a full disk or a size limit does."""

    def __init__(self, handle: Any, room: int, error: BaseException, log: list[str]) -> None:
        self._handle, self._room, self._error, self._log = handle, room, error, log

    def write(self, data: Any) -> int:
        if len(data) > self._room:
            self._handle.write(data[: self._room])
            self._handle.flush()
            self._room = 0
            self._log.append(getattr(self._handle, "name", "?"))
            raise self._error
        self._room -= len(data)
        return self._handle.write(data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __iter__(self) -> Iterator[Any]:
        return iter(self._handle)

    def __enter__(self) -> _FullDisk:
        self._handle.__enter__()
        return self

    def __exit__(self, *exc: Any) -> Any:
        return self._handle.__exit__(*exc)


def _writing(mode: str) -> bool:
    return any(c in mode for c in "wax+")


@contextlib.contextmanager
def disk_full(
    monkeypatch: pytest.MonkeyPatch,
    folder: Path,
    room: int = 64,
    error: BaseException | None = None,
) -> Iterator[list[str]]:
    """Every file opened for writing inside ``folder`` (by ``open``, ``Path.open``,
    ``os.fdopen``) fills up after ``room`` bytes; yields the list of the files it cut."""
    error = error if error is not None else OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    folder = Path(os.path.realpath(folder))
    log: list[str] = []
    real_open, real_fdopen = io.open, os.fdopen

    def inside(path: Any) -> bool:
        try:
            return Path(os.path.realpath(path)).is_relative_to(folder)
        except (TypeError, ValueError):
            return False

    def fake_open(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        handle = real_open(file, mode, *args, **kwargs)
        if _writing(mode) and not isinstance(file, int) and inside(file):
            return _FullDisk(handle, room, error, log)
        return handle

    def fake_fdopen(fd: int, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        handle = real_fdopen(fd, mode, *args, **kwargs)
        if _writing(mode) and inside(os.readlink(f"/proc/self/fd/{fd}")):
            return _FullDisk(handle, room, error, log)
        return handle

    with monkeypatch.context() as m:
        m.setattr(io, "open", fake_open)
        m.setattr(builtins, "open", fake_open)
        m.setattr(os, "fdopen", fake_fdopen)
        yield log


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too), by relative path."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


# ---------------------------------------------------------------------- the writers
_states = random_motion_states


def _description(variant: int):
    desc = preset("desktop")
    if variant == 0:
        return desc
    return desc.replace(gravity=[0.0, 0.0, -9.80665], platform_inertia=1.5 * desc.platform_inertia)


def _result(variant: int) -> SimulationResult:
    t, poses, twists, accels = _states(30, variant)
    rng = np.random.default_rng(10 + variant)
    return SimulationResult(
        t, poses, twists, accels, rng.normal(size=(30, 6)), rng.random((30, 6))
    )


def _bench_json(folder: Path, variant: int, monkeypatch: pytest.MonkeyPatch) -> None:
    import argparse

    from stewart_pin.apps import bench

    result = {
        "machine": "test",
        "median_us_per_state": {"a": 1.0 + variant},
        "ratio_to_pin_constraintDynamics": {"a": 1.0},
    }
    monkeypatch.setattr(bench, "run", lambda *args: result)
    args = argparse.Namespace(preset="desktop", batch=1, repeats=1, quick=True)
    bench.report(argparse.Namespace(**vars(args), json=folder / "bench.json"))


def _figures(folder: Path, variant: int) -> None:
    pytest.importorskip("matplotlib")
    from stewart_pin.viz.plots import save_figures

    save_figures(_result(variant), folder)


def _demo_figure(folder: Path, variant: int) -> None:
    pytest.importorskip("matplotlib")
    from stewart_pin.apps.demo import _validation_figure

    t = np.linspace(0.0, 1.0, 20)
    _validation_figure(folder / "validation.png", t, 1e-12 * (1 + variant + t), t, 1e-13 + t)


def _html(folder: Path, variant: int, robot: Any) -> None:
    pytest.importorskip("meshcat")
    from stewart_pin.viz.viewer import Viewer

    poses = np.array([robot.home_pose] * 3)
    poses[1, 2, 3] += 0.01 * (1 + variant)
    Viewer(robot).export_html(folder / "m.html", poses, [0.0, 0.5, 1.0])


WRITERS: dict[str, Callable[..., Any]] = {
    "csv": lambda f, v, **_: write_csv(f / "s.csv", STATE_COLUMNS, state_table(*_states(40, v))),
    "description toml": lambda f, v, **_: _description(v).write(f / "r.toml"),
    "description json": lambda f, v, **_: _description(v).write(f / "r.json"),
    "urdf and closures": lambda f, v, **_: write_urdf(_description(v), f / "r.urdf"),
    "mjcf": lambda f, v, **_: write_mjcf(_description(v), f / "r.xml"),
    "xacro args": lambda f, v, **_: write_xacro_args(_description(v), f / "r.xacro.yaml"),
    "robot files": lambda f, v, **_: write_robot_files(_description(v), f),
    "simulation npz": lambda f, v, **_: _result(v).save(f / "sim.npz"),
    "simulation csv": lambda f, v, **_: _result(v).save(f / "sim.csv"),
    "measurements csv": lambda f, v, **_: write_measurements_csv(
        f / "log.csv", Measurements(*_states(40, v), np.full((40, 6), 1.0 + v))
    ),
    "figures": lambda f, v, **_: _figures(f, v),
    "demo figure": lambda f, v, **_: _demo_figure(f, v),
    "html animation": lambda f, v, robot, **_: _html(f, v, robot),
    "bench json": lambda f, v, monkeypatch, **_: _bench_json(f, v, monkeypatch),
}


@pytest.mark.parametrize("writer", WRITERS)
def test_writer_interrupted_by_a_full_disk_leaves_the_previous_file(
    writer, tmp_path, monkeypatch, desktop
):
    write = WRITERS[writer]
    folder = tmp_path / "out"
    folder.mkdir()
    kwargs = {"robot": desktop, "monkeypatch": monkeypatch}
    write(folder, 0, **kwargs)
    before = snapshot(folder)
    assert before, "the writer wrote nothing"
    with disk_full(monkeypatch, folder) as cut, pytest.raises(OSError) as info:
        write(folder, 1, **kwargs)
    assert info.value.errno == errno.ENOSPC
    assert cut, "the fault was not injected: the writer did not write in its folder"
    # The previous files, byte for byte, and nothing else (no temporary file).
    assert snapshot(folder) == before
    # Once there is room again, the same call replaces them.
    write(folder, 1, **kwargs)
    after = snapshot(folder)
    assert after.keys() == before.keys() and after != before


@pytest.mark.parametrize(
    "error", [KeyboardInterrupt(), OSError(errno.EFBIG, "File too large")], ids=repr
)
def test_writer_interrupted_by_any_exception_leaves_no_temporary_file(
    tmp_path, monkeypatch, error
):
    path = write_csv(tmp_path / "s.csv", STATE_COLUMNS, state_table(*_states(5, 0)))
    before = snapshot(tmp_path)
    with disk_full(monkeypatch, tmp_path, room=300, error=error), pytest.raises(type(error)):
        write_csv(path, STATE_COLUMNS, state_table(*_states(50, 1)))
    assert snapshot(tmp_path) == before
    np.testing.assert_array_equal(read_csv(path, STATE_COLUMNS), state_table(*_states(5, 0)))


def test_atomic_file_gets_the_usual_permissions(tmp_path):
    old = os.umask(0o027)
    try:
        path = write_csv(tmp_path / "s.csv", STATE_COLUMNS, state_table(*_states(2, 0)))
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o640


# ---------------------------------------------------------------------- every writer, by source
#: Files whose writes are not the package's outputs: the atomic writer itself, and the
#: compiled-library cache, which builds in a private temporary folder (issue 9, item 2).
_EXEMPT = {"_io.py", "codegen/compiled.py"}


def _mode(node: ast.Call, position: int) -> str:
    modes = [k.value for k in node.keywords if k.arg == "mode"]
    args = [*node.args[position : position + 1], *modes]
    return next((a.value for a in args if isinstance(a, ast.Constant)), "")


def _writes_directly(node: ast.Call, handles: frozenset[str]) -> bool:
    """Whether ``node`` writes a file other than through a handle bound by
    ``with atomic_open(...) as handle`` (``handles``)."""
    func = node.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    owner = getattr(func.value, "id", "") if isinstance(func, ast.Attribute) else ""

    def handle(k: int) -> bool:
        return (
            len(node.args) > k
            and isinstance(node.args[k], ast.Name)
            and (node.args[k].id in handles)
        )

    if name in ("write_text", "write_bytes"):
        return True
    if name in ("savefig", "tofile", "to_csv"):
        return not handle(0)
    if name in ("save", "savez", "savez_compressed", "savetxt") and owner in ("np", "numpy"):
        return not handle(0)
    if name == "dump" and owner in ("json", "pickle", "yaml", "tomli_w"):
        return not handle(1)
    if name == "open" and isinstance(func, ast.Name):
        return _writing(_mode(node, 1))
    if name == "open" and owner not in ("webbrowser", "os"):
        return _writing(_mode(node, 0))
    return False


def _direct_writes(tree: ast.AST) -> list[int]:
    """Line numbers of the calls of ``tree`` that write a file in place."""
    found: list[int] = []

    def visit(node: ast.AST, handles: frozenset[str]) -> None:
        if isinstance(node, ast.With | ast.AsyncWith):
            handles = handles | {
                item.optional_vars.id
                for item in node.items
                if isinstance(item.context_expr, ast.Call)
                and isinstance(item.optional_vars, ast.Name)
                and "atomic_open" in ast.unparse(item.context_expr.func)
            }
        if isinstance(node, ast.Call) and _writes_directly(node, handles):
            found.append(node.lineno)
        for child in ast.iter_child_nodes(node):
            visit(child, handles)

    memory = frozenset(  # names bound to in-memory buffers (io.BytesIO(), io.StringIO())
        target.id
        for node in ast.walk(tree)
        if isinstance(node, ast.Assign)
        and isinstance(node.value, ast.Call)
        and ast.unparse(node.value.func).split(".")[-1] in ("BytesIO", "StringIO")
        for target in node.targets
        if isinstance(target, ast.Name)
    )
    visit(tree, memory)
    return found


def test_every_writer_goes_through_atomic_open():
    offenders = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel in _EXEMPT:
            continue
        for line in _direct_writes(ast.parse(path.read_text())):
            offenders.append(f"{rel}:{line}")
    assert offenders == [], f"files written in place (use stewart_pin._io): {offenders}"


def test_the_source_scan_finds_direct_writes():
    text = (
        "from pathlib import Path\n"
        "Path('a').write_text('x')\n"
        "open('b.txt', 'w').write('x')\n"
        "with atomic_open('c', 'wb') as h:\n"
        "    np.savez(h, a=1)\n"
        "    fig.savefig('d.png')\n"
        "np.savez('e.npz', a=1)\n"
        "open('f.txt').read()\n"
        "Path('g').open(mode='a')\n"
        "json.dump({}, Path('h').open('w'))\n"
        "result.save('i.npz')\n"  # a method of the package (itself checked)
        "webbrowser.open('http://x', new=2)\n"
        "buf = io.BytesIO()\n"
        "fig.savefig(buf, format='png')\n"  # in memory
    )
    assert _direct_writes(ast.parse(text)) == [2, 3, 6, 7, 9, 10, 10]


# ---------------------------------------------------------------------- truncated CSV files
def _table_bytes(tmp_path: Path, n: int = 3) -> tuple[bytes, np.ndarray]:
    table = state_table(*_states(n, 0))
    return write_csv(tmp_path / "full.csv", STATE_COLUMNS, table).read_bytes(), table


def test_csv_cut_inside_its_last_field_is_refused_with_the_line(tmp_path):
    # Old code: read back without error, with a last value of fewer digits.
    data, _ = _table_bytes(tmp_path)
    path = tmp_path / "cut.csv"
    path.write_bytes(data[:-4])  # "...,0.123456789" -> "...,0.1234567"
    with pytest.raises(FileFormatError, match=r"cut\.csv, line 4: no line break after the last"):
        read_csv(path, STATE_COLUMNS)


def test_csv_cut_inside_its_last_row_is_refused_with_the_line(tmp_path):
    data, _ = _table_bytes(tmp_path)
    last = data.rstrip(b"\n").rfind(b"\n") + 1
    path = tmp_path / "cut.csv"
    path.write_bytes(data[: last + (len(data) - last) // 2])
    with pytest.raises(
        FileFormatError, match=r"line 4: \d+ fields, expected 20 .*the file ends inside this line"
    ):
        read_csv(path, STATE_COLUMNS)


def test_csv_cut_anywhere_is_refused_or_is_a_complete_prefix(tmp_path):
    """At every byte: a named error, or (cut right after a line break) exactly the rows
    before the cut, never a wrong number."""
    columns = ("t", *FORCE_COLUMNS)
    table = np.column_stack([np.arange(4) * 0.01, np.random.default_rng(3).normal(size=(4, 6))])
    data = write_csv(tmp_path / "full.csv", columns, table).read_bytes()
    path = tmp_path / "cut.csv"
    accepted = []
    for k in range(1, len(data)):
        path.write_bytes(data[:k])
        try:
            rows = read_csv(path, columns)
        except FileFormatError as e:
            assert "line " in str(e)
            continue
        assert data[k - 1 : k] == b"\n", f"accepted a file cut at byte {k}"
        np.testing.assert_array_equal(rows, table[: len(rows)])
        accepted.append(len(rows))
    assert accepted == [1, 2, 3]


def test_csv_cut_inside_a_utf8_character_is_refused_with_the_line(tmp_path):
    data, _ = _table_bytes(tmp_path)
    path = tmp_path / "cut.csv"
    path.write_bytes(b"# a comment\n# caf\xc3\xa9 au lait\n" + data)
    assert read_csv(path, STATE_COLUMNS).shape == (3, 20)
    path.write_bytes(b"# a comment\n# caf\xc3")
    with pytest.raises(FileFormatError, match=r"line 2: not UTF-8 text"):
        read_csv(path, STATE_COLUMNS)


def test_csv_with_crlf_line_ends_and_a_byte_order_mark_reads(tmp_path):
    data, table = _table_bytes(tmp_path)
    path = tmp_path / "dos.csv"
    path.write_bytes(b"\xef\xbb\xbf" + data.replace(b"\n", b"\r\n"))
    np.testing.assert_array_equal(read_csv(path, STATE_COLUMNS), table)
