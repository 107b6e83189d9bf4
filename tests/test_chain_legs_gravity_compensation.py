"""Per-body gravity compensation of chain legs (issue 21, item 5): each
:class:`~stewart_pin.description.chain_leg.ChainLeg`'s ``gravcomp`` (one factor per link,
the fraction of its weight removed: its weight is ``(1 - c) m g`` at its centre of mass)
and the platform's ``platform_gravcomp``, in every model of the chain-leg path.

Independent references:

- Pinocchio's constrained tree (:class:`~stewart_pin.check.chain_legs_tree.ChainTreeSolver`,
  which shares no algebra with the dynamics), the compensating forces ``-c m g`` at the
  centres of mass as external forces: IDM, DDM, energy; the regressor as ``W chi`` against
  the tree's IDM;
- MuJoCo's exact KKT solve (``helpers.mujoco_kkt``; MuJoCo applies ``gravcomp`` as a
  passive force) on the MJCF written for the robot;
- analytic: compensation 1 on every body is the robot without gravity.

The imported community MJCF with ``gravcomp`` on some bodies: ``test_import_chain_legs``.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from conftest import use_compile_cache
from helpers import rel_error

from stewart_pin import FileFormatError, GravityCompensationError, RobotDescription, StewartRobot
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, welded_ups
from stewart_pin.description.leg_architecture import JointDynamics
from stewart_pin.dynamics.chain_leg_dynamics import chain_parameters
from stewart_pin.exceptions import InputError
from stewart_pin.importers import import_mjcf
from stewart_pin.kinematics import chain_legs

TOL = 1e-10  # relative: the references are exact solves on the same model

PRESETS = {"welded": lambda: welded_ups(seed=1), "mixed": lambda: mixed_chain_robot(seed=2)}


def _compensated(desc: RobotDescription, seed: int = 0) -> RobotDescription:
    """Compensations on some links of some legs (one leg without, one link weightless)
    and on the platform."""
    rng = np.random.default_rng(seed)
    legs = []
    for k, leg in enumerate(desc.chain_legs):
        c = rng.uniform(0.0, 1.0, leg.n_joints) * (rng.uniform(size=leg.n_joints) < 0.6)
        if k == 0:
            c[:] = 0.0
        if k == 1:
            c[-1] = 1.0
        legs.append(leg.replace(gravcomp=c))
    out = desc.replace(chain_legs=tuple(legs), platform_gravcomp=0.4)
    assert sum(np.count_nonzero(leg.gravcomp) for leg in out.chain_legs) >= 6
    return out


def _q_legs(desc: RobotDescription, T: np.ndarray) -> list[np.ndarray]:
    return [q[0] for q in chain_legs.inverse_geometry(desc, T[None], False)]


# ---------------------------------------------------------------------- the description
def test_chain_leg_gravcomp_is_validated_and_round_trips(tmp_path) -> None:
    d = welded_ups(seed=1)
    c = _compensated(d)
    assert c.has_gravcomp and c.legs is None and c.chain_legs is not None
    for suffix in (".toml", ".json"):
        back = RobotDescription.read(c.write(tmp_path / f"r{suffix}"))
        assert back.to_dict() == c.to_dict()  # exact: floats by repr
        for a, b in zip(back.chain_legs, c.chain_legs, strict=True):
            np.testing.assert_array_equal(a.gravcomp, b.gravcomp)
        assert back.platform_gravcomp == 0.4
    # absent when zero: the files of robots without it are unchanged
    text = d.write(tmp_path / "a.toml").read_text()
    assert "gravcomp" not in text
    zero = d.replace(chain_legs=tuple(leg.replace(gravcomp=np.zeros(6)) for leg in d.chain_legs))
    assert zero.write(tmp_path / "b.toml").read_text() == text
    leg = d.chain_legs[0]
    bad = [
        ([0.0] * 5, "gravcomp must be 6 factors"),
        ("half", "gravcomp must be 6 factors"),
        ([0.0, 1.5, 0, 0, 0, 0], r"chain leg link 2 must be in \[0, 1\].*got 1.5"),
        ([0.0, -0.1, 0, 0, 0, 0], "chain leg link 2 must be in"),
        ([0.0, 0, float("nan"), 0, 0, 0], "chain leg link 3 must be in"),
        ([0.0, 0, 0, True, 0, 0], "chain leg link 4 must be a number"),
    ]
    for value, message in bad:
        with pytest.raises(GravityCompensationError, match=message):
            leg.replace(gravcomp=value)
    # the three-joint key is refused beside chain legs (each leg carries its own)
    with pytest.raises(GravityCompensationError, match="each link's gravity compensation is"):
        d.replace(leg_gravcomp=np.full((6, 3), 0.5))
    # in a file: the leg and the link named
    d_file = json.loads(c.write(tmp_path / "c.json").read_text())
    d_file["chain_legs"][1]["gravcomp"][5] = 3.0
    (tmp_path / "d.json").write_text(json.dumps(d_file))
    with pytest.raises(FileFormatError, match=r"chain leg 2: .* chain leg link 6 must be in") as e:
        RobotDescription.read(tmp_path / "d.json")
    assert isinstance(e.value.__cause__, GravityCompensationError)
    assert e.value.__cause__.body == "chain leg 2 link 6"


# ---------------------------------------------------------------------- every model
@pytest.mark.parametrize("name", list(PRESETS))
def test_models_equal_the_constrained_tree_with_compensating_forces(name: str) -> None:
    """IDM, DDM, energy and the regressor against the tree with the forces ``-c m g``."""
    desc = _compensated(PRESETS[name]())
    robot = StewartRobot(desc)
    T, V, A = robot.sample_states(3, rng=7)
    gamma = robot.inverse_dynamics(T, V, A)
    uncompensated = StewartRobot(PRESETS[name]()).inverse_dynamics(T, V, A)
    accel = robot.direct_dynamics(T, V, gamma)
    tree = ChainTreeSolver(desc)
    assert len(tree.compensated) == 1 + sum(np.count_nonzero(x.gravcomp) for x in desc.chain_legs)
    W = robot.regressor(T, V, A)
    chi, _ = chain_parameters(desc)
    for n in range(len(T)):
        q = _q_legs(desc, T[n])
        ref = tree.inverse_one(T[n], V[n], A[n], q)
        assert rel_error(gamma[n], ref) < TOL, f"IDM {rel_error(gamma[n], ref):.2e}"
        assert rel_error(uncompensated[n], ref) > 1e-2  # the compensation matters
        acc_ref = tree.forward_one(T[n], V[n], ref, q)
        assert rel_error(accel[n], acc_ref) < TOL, f"DDM {rel_error(accel[n], acc_ref):.2e}"
        assert rel_error(W[n] @ chi, ref) < TOL
        k, u = tree.energy_one(T[n], V[n], q)
        assert abs(robot.energy(T[n], V[n]) - (k + u)) <= 1e-12 * (abs(k) + abs(u))
    with pytest.raises(InputError, match="no per-body gravity compensation"):
        tree.regressor_one(T[0], V[0], A[0], _q_legs(desc, T[0]))


def test_power_balance_with_compensation() -> None:
    """``Gamma . qdot_a = dE/dt + dissipated``, E with the compensated weights' potential,
    along an exact SE(3) motion (constant twist-rate about a fixed axis; central
    differences)."""
    desc = _compensated(mixed_chain_robot(seed=2), seed=5)
    robot = StewartRobot(desc)
    T, V, A = (x[0] for x in robot.sample_states(1, rng=2))
    A = np.r_[A[:3], np.zeros(3)]  # a constant angular velocity: the exponential exact

    def energy_at(t: float) -> float:
        Tt = T.copy()
        Tt[:3, 3] += V[:3] * t + 0.5 * A[:3] * t * t
        Tt[:3, :3] = pin.exp3(V[3:] * t) @ T[:3, :3]
        return float(robot.energy(Tt, V + A * t))

    h = 1e-5
    dE = (energy_at(h) - energy_at(-h)) / (2 * h)
    power = robot.inverse_dynamics(T, V, A) @ (robot.inverse_jacobian(T) @ V)
    loss = robot.dissipated_power(T, V)
    assert abs(dE - (power - loss)) <= 1e-6 * (abs(power) + abs(loss) + abs(dE))


def test_compensation_one_on_every_body_is_the_robot_without_gravity() -> None:
    """Analytic: every weight removed = no gravity (springs and joint terms kept); without
    springs the efforts holding it still are zero."""
    d = mixed_chain_robot(seed=2)
    full = d.replace(
        chain_legs=tuple(leg.replace(gravcomp=np.ones(leg.n_joints)) for leg in d.chain_legs),
        platform_gravcomp=1.0,
    )
    robot, free = StewartRobot(full), StewartRobot(d.replace(gravity=np.zeros(3)))
    T, V, A = free.sample_states(3, rng=3)
    assert rel_error(robot.inverse_dynamics(T, V, A), free.inverse_dynamics(T, V, A)) < TOL
    assert rel_error(robot.gravity_compensation(T), free.gravity_compensation(T)) < TOL
    e, e_free = robot.energy(T, V), free.energy(T, V)
    np.testing.assert_allclose(e, e_free, rtol=1e-12, atol=1e-12 * np.abs(e_free).max())
    stiff = [x.dynamics.stiffness for leg in d.chain_legs for x in leg.joints]
    assert max(stiff) > 0.0  # the springs hold it otherwise
    no_springs = StewartRobot(
        full.replace(
            chain_legs=tuple(
                leg.replace(joints=tuple(replace(j, dynamics=JointDynamics()) for j in leg.joints))
                for leg in full.chain_legs
            )
        )
    )
    assert np.abs(no_springs.gravity_compensation(T)).max() < 1e-12 * 9.81


# ---------------------------------------------------------------------- MJCF
@pytest.mark.parametrize("name", list(PRESETS))
def test_mjcf_written_with_gravcomp_matches_mujoco_kkt_and_reads_back(name: str) -> None:
    pytest.importorskip("mujoco", reason="MuJoCo is optional: pip install mujoco")
    from test_import_chain_legs import matches_mujoco_kkt

    desc = _compensated(PRESETS[name](), seed=4)
    robot = StewartRobot(desc)
    xml = robot.mjcf()
    assert xml.count("gravcomp=") == 1 + sum(np.count_nonzero(x.gravcomp) for x in desc.chain_legs)
    assert re.search(r'<body name="platform"[^>]* gravcomp="0.4"', xml)
    matches_mujoco_kkt(xml, robot, *robot.sample_states(3, rng=5))
    # read back: the same factors on the same links (the legs in the actuators' order)
    result = import_mjcf(xml)
    back = result.description
    assert back.platform_gravcomp == 0.4
    for a, b in zip(back.chain_legs, desc.chain_legs, strict=True):
        np.testing.assert_array_equal(a.gravcomp, b.gravcomp)
    assert "gravity compensation of some bodies" in str(result.report)


# ---------------------------------------------------------------------- URDF
def test_urdf_sidecar_of_chain_legs_records_the_compensation(tmp_path) -> None:
    """URDF has no such field: the sidecar's ``gravcomp`` (link -> factor) of a robot with
    chain legs, read back onto the same links; the robot read back has the same efforts."""
    from stewart_pin.formats.urdf import write_urdf

    desc = _compensated(mixed_chain_robot(seed=2), seed=6)
    urdf, sidecar = write_urdf(desc, tmp_path / "r.urdf")
    assert '"gravcomp"' in sidecar.read_text()
    back = StewartRobot.from_urdf(urdf).description
    assert back.platform_gravcomp == 0.4
    for a, b in zip(back.chain_legs, desc.chain_legs, strict=True):
        np.testing.assert_array_equal(a.gravcomp, b.gravcomp)
    robot = StewartRobot(desc)
    T, V, A = robot.sample_states(2, rng=1)
    ref = StewartRobot(back).inverse_dynamics(T, V, A)
    assert rel_error(robot.inverse_dynamics(T, V, A), ref) < TOL
    _, plain = write_urdf(mixed_chain_robot(seed=2), tmp_path / "p.urdf")
    assert "gravcomp" not in plain.read_text()


@pytest.mark.parametrize("name", ["mixed"])  # ball and weld legs (one compile: suite time)
def test_compiled_models_remove_the_compensated_weights(name: str, shared_compile_cache) -> None:
    """The compiled chain-leg models (generated Newton-Euler with ``c M g``, ``c MS x g``
    per link and the platform's scaled gravity) against the tree with the forces
    ``-c m g``, 1e-10 relative: IDM and DDM."""
    gen = use_compile_cache(shared_compile_cache)
    next(gen)
    try:
        desc = _compensated(PRESETS[name]())
        robot = StewartRobot(desc)
        T, V, A = robot.sample_states(3, rng=11)
        tree = ChainTreeSolver(desc)
        gamma = robot.inverse_dynamics(T, V, A, backend="compiled")
        accel = robot.direct_dynamics(T, V, gamma, backend="compiled")
        for n in range(len(T)):
            q = _q_legs(desc, T[n])
            ref = tree.inverse_one(T[n], V[n], A[n], q)
            assert rel_error(gamma[n], ref) < TOL, f"IDM {rel_error(gamma[n], ref):.2e}"
            acc_ref = tree.forward_one(T[n], V[n], ref, q)
            assert rel_error(accel[n], acc_ref) < TOL, f"DDM {rel_error(accel[n], acc_ref):.2e}"
    finally:
        gen.close()
