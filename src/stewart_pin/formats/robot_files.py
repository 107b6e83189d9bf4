"""Every robot file stewart-pin writes, for one robot, in one folder.

For a robot named ``<name>``:

- ``<name>.toml``: the description (:meth:`RobotDescription.write`);
- ``<name>.urdf`` and ``<name>.closures.json``: the tree and its loop closures
  (:mod:`stewart_pin.formats.urdf`);
- ``<name>.xacro.yaml``: the arguments of ``models/urdf/stewart.urdf.xacro`` (6-UPS),
  ``models/urdf/stewart_general.urdf.xacro`` (general legs) or
  ``models/urdf/stewart_chain.urdf.xacro`` (chain legs) (:mod:`stewart_pin.formats.xacro`);
- ``<name>.xml``: the MJCF for MuJoCo (:mod:`stewart_pin.formats.mjcf`).

``scripts/generate_models.py`` writes them for the presets into ``models/urdf/``, and a test
checks that the committed files are current. Those files and the xacro sources ship with
the package: :func:`model_files`.
"""

from __future__ import annotations

import importlib.resources
from importlib.resources.abc import Traversable
from pathlib import Path

from stewart_pin._safe import file_in_folder
from stewart_pin.description import RobotDescription
from stewart_pin.formats.mjcf import write_mjcf
from stewart_pin.formats.urdf import write_urdf
from stewart_pin.formats.xacro import write_xacro_args

__all__ = ["MODEL_FILES_PACKAGE", "model_files", "robot_file_names", "write_robot_files"]

#: The package data holding the shipped model files (``models/`` of the source tree).
MODEL_FILES_PACKAGE = "stewart_pin.model_files"


def model_files() -> Traversable:
    """The model files shipped with stewart-pin, a folder of :mod:`importlib.resources`:
    ``package.xml`` and ``urdf/`` with the xacro sources (``stewart.urdf.xacro``,
    ``stewart_leg.xacro``, ``stewart_general.urdf.xacro``, ``stewart_general_leg.xacro``,
    ``stewart_chain.urdf.xacro``)
    and, for each preset, the files of :func:`robot_file_names`.

    Read one with ``(model_files() / "urdf" / "paper.urdf").read_text()``, or get its
    path with ``importlib.resources.as_file`` (a file on disk in an ordinary install, so
    that a URDF finds its ``.closures.json`` beside it and xacro finds ``package.xml``
    above it). Installed (wheel or editable), this is
    the package :data:`MODEL_FILES_PACKAGE`; in a source checkout used without installing
    (``PYTHONPATH=src``), the ``models/`` folder beside ``src/``.
    """
    try:
        return importlib.resources.files(MODEL_FILES_PACKAGE)
    except ModuleNotFoundError:
        source = Path(__file__).resolve().parents[3] / "models"
        if not (source / "package.xml").is_file():
            raise
        return source


def robot_file_names(name: str) -> list[str]:
    """The names of the files :func:`write_robot_files` writes for robot ``name``."""
    return [
        f"{name}.toml",
        f"{name}.urdf",
        f"{name}.closures.json",
        f"{name}.xacro.yaml",
        f"{name}.xml",
    ]


def write_robot_files(desc: RobotDescription, folder: str | Path) -> list[Path]:
    """Write the description, URDF, closures, xacro arguments and MJCF of ``desc`` into
    ``folder`` (created if needed); returns the paths, in :func:`robot_file_names` order
    (for a robot with general legs the xacro arguments are those of
    ``models/urdf/stewart_general.urdf.xacro``).

    Every file is written atomically (a temporary file in ``folder``, then renamed). The
    file names come from the robot name and are checked to stay directly inside ``folder``
    (:func:`stewart_pin._safe.file_in_folder`, :class:`InputError` otherwise).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    toml_path, urdf_path, _, yaml_path, xml_path = (
        file_in_folder(folder, n) for n in robot_file_names(desc.name)
    )
    desc.write(toml_path)
    urdf_path, closures_path = write_urdf(desc, urdf_path)
    write_xacro_args(desc, yaml_path)
    write_mjcf(desc, xml_path)
    return [toml_path, urdf_path, closures_path, yaml_path, xml_path]
