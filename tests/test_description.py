"""The robot description: construction, validation, files, MDH helpers, presets."""

from __future__ import annotations

import copy
import json
import re

import numpy as np
import pytest
from helpers import rot_x, rot_z, trans

from stewart_pin import (
    DescriptionError,
    FileFormatError,
    InertiaError,
    InputError,
    RobotDescription,
    StewartPinError,
    leg_base_rotation_from_axis,
    leg_frame_from_mdh,
    preset,
    random_robot,
)
from stewart_pin.description.presets import PRESETS
from stewart_pin.description.robot_description import OPTIONAL_KEYS, REQUIRED_KEYS

ARRAY_KEYS = (
    "base_points",
    "platform_points",
    "leg_base_rotations",
    "stroke",
    "leg_inertia",
    "platform_inertia",
    "gravity",
    "home_pose",
)


@pytest.fixture(scope="module")
def good() -> dict:
    """A valid dictionary form (the random robot has every optional key but the limits)."""
    return random_robot(5).to_dict()


def modified(d: dict, key: str, value) -> dict:
    out = copy.deepcopy(d)
    out[key] = value
    return out


def assert_same(a: RobotDescription, b: RobotDescription) -> None:
    assert a.name == b.name
    for key in (*ARRAY_KEYS, "u_joint_limits"):
        x, y = getattr(a, key), getattr(b, key)
        if x is None:
            assert y is None
        else:
            np.testing.assert_array_equal(x, y, err_msg=key)


# ---------------------------------------------------------------------- construction
def test_dict_round_trip_is_exact(good):
    d = RobotDescription.from_dict(good)
    assert_same(RobotDescription.from_dict(d.to_dict()), d)
    assert set(d.to_dict()) <= set(REQUIRED_KEYS + OPTIONAL_KEYS)
    # the values are plain lists, as JSON and TOML need
    json.dumps(d.to_dict())


def test_dict_round_trip_with_limits(good):
    limits = [[-1.0, 1.5], [0.2, 2.9]]
    d = RobotDescription.from_dict({**good, "u_joint_limits": limits})
    assert d.u_joint_limits.shape == (6, 2, 2)
    np.testing.assert_array_equal(d.u_joint_limits, np.broadcast_to(limits, (6, 2, 2)))
    assert_same(RobotDescription.from_dict(d.to_dict()), d)


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_file_round_trip_is_exact(tmp_path, good, suffix):
    d = RobotDescription.from_dict({**good, "u_joint_limits": [[-1.0, 1.5], [0.2, 2.9]]})
    path = d.write(tmp_path / f"robot{suffix}")
    assert path.exists()
    assert_same(RobotDescription.read(path), d)


def test_arrays_are_copied_and_read_only(good):
    B = np.array(good["base_points"])
    d = RobotDescription.from_dict({**good, "base_points": B})
    B[0, 0] += 1.0
    assert d.base_points[0, 0] == good["base_points"][0][0]
    for key in ARRAY_KEYS:
        assert not getattr(d, key).flags.writeable, key
    with pytest.raises(ValueError, match="read-only"):
        d.leg_inertia[0, 0, 9] = 1.0


def test_replace_validates_again(good):
    d = RobotDescription.from_dict(good)
    assert d.replace(name="other").name == "other"
    with pytest.raises(DescriptionError, match="stroke"):
        d.replace(stroke=[1.0, 0.5])


def test_default_home_pose_puts_legs_at_mid_stroke(good):
    d = RobotDescription.from_dict({k: v for k, v in good.items() if k != "home_pose"})
    T = d.home_pose
    np.testing.assert_array_equal(T[:3, :3], np.eye(3))
    P = d.platform_points + T[:3, 3]
    mean_length = np.linalg.norm(P - d.base_points, axis=1).mean()
    assert mean_length == pytest.approx(d.stroke.mean(), rel=1e-12)


# ---------------------------------------------------------------------- validation
def _repeated(d):
    # Legs 2 and 4 with both ends at one point (a shared joint on one side only is the
    # legitimate 3-3 / 6-3 design, see test_bad_input.py).
    B, P = np.array(d["base_points"]), np.array(d["platform_points"])
    B[3], P[3] = B[1], P[1]
    return modified(modified(d, "base_points", B), "platform_points", P)


