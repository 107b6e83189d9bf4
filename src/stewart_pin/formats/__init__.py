"""Model files out (and, next, in): URDF with its loop-closure sidecar, xacro arguments,
MJCF for MuJoCo, and the CSV / NPZ tables of states, forces and lengths.

Every writer is atomic (:mod:`stewart_pin._io`) and writes no user text unescaped;
every reader names the file and line of what it refuses (``FileFormatError``).

Modules: :mod:`.urdf` (the 24-dof tree, ``*.closures.json``) and :mod:`.mjcf`, each
the writer of every leg architecture (``general_urdf`` and ``general_mjcf`` remain as
deprecated aliases), :mod:`.xacro`, :mod:`.robot_files` (all of a robot's files into
one folder; the model files shipped as
package data), :mod:`.csv_tables`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stewart_pin._lazy import lazy_names

if TYPE_CHECKING:  # what type checkers see; at run time each name is imported on first use
    from .general_mjcf import general_mjcf_string, write_general_mjcf
    from .general_urdf import general_urdf_string, write_general_urdf
    from .mjcf import mjcf_string, write_mjcf
    from .robot_files import model_files, robot_file_names, write_robot_files
    from .urdf import read_closures, urdf_string, write_urdf
    from .xacro import write_xacro_args, xacro_args

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "general_mjcf_string": ".general_mjcf",
        "write_general_mjcf": ".general_mjcf",
        "general_urdf_string": ".general_urdf",
        "write_general_urdf": ".general_urdf",
        "mjcf_string": ".mjcf",
        "write_mjcf": ".mjcf",
        "model_files": ".robot_files",
        "robot_file_names": ".robot_files",
        "write_robot_files": ".robot_files",
        "read_closures": ".urdf",
        "urdf_string": ".urdf",
        "write_urdf": ".urdf",
        "write_xacro_args": ".xacro",
        "xacro_args": ".xacro",
    },
)

__all__ = [
    "general_mjcf_string",
    "general_urdf_string",
    "mjcf_string",
    "model_files",
    "read_closures",
    "robot_file_names",
    "urdf_string",
    "write_general_mjcf",
    "write_general_urdf",
    "write_mjcf",
    "write_robot_files",
    "write_urdf",
    "write_xacro_args",
    "xacro_args",
]
