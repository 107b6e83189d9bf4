"""State sampling on chain legs (issue 24, item 5): the sampled poses and the batch decision.

References: Pinocchio's forward kinematics of each leg's serial model (``robot.leg_models``)
at the legs' joint values, which must put the attachment frame at ``0Tp [P_i, R_pi]``
(1e-12 m, 1e-12 rad); the joint limits read from the description; and a decision
written here from :func:`chain_legs.solve_legs` on the whole batch (every leg solved for
every pose, the singular values of each leg's square Jacobian, ``Jp^-1``'s condition
number), which the sampler's decision (a pose one leg rejects not solved for the next
legs, poses outside a leg's reach rejected before its Newton, the rank test by a norm
bound) must equal pose by pose. The sampler's Newton is the same arithmetic as before
(only the states not yet converged are stepped, on (3, N) arrays); the sampled poses of
the three chain presets were checked bit-identical to the former code's for seeds 0 and 1
(10 000 states; rss-asymmetric 3 000) when this file was written.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin import StewartRobot
from stewart_pin.description.chain_leg import full_turn
from stewart_pin.description.chain_leg_presets import CHAIN_PRESETS
from stewart_pin.kinematics import chain_legs

PRESETS = ("welded-ups", "mixed-chain", "rss-asymmetric")
_ROBOTS: dict[str, StewartRobot] = {}


def robot_of(name: str) -> StewartRobot:
    if name not in _ROBOTS:
        _ROBOTS[name] = StewartRobot(CHAIN_PRESETS[name]())
    return _ROBOTS[name]


def inside_limits(leg, q: np.ndarray) -> np.ndarray:
    """(N,) bool: q (N, n) inside the leg's limits, revolute joints modulo 2 pi (a full
    turn limits nothing), written here."""
    lim = leg.limits
    ok = np.ones(q.shape[0], bool)
    for j in range(leg.n_joints):
        lo, hi = lim[j]
        if leg.revolute[j]:
            if full_turn(lo, hi):
                continue
            # some q + 2 pi m within [lo, hi]
            m = np.ceil((lo - q[:, j]) / (2 * np.pi))
            ok &= q[:, j] + 2 * np.pi * m <= hi + 1e-12
        else:
            ok &= (q[:, j] >= lo) & (q[:, j] <= hi)
    return ok


@pytest.mark.parametrize("name", PRESETS)
def test_sampled_poses_close_every_leg_inside_its_limits(name):
    """Each sampled pose: every leg's chain at its inverse geometry puts the attachment
    at P_i (and, welded, at the platform's orientation) by Pinocchio's forward
    kinematics, to 1e-12; the joint values are inside the limits; Jp^-1's condition
    number is within the robot's bound."""
    robot = robot_of(name)
    desc = robot.description
    T, V, A = robot.sample_states(60, 5)
    assert T.shape == (60, 4, 4) and V.shape == A.shape == (60, 6)
    qs = chain_legs.inverse_geometry(desc, T, check_limits=True)
    size = chain_legs.robot_size(desc)
    for k, (leg, model) in enumerate(zip(desc.chain_legs, robot.leg_models, strict=True)):
        assert model.nq == leg.n_joints
        assert inside_limits(leg, qs[k]).all()
        data = model.createData()
        tip = pin.SE3(leg.attachment())
        for n in range(len(T)):
            pin.forwardKinematics(model, data, qs[k][n])
            reached = data.oMi[model.njoints - 1] * tip
            np.testing.assert_allclose(
                reached.translation,
                T[n, :3, :3] @ desc.platform_points[k] + T[n, :3, 3],
                rtol=0,
                atol=1e-12 * max(size, 1.0),
            )
            if leg.closure == "weld":
                R = T[n, :3, :3] @ leg.platform_rotation
                assert np.linalg.norm(pin.log3(R @ reached.rotation.T)) < 1e-12
    assert np.all(robot.condition_number(T) <= robot.max_condition)


def decision_written_here(desc, T: np.ndarray, max_condition: float) -> np.ndarray:
    """Every leg solved for every pose (:func:`chain_legs.solve_legs`), then: reached,
    inside the limits, each leg's square Jacobian of rank n by its singular values, and
    Jp^-1's condition number within ``max_condition``."""
    qs, reached = chain_legs.solve_legs(desc, T)
    ok = reached.all(axis=1)
    rows = np.zeros((len(T), 6, 6))
    for k, (leg, q) in enumerate(zip(desc.chain_legs, qs, strict=True)):
        ok &= inside_limits(leg, q)
        frames = chain_legs.chain_frames(leg, chain_legs.leg_base_pose(desc, k), q)
        J = chain_legs.chain_jacobian(leg, frames)
        if leg.idle_joint is not None:
            e = np.zeros((len(T), 1, leg.n_joints))
            e[:, 0, leg.idle_joint - 1] = 1.0
            J = np.concatenate([J, e], axis=1)
        for n in np.flatnonzero(ok):
            s = np.linalg.svd(J[n], compute_uv=False)
            if not s[-1] > chain_legs.RANK_TOLERANCE * s[0]:
                ok[n] = False
                continue
            L = T[n, :3, :3] @ desc.platform_points[k]
            G = chain_legs.platform_map(leg, L[None])[0]
            rows[n, k] = (np.linalg.inv(J[n])[:, : leg.constraints] @ G)[leg.actuated - 1]
    for n in np.flatnonzero(ok):
        ok[n] = chain_legs.condition_number(desc, rows[n : n + 1])[0] <= max_condition
    return ok


@pytest.mark.parametrize(
    ("name", "translation", "rotation"),
    [("welded-ups", 2.0, 1.2), ("mixed-chain", 2.0, 1.2), ("rss-asymmetric", 0.3, 0.4)],
)
def test_batch_decision_equals_every_leg_solved(name, translation, rotation):
    """Draws over a wide range (many refused: out of a leg's reach, Newton not
    converging, joint limits; with the condition bound at the median of the accepted,
    half of those refused as near a parallel singularity; a range per robot that
    refuses some and accepts some): ``admissible_poses`` decides
    as :func:`decision_written_here`, pose by pose."""
    robot = robot_of(name)
    desc = robot.description
    rng = np.random.default_rng(3)
    m = 300
    T = np.broadcast_to(desc.home_pose, (m, 4, 4)).copy()
    T[:, :3, 3] += rng.uniform(-1, 1, (m, 3)) * translation * desc.stroke_mid
    for Ti, w in zip(T, rng.uniform(-rotation, rotation, (m, 3)), strict=True):
        Ti[:3, :3] = pin.exp3(w) @ desc.home_pose[:3, :3]
    chain_legs._LAST.pop(desc, None)  # the continuation from the home pose in both
    want = decision_written_here(desc, T, robot.max_condition)
    assert 0.02 < want.mean() < 0.9  # both met
    chain_legs._LAST.pop(desc, None)
    np.testing.assert_array_equal(chain_legs.admissible_poses(desc, T, robot.max_condition), want)
    median = float(np.median(robot.condition_number(T[want])))
    chain_legs._LAST.pop(desc, None)
    tight = decision_written_here(desc, T, median)
    assert tight.sum() < want.sum()
    chain_legs._LAST.pop(desc, None)
    np.testing.assert_array_equal(chain_legs.admissible_poses(desc, T, median), tight)


@pytest.mark.parametrize("name", PRESETS)
def test_reach_bounds_hold_over_the_joint_space(name):
    """The reach bounds the sampler rejects by: Pinocchio's forward kinematics of each
    leg at random joint values inside the limits keeps the attachment's distance to the
    leg's frame 0 origin within them (and the bounds are met within 2 % for a 3-link
    R-S-S leg, whose distance spans exactly |rod -+ crank|)."""
    robot = robot_of(name)
    desc = robot.description
    rng = np.random.default_rng(1)
    for k, (leg, model) in enumerate(zip(desc.chain_legs, robot.leg_models, strict=True)):
        lo, hi = chain_legs._reach(leg, chain_legs.robot_size(desc))
        lim = np.clip(leg.limits, -np.pi, np.pi)
        data = model.createData()
        tip = pin.SE3(leg.attachment())
        dist = []
        for _ in range(400):
            q = rng.uniform(lim[:, 0], lim[:, 1])
            pin.forwardKinematics(model, data, q)
            p = (data.oMi[model.njoints - 1] * tip).translation
            dist.append(np.linalg.norm(p - desc.base_points[k]))
        assert lo <= min(dist) and max(dist) <= hi
        if name == "rss-asymmetric":
            assert min(dist) < lo + 0.02 * (hi - lo) and max(dist) > hi - 0.02 * (hi - lo)