def _collinear(d):
    t = np.linspace(-0.3, 0.3, 6)
    return modified(d, "platform_points", np.column_stack([t, 2 * t, 0.1 + 0 * t]))


def _rotation(d, change):
    R = np.array(d["leg_base_rotations"])
    R[2] = change(R[2])
    return modified(d, "leg_base_rotations", R)


def _leg_inertia(d, leg, link, params):
    I = np.array(d["leg_inertia"])
    I[leg, link] = params
    return modified(d, "leg_inertia", I)


def _with(d, key, index, value):
    a = np.array(d[key], dtype=float)
    a[index] = value
    return modified(d, key, a)


# Khalil parameters: a negative mass, an inertia about the com with a negative principal
# moment, principal moments (1, 1, 3) violating I1 + I2 >= I3.
NEGATIVE_MASS = [1, 0, 0, 1, 0, 1, 0, 0, 0, -2.0]
NON_PSD = [1, 0, 0, 1, 0, -0.5, 0, 0, 0, 1.0]
TRIANGLE = [1, 0, 0, 1, 0, 3.0, 0, 0, 0, 1.0]

BAD_INPUTS = {
    "repeated": (_repeated, DescriptionError, r"legs 2 and 4 coincide: B_2 = B_4"),
    "collinear": (_collinear, DescriptionError, r"platform attachment points P_i are collinear"),
    "non-orthonormal": (
        lambda d: _rotation(d, lambda R: R + 1e-3 * np.outer(R[:, 0], R[:, 1])),
        DescriptionError,
        r"leg_base_rotations\[2\] \(leg 3\) is not orthonormal",
    ),
    "non-unit": (
        lambda d: _rotation(d, lambda R: 1.01 * R),
        DescriptionError,
        r"leg 3\) is not orthonormal",
    ),
    "reflection": (
        lambda d: _rotation(d, lambda R: R * [1, 1, -1]),
        DescriptionError,
        r"leg 3\) is a reflection",
    ),
    "stroke-reversed": (
        lambda d: modified(d, "stroke", [1.0, 0.5]),
        DescriptionError,
        r"stroke must satisfy 0 < min < max",
    ),
    "stroke-empty": (
        lambda d: modified(d, "stroke", [0.7, 0.7]),
        DescriptionError,
        r"stroke must satisfy 0 < min < max",
    ),
    "stroke-negative": (
        lambda d: modified(d, "stroke", [-0.1, 0.7]),
        DescriptionError,
        r"stroke must satisfy 0 < min < max",
    ),
    "negative-mass": (
        lambda d: _leg_inertia(d, 1, 2, NEGATIVE_MASS),
        InertiaError,
        r"leg 2 link 3: negative mass",
    ),
    "non-psd": (
        lambda d: _leg_inertia(d, 4, 0, NON_PSD),
        InertiaError,
        r"leg 5 link 1: inertia about the centre of mass is not positive semi-definite",
    ),
    "triangle": (
        lambda d: modified(d, "platform_inertia", TRIANGLE),
        InertiaError,
        r"platform: principal moments .* violate the triangle inequality",
    ),
    "nan-point": (
        lambda d: _with(d, "base_points", (2, 1), np.nan),
        DescriptionError,
        r"base_points holds a non-finite value nan at index \(2, 1\)",
    ),
    "inf-inertia": (
        lambda d: _with(d, "leg_inertia", (0, 1, 3), np.inf),
        DescriptionError,
        r"leg_inertia holds a non-finite value inf",
    ),
    "nan-gravity": (
        lambda d: modified(d, "gravity", [0.0, np.nan, -9.81]),
        DescriptionError,
        r"gravity holds a non-finite",
    ),
    "shape-points": (
        lambda d: modified(d, "base_points", np.zeros((5, 3)).tolist()),
        DescriptionError,
        r"base_points must have shape \(6, 3\), got \(5, 3\)",
    ),
    "shape-rotations": (
        lambda d: modified(d, "leg_base_rotations", np.zeros((6, 9)).tolist()),
        DescriptionError,
        r"leg_base_rotations must have shape \(6, 3, 3\)",
    ),
    "shape-inertia": (
        lambda d: modified(d, "leg_inertia", np.zeros((6, 3, 9)).tolist()),
        DescriptionError,
        r"leg_inertia must have shape \(6, 3, 10\)",
    ),
    "shape-stroke": (
        lambda d: modified(d, "stroke", [0.5, 0.6, 0.7]),
        DescriptionError,
        r"stroke must have shape \(2,\)",
    ),
    "ragged": (
        lambda d: modified(d, "gravity", [[0.0], [0.0, -9.81]]),
        DescriptionError,
        r"gravity must be a numeric array",
    ),
    "not-numeric": (
        lambda d: modified(d, "stroke", ["a", "b"]),
        DescriptionError,
        r"stroke must be a numeric array",
    ),
    "limits-reversed": (
        lambda d: modified(d, "u_joint_limits", [[-1.0, 1.0], [2.0, 1.0]]),
        DescriptionError,
        r"u_joint_limits of leg 1, q2: lower 2 >= upper 1",
    ),
    "limits-shape": (
        lambda d: modified(d, "u_joint_limits", [-1.0, 1.0]),
        DescriptionError,
        r"u_joint_limits must have shape \(6, 2, 2\)",
    ),
    "home-not-rotation": (
        lambda d: _with(d, "home_pose", (0, 0), 2.0),
        DescriptionError,
        r"home_pose rotation block is not orthonormal",
    ),
    "home-last-row": (
        lambda d: _with(d, "home_pose", (3, 0), 1.0),
        DescriptionError,
        r"home_pose last row must be \[0, 0, 0, 1\]",
    ),
    "empty-name": (
        lambda d: modified(d, "name", ""),
        DescriptionError,
        r"robot name must be a non-empty string",
    ),
    "missing-key": (
        lambda d: {k: v for k, v in d.items() if k != "stroke"},
        DescriptionError,
        r"missing \['stroke'\], unknown \[\]",
    ),
    "unknown-key": (
        lambda d: modified(d, "strokes", [0.5, 1.0]),
        DescriptionError,
        r"missing \[\], unknown \['strokes'\]",
    ),
}


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_description_raises_its_named_error(good, case):
    make, error, message = BAD_INPUTS[case]
    with pytest.raises(error, match=message) as info:
        RobotDescription.from_dict(make(good))
    assert isinstance(info.value, StewartPinError)
    assert isinstance(info.value, ValueError)  # the stdlib convention for bad values


