"""Base parameters of robots with general legs and joint terms (issue 13, item 1).

References: the numerical rank of the stacked regressor (SVD, with a gap of at least 1e6
around the cut), principal angles between the analytic and the full regressor's column
spaces on states neither set was built from, the null space of the grouping map (the
directions declared unidentifiable move no force), the inverse dynamic model for the
forces the base sets predict, and the paper's hand-written 6-UPS relations (eq. 44-66)
for general ``ups`` legs.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest
from test_base_params import special_robot

from stewart_pin import RobotDescription, StewartRobot, random_robot
from stewart_pin.description.leg_chain_hexapod import general_from_description
from stewart_pin.description.leg_chain_presets import random_joint_dynamics
from stewart_pin.description.presets import preset
from stewart_pin.dynamics.regressor import (
    GENERAL_STANDARD_NAMES,
    joint_index,
    standard_parameters,
)
from stewart_pin.exceptions import (
    BaseParameterWarning,
    InputError,
    UnsupportedArchitectureError,
)
from stewart_pin.parameters.base import (
    GENERAL_RANK_TOLERANCE,
    analytic_base_parameters,
    base_parameters,
    dimensionless_scales,
    essential_parameters,
    numerical_base_parameters,
    stacked_regressor,
)


# ---------------------------------------------------------------------- robots
def with_joint_terms(desc: RobotDescription, seed: int = 0) -> RobotDescription:
    """``desc`` (ideal or general) as general legs with every joint term non-zero (a gear
    or a screw on the actuated joints)."""
    rng = np.random.default_rng(seed)
    general = general_from_description(desc)
    dynamics = [
        [
            random_joint_dynamics(rng, joint.kind, transmission=k == leg.actuated - 1)
            for k, joint in enumerate(leg.joints)
        ]
        for leg in general.legs
    ]
    return general.with_joint_dynamics(dynamics).to_description()


def rebuild(desc: RobotDescription, legs: list, q_home: np.ndarray) -> RobotDescription:
    """``desc`` with other legs, the platform points moved to their tips at ``q_home``
    (6, 3) (the home pose kept), each leg on the branch of its home configuration."""
    T = desc.home_pose
    tips = []
    for k, leg in enumerate(legs):
        T0 = np.eye(4)
        T0[:3, :3], T0[:3, 3] = desc.leg_base_rotations[k], desc.base_points[k]
        tips.append(leg.tip_position(q_home[k], T0))
    legs = [
        leg.replace(branch=leg.branch_at(q), guess=q) for leg, q in zip(legs, q_home, strict=True)
    ]
    points = (np.array(tips) - T[:3, 3]) @ T[:3, :3]
    return desc.replace(legs=tuple(legs), platform_points=points)


def pus_parallel(alpha2: float = 0.0, gravity: list[float] | None = None) -> StewartRobot:
    """The ``pus`` preset (joint terms added) with the universal joint's first axis at
    ``alpha2`` [rad] from the rail (0: parallel to it, and to gravity)."""
    desc = with_joint_terms(preset("pus"))
    q = StewartRobot(desc).inverse_geometry(desc.home_pose)
    legs = [
        leg.replace(joints=(leg.joints[0], replace(leg.joints[1], alpha=alpha2), leg.joints[2]))
        for leg in desc.legs
    ]
    out = rebuild(desc, legs, q)
    return StewartRobot(out if gravity is None else out.replace(gravity=gravity))


def _ideal_as_ups(build: dict) -> Callable[[], StewartRobot]:
    return lambda: StewartRobot(with_joint_terms(special_robot(**build).description))


def _gravity(name: str, g: Callable[[RobotDescription], np.ndarray]) -> StewartRobot:
    desc = preset(name)
    desc = desc if name.startswith("random") else with_joint_terms(desc)
    return StewartRobot(desc.replace(gravity=g(desc)))


def _rail(desc: RobotDescription, leg: int) -> np.ndarray:
    """Leg ``leg``'s (0-based) first joint axis z1 in F0."""
    return desc.leg_base_rotations[leg] @ desc.legs[leg].joints[0].placement()[:3, 2]


