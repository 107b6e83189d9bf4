"""Regenerate the committed robot files of the presets in ``models/urdf/``.

For each preset (simulator, desktop, paper): ``<name>.toml``, ``<name>.urdf``,
``<name>.closures.json``, ``<name>.xacro.yaml`` and ``<name>.xml`` (MJCF), written by
:func:`stewart_pin.formats.robot_files.write_robot_files`. ``tests/test_generated_models.py`` fails
when the committed files differ from what this script writes.

Usage: ``python scripts/generate_models.py [output folder]`` (default ``models/urdf``).
"""

from __future__ import annotations

import sys
from pathlib import Path

from stewart_pin.description.presets import PRESETS
from stewart_pin.formats.robot_files import write_robot_files

MODELS_DIR = Path(__file__).resolve().parent.parent / "models" / "urdf"


def main(argv: list[str]) -> None:
    folder = Path(argv[0]) if argv else MODELS_DIR
    for name, make in PRESETS.items():
        for path in write_robot_files(make(), folder):
            print(f"{name}: wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