def test_inertia_error_names_the_body(good):
    with pytest.raises(InertiaError) as info:
        RobotDescription.from_dict(_leg_inertia(good, 3, 1, NEGATIVE_MASS))
    assert info.value.body == "leg 4 link 2"


def test_from_dict_rejects_a_non_dict():
    with pytest.raises(DescriptionError, match="must be a dict, got list"):
        RobotDescription.from_dict([1, 2, 3])


def test_repeated_points_are_relative_to_the_robot_size(good):
    # Points 1e-6 apart on a 0.5 m robot are distinct: no error.
    B = np.array(good["base_points"])
    B[3] = B[1] + 1e-6
    RobotDescription.from_dict(modified(good, "base_points", B))


def test_a_rotation_off_by_round_off_is_accepted(good):
    R = np.array(good["leg_base_rotations"])
    R[0] *= 1.0 + 1e-12
    RobotDescription.from_dict(modified(good, "leg_base_rotations", R))


# ---------------------------------------------------------------------- files
@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("bad.toml", "name = 'x'\nbase_points = [[0, 0, 0],\n"),
        ("bad.toml", "name = = 3\n"),
        ("bad.json", '{"name": "x", "base_points": [[0, 0, 0]]'),
        ("bad.json", "not json at all"),
    ],
)
def test_malformed_file_raises_file_format_error(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(FileFormatError, match=r"malformed robot description .*bad\.(toml|json)"):
        RobotDescription.read(path)


def test_file_with_bad_content_raises_file_format_error(tmp_path, good):
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(modified(good, "stroke", [1.0, 0.5])))
    with pytest.raises(FileFormatError, match=r"robot\.json: .*stroke must satisfy"):
        RobotDescription.read(path)