#: (label, builder, expected count, why). Per leg on a general geometry: ups 26 (the
#: paper's 13, IA1 and IA2 grouped into ZZ1R, ZZ2R, IA3 and the 12 FV FC K OF); rus 30
#: (links 3 + 7 + 6 after the loop, IA2, IA3, 12); pus 23 (link 2: ZZ2R MX2 MY2, link 3:
#: 7 - 1, IA1R OF1R with the slide's mass, IA3, FV FC x 3, K x 3, OF2 OF3). Platform 10.
SPECIAL = [
    ("ups-paper-symmetric-planar", _ideal_as_ups(dict(name="paper")), 166, "general"),
    (
        "ups-first-axes-vertical",
        _ideal_as_ups(dict(name="simulator", axes="vertical")),
        154,
        "MX1, MY1R go on every leg",
    ),
    (
        "ups-legs-1-3-5-vertical",
        _ideal_as_ups(dict(name="paper", axes="vertical", legs=[0, 2, 4])),
        160,
        "MX1, MY1R go on legs 1, 3, 5",
    ),
    (
        "ups-zero-gravity",
        lambda: StewartRobot(preset("random-ups-0").replace(gravity=[0.0, 0.0, 0.0])),
        142,
        "MX1, MY1R, MX2, MY2 act through gravity only (O2 = B_i fixed)",
    ),
    (
        "ups-offset-zero-gravity",
        lambda: StewartRobot(preset("random-ups-offset-0").replace(gravity=[0.0, 0.0, 0.0])),
        154,
        "MX1, MY1R go; MX2, MY2 stay (O2 moves on the offset)",
    ),
    ("ups-offset-preset", lambda: StewartRobot.from_preset("ups-offset"), 166, "general"),
    (
        "rus-parallel-axes-symmetric",
        lambda: StewartRobot(with_joint_terms(preset("rus"))),
        160,
        "alpha2 = 0: link 2 turns about z1 (XX2R XY2 XZ2 YZ2 go); alpha3 = pi/2: IA3 into ZZ3R",
    ),
    (
        "rus-zero-gravity",
        lambda: _gravity("rus", lambda d: np.zeros(3)),
        148,
        "MX1, MY1R go (MX2, MY2 stay: the crank moves O2)",
    ),
    (
        "rus-gravity-along-crank-1",
        lambda: _gravity("rus", lambda d: 9.81 * _rail(d, 0)),
        158,
        "MX1, MY1R of leg 1 go",
    ),
    ("rus-general", lambda: StewartRobot.from_preset("random-rus-4"), 190, "general"),
    (
        "rus-general-gravity-along-crank-2",
        lambda: _gravity("random-rus-4", lambda d: -9.81 * _rail(d, 1)),
        188,
        "MX1, MY1R of leg 2 go",
    ),
    (
        "pus-rails-along-gravity-symmetric",
        lambda: StewartRobot(with_joint_terms(preset("pus"))),
        142,
        "alpha3 = pi/2 with link 2 turning about a fixed z2: IA3 into ZZ3R",
    ),
    ("pus-zero-gravity", lambda: _gravity("pus", lambda d: np.zeros(3)), 142, "no change"),
    (
        "pus-gravity-across-rails",
        lambda: _gravity("pus", lambda d: np.array([9.81, 0.0, 0.0])),
        142,
        "no change",
    ),
    (
        "pus-u-axis-along-rail",
        lambda: pus_parallel(0.0),
        130,
        "alpha2 = 0: O2 moves along z2, MX2 MY2 act by gravity only, and it is along z2",
    ),
    (
        "pus-u-axis-along-rail-zero-gravity",
        lambda: pus_parallel(0.0, [0.0, 0.0, 0.0]),
        130,
        "the same",
    ),
    (
        "pus-u-axis-along-rail-gravity-across",
        lambda: pus_parallel(0.0, [0.0, 9.81, 0.0]),
        142,
        "MX2, MY2 act through the gravity across z2",
    ),
    ("pus-general", lambda: StewartRobot.from_preset("random-pus-1"), 148, "general"),
    (
        "pus-general-gravity-along-rail-3",
        lambda: _gravity("random-pus-1", lambda d: 9.81 * _rail(d, 2)),
        148,
        "no change (the slide's weight is in OF1R)",
    ),
]


def _dimensionless(W: np.ndarray, desc: RobotDescription) -> np.ndarray:
    columns, rows = dimensionless_scales(desc)
    n = W.shape[-1]
    return (W.reshape(-1, 6, n) * rows[:, None] * columns).reshape(-1, n)


