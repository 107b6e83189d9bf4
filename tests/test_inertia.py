"""Khalil's 10 inertial parameters and their conversions (stewart_pin.description.inertia).

References: Pinocchio's own ``pin.Inertia`` (constructor from mass, centre of mass and
inertia about it; ``SE3.act``), and textbook formulas (parallel-axis theorem, box and
point-mass inertia) written out in the tests.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from helpers import random_rotation
from hypothesis import given, settings
from hypothesis import strategies as st

from stewart_pin import DescriptionError as DescriptionErrorType
from stewart_pin import InertiaError
from stewart_pin.description.inertia import (
    check_physical,
    check_physical_bodies,
    khalil_from_pin_inertia,
    khalil_from_urdf_inertial,
    pin_inertia_from_khalil,
    random_physical_khalil,
    transform_khalil,
    urdf_inertial_from_khalil,
)


def khalil_by_hand(mass: float, com: np.ndarray, I_c: np.ndarray) -> np.ndarray:
    """Khalil's XX XY XZ YY YZ ZZ MX MY MZ M from mass, com and the inertia about the com,
    by the parallel-axis theorem I_O = I_c + m (|c|^2 I3 - c c^T)."""
    I_O = I_c + mass * (com @ com * np.eye(3) - np.outer(com, com))
    return np.array(
        [I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2], *(mass * com), mass]
    )


def random_body(rng: np.random.Generator) -> tuple[float, np.ndarray, np.ndarray]:
    """A random rigid body: (mass [kg], com [m], inertia about the com [kg m^2])."""
    mass = rng.uniform(0.5, 5.0)
    com = rng.uniform(-0.3, 0.3, 3)
    half = rng.uniform(0.05, 0.4, 3)  # a box of half-sides ``half``
    a, b, c = half**2
    principal = mass / 3.0 * np.array([b + c, a + c, a + b])
    R = random_rotation(rng)
    return mass, com, R @ np.diag(principal) @ R.T


# ---------------------------------------------------------------------- Pinocchio round trip
def test_pin_inertia_from_khalil_matches_pinocchio_constructor(rng):
    for _ in range(10):
        mass, com, I_c = random_body(rng)
        Y = pin_inertia_from_khalil(khalil_by_hand(mass, com, I_c))
        assert Y.mass == pytest.approx(mass, rel=1e-14)
        np.testing.assert_allclose(Y.lever, com, rtol=0, atol=1e-14)
        np.testing.assert_allclose(Y.inertia, I_c, rtol=0, atol=1e-13)


def test_khalil_from_pin_inertia_matches_hand_parallel_axis(rng):
    for _ in range(10):
        mass, com, I_c = random_body(rng)
        Y = pin.Inertia(mass, com, I_c)
        np.testing.assert_allclose(
            khalil_from_pin_inertia(Y), khalil_by_hand(mass, com, I_c), rtol=0, atol=1e-13
        )


def test_khalil_pin_round_trip(rng):
    for _ in range(10):
        params = khalil_by_hand(*random_body(rng))
        back = khalil_from_pin_inertia(pin_inertia_from_khalil(params))
        np.testing.assert_allclose(back, params, rtol=0, atol=1e-14 * np.abs(params).max())


# ---------------------------------------------------------------------- URDF inertial
def test_urdf_inertial_of_a_point_mass():
    # A 2 kg point at c = (0.1, -0.2, 0.3) m: I_O = m (|c|^2 I - c c^T), inertia about com 0.
    m, c = 2.0, np.array([0.1, -0.2, 0.3])
    XX, YY, ZZ = m * (0.04 + 0.09), m * (0.01 + 0.09), m * (0.01 + 0.04)
    XY, XZ, YZ = -m * 0.1 * -0.2, -m * 0.1 * 0.3, -m * -0.2 * 0.3
    params = np.array([XX, XY, XZ, YY, YZ, ZZ, m * 0.1, m * -0.2, m * 0.3, m])
    mass, com, I_c = urdf_inertial_from_khalil(params)
    assert mass == pytest.approx(2.0, rel=1e-15)
    np.testing.assert_allclose(com, c, rtol=0, atol=1e-15)
    np.testing.assert_allclose(I_c, np.zeros((3, 3)), rtol=0, atol=1e-15)


def test_urdf_inertial_of_an_offset_box():
    # A solid box 3 kg with sides (0.4, 0.2, 0.1) m, axes along the frame's, centred at
    # (0.5, 0, -0.2) m: I_c = m/12 diag(b^2 + c^2, a^2 + c^2, a^2 + b^2).
    m, (a, b, c), r = 3.0, (0.4, 0.2, 0.1), np.array([0.5, 0.0, -0.2])
    I_c_box = m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    params = np.array(
        [
            I_c_box[0, 0] + m * (0.0**2 + 0.2**2),  # XX
            -m * 0.5 * 0.0,  # XY
            -m * 0.5 * -0.2,  # XZ
            I_c_box[1, 1] + m * (0.5**2 + 0.2**2),  # YY
            -m * 0.0 * -0.2,  # YZ
            I_c_box[2, 2] + m * (0.5**2 + 0.0**2),  # ZZ
            m * 0.5,
            0.0,
            m * -0.2,
            m,
        ]
    )
    mass, com, I_c = urdf_inertial_from_khalil(params)
    assert mass == pytest.approx(m, rel=1e-15)
    np.testing.assert_allclose(com, r, rtol=0, atol=1e-15)
    np.testing.assert_allclose(I_c, I_c_box, rtol=0, atol=1e-15)
    # and back
    np.testing.assert_allclose(
        khalil_from_urdf_inertial(m, r, I_c_box), params, rtol=0, atol=1e-15
    )


def test_urdf_inertial_of_a_massless_body():
    mass, com, I_c = urdf_inertial_from_khalil(np.zeros(10))
    assert mass == 0.0
    np.testing.assert_array_equal(com, np.zeros(3))
    np.testing.assert_array_equal(I_c, np.zeros((3, 3)))


def test_urdf_inertial_round_trip(rng):
    for _ in range(10):
        mass, com, I_c = random_body(rng)
        m2, c2, I2 = urdf_inertial_from_khalil(khalil_from_urdf_inertial(mass, com, I_c))
        assert m2 == pytest.approx(mass, rel=1e-15)
        np.testing.assert_allclose(c2, com, rtol=0, atol=1e-14)
        np.testing.assert_allclose(I2, I_c, rtol=0, atol=1e-13)


# ---------------------------------------------------------------------- change of frame
def test_transform_khalil_matches_pinocchio_se3_act(rng):
    for _ in range(20):
        mass, com, I_c = random_body(rng)
        R, p = random_rotation(rng), rng.uniform(-1.0, 1.0, 3)
        Y_a = pin.SE3(R, p).act(pin.Inertia(mass, com, I_c))  # body inertia seen in frame a
        expected = khalil_by_hand(Y_a.mass, Y_a.lever, Y_a.inertia)
        got = transform_khalil(khalil_by_hand(mass, com, I_c), R, p)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_transform_khalil_of_a_point_mass_in_a_translated_frame():
    # A 1.5 kg point at O_b, and frame b at p in frame a: first moments m p, I_O = m(|p|^2 - pp^T).
    m, p = 1.5, np.array([0.3, 0.4, -0.1])
    point = np.array([0, 0, 0, 0, 0, 0, 0, 0, 0, m], dtype=float)
    expected = khalil_by_hand(m, p, np.zeros((3, 3)))
    np.testing.assert_allclose(transform_khalil(point, np.eye(3), p), expected, atol=1e-15)


def test_transform_khalil_identity_and_inverse(rng):
    params = khalil_by_hand(*random_body(rng))
    np.testing.assert_allclose(
        transform_khalil(params, np.eye(3), np.zeros(3)), params, rtol=0, atol=1e-15
    )
    R, p = random_rotation(rng), rng.uniform(-1.0, 1.0, 3)
    there = transform_khalil(params, R, p)
    back = transform_khalil(there, R.T, -R.T @ p)
    np.testing.assert_allclose(back, params, rtol=0, atol=1e-13)


# ---------------------------------------------------------------------- physical consistency
def test_check_physical_accepts_physical_bodies(rng):
    params = khalil_by_hand(*random_body(rng))
    out = check_physical(params.tolist(), "body")
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, params)
    np.testing.assert_array_equal(check_physical(np.zeros(10), "massless"), np.zeros(10))


def test_check_physical_rejects_negative_mass():
    params = khalil_by_hand(-1.0, np.zeros(3), np.eye(3))
    with pytest.raises(InertiaError, match="negative mass") as info:
        check_physical(params, "leg 2 link 3")
    assert info.value.body == "leg 2 link 3"


def test_check_physical_rejects_non_psd_inertia_about_the_com():
    with pytest.raises(InertiaError, match="not positive semi-definite"):
        check_physical(khalil_by_hand(1.0, np.zeros(3), np.diag([1.0, 1.0, -0.1])), "body")
    # PSD about the origin, not about the centre of mass: a first moment and no inertia.
    offset = np.array([0, 0, 0, 0, 0, 0, 0.5, 0, 0, 1.0])
    with pytest.raises(InertiaError, match="not positive semi-definite"):
        check_physical(offset, "body")


def test_check_physical_rejects_the_triangle_inequality_violation():
    # Principal moments (1, 1, 2.5): PSD, but 1 + 1 < 2.5.
    params = khalil_by_hand(1.0, np.array([0.1, 0.2, 0.0]), np.diag([1.0, 1.0, 2.5]))
    with pytest.raises(InertiaError, match="triangle inequality"):
        check_physical(params, "body")
    # A thin rod (1, 1, 0) is the limit case and passes.
    check_physical(khalil_by_hand(1.0, np.zeros(3), np.diag([1.0, 1.0, 0.0])), "rod")


def test_check_physical_rejects_massless_with_moments():
    with pytest.raises(InertiaError, match="massless"):
        check_physical(np.array([1e-3, 0, 0, 1e-3, 0, 1e-3, 0, 0, 0, 0.0]), "body")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_check_physical_rejects_non_finite(bad):
    params = khalil_by_hand(1.0, np.zeros(3), np.eye(3))
    params[4] = bad
    with pytest.raises(InertiaError, match="non-finite") as info:
        check_physical(params, "platform")
    assert info.value.body == "platform"


def test_check_physical_rejects_wrong_shape():
    with pytest.raises(InertiaError, match="shape"):
        check_physical(np.ones(9), "body")


def test_random_physical_khalil_is_physical(rng):
    for _ in range(20):
        mass, size, offset = rng.uniform(0.1, 10.0), rng.uniform(0.01, 1.0), 0.2
        p = random_physical_khalil(rng, mass, size, offset)
        assert p.shape == (10,)
        assert p[9] == pytest.approx(mass, rel=1e-15)
        com = p[6:9] / p[9]
        assert np.all(np.abs(com) <= offset)
        I_O = np.array([[p[0], p[1], p[2]], [p[1], p[3], p[4]], [p[2], p[4], p[5]]])
        I_c = I_O - mass * (com @ com * np.eye(3) - np.outer(com, com))
        eig = np.linalg.eigvalsh(I_c)
        tol = 1e-12 * eig.max()
        assert eig[0] > 0.0
        assert eig[0] + eig[1] >= eig[2] - tol
        # A full tensor: off-diagonal terms about the com are not negligible.
        assert np.abs(I_c[np.triu_indices(3, 1)]).max() > 1e-6 * eig.max()


# ---------------------------------------------------------------------- scale-aware check
def _rotation_from(q: list[float]) -> np.ndarray:
    """The rotation of the quaternion (w, x, y, z) = q / |q| (textbook formula)."""
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _principal_moments(kind: str, mass: float, sides: np.ndarray) -> np.ndarray:
    """Principal moments about the centre of mass [kg m^2] of textbook bodies: a point, a
    thin rod of length ``a`` (0, I, I), a thin plate ``a x b`` (I1 + I2 = I3) and a box."""
    a, b, c = sides
    if kind == "point":
        return np.zeros(3)
    if kind == "rod":
        return mass * a * a / 12.0 * np.array([0.0, 1.0, 1.0])
    if kind == "plate":
        return mass / 12.0 * np.array([b * b, a * a, a * a + b * b])
    return mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


body_strategy = st.tuples(
    st.sampled_from(["point", "rod", "plate", "box"]),
    st.floats(-6.0, 6.0),  # log10 of the mass [kg]
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3),  # com direction
    st.floats(-4.0, 2.0),  # log10 of the com offset scale [m]
    st.floats(-4.0, 1.0),  # log10 of the body size [m]
    st.lists(st.floats(0.05, 1.0), min_size=3, max_size=3),  # side ratios
    st.lists(st.floats(0.1, 1.0), min_size=4, max_size=4),  # quaternion (away from 0)
    st.lists(st.sampled_from([-1.0, 1.0]), min_size=4, max_size=4),  # its signs
)

#: A non-physical body violates a bound by this fraction of its inertia scale
#: ``S = ||I_O||_F + M |c|^2`` (plus ``M size^2``): 100 times the check's tolerance
#: (PHYSICAL_TOLERANCE, 1e-10).
NON_PHYSICAL_MARGIN = 1e-8


def _body(draw: tuple) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    kind, log_m, direction, log_offset, log_size, ratios, q, signs = draw
    mass = 10.0**log_m
    com = np.array(direction) * 10.0**log_offset
    R = _rotation_from(np.array(q) * signs)
    return mass, com, R, _principal_moments(kind, mass, 10.0**log_size * np.array(ratios))


def _scale(mass: float, com: np.ndarray, I_c: np.ndarray) -> float:
    I_O = I_c + mass * (com @ com * np.eye(3) - np.outer(com, com))
    return float(np.linalg.norm(I_O) + mass * com @ com)


@settings(max_examples=300, deadline=None)
@given(body_strategy)
def test_point_masses_rods_plates_and_boxes_pass_the_physical_check(draw):
    # Before: the tolerance was relative to the inertia about the com itself, which is a
    # round-off for a point mass: about one point mass in four at a random offset failed.
    mass, com, R, moments = _body(draw)
    params = khalil_by_hand(mass, com, R @ np.diag(moments) @ R.T)
    np.testing.assert_array_equal(check_physical(params, "body"), params)


@settings(max_examples=300, deadline=None)
@given(body_strategy, st.sampled_from(["triangle", "negative"]))
def test_non_physical_tensors_fail_the_physical_check(draw, violation):
    mass, com, R, moments = _body(draw)
    I1, I2, I3 = np.sort(moments)
    # the margin relative to the scale, with the body's size as a floor (a point mass at
    # the origin has S = 0)
    size = 10.0 ** draw[4]
    delta = NON_PHYSICAL_MARGIN * (_scale(mass, com, R @ np.diag(moments) @ R.T) + mass * size**2)
    if violation == "triangle":  # I3 > I1 + I2 by delta
        bad = np.array([I1, I2, I1 + I2 + delta])
    else:  # a negative principal moment, -delta
        bad = np.array([-delta, I2, I3])
    with pytest.raises(InertiaError, match=r"triangle inequality|not positive semi-definite"):
        check_physical(khalil_by_hand(mass, com, R @ np.diag(bad) @ R.T), "body")


def _one_by_one(params: np.ndarray) -> str | None:
    """The reference: :func:`check_physical` on each body in order, the first error."""
    try:
        for k, p in enumerate(params):
            check_physical(p, f"body {k}")
    except InertiaError as e:
        return str(e)
    return None


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(body_strategy, st.sampled_from(["physical", "triangle", "negative", "other"])),
        min_size=1,
        max_size=19,
    )
)
def test_bodies_checked_together_decide_as_one_by_one(draws):
    """:func:`check_physical_bodies` (a description's bodies in one pass): the bodies the
    per-body check accepts are accepted, else the error is the first failing body's."""
    rows = []
    for draw, case in draws:
        mass, com, R, moments = _body(draw)
        I1, I2, I3 = np.sort(moments)
        size = 10.0 ** draw[4]
        delta = NON_PHYSICAL_MARGIN * (
            _scale(mass, com, R @ np.diag(moments) @ R.T) + mass * size**2
        )
        if case == "triangle":
            moments = np.array([I1, I2, I1 + I2 + delta])
        elif case == "negative":
            moments = np.array([-delta, I2, I3])
        row = khalil_by_hand(mass, com, R @ np.diag(moments) @ R.T)
        if case == "other":  # a massless body, with or without moments; a negative mass
            row = [np.zeros(10), np.r_[np.ones(6), np.zeros(4)], -row][int(draw[4] * 7) % 3]
        rows.append(row)
    params = np.array(rows)
    expected = _one_by_one(params)
    if expected is None:
        check_physical_bodies(params, lambda k: f"body {k}")
    else:
        with pytest.raises(InertiaError) as got:
            check_physical_bodies(params, lambda k: f"body {k}")
        assert str(got.value) == expected


def test_point_mass_check_is_independent_of_units():
    # The same 2 kg point mass at 0.3 m, in m and kg, in mm and g, and in km and t.
    c = np.array([0.1, -0.2, 0.2])
    for length, mass in ((1.0, 1.0), (1e3, 1e3), (1e-3, 1e-3)):
        params = khalil_by_hand(2.0 * mass, c * length, np.zeros((3, 3)))
        check_physical(params, "point")


@pytest.mark.parametrize("tol", [-1e-10, np.nan, "1e-10", True])
def test_check_physical_refuses_a_bad_tolerance(tol):
    from stewart_pin import InputError

    with pytest.raises(InputError, match="tol must be"):
        check_physical(khalil_by_hand(1.0, np.zeros(3), np.eye(3)), "body", tol=tol)


# ---------------------------------------------------------------- URDF-style inertial tables
def _rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's ``Rz(yaw) Ry(pitch) Rx(roll)``, written out (not Pinocchio's rpy module)."""
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (np.cos, np.sin))
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _table(mass, com, I_axes, rpy=None) -> dict:
    t = {"mass": mass, "com": list(com), "ixx": I_axes[0, 0], "iyy": I_axes[1, 1]}
    t |= {"izz": I_axes[2, 2], "ixy": I_axes[0, 1], "ixz": I_axes[0, 2], "iyz": I_axes[1, 2]}
    if rpy is not None:
        t["rpy"] = list(rpy)
    return t


def test_inertial_table_equals_khalil_by_parallel_axis(rng):
    from stewart_pin.description.inertia import khalil_from_inertial_table

    for _ in range(5):
        mass, com, I_c = random_body(rng)
        got = khalil_from_inertial_table(_table(mass, com, I_c), "body")
        np.testing.assert_allclose(got, khalil_by_hand(mass, com, I_c), rtol=1e-13, atol=1e-15)
        # the same body with its inertia given in axes turned by rpy
        rpy = rng.uniform(-np.pi, np.pi, 3)
        R = _rpy_matrix(*rpy)
        turned = khalil_from_inertial_table(_table(mass, com, R.T @ I_c @ R, rpy), "body")
        np.testing.assert_allclose(turned, khalil_by_hand(mass, com, I_c), rtol=1e-12, atol=1e-14)


def test_inertial_table_defaults_and_refusals():
    from stewart_pin.description.inertia import khalil_from_inertial_table

    point = khalil_from_inertial_table({"mass": 2.0, "ixx": 0, "iyy": 0, "izz": 0}, "b")
    np.testing.assert_array_equal(point, [0, 0, 0, 0, 0, 0, 0, 0, 0, 2.0])
    bad = {
        "not a table": ([1.0] * 10, "an inertial table"),
        "both forms": ({"mass": 1, "ixx": 1, "iyy": 1, "izz": 1, "XX": 1}, "not both"),
        "unknown key": ({"mass": 1, "ixx": 1, "iyy": 1, "izz": 1, "Ixx": 1}, r"unknown \['Ixx'\]"),
        "missing izz": ({"mass": 1, "ixx": 1, "iyy": 1}, r"missing \['izz'\]"),
        "negative mass": ({"mass": -1, "ixx": 1, "iyy": 1, "izz": 1}, "negative mass"),
        "string": ({"mass": "1", "ixx": 1, "iyy": 1, "izz": 1}, "mass"),
        "nan": ({"mass": 1, "ixx": float("nan"), "iyy": 1, "izz": 1}, "ixx"),
        "com shape": ({"mass": 1, "com": [0, 0], "ixx": 1, "iyy": 1, "izz": 1}, "com"),
        "not psd": ({"mass": 1, "ixx": 1, "iyy": 1, "izz": 1, "ixy": 2}, "semi-definite"),
        "triangle": ({"mass": 1, "ixx": 1, "iyy": 1, "izz": 3}, "triangle inequality"),
    }
    for why, (table, match) in bad.items():
        with pytest.raises(InertiaError, match=match) as info:
            khalil_from_inertial_table(table, "leg 2 link 3")
        assert info.value.body == "leg 2 link 3", why


def test_description_file_with_urdf_inertia_equals_khalil_form(tmp_path):
    """A description written with the URDF form reads as the Khalil form computed here, and
    round-trips through write / read."""
    import json

    from stewart_pin import FileFormatError, RobotDescription, preset

    base = preset("desktop").to_dict()
    rng = np.random.default_rng(7)
    links = [random_body(rng) for _ in range(3)]
    platform = random_body(rng)
    rpy = [0.3, -0.2, 1.1]
    R = _rpy_matrix(*rpy)
    d = {k: v for k, v in base.items() if k not in ("leg_inertia", "platform_inertia")}
    d["leg_inertial"] = [_table(m, c, I) for m, c, I in links]
    d["platform_inertial"] = _table(platform[0], platform[1], R.T @ platform[2] @ R, rpy)
    path = tmp_path / "urdf_style.json"
    path.write_text(json.dumps(d))
    desc = RobotDescription.read(path)
    expected = np.array([khalil_by_hand(*body) for body in links])
    for i in range(6):
        np.testing.assert_allclose(desc.leg_inertia[i], expected, rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(
        desc.platform_inertia, khalil_by_hand(*platform), rtol=1e-12, atol=1e-15
    )
    back = RobotDescription.read(desc.write(tmp_path / "khalil.toml"))
    np.testing.assert_array_equal(back.leg_inertia, desc.leg_inertia)
    np.testing.assert_array_equal(back.platform_inertia, desc.platform_inertia)
    # six lists of three: one per leg
    d6 = d | {"leg_inertial": [d["leg_inertial"]] * 6}
    np.testing.assert_array_equal(RobotDescription.from_dict(d6).leg_inertia, desc.leg_inertia)
    # both forms of one key, a wrong nesting, a non-physical body: named, with the line
    both = d | {"platform_inertia": base["platform_inertia"]}
    with pytest.raises(DescriptionErrorType, match=r"platform_inertia .* or platform_inertial"):
        RobotDescription.from_dict(both)
    with pytest.raises(DescriptionErrorType, match=r"three inertial tables .* or six lists"):
        RobotDescription.from_dict(d | {"leg_inertial": d["leg_inertial"][:2]})
    toml = tmp_path / "bad.toml"
    toml.write_text(
        'name = "bad"\n[platform_inertial]\nmass = 1.0\nixx = 1.0\niyy = 1.0\nizz = 3.0\n'
    )
    with pytest.raises(FileFormatError, match="missing"):  # the other keys are missing
        RobotDescription.read(toml)
    text = (tmp_path / "khalil.toml").read_text()
    text = text[: text.index("leg_inertia = ")] + text[text.index("platform_inertia = ") :]
    text += "\n[[leg_inertial]]\nmass = 1.0\nixx = 1.0\niyy = 1.0\nizz = 3.0\n"
    text += "[[leg_inertial]]\nmass = 1.0\nixx = 1.0\niyy = 1.0\nizz = 1.0\n" * 2
    toml.write_text(text)
    line = text[: text.index("[[leg_inertial]]")].count("\n") + 1
    with pytest.raises(FileFormatError, match=rf"line {line}: leg 1 link 1: .*triangle"):
        RobotDescription.read(toml)
