"""Chain legs (any 1-dof joints, ball or weld closure, every link massive, joint terms
on) against independent references: Pinocchio's constrained tree with 3D and 6D loop
constraints (exact KKT solves), central differences of the inverse geometry and of the
energy, and the robot's mobility rules."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot
from stewart_pin._so3 import so3_exp
from stewart_pin.architectures import ChainLegPath
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg import ChainLeg
from stewart_pin.description.chain_leg_presets import (
    UPPER_U_OFFSET,
    mixed_chain_robot,
    rss_robot,
    welded_joints,
    welded_ups,
)
from stewart_pin.description.leg_architecture import prismatic, revolute
from stewart_pin.exceptions import (
    ArchitectureError,
    InertiaError,
    InputError,
    LegMobilityError,
    UnsupportedArchitectureError,
)
from stewart_pin.kinematics import chain_legs

TOL = 1e-10  # relative agreement with the constrained tree


@pytest.fixture(scope="module", params=["welded", "mixed"])
def robot(request: pytest.FixtureRequest) -> StewartRobot:
    desc = welded_ups(seed=1) if request.param == "welded" else mixed_chain_robot(seed=2)
    return StewartRobot(desc)


@pytest.fixture(scope="module")
def states(robot: StewartRobot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return robot.sample_states(4, rng=7)


def _q_legs(robot: StewartRobot, T: np.ndarray) -> list[np.ndarray]:
    return chain_legs.inverse_geometry(robot.description, T[None], False)


def test_the_robots_are_what_the_issue_asks(robot: StewartRobot) -> None:
    legs = robot.description.chain_legs
    assert legs is not None and isinstance(robot._kind, ChainLegPath)
    welded = [leg for leg in legs if leg.closure == "weld"]
    assert welded and all(leg.n_joints == 6 for leg in welded)
    assert all(leg.n_joints == 3 for leg in legs if leg.closure == "ball")
    for leg in legs:  # every link massive, every joint with its terms
        assert np.all(leg.inertia[:, 9] > 0)
        assert all(not j.dynamics.is_zero and j.dynamics.coulomb > 0 for j in leg.joints)
    for leg in welded:  # the upper U-joint's axes miss each other by 0.5 mm
        assert leg.joints[5].d == UPPER_U_OFFSET and leg.joints[5].alpha == math.pi / 2


def test_leg_rates_and_accelerations_match_central_differences(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, A = (x[:2] for x in states)
    q, qd, qdd = robot.leg_kinematics(T, V, A)
    h = 1e-4

    def pose_at(t: float) -> np.ndarray:
        out = T.copy()
        out[:, :3, 3] += V[:, :3] * t + 0.5 * A[:, :3] * t * t
        out[:, :3, :3] = so3_exp(V[:, 3:] * t + 0.5 * A[:, 3:] * t * t) @ T[:, :3, :3]
        return out

    qp, qm = robot.inverse_geometry(pose_at(h)), robot.inverse_geometry(pose_at(-h))
    fd = (qp - qm) / (2 * h)
    fdd = (qp - 2 * q + qm) / h**2
    assert np.allclose(fd, qd, atol=1e-7)
    assert np.allclose(fdd, qdd, atol=1e-5)


def test_inverse_dynamics_matches_the_constrained_tree(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, A = states
    gamma = robot.inverse_dynamics(T, V, A)
    tree = ChainTreeSolver(robot.description)
    for n in range(T.shape[0]):
        ref = tree.inverse_one(T[n], V[n], A[n], [q[0] for q in _q_legs(robot, T[n])])
        assert np.abs(gamma[n] - ref).max() <= TOL * np.abs(ref).max()


def test_direct_dynamics_matches_pinocchio_constraint_dynamics(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, _ = states
    rng = np.random.default_rng(3)
    tree = ChainTreeSolver(robot.description)
    g0 = robot.inverse_dynamics(T, V, np.zeros_like(V))
    gammas = g0 + rng.normal(size=g0.shape) * np.abs(g0).mean() * 0.2
    acc = robot.direct_dynamics(T, V, gammas)
    for n in range(T.shape[0]):
        ref = tree.forward_one(T[n], V[n], gammas[n], [q[0] for q in _q_legs(robot, T[n])])
        assert np.abs(acc[n] - ref).max() <= TOL * np.abs(ref).max()


def test_direct_dynamics_inverts_the_inverse_dynamics(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, A = states
    back = robot.direct_dynamics(T, V, robot.inverse_dynamics(T, V, A))
    assert np.abs(back - A).max() <= TOL * np.abs(A).max()


def test_energy_matches_the_tree_and_balances_the_power(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T, V, A = (x[0] for x in states)
    tree = ChainTreeSolver(robot.description)
    k, u = tree.energy_one(T, V, [q[0] for q in _q_legs(robot, T)])
    assert abs(robot.energy(T, V) - (k + u)) <= 1e-12 * (abs(k) + abs(u))
    # dE/dt = Gamma . qdot_a - dissipated power, E by central differences along the motion
    h = 1e-5

    def energy_at(t: float) -> float:
        Tt = T.copy()
        Tt[:3, 3] += V[:3] * t + 0.5 * A[:3] * t * t
        Tt[:3, :3] = pin.exp3(V[3:] * t + 0.5 * A[3:] * t * t) @ T[:3, :3]
        return float(robot.energy(Tt, V + A * t))

    dE = (energy_at(h) - energy_at(-h)) / (2 * h)
    power = robot.inverse_dynamics(T, V, A) @ (robot.inverse_jacobian(T) @ V)
    loss = robot.dissipated_power(T, V)
    assert abs(dE - (power - loss)) <= 1e-6 * (abs(power) + abs(loss))


def test_simulation_keeps_the_energy_balance() -> None:
    from stewart_pin.motion.simulation import simulate

    # without joint terms: the power is smooth (Coulomb's sign switches would make
    # Simpson's rule first order); test_energy_matches... covers the joint terms
    r = StewartRobot(welded_ups(seed=3, joint_terms=False))
    g0 = r.inverse_dynamics(r.description.home_pose, np.zeros(6), np.zeros(6))
    wave = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
    res = simulate(r, 0.04, forces=lambda t, T, V: g0 + 20 * math.sin(40 * t) * wave, dt=0.001)
    E = r.energy(res.poses, res.twists)
    p_in = np.einsum("ni,nij,nj->n", res.gammas, r.inverse_jacobian(res.poses), res.twists)
    net = p_in - r.dissipated_power(res.poses, res.twists)
    assert len(res.t) == 41 and np.allclose(np.diff(res.t), 0.001)
    work = 0.001 / 3 * (net[0] + 4 * net[1:-1:2].sum() + 2 * net[2:-1:2].sum() + net[-1])
    assert abs(E[-1] - E[0] - work) <= 1e-6 * np.abs(net).sum() * 0.001


def test_forward_geometry_returns_the_pose(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    T = states[0][1]
    found = robot.forward_geometry(robot.actuator_positions(T))
    assert np.abs(found - T).max() <= 1e-10


def test_a_full_turn_hinge_limits_nothing() -> None:
    r = StewartRobot(welded_ups(seed=1, spin=-0.3))  # the spin's range is [0, 2 pi]
    q = r.inverse_geometry(r.description.home_pose)
    assert np.allclose(q[:, 3], 2 * math.pi - 0.3)


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_description_files_round_trip(tmp_path: Path, suffix: str) -> None:
    from stewart_pin.description import RobotDescription

    for desc in (mixed_chain_robot(seed=2), rss_robot(symmetric=False)):
        back = RobotDescription.read(desc.write(tmp_path / f"robot{suffix}"))
        assert back.to_dict() == desc.to_dict()
        for a, b in zip(back.chain_legs or (), desc.chain_legs or (), strict=True):
            assert (a.closure, a.idle_joint, a.joints) == (b.closure, b.idle_joint, b.joints)
            for key in ("inertia", "tip", "tip_rotation", "platform_rotation", "guess"):
                assert np.array_equal(getattr(a, key), getattr(b, key))
    with pytest.raises(ArchitectureError, match="chain leg 2: keys: missing"):
        d = desc.to_dict()
        del d["chain_legs"][1]["closure"]
        RobotDescription.from_dict(d)


def test_the_limit_margin_skips_full_turn_hinges() -> None:
    r = StewartRobot(welded_ups(seed=1, joint_terms=False))
    margin, sentence = r.limit_margin(r.description.home_pose)
    q = r.inverse_geometry(r.description.home_pose)
    nearest = min(min(q[k, 2] - 0.2, 2.0 - q[k, 2]) for k in range(6))
    assert margin == pytest.approx(nearest / r.description.stroke_mid, rel=1e-12)
    assert "joint 3" in sentence  # the slide: the spin's full turn limits nothing


def _with_leg(desc, k: int, leg: ChainLeg):  # type: ignore[no-untyped-def]
    legs = list(desc.chain_legs)
    legs[k] = leg
    return desc.replace(chain_legs=tuple(legs))


@pytest.mark.parametrize(
    ("closure", "n", "words"),
    [
        ("weld", 5, "1 freedom(s) short"),
        ("ball", 4, "idle freedom"),
        ("ball", 5, "2 extra freedoms"),
    ],
)
def test_a_leg_without_six_freedoms_is_refused(closure: str, n: int, words: str) -> None:
    desc = welded_ups(seed=1, joint_terms=False)
    joints = welded_joints(np.random.default_rng(0), UPPER_U_OFFSET, False)[:n]
    leg = ChainLeg(joints, 3, closure, np.tile([0, 0, 0, 0, 0, 0, 0, 0, 0, 0.1], (n, 1)))
    with pytest.raises(LegMobilityError, match=f"leg 3: .*{re.escape(words)}") as e:
        _with_leg(desc, 2, leg)
    assert e.value.leg == 3


def test_a_leg_singular_at_home_is_refused() -> None:
    with pytest.raises(LegMobilityError, match=r"leg 1: .*rank of J_1 5 < 6") as e:
        StewartRobot(welded_ups(seed=1, offset=0.0, wrist=0.0))
    assert e.value.missing == 1


def test_description_rules() -> None:
    desc = welded_ups(seed=1, joint_terms=False)
    with pytest.raises(InertiaError, match="leg_inertia must be zeros"):
        desc.replace(leg_inertia=np.full((6, 3, 10), 0.0) + np.eye(10)[9])
    with pytest.raises(ArchitectureError, match="closure must be one of"):
        ChainLeg((revolute(),) * 3, 1, "glue", np.zeros((3, 10)))
    with pytest.raises(ArchitectureError, match=r"inertia"):
        ChainLeg((revolute(), revolute(), prismatic()), 1, "ball", np.zeros((2, 10)))


def test_what_takes_three_joint_legs_refuses_chain_legs_clearly(tmp_path: Path) -> None:
    r = StewartRobot(welded_ups(seed=1, joint_terms=False))
    assert "stewart_chain.urdf.xacro" in r.write_xacro_args(tmp_path / "robot.yaml").read_text()
    assert "<weld" in r.write_mjcf(tmp_path / "robot.xml").read_text()  # the MJCF is written
    spin = StewartRobot(rss_robot())  # idle joints: every backend needs the spin state
    H, zero = spin.description.home_pose, np.zeros(6)
    with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
        spin.inverse_dynamics(H, zero, zero, backend="compiled")
    with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
        spin.inverse_dynamics_derivatives(H, zero, zero)


# ---------------------------------------------------------------------------- idle spin
@pytest.fixture(scope="module", params=[True, False], ids=["symmetric-rods", "asymmetric-rods"])
def rss(request: pytest.FixtureRequest) -> StewartRobot:
    return StewartRobot(rss_robot(symmetric=request.param))


def _idle_state(n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(11)
    return rng.uniform(-1.0, 1.0, (n, 6)), rng.uniform(-5.0, 5.0, (n, 6))


def test_rss_inverse_dynamics_and_spin_accelerations_match_the_tree(rss: StewartRobot) -> None:
    T, V, A = rss.sample_states(3, rng=2)
    spin, rate = _idle_state(3)
    res = rss.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    qs = chain_legs.inverse_geometry(rss.description, T, False, spin)
    tree = ChainTreeSolver(rss.description)
    for n in range(3):
        q = [x[n] for x in qs]
        gamma, sigma = tree.inverse_idle_one(T[n], V[n], A[n], q, rate[n])
        assert np.abs(res.gamma[n] - gamma).max() <= TOL * np.abs(gamma).max()
        assert np.abs(res.idle_accel[n] - sigma).max() <= TOL * np.abs(sigma).max()
        # the spin angle is the idle joint's value
        assert np.allclose([x[3] for x in q], spin[n])


def test_rss_direct_dynamics_returns_the_spin_accelerations_of_the_tree(
    rss: StewartRobot,
) -> None:
    T, V, A = rss.sample_states(3, rng=3)
    spin, rate = _idle_state(3)
    gammas = rss.chain_dynamics.inverse_dynamics(T, V, A, idle=(spin, rate))
    gammas = gammas * np.random.default_rng(0).uniform(0.5, 1.5, gammas.shape)
    acc, sigma = rss.chain_dynamics.direct_dynamics_idle(T, V, gammas, idle=(spin, rate))
    # the tree at the legs' configuration the model used (cartesian_dynamics' legs): this
    # desktop robot's leg loops fix its joint values to ~5e-14 rad only (two solves from
    # different continuation starts, both closing the loops to 2e-15 of its size, differ
    # that much), and its accelerations, a small difference of near-cancelling gravity
    # load and efforts (cond(A_robot) ~ 700), move by up to 1e-10 relative between them;
    # at the same configuration the two agree to 7e-13 (30 states, 3 seeds)
    legs = rss.chain_dynamics.cartesian_dynamics(T, V, idle=(spin, rate)).legs
    tree = ChainTreeSolver(rss.description)
    for n in range(3):
        q = [s.q[n] for s in legs]
        ref, ref_sigma = tree.forward_idle_one(T[n], V[n], gammas[n], q, rate[n])
        assert np.abs(acc[n] - ref).max() <= TOL * np.abs(ref).max()
        assert np.abs(sigma[n] - ref_sigma).max() <= TOL * np.abs(ref_sigma).max()


def test_the_spin_state_is_required_not_assumed(rss: StewartRobot) -> None:
    H, zero = rss.description.home_pose, np.zeros(6)
    for model in (rss.inverse_dynamics, rss.direct_dynamics):
        with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4"):
            model(H, zero, zero)
    with pytest.raises(InputError, match="idle freedoms"):
        rss.energy(H, zero)
    from stewart_pin.exceptions import SimulationError
    from stewart_pin.motion.simulation import simulate

    with pytest.raises(SimulationError, match=r"idle freedoms.*simulate_idle"):
        simulate(rss, 0.01)
    # the spin's rate matters: the rods' inertia couples it (gyroscopic terms)
    g0 = rss.chain_dynamics.inverse_dynamics(H, zero, zero, idle=(zero, zero))
    g1 = rss.chain_dynamics.inverse_dynamics(H, zero, zero, idle=(zero, np.full(6, 20.0)))
    assert np.abs(g1 - g0).max() > 1e-6 * np.abs(g0).max()


def test_an_idle_joint_must_move_the_idle_freedom() -> None:
    desc = rss_robot()
    legs = list(desc.chain_legs)
    legs[1] = legs[1].replace(idle_joint=2)  # the U-joint's first axis: not the spin
    with pytest.raises(LegMobilityError, match=r"leg 2: joint 2 \(idle_joint\) does not move"):
        StewartRobot(desc.replace(chain_legs=tuple(legs)))
    with pytest.raises(ArchitectureError, match="cannot be the actuated joint"):
        legs[1].replace(idle_joint=1)
    welded = welded_ups(seed=1, joint_terms=False).chain_legs[0]
    with pytest.raises(LegMobilityError, match="has none"):
        _with_leg(welded_ups(seed=1, joint_terms=False), 0, welded.replace(idle_joint=4))


def test_simulating_the_spins_keeps_the_energy_balance() -> None:
    from stewart_pin.motion.idle_simulation import simulate_idle

    r = StewartRobot(rss_robot(symmetric=False, joint_terms=False))  # smooth power
    dyn = r.chain_dynamics
    H, zero = r.description.home_pose, np.zeros(6)
    s0 = chain_legs.idle_home(r.description)
    v0 = np.random.default_rng(0).uniform(-8.0, 8.0, 6)
    g0 = dyn.inverse_dynamics(H, zero, zero, idle=(s0, zero))
    wave = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0]) * 0.3 * np.abs(g0).max()
    res = simulate_idle(
        r, 0.02, idle=(s0, v0), forces=lambda t, T, V: g0 + math.sin(60 * t) * wave, dt=0.001
    )
    assert len(res.t) == 21 and np.abs(res.idle_v[-1] - v0).max() > 0.1  # the spins move
    E = [
        sum(dyn.energy(T, V, idle=(q, v)))
        for T, V, q, v in zip(res.poses, res.twists, res.idle_q, res.idle_v, strict=True)
    ]
    _, J_inv = dyn.states(
        res.poses, res.twists, None, chain_legs.IdleState(res.idle_q, res.idle_v)
    )
    p = np.einsum("ni,nij,nj->n", res.gammas, J_inv, res.twists)
    work = 0.001 / 3 * (p[0] + 4 * p[1:-1:2].sum() + 2 * p[2:-1:2].sum() + p[-1])
    assert abs(E[-1] - E[0] - work) <= 1e-6 * np.abs(p).sum() * 0.001


def test_the_regressor_matches_the_tree_and_gives_the_inverse_model(
    robot: StewartRobot, states: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> None:
    from stewart_pin.dynamics.chain_leg_dynamics import chain_parameters

    T, V, A = (x[:2] for x in states)
    W = robot.regressor(T, V, A)
    chi, names = chain_parameters(robot.description)
    assert W.shape == (2, 6, len(chi)) == (2, 6, len(names))
    gamma = robot.inverse_dynamics(T, V, A)
    assert np.abs(W @ chi - gamma).max() <= TOL * np.abs(gamma).max()
    tree = ChainTreeSolver(robot.description)
    for n in range(2):
        ref = tree.regressor_one(T[n], V[n], A[n], [q[0] for q in _q_legs(robot, T[n])])
        assert np.abs(W[n] - ref).max() <= TOL * np.abs(ref).max()


def test_legs_with_idle_joints_need_the_spin_state_for_their_regressor() -> None:
    r = StewartRobot(rss_robot())
    with pytest.raises(InputError, match=r"idle=\(values, rates, accelerations\)"):
        r.regressor(r.description.home_pose, np.zeros(6), np.zeros(6))


def test_numerical_base_parameters_predict_the_efforts() -> None:
    import warnings

    from stewart_pin.exceptions import BaseParameterWarning
    from stewart_pin.parameters import base_parameters

    r = StewartRobot(mixed_chain_robot(seed=2))
    with pytest.warns(BaseParameterWarning, match="no rules for chain legs"):
        bp = base_parameters(r)  # analytic asked: the numerical set, said so
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BaseParameterWarning)
        assert bp.names == base_parameters(r, "numerical").names
    assert (
        0 < len(bp.names) < len(r.regressor(r.description.home_pose, np.zeros(6), np.zeros(6))[0])
    )
    T, V, A = r.sample_states(4, rng=9)
    W = r.regressor(T, V, A).reshape(-1, bp.K.shape[1])
    gamma = r.inverse_dynamics(T, V, A).ravel()
    assert np.abs(bp.reduce(W) @ bp.values - gamma).max() <= TOL * np.abs(gamma).max()


def test_the_command_line_reads_chain_legs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from stewart_pin.cli import main

    path = mixed_chain_robot(seed=2).write(tmp_path / "chain.toml")
    assert main(["ik", "--description", str(path)]) == 0
    out = capsys.readouterr().out
    assert "chain legs" in out and "q6" in out
    q = StewartRobot.from_file(path).inverse_geometry(mixed_chain_robot(seed=2).home_pose)
    assert f"{q[1, 5]:12.6f}" in out  # a welded leg's sixth joint
    assert main(["urdf", "--description", str(path), "-o", str(tmp_path / "r.urdf")]) == 0
    assert (tmp_path / "r.closures.json").exists()
    assert main(["validate", "--description", str(path), "--states", "3"]) == 0
    assert "PASSED" in capsys.readouterr().out


def test_validate_takes_chain_legs() -> None:
    from stewart_pin.check.constrained_dynamics import validate

    report = validate(StewartRobot(mixed_chain_robot(seed=5)), n_states=6, seed=1)
    assert report.n_states == 6 and report.passed(1e-10, 1e-10)
    assert max(report.idm_error, report.ddm_error, report.round_trip_error) <= 1e-10


def test_identification_recovers_the_base_parameters() -> None:
    import warnings

    from stewart_pin.dynamics.regressor import (
        parameter_groups,
        standard_parameters,
        with_standard_parameters,
    )
    from stewart_pin.exceptions import BaseParameterWarning
    from stewart_pin.parameters import base_parameters, identify
    from stewart_pin.parameters.identification import Measurements

    r = StewartRobot(mixed_chain_robot(seed=2))
    desc = r.description
    chi = standard_parameters(desc)
    groups = parameter_groups(desc)
    assert len(groups.bodies) == 3 * 3 + 3 * 6 + 1 and len(groups.joints) == 27
    assert groups.joints[3].name == "leg 2 joint 1" and groups.joints[5].actuated
    # a changed vector makes a changed robot, whose forces the regressor predicts
    chi2 = chi.copy()
    chi2[groups.joints[0].viscous] *= 3.0
    chi2[groups.bodies[-1].index.stop - 1] *= 1.5  # the platform's mass
    other = StewartRobot(with_standard_parameters(desc, chi2))
    assert np.array_equal(standard_parameters(other.description), chi2)
    T, V, A = r.sample_states(70, rng=4)
    assert np.allclose(
        r.regressor(T[:3], V[:3], A[:3]) @ chi2, other.inverse_dynamics(T[:3], V[:3], A[:3])
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BaseParameterWarning)
        base = base_parameters(r, "numerical")
    times = 0.01 * np.arange(70)
    result = identify(r, Measurements(times, T, V, A, r.inverse_dynamics(T, V, A)), base, False)
    assert np.abs(result.estimate - base.values).max() <= 1e-9 * np.abs(base.values).max()


def test_the_urdf_and_its_sidecar_are_the_checked_tree(tmp_path: Path) -> None:
    import json

    desc = mixed_chain_robot(seed=2)
    urdf, sidecar = StewartRobot(desc).write_urdf(tmp_path / "chain.urdf")
    model = pin.buildModelFromXML(urdf.read_text())
    ref = ChainTreeSolver(desc).model
    assert (model.nq, model.nv) == (ref.nq, ref.nv) == (7 + 27, 6 + 27)
    for name in [n for n in ref.names[1:] if n != "platform"]:
        k, j = name[1:].split("j")
        mine, theirs = model.getJointId(f"leg{k}_q{j}"), ref.getJointId(name)
        assert model.joints[mine].shortname() == ref.joints[theirs].shortname()
        M1, M2 = model.jointPlacements[mine], ref.jointPlacements[theirs]
        assert M1.isApprox(M2, 1e-12)
        p1 = model.inertias[mine].toDynamicParameters()
        assert np.allclose(p1, ref.inertias[theirs].toDynamicParameters(), rtol=1e-12, atol=1e-15)
    data = json.loads(sidecar.read_text())
    kinds = [c["type"] for c in data["closures"]]
    assert kinds == ["point", "frame"] * 3
    for leg, c, P in zip(
        desc.chain_legs or (), data["closures"], desc.platform_points, strict=True
    ):
        if c["type"] == "frame":
            assert np.allclose(pin.rpy.rpyToMatrix(np.array(c["frame1"]["rpy"])), leg.tip_rotation)
            assert np.allclose(
                pin.rpy.rpyToMatrix(np.array(c["frame2"]["rpy"])), leg.platform_rotation
            )
            assert np.allclose(c["frame2"]["xyz"], P)
        else:
            assert np.allclose(c["point2"], P)
    terms = data["joint_terms"]
    assert (
        len(terms) == 27
        and terms["leg2_q6"]["armature"] == desc.chain_legs[1].joints[5].dynamics.total_armature
    )
    # the importer and the Pinocchio loader read point closures only: a clear refusal
    from stewart_pin.exceptions import FileFormatError
    from stewart_pin.formats.urdf import read_sidecar

    with pytest.raises(FileFormatError, match="type 'frame', not 'point'"):
        read_sidecar(sidecar)


def test_chain_models_of_a_robot_without_chain_legs_name_what_they_need() -> None:
    """The chain-leg models and the idle simulation asked of a robot of three-joint legs
    (the ideal 6-UPS): the project's error naming the chain legs, not an assertion."""
    from stewart_pin.motion.idle_simulation import simulate_idle

    robot = StewartRobot.from_preset("simulator")
    H, zero = robot.home_pose, np.zeros(6)
    with pytest.raises(UnsupportedArchitectureError, match="no chain legs") as info:
        robot.chain_dynamics.inverse_dynamics(H, zero, zero)
    assert info.value.field == "chain_legs"
    with pytest.raises(UnsupportedArchitectureError, match="no chain legs"):
        simulate_idle(robot, 0.01)


