"""State sampling decided in batches (issue 24, item 5) on every leg architecture.

References: the sampler written one draw at a time in this file (six numbers from the
generator, the pose ``exp(w) R_home``, then the raising checks of the reference path on
that pose alone: :func:`inverse_geometry_batch` and :func:`check_condition` for 6-UPS,
:func:`leg_state` with limits and :func:`check_parallel` for general legs), the
per-leg Newton of :func:`solve_leg`, forward geometry after inverse geometry, and the
loop closure of the legs' forward kinematics at the sampled poses.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from test_every_architecture import ARCHITECTURES, robot_of

from stewart_pin import StewartRobot, WorkspaceError
from stewart_pin.description.leg_chain_hexapod import GeneralHexapod
from stewart_pin.exceptions import LegReachError, StewartPinError
from stewart_pin.kinematics import leg_chains, workspace
from stewart_pin.kinematics.geometry import inverse_geometry_batch
from stewart_pin.kinematics.jacobians import check_condition, inverse_jacobian_batch


def one_at_a_time(robot, n, seed, translation=None, rotation=0.25, max_draws=100):
    """The reference sampler: one draw, one decision at a time; ``(poses, twists, accels)``
    with the twists and accelerations drawn from the generator afterwards as
    :func:`workspace._motion` does."""
    desc = robot.description
    rng = np.random.default_rng(seed)
    half = 0.15 * desc.stroke_mid if translation is None else translation
    out, draws = [], 0
    while len(out) < n:
        if draws >= max_draws * n:
            raise WorkspaceError(f"only {len(out)} of {n} poses reachable after {draws} draws")
        draws += 1
        T = desc.home_pose.copy()
        T[:3, 3] += rng.uniform(-half, half, 3)
        T[:3, :3] = pin.exp3(rng.uniform(-rotation, rotation, 3)) @ desc.home_pose[:3, :3]
        if accepts_one(robot, T):
            out.append(T)
    s, w = desc.stroke_mid, 1.0
    scale = np.array([s, s, s, w, w, w])
    twists = rng.uniform(-1, 1, (n, 6)) * scale
    accels = rng.uniform(-1, 1, (n, 6)) * scale * 3.0
    return np.array(out), twists, accels


@pytest.mark.parametrize("name", ARCHITECTURES)
@pytest.mark.parametrize("chunk", [7, workspace.CHUNK])
def test_batched_sampling_equals_one_at_a_time(name, chunk, monkeypatch):
    """Same poses, twists and accelerations as drawing and deciding one pose at a time
    (several batches with ``CHUNK = 7``: the generator set back after each)."""
    monkeypatch.setattr(workspace, "CHUNK", chunk)
    robot = robot_of(name)
    got = robot.sample_states(40, 11)
    want = one_at_a_time(robot, 40, 11)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)


def accepts_one(robot: StewartRobot, T: np.ndarray, max_condition: float | None = None) -> bool:
    """The reference decision on one pose (4, 4): the raising checks on it alone."""
    max_condition = robot.max_condition if max_condition is None else max_condition
    try:
        if robot.is_ideal_ups:
            inverse_geometry_batch(robot.description, T[None])
            J_inv = inverse_jacobian_batch(robot.description, T[None])
            check_condition(J_inv, max_condition, robot.description)
        else:
            legs = leg_chains.leg_state(robot.general, T[None], np.zeros((1, 6)), None, True)
            J_inv = leg_chains.inverse_jacobian_from_legs(robot.general, legs.J_inv, legs.L)
            leg_chains.check_parallel(robot.general, J_inv, max_condition)
    except StewartPinError:
        return False
    return True


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_batched_decision_equals_the_raising_checks(name):
    """Draws over a wide range (many refused: unreachable legs, Newton not converging,
    joint limits) and a threshold on the condition number at the median of the accepted
    ones (half of those refused as near a parallel singularity): the batch decision is
    the one of the raising checks, pose by pose."""
    robot = robot_of(name)
    desc = robot.description
    rng = np.random.default_rng(3)
    m = 200
    T = np.broadcast_to(desc.home_pose, (m, 4, 4)).copy()
    T[:, :3, 3] += rng.uniform(-1, 1, (m, 3)) * 0.2 * desc.stroke_mid
    for Ti, w in zip(T, rng.uniform(-0.3, 0.3, (m, 3)), strict=True):
        Ti[:3, :3] = pin.exp3(w) @ desc.home_pose[:3, :3]
    inside = np.array([accepts_one(robot, Ti) for Ti in T])
    assert 0.05 < inside.mean() < 0.8  # both met
    median = float(np.median(robot.condition_number(T[inside])))
    # a tighter threshold refuses a subset of `inside`: the others need no second check
    tight = inside.copy()
    tight[inside] = [accepts_one(robot, Ti, median) for Ti in T[inside]]
    for max_condition, want in ((robot.max_condition, inside), (median, tight)):
        if robot.is_ideal_ups:
            from stewart_pin.kinematics.geometry import admissible_poses
            from stewart_pin.kinematics.jacobians import condition_number_batch

            ok = admissible_poses(desc, T)
            ok[ok] = condition_number_batch(desc, T[ok]) <= max_condition
        else:
            ok = leg_chains.admissible_poses(robot.general, T, max_condition)
        np.testing.assert_array_equal(ok, want)
    assert want.sum() < inside.sum()


@pytest.mark.parametrize("name", ARCHITECTURES)
def test_sampled_states_are_within_limits_and_consistent(name):
    """Every sampled pose: legs within their limits (the raising checks pass on the whole
    batch), the legs' forward kinematics closes the loops (P_i of the joint chain at the
    platform point, 1e-9 of the size), and forward geometry from the actuated values
    returns the pose (1e-9; Newton started 0.1 % of the size and 5e-3 rad away)."""
    robot = robot_of(name)
    desc = robot.description
    P, _, _ = robot.sample_states(25, 4)
    q = robot.inverse_geometry(P)  # raises outside a limit
    robot.inverse_jacobian(P)
    points = np.einsum("nij,kj->nki", P[:, :3, :3], desc.platform_points) + P[:, None, :3, 3]
    if robot.is_ideal_ups:
        lengths = np.linalg.norm(points - desc.base_points, axis=-1)
        np.testing.assert_allclose(q[..., 2], lengths, rtol=0, atol=1e-12 * desc.size)
        actuated = q[..., 2]
    else:
        frames = leg_chains.leg_forward(robot.general, q)
        assert np.abs(frames.P - points).max() < 1e-9 * desc.size
        a = leg_chains.constants(robot.general).actuated
        actuated = q[:, np.arange(6), a]
    nudge = pin.exp6(pin.Motion(np.r_[1e-3 * desc.size * np.ones(3), 5e-3 * np.ones(3)]))
    for T, qa in zip(P[:8], actuated[:8], strict=True):
        back = robot.forward_geometry(qa, guess=T @ nudge.homogeneous)  # Newton from nearby
        assert np.abs(back[:3, 3] - T[:3, 3]).max() < 1e-9 * desc.size
        assert np.abs(back[:3, :3] - T[:3, :3]).max() < 1e-9


@pytest.mark.parametrize("name", ["random-custom-0", "mixed"])
def test_newton_state_by_state_equals_solve_leg_on_each(name):
    """The batch Newton of custom legs equals :func:`solve_leg` run on each state alone
    (to 1e-12 [rad or m]; it stops each state where that would), and marks the point out
    of reach as not converged."""
    robot = robot_of(name).general
    P, _, _ = robot_of(name).sample_states(20, 2)
    P0i = leg_chains._leg_points(robot, P)
    for k, leg in enumerate(robot.legs):
        if leg.name != "custom":
            continue
        points = P0i[:, k].copy()
        points[5] *= 100.0  # far out of reach
        guess = np.broadcast_to(leg.guess, (20, 3))
        q, converged = leg_chains._solve_leg_each(leg, points, guess)
        assert not converged[5] and converged[np.arange(20) != 5].all()
        for n in np.flatnonzero(converged):
            ref = leg_chains.solve_leg(leg, np.eye(4), points[n : n + 1], guess[n : n + 1])
            np.testing.assert_allclose(q[n], ref[0], rtol=0, atol=1e-12)


def test_a_floating_point_exception_is_decided_one_pose_at_a_time(monkeypatch):
    """Translations of 1e300 m overflow a closed form of the batch (the slide's squared
    offsets): the sampler then decides pose by pose (every pose refused, as the
    reference does) and gives up with the reference's message."""
    robot = robot_of("pus")
    decided = []

    def accepts(accept, T):
        decided.append(T)
        return real(accept, T)

    real = workspace._accepts
    monkeypatch.setattr(workspace, "_accepts", accepts)
    message = r"only 0 of 2 poses reachable after 10 draws"
    with pytest.raises(WorkspaceError, match=message):
        workspace.sample_general_poses(
            robot.description, robot.general, 2, 0, translation=1e300, max_draws=5
        )
    assert len(decided) == 10
    with pytest.raises(WorkspaceError, match=message), np.errstate(all="ignore"):
        one_at_a_time(robot, 2, 0, translation=1e300, max_draws=5)


