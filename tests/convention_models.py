"""MJCF files of the project's presets with their joints zeroed and pointed the way
hand-written and CAD models do, for the import tests (``test_import_conventions.py``).

The project's MJCF writer places every leg body at its joint's zero (the modified-DH
zero, far from home for most joints) and writes a ``home`` keyframe. :func:`rezeroed`
edits that XML joint by joint, keeping the same mechanism:

- ``"baked"``: the body is placed where the joint puts it at home, so the joint reads 0
  at home (no ``ref``: hinges at zero at home, the slide at zero at the home length);
- ``"ref"``: the joint gets a ``ref`` (its value at the body's placement), so ``qpos0``
  is away from home;
- ``flip``: the joint's axis points the other way (``axis="0 0 -1"``), its values,
  range and ``springref`` negated (an inverted slide, a hinge turning the other way).

Every joint value of the file is then ``q_file = s (q_writer - b) + r`` with ``s = -1``
for a flipped joint, ``b`` the home value for a baked one, ``r`` the ``ref``; the keyframe,
ranges and ``springref`` are rewritten with it. Nothing here uses the importer.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
from scipy.spatial.transform import Rotation


def _floats(text: str | None, default: str) -> np.ndarray:
    return np.array([float(x) for x in (text or default).split()])


def _text(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def rezeroed(
    xml: str,
    mode: dict[str, str],
    flip: set[str] = frozenset(),
    ref: float = 0.3,
    drop_keyframe: bool = False,
    full_turn: set[str] = frozenset(),
) -> str:
    """``xml`` (the project's MJCF writer's output) with the joints of ``mode`` (joint
    name -> ``"baked"`` or ``"ref"``) re-zeroed and those of ``flip`` pointed the other
    way (module docstring); ``ref``: the ``ref`` value given in ``"ref"`` mode (its sign
    alternates from joint to joint); ``drop_keyframe``: remove the ``home`` keyframe (for
    files whose ``qpos0`` is home: every leg joint baked); ``full_turn``: hinges given the
    range ``0 .. 2 pi`` (a CAD export's "no limit")."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(xml)
    root = ET.fromstring(xml)
    key = root.find("keyframe/key")
    assert key is not None
    qpos = _floats(key.get("qpos"), "")
    sign = 1.0
    for body in root.iter("body"):
        joint = body.find("joint")
        if joint is None or joint.get("name") not in set(mode) | set(flip) | set(full_turn):
            continue
        name = joint.get("name")
        assert joint.get("pos") is None and joint.get("ref") is None
        adr = m.joint(name).qposadr[0]
        home = qpos[adr]
        s = -1.0 if name in flip else 1.0
        b = home if mode.get(name) == "baked" else 0.0
        sign = -sign
        r = sign * ref if mode.get(name) == "ref" else 0.0
        axis = _floats(joint.get("axis"), "0 0 1")
        hinge = joint.get("type") == "hinge"
        if b:
            quat = _floats(body.get("quat"), "1 0 0 0")
            R = Rotation.from_quat(quat, scalar_first=True).as_matrix()
            if hinge:
                R = R @ Rotation.from_rotvec(axis * b).as_matrix()
                body.set("quat", _text(Rotation.from_matrix(R).as_quat(scalar_first=True)))
            else:
                pos = _floats(body.get("pos"), "0 0 0")
                body.set("pos", _text(pos + R @ axis * b))

        def to_file(v: np.ndarray, s=s, b=b, r=r) -> np.ndarray:
            return s * (v - b) + r

        joint.set("axis", _text(s * axis))
        if r:
            joint.set("ref", repr(r))
        qpos[adr] = to_file(np.array([home]))[0]
        if joint.get("range") is not None:
            joint.set("range", _text(np.sort(to_file(_floats(joint.get("range"), "")))))
        if joint.get("springref") is not None:
            joint.set("springref", _text(to_file(_floats(joint.get("springref"), ""))))
        if name in full_turn:
            assert hinge
            joint.set("range", f"0 {2 * math.pi!r}")
    if drop_keyframe:
        root.remove(root.find("keyframe"))
    else:
        key.set("qpos", _text(qpos))
    return ET.tostring(root, encoding="unicode")
