"""Chain legs whose consecutive joint lines are nearly parallel and offset (an R-S-S
file whose crank and U-joint axes are tilted by ``eps``): the modified-DH frames rebuilt
from the imported parameters (here by hand: ``Rx(alpha) Tx(d) Rz(theta) Tz(r)``) lie on
the file's joint lines (MuJoCo's ``xanchor``/``xaxis`` at the zero configuration) to
1e-9 of the size, or the import says it took them as parallel; the imported robot's IDM
against MuJoCo's exact KKT solve of the file."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from helpers import rel_error

from stewart_pin import StewartRobot
from stewart_pin.exceptions import ModelImportWarning
from stewart_pin.importers import import_mjcf

mujoco = pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")


def _rss_xml(eps: float, about: str) -> str:
    """The asymmetric 6-RSS preset's MJCF with leg 1's second hinge (parallel to the
    crank, 3 cm away along the crank's x) tilted by ``eps`` [rad] about its body's
    ``about`` axis (``x``: the lines still meet a common normal near the joints; ``y``: the
    common normal lies ~0.03 / eps away)."""
    from test_chain_legs_mjcf import without_coulomb

    from stewart_pin.description.chain_leg_presets import rss_robot

    xml = StewartRobot(without_coulomb(rss_robot(False))).mjcf()
    s, c = repr(float(np.sin(eps))), repr(float(np.cos(eps)))
    axis = f"0 {s} {c}" if about == "x" else f"{s} 0 {c}"
    xml, n = re.subn(r'(<joint name="leg1_q2" type="hinge" axis=)"0 0 1"', rf'\1"{axis}"', xml)
    assert n == 1
    return xml


def _rx(a: float) -> np.ndarray:
    T = np.eye(4)
    T[1:3, 1:3] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    return T


def _rz(a: float) -> np.ndarray:
    T = np.eye(4)
    T[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    return T


def _t(x: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[0, 3], T[2, 3] = x, z
    return T


def _line_mismatch(xml: str, desc) -> float:  # type: ignore[no-untyped-def]
    """The largest distance [m] of a frame rebuilt from the description from its file
    joint line (MuJoCo at qpos = 0 with the platform where the file puts it), and of its
    z axis from the line's direction (times the size)."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    size = float(np.linalg.norm(desc.platform_points, axis=1).mean())
    worst = 0.0
    for k, leg in enumerate(desc.chain_legs):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
        for j, jt in enumerate(leg.joints):
            if j:
                T = T @ _rx(jt.alpha) @ _t(x=jt.d) @ _rz(jt.theta) @ _t(z=jt.r)
            jid = m.joint(f"leg{k + 1}_q{j + 1}").id
            a, z = d.xanchor[jid], d.xaxis[jid]
            worst = max(
                worst,
                float(np.linalg.norm(np.cross(T[:3, 3] - a, z))),
                float(np.linalg.norm(np.cross(T[:3, 2], z))) * size,
            )
    return worst / size


@pytest.mark.parametrize("eps", [1e-8, 3e-8, 1e-6])
def test_nearly_parallel_offset_lines_meeting_a_near_normal_are_rebuilt_exactly(eps) -> None:
    xml = _rss_xml(eps, "x")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)  # the loop residual ~eps
        result = import_mjcf(xml)
    assert not any("parallel" in a for a in result.report.approximations)
    assert _line_mismatch(xml, result.description) < 1e-9


@pytest.mark.parametrize("eps", [1e-8, 3e-8, 1e-6])
def test_nearly_parallel_lines_with_a_far_normal_are_taken_as_parallel_and_reported(eps) -> None:
    xml = _rss_xml(eps, "y")
    with pytest.warns(ModelImportWarning, match="'leg1_q1'-'leg1_q2'.*taken as parallel"):
        result = import_mjcf(xml)
    near = [a for a in result.report.approximations if "taken as parallel" in a]
    assert len(near) == 1 and "leg1_q1" in near[0]
    # the approximation moves the frames by about eps times the leg's reach, no more
    assert _line_mismatch(xml, result.description) < 10 * eps