def test_unknown_suffix_raises_file_format_error(tmp_path, good):
    d = RobotDescription.from_dict(good)
    with pytest.raises(FileFormatError, match=r"unknown description file type '\.yaml'"):
        d.write(tmp_path / "robot.yaml")
    path = tmp_path / "robot.yaml"
    path.write_text("name: x\n")
    with pytest.raises(FileFormatError, match=r"unknown description file type '\.yaml'"):
        RobotDescription.read(path)


def test_missing_file_raises_file_format_error(tmp_path):
    with pytest.raises(FileFormatError, match="cannot read robot description"):
        RobotDescription.read(tmp_path / "nowhere.toml")


def test_toml_file_has_a_unit_header(tmp_path, good):
    text = RobotDescription.from_dict(good).write(tmp_path / "r.toml").read_text()
    assert text.startswith("# stewart-pin robot description (SI units")


# ---------------------------------------------------------------------- MDH helpers
@pytest.mark.parametrize(
    ("gamma", "b", "alpha", "d"),
    [(0.0, 0.0, 0.0, 0.0), (0.3, 0.1, -1.2, 0.5), (-2.5, -0.2, 2.0, 0.05), (np.pi, 1.0, 0.5, 0)],
)
def test_leg_frame_from_mdh_is_the_product_of_the_four_transforms(gamma, b, alpha, d):
    # Khalil-Kleinfinger: 0T1 = Rz(gamma) Tz(b) Rx(alpha) Tx(d) (Rz(q1) with q1 = 0).
    T = rot_z(gamma) @ trans(z=b) @ rot_x(alpha) @ trans(x=d)
    B, R = leg_frame_from_mdh(gamma, b, alpha, d)
    np.testing.assert_allclose(B, T[:3, 3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(R, T[:3, :3], rtol=0, atol=1e-15)


def test_leg_base_rotation_from_axis(rng):
    for _ in range(20):
        axis, direction = rng.normal(size=3) * rng.uniform(0.1, 10), rng.normal(size=3)
        R = leg_base_rotation_from_axis(axis, direction)
        np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-14)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(R[:, 2], axis / np.linalg.norm(axis), rtol=0, atol=1e-15)
        # x1 lies in the plane of the axis and the leg direction, on the leg's side.
        assert abs(np.cross(axis, direction) @ R[:, 0]) < 1e-12 * np.linalg.norm(axis)
        assert R[:, 0] @ direction > 0


def test_leg_base_rotation_from_axis_perpendicular_leg_is_at_q2_half_pi():
    # With the axis perpendicular to the leg, the leg direction in frame 1 is x1, which the
    # MDH chain reaches at q1 = 0 and q2 = pi/2: u = [cos q1 sin q2, sin q1 sin q2, -cos q2].
    axis, direction = np.array([0.0, 0.0, 2.0]), np.array([0.0, 3.0, 0.0])
    R = leg_base_rotation_from_axis(axis, direction)
    np.testing.assert_allclose(R.T @ direction / 3.0, [1.0, 0.0, 0.0], atol=1e-15)


def test_leg_base_rotation_from_axis_errors():
    with pytest.raises(InputError, match="must be non-zero"):
        leg_base_rotation_from_axis([0, 0, 0], [1, 0, 0])
    with pytest.raises(InputError, match="parallel to the U-joint axis"):
        leg_base_rotation_from_axis([0, 0, 1], [0, 0, -2])
    with pytest.raises(InputError, match=r"axis must have shape \(3,\)"):
        leg_base_rotation_from_axis([0, 1], [1, 0, 0])


# ---------------------------------------------------------------------- presets
@pytest.mark.parametrize("name", [*PRESETS, "random-0", "random-7"])
def test_presets_build(name):
    d = preset(name)
    assert isinstance(d, RobotDescription)
    assert d.name == name
    # the home pose is reachable: every leg length inside the stroke
    T = d.home_pose
    lengths = np.linalg.norm(d.platform_points @ T[:3, :3].T + T[:3, 3] - d.base_points, axis=1)
    assert np.all((d.stroke[0] < lengths) & (lengths < d.stroke[1]))


def test_unknown_preset():
    with pytest.raises(DescriptionError, match=r"unknown preset 'hexapod'; choose one of"):
        preset("hexapod")
    with pytest.raises(DescriptionError, match="unknown preset 'random-x'"):
        preset("random-x")


def test_paper_preset_has_the_paper_frames():
    d = preset("paper")
    B, P, tol = d.base_points, d.platform_points, 1e-12  # [m]
    # F0 at B_1, x0 along B_1 B_2, B_6 in the (x0, y0) plane (fig. 2 of the paper).
    np.testing.assert_allclose(B[0], 0.0, atol=tol)
    np.testing.assert_allclose(B[1, 1:], 0.0, atol=tol)
    assert B[1, 0] > 0.01
    assert abs(B[5, 2]) < tol
    # Fp at P_1, xp along P_1 P_2, P_6 in the (xp, yp) plane.
    np.testing.assert_allclose(P[0], 0.0, atol=tol)
    np.testing.assert_allclose(P[1, 1:], 0.0, atol=tol)
    assert P[1, 0] > 0.01
    assert abs(P[5, 2]) < tol
    # Same shape as a symmetric hexapod: the platform points keep their pairwise distances
    # at the home pose, and the home legs are all the same length.
    T = d.home_pose
    lengths = np.linalg.norm(P @ T[:3, :3].T + T[:3, 3] - B, axis=1)
    np.testing.assert_allclose(lengths, lengths.mean(), rtol=1e-12)
    # the base plane is horizontal, so gravity is -9.81 m/s^2 along z0
    np.testing.assert_allclose(d.gravity, [0.0, 0.0, -9.81], rtol=0, atol=1e-14)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_random_robots_have_full_inertia_on_every_body(seed):
    d = random_robot(seed)
    bodies = [*d.leg_inertia.reshape(18, 10), d.platform_inertia]
    for params in bodies:
        assert params[9] > 0
        assert np.all(np.abs(params[[1, 2, 4]]) > 1e-6)  # XY, XZ, YZ
        assert np.all(np.abs(params[6:9]) > 1e-6)  # MX, MY, MZ
    # and the U-joint axes are oblique: not all perpendicular to the base normal
    assert np.abs(d.leg_base_rotations[:, 2, 2]).max() > 0.05


# ---------------------------------------------------------------------- documentation
def test_docs_toml_excerpt_matches_the_desktop_preset():
    # docs/description.md shows an excerpt of the desktop preset: it must stay valid TOML
    # and agree with the preset (to the digits printed there).
    import re
    import tomllib
    from pathlib import Path

    text = (Path(__file__).parents[1] / "docs" / "description.md").read_text()
    excerpt = tomllib.loads(re.search(r"```toml\n(.*?)```", text, re.S).group(1))
    full = preset("desktop").to_dict()
    assert set(excerpt) == set(full) - {"u_joint_limits"}
    for key, value in excerpt.items():
        if key == "name":
            assert value == full[key]
            continue
        expected = np.asarray(full[key])[: len(value)]  # the excerpt keeps the first rows
        np.testing.assert_allclose(np.asarray(value), expected, rtol=1e-12, atol=1e-17)


# ---------------------------------------------------------------------- legitimate designs
def _ring(radius: float, degrees: list[float]) -> np.ndarray:
    a = np.radians(degrees)
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(6)])