def test_an_idle_state_given_to_a_robot_without_idle_joints_is_refused() -> None:
    """``idle=(values, rates)`` to a chain-leg robot without idle joints would be ignored:
    every model refuses it (the project's error), and the idle simulation too; without it
    the simulation runs, at rest, its idle entries 0."""
    from stewart_pin.motion.idle_simulation import simulate_idle

    robot = StewartRobot(welded_ups(seed=1))
    dyn = robot.chain_dynamics
    assert not dyn.idle_legs
    H, zero = robot.home_pose, np.zeros(6)
    for call in (
        lambda: dyn.inverse_dynamics(H, zero, zero, idle=(zero, zero)),
        lambda: dyn.direct_dynamics_idle(H, zero, zero, idle=(zero, zero)),
        lambda: dyn.energy(H, zero, idle=(zero, zero)),
    ):
        with pytest.raises(InputError, match="no idle joints"):
            call()
    with pytest.raises(InputError, match="no idle joints"):
        simulate_idle(robot, 0.002, idle=(zero, zero))
    res = simulate_idle(robot, 0.002)
    assert np.all(res.idle_q == 0.0) and np.all(res.idle_v == 0.0)


def test_the_tree_check_builds_its_placements_and_inertias_itself(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The check shares no algebra with the code it checks: with ``Joint.placement``,
    ``Joint.transform`` and ``pin_inertia_from_khalil`` broken, it builds the same tree
    (its IDM equals the robot's, computed before)."""
    import stewart_pin.check.chain_legs_tree as check
    import stewart_pin.description.inertia as inertia
    from stewart_pin.description.leg_architecture import Joint

    robot = StewartRobot(mixed_chain_robot(seed=2))
    T, V, A = robot.sample_states(2, rng=3)
    gamma = robot.inverse_dynamics(T, V, A)
    q_legs = [[q[0] for q in _q_legs(robot, T[n])] for n in range(2)]

    def broken(*args: object) -> None:
        raise AssertionError("the check used the code it checks")

    monkeypatch.setattr(Joint, "placement", broken)
    monkeypatch.setattr(Joint, "transform", broken)
    monkeypatch.setattr(inertia, "pin_inertia_from_khalil", broken)
    monkeypatch.setattr(check, "pin_inertia_from_khalil", broken, raising=False)
    tree = ChainTreeSolver(robot.description)
    for n in range(2):
        ref = tree.inverse_one(T[n], V[n], A[n], q_legs[n])
        assert np.abs(gamma[n] - ref).max() <= TOL * np.abs(ref).max()


@pytest.mark.parametrize("make", [welded_ups, mixed_chain_robot, rss_robot])
def test_a_pose_solves_the_same_alone_and_in_any_batch(make) -> None:
    """Each pose's continuation from home takes its own number of sub-steps: its legs'
    joint values and ``reached`` are bit-identical whether it is solved alone or with
    poses farther from home (which need more sub-steps) in its batch."""
    desc = make()
    size = chain_legs.robot_size(desc)
    rng = np.random.default_rng(3)
    T = np.tile(desc.home_pose, (60, 1, 1))
    T[:, :3, 3] += rng.uniform(-0.3 * size, 0.3 * size, (60, 3))
    T[:, :3, :3] = so3_exp(rng.uniform(-0.6, 0.6, (60, 3))) @ desc.home_pose[:3, :3]
    # sub-steps from home (module constants): a fraction of the size, an angle
    H = desc.home_pose
    dp = np.linalg.norm(T[:, :3, 3] - H[:3, 3], axis=1) / size
    da = np.array([np.linalg.norm(pin.log3(R @ H[:3, :3].T)) for R in T[:, :3, :3]])
    ratio = np.maximum(
        dp / chain_legs.CONTINUATION_TRANSLATION, da / chain_legs.CONTINUATION_ROTATION
    )
    steps = np.maximum(np.ceil(ratio), 1)
    assert steps.min() < steps.max()  # the batch mixes poses of different counts
    chain_legs._LAST.pop(desc, None)  # the continuation from the home pose in every call
    qs, reached = chain_legs.solve_legs(desc, T)
    for n in np.flatnonzero(steps < steps.max()):
        chain_legs._LAST.pop(desc, None)
        q1, r1 = chain_legs.solve_legs(desc, T[n : n + 1])
        np.testing.assert_array_equal(r1[0], reached[n])
        for k in range(6):
            np.testing.assert_array_equal(q1[k][0], qs[k][n])
    chain_legs._LAST.pop(desc, None)