@pytest.mark.parametrize(
    ("label", "build", "expected", "why"), SPECIAL, ids=[c[0] for c in SPECIAL]
)
def test_analytic_base_set_equals_the_numerical_rank_and_span(label, build, expected, why):
    """On every geometry the analytic set has the numerical rank, spans the regressor's
    columns, keeps independent columns, and the directions it drops move no force."""
    robot = build()
    with warnings.catch_warnings():
        warnings.simplefilter("error", BaseParameterWarning)  # no grey zone on these
        analytic = base_parameters(robot, "analytic")
        numerical, report = numerical_base_parameters(robot, n_states=50, seed=3)
    W_raw = stacked_regressor(robot, 40, 17)  # states neither set was built from
    W = _dimensionless(W_raw, robot.description)
    U, sv, _ = np.linalg.svd(W, full_matrices=False)
    sv = sv / sv[0]
    rank = int(np.sum(sv > GENERAL_RANK_TOLERANCE))
    assert sv[rank - 1] > 1e6 * sv[rank]  # a wide gap: the rank does not hinge on the cut
    assert rank == expected, why
    assert len(analytic) == report.rank == len(numerical) == expected
    # Same span: the sine of the largest principal angle between the kept columns' span
    # and W's is at most ||Q - U_r U_r^T Q||_F; its round-off is eps over the smallest
    # kept singular value (down to 3e-8 here), hence 1e-6.
    Wb = analytic.reduce(W)
    Q, _ = np.linalg.qr(Wb)
    U_r = U[:, :rank]
    assert np.linalg.norm(Q - U_r @ (U_r.T @ Q)) < 1e-6
    # The kept columns are independent (dimensionless: a round-off column would show).
    sb = np.linalg.svd(Wb, compute_uv=False)
    assert sb[-1] > 1e3 * GENERAL_RANK_TOLERANCE * sb[0]
    # W = W[:, kept] K exactly (the relations are identities of the regressor), so the
    # directions K drops (its null space, 280 - nb of them) move no force.
    assert np.abs(W_raw - W_raw[:, analytic.kept] @ analytic.K).max() < 1e-12 * np.abs(W_raw).max()


@pytest.mark.parametrize("name", ["random-ups-offset-2", "rus", "random-pus-1"])
@pytest.mark.parametrize("method", ["analytic", "numerical"])
def test_base_regressor_reproduces_inverse_dynamics(name, method):
    robot = StewartRobot.from_preset(name)
    poses, twists, accels = robot.sample_states(30, 8)
    gamma = robot.inverse_dynamics(poses, twists, accels)
    bp = base_parameters(robot, method)
    Wb = bp.regressor(poses, twists, accels)
    assert Wb.shape == (30, 6, len(bp))
    assert np.abs(Wb @ bp.values - gamma).max() < 1e-12 * np.abs(gamma).max()
    np.testing.assert_allclose(bp.values, bp.K @ standard_parameters(robot.description))


def test_general_ups_legs_follow_the_paper_relations_plus_the_armatures():
    """A 6-UPS robot as general ``ups`` legs: its analytic base parameters are the paper's
    (eq. 44-66, hand-written in the ideal robot's set) with IA1 in ZZ1R and IA2 in ZZ2R
    (``alpha2 = pi/2``), IA3 and the 12 friction, spring and offset terms apart."""
    ideal = random_robot(5)
    general = with_joint_terms(ideal)
    paper = dict(zip(*_named(analytic_base_parameters(ideal)), strict=True))
    bp = analytic_base_parameters(general)
    values = dict(zip(*_named(bp), strict=True))
    chi = standard_parameters(general)
    extra = {}
    for i in range(1, 7):
        extra[f"ZZ1R_{i}"] = chi[joint_index(i, 1, "IA")]
        extra[f"ZZ2R_{i}"] = chi[joint_index(i, 2, "IA")]
    for name, value in paper.items():
        assert values[name] == pytest.approx(value + extra.get(name, 0.0), rel=1e-12), name
    rest = set(values) - set(paper)
    assert rest == {
        f"{t}{j}_{i}" for i in range(1, 7) for j in (1, 2, 3) for t in ("FV", "FC", "K", "OF")
    } | {f"IA3_{i}" for i in range(1, 7)}


def _named(bp) -> tuple[tuple[str, ...], np.ndarray]:
    return bp.names, bp.values


def test_first_slide_mass_goes_to_the_armature_and_the_offset():
    """PUS: the slide's mass (with the rod's and the cross's moved onto it) enters the
    slide's armature and, times ``-g . z1``, its offset (rule 5): ``OF1R - OF1 =
    -(g . z1) (IA1R - IA1)``; for vertical rails under -z gravity, ``-g . z1 = 9.81``."""
    desc = with_joint_terms(preset("pus"))
    bp = analytic_base_parameters(desc)
    values = dict(zip(bp.names, bp.values, strict=True))
    chi = standard_parameters(desc)
    for i in range(1, 7):
        ia = values[f"IA1R_{i}"] - chi[joint_index(i, 1, "IA")]
        of = values[f"OF1R_{i}"] - chi[joint_index(i, 1, "OF")]
        g_z1 = float(desc.gravity @ _rail(desc, i - 1))
        assert g_z1 == pytest.approx(-9.81, rel=1e-12)
        assert ia > 0.5 * desc.leg_inertia[i - 1, :, 9].sum()  # the moving masses
        assert of == pytest.approx(-g_z1 * ia, rel=1e-12)
        assert f"IA2_{i}" not in values and f"IA3_{i}" not in values  # in ZZ2R, ZZ3R
        row = bp.K[bp.names.index(f"ZZ2R_{i}")]
        assert row[joint_index(i, 2, "IA")] == 1.0