#: Classic designs with legs sharing a joint centre, on the desktop preset's scale [m, deg].
#: 3-3 (octahedral): three base and three platform points, each shared by two legs;
#: 6-3: six base points, three shared platform points.
SHARED_JOINT_DESIGNS = {
    "3-3": (_ring(0.10, [0, 0, 120, 120, 240, 240]), _ring(0.075, [300, 60, 60, 180, 180, 300])),
    "6-3": (
        _ring(0.10, [-12, 12, 108, 132, 228, 252]),
        _ring(0.075, [300, 60, 60, 180, 180, 300]),
    ),
}


def shared_joint_robot(kind: str) -> RobotDescription:
    """The desktop preset's legs, strokes and platform on a 3-3 or 6-3 geometry, with
    oblique first U-joint axes."""
    B, P = SHARED_JOINT_DESIGNS[kind]
    draft = preset("desktop").replace(
        base_points=B,
        platform_points=P,
        leg_base_rotations=np.tile(np.eye(3), (6, 1, 1)),
        home_pose=None,
        name=f"design-{kind}",
    )
    T = draft.home_pose
    P_home = P @ T[:3, :3].T + T[:3, 3]
    R = [
        leg_base_rotation_from_axis(
            np.cross([0, 0, 1], p - b) + np.array([0.1, -0.2, 0.05]), p - b
        )
        for b, p in zip(B, P_home, strict=True)
    ]
    return draft.replace(leg_base_rotations=np.array(R))


