"""XML pieces shared by the URDF and MJCF writers (private module, public names).

Numbers are written with ``repr(float(x))``: the shortest text that reads back to the same
double. URDF elements: ``origin``, ``inertial`` (mass, centre of mass, inertia about it, in
the link frame), ``visual``. MJCF elements: ``body``, ``inertial`` (``fullinertia`` in
MuJoCo's order), ``geom``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stewart_pin._so3 import quaternion_wxyz_from_rotation
from stewart_pin.description.inertia import urdf_inertial_from_khalil

__all__ = [
    "MJCF_RGBA",
    "Visual",
    "mjcf_body",
    "mjcf_geom",
    "mjcf_inertial",
    "num",
    "urdf_inertial",
    "urdf_origin",
    "urdf_visual",
    "vec",
]

#: Colours of the MJCF visual geoms (those of the URDF's materials).
MJCF_RGBA = {
    "base": "0.35 0.35 0.38 1",
    "cylinder": "0.20 0.40 0.80 1",
    "rod": "0.80 0.80 0.82 1",
    "joint": "0.15 0.15 0.15 1",
    "platform": "0.95 0.55 0.15 1",
}


def num(x: float) -> str:
    """A number as XML text: the shortest repr of the double."""
    return repr(float(x))


def vec(v: Any) -> str:
    """Numbers (any array shape, flattened) as space-separated :func:`num` text."""
    return " ".join(num(x) for x in np.asarray(v, dtype=float).ravel())


# ---------------------------------------------------------------------------------- URDF
@dataclass(frozen=True)
class Visual:
    """One URDF visual: ``shape`` ("cylinder" | "sphere" | "box"), ``material``, origin
    ``xyz`` [m] and ``rpy`` [rad] in the link frame, and ``size``: ``{radius, length}``,
    ``{radius}`` or ``{size: (x, y, z)}`` [m]."""

    shape: str
    material: str
    xyz: Any = (0, 0, 0)
    rpy: Any = (0, 0, 0)
    size: dict[str, Any] = field(default_factory=dict)


def urdf_origin(parent: ET.Element, xyz: Any = (0, 0, 0), rpy: Any = (0, 0, 0)) -> None:
    """``<origin xyz rpy>`` [m, rad]."""
    ET.SubElement(parent, "origin", xyz=vec(xyz), rpy=vec(rpy))


def urdf_inertial(link: ET.Element, params: np.ndarray) -> None:
    """``<inertial>`` of Khalil parameters ``params`` (10,) about the link frame's origin."""
    mass, com, I = urdf_inertial_from_khalil(params)
    el = ET.SubElement(link, "inertial")
    urdf_origin(el, com)
    ET.SubElement(el, "mass", value=num(mass))
    ET.SubElement(
        el,
        "inertia",
        ixx=num(I[0, 0]),
        ixy=num(I[0, 1]),
        ixz=num(I[0, 2]),
        iyy=num(I[1, 1]),
        iyz=num(I[1, 2]),
        izz=num(I[2, 2]),
    )


def urdf_visual(link: ET.Element, visual: Visual) -> None:
    """``<visual>`` of ``visual``: a tuple size is written as a vector, a number as one."""
    el = ET.SubElement(link, "visual")
    urdf_origin(el, visual.xyz, visual.rpy)
    geom = ET.SubElement(el, "geometry")
    attrs = {k: vec(v) if isinstance(v, tuple) else num(v) for k, v in visual.size.items()}
    ET.SubElement(geom, visual.shape, attrs)
    ET.SubElement(el, "material", name=visual.material)


# ---------------------------------------------------------------------------------- MJCF
def mjcf_body(parent: ET.Element, name: str, pos: Any = None, R: Any = None) -> ET.Element:
    """``<body name pos quat>`` (``quat`` (w, x, y, z) of the rotation matrix ``R``)."""
    attrs = {"name": name}
    if pos is not None:
        attrs["pos"] = vec(pos)
    if R is not None:
        attrs["quat"] = vec(quaternion_wxyz_from_rotation(R))
    return ET.SubElement(parent, "body", attrs)


def mjcf_inertial(body: ET.Element, params: np.ndarray) -> None:
    """``<inertial pos mass fullinertia>`` of Khalil parameters about the body origin."""
    mass, com, I = urdf_inertial_from_khalil(params)
    # MuJoCo's order: Ixx Iyy Izz Ixy Ixz Iyz, about the centre of mass.
    full = (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    ET.SubElement(body, "inertial", pos=vec(com), mass=num(mass), fullinertia=vec(full))


def mjcf_geom(
    body: ET.Element, kind: str, rgba: str, size: Any, pos: Any = None, R: Any = None
) -> None:
    """A visual ``<geom>``; ``rgba`` is a key of :data:`MJCF_RGBA`."""
    attrs = {"type": kind, "size": vec(size)}
    if pos is not None:
        attrs["pos"] = vec(pos)
    if R is not None:
        attrs["quat"] = vec(quaternion_wxyz_from_rotation(R))
    attrs["rgba"] = MJCF_RGBA[rgba]
    ET.SubElement(body, "geom", attrs)