def test_rus_armatures_group_where_the_axes_are_perpendicular():
    """RUS preset: the U-joint's first axis is parallel to the crank's (alpha2 = 0), so IA2
    is a base parameter of its own; the rod axis is perpendicular to both (alpha3 = pi/2),
    so IA3 groups into ZZ3R; IA1 groups into ZZ1R (a first revolute joint)."""
    bp = analytic_base_parameters(with_joint_terms(preset("rus")))
    for i in range(1, 7):
        assert f"IA2_{i}" in bp.names
        assert not {f"IA1_{i}", f"IA3_{i}", f"IA1R_{i}", f"IA3R_{i}"} & set(bp.names)
        for j in (1, 3):
            row = bp.K[bp.names.index(f"ZZ{j}R_{i}")]
            assert row[joint_index(i, j, "IA")] == 1.0
    assert len(bp.joint_terms) == 6 * 13  # IA2 and the 12 FV FC K OF per leg


def test_custom_legs_fall_back_to_the_numerical_set():
    desc = preset("random-pus-4")
    legs = [leg if k < 3 else leg.replace(name="custom") for k, leg in enumerate(desc.legs)]
    robot = StewartRobot(desc.replace(legs=tuple(legs)))
    with pytest.raises(UnsupportedArchitectureError, match=r"custom legs \[4, 5, 6\]"):
        analytic_base_parameters(robot.description)
    with pytest.warns(BaseParameterWarning, match="numerical base parameters"):
        bp = base_parameters(robot)
    numerical, report = numerical_base_parameters(robot)
    assert bp.names == numerical.names and len(bp) == report.rank == 148  # as random-pus-4


def test_an_axis_a_hair_off_parallel_is_flagged():
    """The U-joint's first axis 1e-7 rad off the rail: MX2, MY2 act (kept: 142) but their
    kinetic coupling is 1e-7 of the others', so the analytic set warns."""
    robot = pus_parallel(1e-7)
    with pytest.warns(BaseParameterWarning, match="within a hair"):
        bp = base_parameters(robot)
    assert len(bp) == 142


def test_numerical_base_set_of_general_legs():
    robot = StewartRobot.from_preset("rus")
    bp, report = numerical_base_parameters(robot, n_states=40)
    assert report.tolerance == GENERAL_RANK_TOLERANCE and report.n_standard == 280
    assert "of 280" in str(report)
    assert all(name.rstrip("*") in GENERAL_STANDARD_NAMES for name in bp.names)
    assert report.smallest_kept > 1e6 * report.largest_dropped
    rows = [line for line in bp.table().splitlines()[1:] if not line.startswith("  --")]
    assert len(rows) == len(bp)


@pytest.mark.parametrize("preset_name", ("rus", "simulator"))
def test_too_few_states_for_the_rank_are_refused(preset_name, capsys):
    """Two states give 12 rows: any 12 columns look independent, so a "rank 12" base set
    would be read off the sample size, not the robot (the true ranks are 160 and 88)."""
    from stewart_pin.cli import main

    robot = StewartRobot.from_preset(preset_name)
    with pytest.raises(InputError, match="limited by the number of states"):
        numerical_base_parameters(robot, n_states=2)
    argv = ["base-params", "--preset", preset_name, "--method", "numerical", "--states", "2"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "use more states" in err and err.count("\n") == 1


def test_bad_counts_and_thresholds_are_input_errors():
    robot = StewartRobot.from_preset("pus")
    for bad in (0, -3, True, 2.5, "60"):
        with pytest.raises(InputError, match="n_states"):
            numerical_base_parameters(robot, n_states=bad)
    for bad in (float("nan"), -1.0, 0.0, True):
        with pytest.raises(InputError, match="threshold"):
            essential_parameters(robot, threshold=bad)


def test_essential_parameters_of_a_general_robot():
    robot = StewartRobot.from_preset("pus")
    ess = essential_parameters(robot, threshold=1e-2, n_states=40)
    assert 0 < len(ess) < len(base_parameters(robot)) and ess.relative_error <= 1e-2


def test_cli_base_params_shows_the_joint_terms(capsys):
    from stewart_pin.cli import main

    assert main(["base-params", "--preset", "rus", "--states", "30"]) == 0
    out = capsys.readouterr().out
    assert "160 analytic base parameters of 280 standard" in out
    assert "joint terms" in out and "IA2_1" in out and "FV1_1" in out and "OF3_6" in out
    assert "numerical rank: rank 160 of 280" in out