@pytest.mark.parametrize("kind", list(SHARED_JOINT_DESIGNS))
def test_shared_joint_designs_are_accepted_and_match_the_constrained_tree(kind):
    from stewart_pin import StewartRobot, validate

    d = shared_joint_robot(kind)
    B, P = SHARED_JOINT_DESIGNS[kind]
    np.testing.assert_array_equal(d.base_points, B)  # kept as given
    np.testing.assert_array_equal(d.platform_points, P)
    # The paper's models against Pinocchio's constrained dynamics of the 24-dof tree, which
    # closes each leg on its own point (coincident or not): IDM to 1e-9, DDM to 1e-8.
    report = validate(StewartRobot(d), n_states=12, seed=3)
    assert report.passed(), str(report)
    assert report.idm_error < 1e-12 and report.ddm_error < 1e-10


def _shared_points(d: dict, base: dict[int, int], platform: dict[int, int]) -> dict:
    """``d`` with B_i = B_j for each ``i: j`` of ``base`` (0-based), likewise P."""
    B, P = np.array(d["base_points"]), np.array(d["platform_points"])
    for i, j in base.items():
        B[i] = B[j]
    for i, j in platform.items():
        P[i] = P[j]
    return modified(modified(d, "base_points", B), "platform_points", P)


@pytest.mark.parametrize(
    ("base", "platform", "message"),
    [
        ({3: 1}, {3: 1}, r"legs 2 and 4 coincide: B_2 = B_4"),
        ({1: 0, 2: 0, 3: 0}, {}, r"4 base attachment points \(B_1, B_2, B_3, B_4\) coincide"),
        ({}, {k: 5 for k in range(5)}, r"6 platform attachment points .* coincide"),
    ],
)
def test_degenerate_shared_joints_are_refused(good, base, platform, message):
    # Two legs on one line, or more than three lines through one point: the six leg lines
    # are dependent, so every pose is singular.
    with pytest.raises(DescriptionError, match=message):
        RobotDescription.from_dict(_shared_points(good, base, platform))


def test_legs_sharing_one_end_are_accepted(good):
    # Before: "B_2 and B_4 are repeated". A shared joint centre on one side is legitimate.
    d = RobotDescription.from_dict(_shared_points(good, {3: 1}, {}))
    np.testing.assert_array_equal(d.base_points[3], d.base_points[1])


def _round_to(x: np.ndarray, digits: int) -> np.ndarray:
    """Each entry written with ``digits`` significant digits, as a CAD export prints it."""
    return np.vectorize(lambda v: float(f"{v:.{digits - 1}e}"))(x)


def _nearest_rotation(R: np.ndarray) -> np.ndarray:
    """Reference: the orthogonal polar factor (scipy), the rotation nearest to R."""
    from scipy.linalg import polar

    return polar(R)[0]


def test_cad_rounded_rotations_are_projected_with_a_warning(good):
    from stewart_pin.exceptions import StewartPinWarning

    exact = np.array(good["leg_base_rotations"])
    rounded = _round_to(exact, 6)
    assert np.abs(np.einsum("nji,njk->nik", rounded, rounded) - np.eye(3)).max() > 1e-7
    with pytest.warns(StewartPinWarning) as record:
        d = RobotDescription.from_dict(modified(good, "leg_base_rotations", rounded))
    assert len(record) == 6  # one per leg, each naming the field and the correction
    fields = sorted(w.message.field for w in record)
    assert fields == [f"leg_base_rotations[{i}] (leg {i + 1})" for i in range(6)]
    for w in record:
        assert 0 < w.message.correction < 1e-6
        assert re.search(r"projected onto SO\(3\), max \|R_projected - R\| = ", str(w.message))
    for i in range(6):
        R = d.leg_base_rotations[i]
        np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-15)
        np.testing.assert_allclose(R, _nearest_rotation(rounded[i]), rtol=0, atol=1e-14)
        np.testing.assert_allclose(R, exact[i], rtol=0, atol=1e-6)  # the rounding's size


