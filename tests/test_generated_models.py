"""The robot files committed in models/urdf/ are what scripts/generate_models.py writes now."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from stewart_pin.description.presets import PRESETS
from stewart_pin.formats.robot_files import robot_file_names, write_robot_files

MODELS = Path(__file__).resolve().parent.parent / "models" / "urdf"
STALE = "stale: run python scripts/generate_models.py"
#: Hand-written files in models/urdf/ (the xacro sources), not generated.
SOURCES = {
    "stewart.urdf.xacro",
    "stewart_leg.xacro",
    "stewart_general.urdf.xacro",
    "stewart_general_leg.xacro",
    "stewart_chain.urdf.xacro",
}


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_committed_files_are_current(name, tmp_path):
    paths = write_robot_files(PRESETS[name](), tmp_path)
    assert [p.name for p in paths] == robot_file_names(name)
    for fresh in paths:
        committed = MODELS / fresh.name
        assert committed.is_file(), f"{committed} is missing; {STALE}"
        _assert_same_text(committed.read_text(), fresh.read_text(), f"{committed} is {STALE}")


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def _assert_same_text(committed: str, fresh: str, message: str) -> None:
    """Equal text, with numbers allowed to differ in their last bits (1e-12 relative):
    another BLAS or CPU may round an SVD or a matrix product differently."""
    assert _NUMBER.sub("#", committed) == _NUMBER.sub("#", fresh), message
    a = np.array([float(x) for x in _NUMBER.findall(committed)])
    b = np.array([float(x) for x in _NUMBER.findall(fresh)])
    assert np.allclose(a, b, rtol=1e-12, atol=1e-12), message


def test_no_leftover_files():
    expected = {n for name in PRESETS for n in robot_file_names(name)} | SOURCES
    found = {p.name for p in MODELS.iterdir() if p.is_file()}
    assert found == expected, (
        f"unexpected files {sorted(found - expected)} or missing {sorted(expected - found)} "
        f"in {MODELS}; {STALE} and remove files of presets that no longer exist"
    )