def test_zero_states_and_the_draw_budget():
    robot = robot_of("pus")
    assert robot.sample_poses(0, 0).shape == (0, 4, 4)
    with pytest.raises(WorkspaceError, match=r"only 0 of 3 poses reachable after 300 draws"):
        robot.sample_poses(3, 0, translation=10.0)


def interleaved(name: str, rename: str) -> GeneralHexapod:
    """The general legs of robot ``name`` with legs 2, 4 and 6 renamed ``rename`` (the
    same chains: ``ups-offset`` with a zero offset is ``ups``; ``custom`` takes Newton's
    method): the legs' groups interleave."""
    general = robot_of(name).general
    legs = tuple(leg.replace(name=rename) if k % 2 else leg for k, leg in enumerate(general.legs))
    return general.replace(legs=legs)


def legs_one_by_one(general: GeneralHexapod, P0i: np.ndarray) -> np.ndarray:
    """The reference: each leg's inverse geometry alone, in the legs' order."""
    return np.stack(
        [leg_chains._inverse_leg(leg, P0i[:, k], k, None) for k, leg in enumerate(general.legs)],
        axis=1,
    )


@pytest.mark.parametrize(
    "robot",
    ["rus", "pus", "ups-offset", "simulator", "mixed", "simulator|ups-offset", "pus|custom"],
)
def test_inverse_geometry_of_grouped_legs_equals_the_legs_one_by_one(robot):
    """The legs of one architecture are solved together: the joint values equal each
    leg's own closed form or Newton's method (1e-12), and where some leg cannot reach,
    or meets an overflow, the error is the one the legs solved one by one in their order
    raise (the first failing leg's, the same state and counts), for a batch and for each
    state alone."""
    name, _, rename = robot.partition("|")
    general = interleaved(name, rename) if rename else robot_of(name).general
    assert {g.name for g in leg_chains.leg_groups(general.legs).closed_forms} >= (
        {rename} - {"custom"} if rename else set()
    )
    rng = np.random.default_rng(3)
    n = 60
    size = robot_of(name).description.stroke_mid
    T = np.broadcast_to(general.home_pose, (n, 4, 4)).copy()
    T[:, :3, 3] += rng.uniform(-1, 1, (n, 3)) * size * np.linspace(0.05, 1.5, n)[:, None]
    for k in range(n):
        T[k, :3, :3] = pin.exp3(rng.uniform(-0.3, 0.3, 3)) @ T[k, :3, :3]
    T[n // 3, :3, 3] = 1e300  # an overflow: a NumericalError (rus, pus: |P|^2)
    P0i = leg_chains._leg_points(general, T)
    failures = 0
    for batch in [np.arange(n), *([k] for k in range(n))]:
        try:
            expected = legs_one_by_one(general, P0i[batch])
        except StewartPinError as e:
            failures += 1
            with pytest.raises(type(e)) as got:
                leg_chains._inverse_legs(general, P0i[batch])
            assert str(got.value) == str(e)
            continue
        np.testing.assert_allclose(
            leg_chains._inverse_legs(general, P0i[batch]), expected, rtol=0, atol=1e-12
        )
    if name in ("rus", "pus", "mixed"):  # some states reach, some do not
        assert 3 <= failures < n
    else:  # a U-P leg reaches anywhere, and its closed form takes |P| = 1e300
        assert failures == 0


@pytest.mark.parametrize("name", ["ups-offset", "rus", "pus", "mixed"])
def test_closed_forms_over_a_batch_equal_each_leg_alone(name):
    """The closed forms of each group of legs (one pass over the legs of an architecture)
    over a batch with unreachable states marked (not raised): the marked states are those
    where the leg alone raises :class:`LegReachError`, the others have the joint values
    of the leg alone (1e-12)."""
    robot = robot_of(name)
    desc = robot.description
    rng = np.random.default_rng(8)
    m = 120
    T = np.broadcast_to(desc.home_pose, (m, 4, 4)).copy()
    T[:, :3, 3] += rng.uniform(-1, 1, (m, 3)) * 0.4 * desc.stroke_mid
    P0i = leg_chains._leg_points(robot.general, T)
    marked = 0
    groups = leg_chains.leg_groups(robot.general.legs).closed_forms
    assert sorted(k for g in groups for k in g.legs) == [
        k for k, leg in enumerate(robot.general.legs) if leg.name != "custom"
    ]
    for forms in groups:
        unreachable = np.zeros((m, forms.legs.size), dtype=bool)
        q = leg_chains._closed_form(forms, P0i[:, forms.legs], unreachable)
        for j, k in enumerate(forms.legs):
            leg = robot.general.legs[k]
            for n in range(m):
                try:
                    alone = leg_chains._inverse_leg(leg, P0i[n : n + 1, k], k, None)
                except LegReachError:
                    assert unreachable[n, j]
                    continue
                assert not unreachable[n, j]
                np.testing.assert_allclose(q[n, j], alone[0], rtol=0, atol=1e-12)
        marked += unreachable.sum()
    assert (marked > 0) == (name != "ups-offset")  # an offset U-joint leg reaches anywhere