def test_cad_rounded_home_pose_is_projected_with_a_warning(good):
    from stewart_pin.exceptions import StewartPinWarning

    T = np.array(good["home_pose"])
    T_rounded = T.copy()
    T_rounded[:3, :3] = _round_to(T[:3, :3], 6)
    with pytest.warns(StewartPinWarning, match=r"home_pose rotation block .* projected"):
        d = RobotDescription.from_dict(modified(good, "home_pose", T_rounded))
    np.testing.assert_allclose(
        d.home_pose[:3, :3], _nearest_rotation(T_rounded[:3, :3]), rtol=0, atol=1e-14
    )
    np.testing.assert_array_equal(d.home_pose[:3, 3], T[:3, 3])


def test_exact_rotations_are_kept_as_given_without_warning(good):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = RobotDescription.from_dict(good)
    np.testing.assert_array_equal(d.leg_base_rotations, good["leg_base_rotations"])


@pytest.mark.parametrize("error", [2e-4, 1e-2])
def test_rotations_beyond_the_projection_tolerance_are_refused(good, error):
    R = np.array(good["leg_base_rotations"])
    R[4] = R[4] @ (np.eye(3) + error * np.diag([1.0, 0.0, 0.0]))  # |R^T R - I| ~ 2 error
    with pytest.raises(DescriptionError, match=r"leg_base_rotations\[4\] \(leg 5\) is not "):
        RobotDescription.from_dict(modified(good, "leg_base_rotations", R))


@pytest.mark.parametrize("suffix", [".TOML", ".Toml", ".JSON"])
def test_upper_case_suffix_is_read_and_written(tmp_path, good, suffix):
    d = RobotDescription.from_dict(good)
    path = d.write(tmp_path / f"robot{suffix}")
    assert_same(RobotDescription.read(path), d)


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_utf8_byte_order_mark_is_accepted(tmp_path, good, suffix):
    d = RobotDescription.from_dict({**good, "name": "hexapod"})
    plain = d.write(tmp_path / f"plain{suffix}")
    path = tmp_path / f"bom{suffix}"
    path.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert_same(RobotDescription.read(path), d)


def test_utf8_byte_order_mark_is_accepted_in_csv_tables(tmp_path):
    from stewart_pin.formats.csv_tables import STATE_COLUMNS, read_csv

    rows = np.zeros((2, len(STATE_COLUMNS)))
    rows[:, 0], rows[:, 7] = [0.0, 0.5], 1.0  # t, qw
    text = (
        ",".join(STATE_COLUMNS)
        + "\n"
        + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in rows)
    )
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())  # as spreadsheet tools save UTF-8
    np.testing.assert_array_equal(read_csv(path, STATE_COLUMNS), rows)


@pytest.mark.parametrize(
    ("name", "efforts", "positions"),
    [("desktop", "N", "m"), ("ups-offset", "N", "m"), ("rus", "N m", "rad"), ("pus", "N", "m")],
)
def test_actuator_units_follow_the_actuated_joint(name, efforts, positions):
    """A prismatic actuator (6-UPS legs, PUS slides) exerts a force [N] and moves by
    metres; a revolute one (RUS cranks) a torque [N m] through radians. Crank torques were
    labelled [N] in the plots, identify's report and the help."""
    desc = preset(name)
    assert desc.actuator_units == (efforts,) * 6
    assert (desc.effort_unit, desc.position_unit) == (efforts, positions)


def test_mixed_legs_name_both_units():
    rus, pus = preset("rus"), preset("pus")
    mixed = rus.replace(legs=rus.legs[:3] + pus.legs[3:])
    assert mixed.actuator_units == ("N m",) * 3 + ("N",) * 3
    assert (mixed.effort_unit, mixed.position_unit) == ("N m or N", "rad or m")