def test_a_tilted_crank_hinge_imported_exactly_matches_mujoco_kkt() -> None:
    from test_chain_legs_mjcf import mujoco_kkt_inverse_dynamics

    xml = _rss_xml(3e-8, "x")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)
        result = import_mjcf(xml)
    robot = StewartRobot(result.description)
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    T, V, A = robot.sample_states(2, rng=3)
    rng = np.random.default_rng(2)
    spin, rate = rng.uniform(-1.0, 1.0, (2, 6)), rng.uniform(-5.0, 5.0, (2, 6))
    res = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    for n in range(2):
        got, sigma = mujoco_kkt_inverse_dynamics(
            m, data, robot, T[n], V[n], A[n], (spin[n], rate[n])
        )
        assert rel_error(res.gamma[n], got) < 1e-10
        assert rel_error(res.idle_accel[n], sigma) < 1e-10


# --- R-S-S rods written in oblique frames and rounded to 6 digits: the idle joint ---------


def _rounded_rss_xml(digits: int = 6) -> str:
    """The asymmetric 6-RSS preset's MJCF with each rod body's frame turned obliquely (its
    spin axis written unnormalised and anchored 37 mm along the rod, the ball site, the
    inertial in that frame) and every number rounded to ``digits`` significant digits, as a
    CAD export writes it: the spin axes miss the ball centres by ~1e-7 m."""
    from scipy.spatial.transform import Rotation
    from test_chain_legs_mjcf import without_coulomb

    from stewart_pin.description.chain_leg_presets import rss_robot

    xml = StewartRobot(without_coulomb(rss_robot(False))).mjcf()
    turn = Rotation.from_rotvec([0.4, -0.9, 0.7])
    R = turn.as_matrix()

    def text(v) -> str:  # type: ignore[no-untyped-def]
        return " ".join(repr(float(x)) for x in v)

    def floats(pattern: str, tag: str) -> list[float]:
        return [float(x) for x in re.search(pattern, tag).group(1).split()]  # type: ignore[union-attr]

    def body(m: re.Match[str]) -> str:
        b = m.group(0)
        q = floats(r'quat="([^"]+)"', b)
        qn = (Rotation.from_quat([*q[1:], q[0]]) * turn).as_quat()
        b = re.sub(r'quat="[^"]+"', f'quat="{text([qn[3], *qn[:3]])}"', b, count=1)
        a = R.T @ [0.0, 0.0, 1.0]
        b = b.replace('axis="0 0 1"', f'pos="{text(0.037 * a)}" axis="{text(3.7 * a)}"')
        p = floats(r'<inertial pos="([^"]+)"', b)
        b = re.sub(r'<inertial pos="[^"]+"', f'<inertial pos="{text(R.T @ p)}"', b)
        f = floats(r'fullinertia="([^"]+)"', b)
        Ic = R.T @ np.array([[f[0], f[3], f[4]], [f[3], f[1], f[5]], [f[4], f[5], f[2]]]) @ R
        six = [Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2]]
        b = re.sub(r'fullinertia="[^"]+"', f'fullinertia="{text(six)}"', b)
        tip = re.search(r'<site name="(leg\d_tip)" pos="([^"]+)"', b)
        assert tip is not None
        t = R.T @ [float(x) for x in tip.group(2).split()]
        return b.replace(tip.group(0), f'<site name="{tip.group(1)}" pos="{text(t)}"')

    xml, n = re.subn(r'<body name="leg\d_link4".*?</body>', body, xml, flags=re.S)
    assert n == 6
    return re.sub(r"-?\d+\.\d+(?:e-?\d+)?", lambda m: f"{float(m.group(0)):.{digits}g}", xml)


def test_rss_rods_rounded_to_six_digits_keep_their_idle_joints_and_match_mujoco_kkt() -> None:
    from test_chain_legs_mjcf import mujoco_kkt_inverse_dynamics

    xml = _rounded_rss_xml(6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelImportWarning)  # the rounded loops' residual
        result = import_mjcf(xml)
    assert [leg.idle_joint for leg in result.description.chain_legs] == [4] * 6
    said = [n for n in result.report.notes if "passes the ball centre within" in n]
    assert said and all("leg" in n for n in said)
    robot = StewartRobot(result.description)
    m = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(m)
    T, V, A = robot.sample_states(2, rng=4)
    rng = np.random.default_rng(5)
    spin, rate = rng.uniform(-1.0, 1.0, (2, 6)), rng.uniform(-5.0, 5.0, (2, 6))
    res = robot.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    for n in range(2):
        got, sigma = mujoco_kkt_inverse_dynamics(
            m, data, robot, T[n], V[n], A[n], (spin[n], rate[n])
        )
        assert rel_error(res.gamma[n], got) < 1e-10
        assert rel_error(res.idle_accel[n], sigma) < 1e-10
