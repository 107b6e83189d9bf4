"""The regressor, numerical base parameters and identification of robots with idle
freedoms (6-RSS rods spinning about their ball-to-ball line, ``ChainLeg.idle_joint``):
with the spin accelerations given, Gamma is linear in the standard parameters.

References: the independent constrained tree (:class:`ChainTreeSolver`: Pinocchio on the
closed-loop tree with 3D loop constraints, its spin accelerations from the KKT solve).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from stewart_pin import StewartRobot
from stewart_pin.check.chain_legs_tree import ChainTreeSolver
from stewart_pin.description.chain_leg_presets import mixed_chain_robot, rss_robot
from stewart_pin.dynamics.regressor import standard_parameters, with_standard_parameters
from stewart_pin.exceptions import BaseParameterWarning, InputError
from stewart_pin.kinematics import chain_legs

TOL = 1e-10  # relative agreement of efforts with the constrained tree / the full set


@pytest.fixture(scope="module", params=[True, False], ids=["symmetric-rods", "asymmetric-rods"])
def rss(request: pytest.FixtureRequest) -> StewartRobot:
    return StewartRobot(rss_robot(symmetric=request.param))


def _spin(n: int, seed: int = 11) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, (n, 6)), rng.uniform(-5.0, 5.0, (n, 6))


def _tree(robot: StewartRobot, T, V, A, spin, rate):  # type: ignore[no-untyped-def]
    """The tree's efforts and spin accelerations (N, 6) each."""
    qs = chain_legs.inverse_geometry(robot.description, T, False, spin)
    tree = ChainTreeSolver(robot.description)
    out = [
        tree.inverse_idle_one(T[n], V[n], A[n], [x[n] for x in qs], rate[n]) for n in range(len(T))
    ]
    return np.array([g for g, _ in out]), np.array([s for _, s in out])


def test_w_chi_is_the_trees_efforts_with_its_spin_accelerations(rss: StewartRobot) -> None:
    T, V, A = rss.sample_states(3, rng=2)
    spin, rate = _spin(3)
    gamma, sigma = _tree(rss, T, V, A, spin, rate)
    assert np.abs(sigma).max() > 1.0  # the spins do accelerate: the columns carry them
    W = rss.regressor(T, V, A, idle=(spin, rate, sigma))
    chi = standard_parameters(rss.description)
    assert W.shape == (3, 6, chi.size)
    assert np.abs(W @ chi - gamma).max() <= TOL * np.abs(gamma).max()
    # linear in chi: another robot's parameters (same geometry), its own tree and spins
    # (each body's ten scaled together: physically consistent; joint terms each)
    rng = np.random.default_rng(3)
    n_bodies = sum(leg.n_joints for leg in rss.description.chain_legs or ()) + 1
    scale = np.concatenate(
        [
            np.repeat(rng.uniform(0.5, 1.5, n_bodies), 10),
            rng.uniform(0.5, 1.5, chi.size - 10 * n_bodies),
        ]
    )
    chi2 = chi * scale
    other = StewartRobot(with_standard_parameters(rss.description, chi2))
    gamma2, sigma2 = _tree(other, T, V, A, spin, rate)
    W2 = rss.regressor(T, V, A, idle=(spin, rate, sigma2))
    assert np.abs(W2 @ chi2 - gamma2).max() <= TOL * np.abs(gamma2).max()
    # one state: (6, n_p)
    W0 = rss.regressor(T[0], V[0], A[0], idle=(spin[0], rate[0], sigma[0]))
    assert np.abs(W0 @ chi - gamma[0]).max() <= TOL * np.abs(gamma[0]).max()


def test_the_spin_state_is_required_and_checked() -> None:
    r = StewartRobot(rss_robot(symmetric=False))
    H, z = r.description.home_pose, np.zeros(6)
    with pytest.raises(InputError, match=r"idle freedoms \(leg 1 joint 4.*accelerations"):
        r.regressor(H, z, z)
    with pytest.raises(InputError, match=r"\(values, rates, accelerations\)"):
        r.regressor(H, z, z, idle=(z, z))  # the inverse model's pair: no accelerations
    with pytest.raises(InputError, match="idle accelerations"):
        r.regressor(H, z, z, idle=(z, z, np.zeros(5)))
    with pytest.raises(InputError, match="idle rates must be finite"):
        r.regressor(H, z, z, idle=(z, np.full(6, np.nan), z))
    for other in (StewartRobot(mixed_chain_robot(seed=2)), StewartRobot.from_preset("desktop")):
        with pytest.raises(InputError, match="no idle joints"):
            other.regressor(other.description.home_pose, z, z, idle=(z, z, z))


def _numerical(robot: StewartRobot, **kw):  # type: ignore[no-untyped-def]
    from stewart_pin.parameters import base_parameters

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BaseParameterWarning)
        return base_parameters(robot, "numerical", **kw)


def test_numerical_base_parameters_predict_the_efforts(rss: StewartRobot) -> None:
    bp = _numerical(rss)
    n = standard_parameters(rss.description).size
    # the rank does not depend on the sampled states (poses, spins, rates, accelerations)
    again = _numerical(rss, n_states=90, seed=5)
    assert len(bp) == len(again) and 0 < len(bp) < n
    # the spin joints' own terms (joint 4) do not reach the actuators: not in the set
    assert not [
        x for x in bp.names if x.rstrip("*").endswith("_4") and x[:2] in ("IA", "FV", "FC", "OF")
    ]
    T, V, A = rss.sample_states(4, rng=9)
    spin, rate = _spin(4, seed=12)
    gamma, sigma = _tree(rss, T, V, A, spin, rate)
    W = rss.regressor(T, V, A, idle=(spin, rate, sigma))
    assert np.abs(bp.reduce(W) @ bp.values - gamma).max() <= TOL * np.abs(gamma).max()
    # any parameter vector: W chi = W_b K chi
    chi = np.random.default_rng(1).normal(size=n)
    full = W @ chi
    assert np.abs(bp.reduce(W) @ bp.from_standard(chi) - full).max() <= TOL * np.abs(full).max()
    assert (
        np.abs(again.reduce(W) @ again.from_standard(chi) - full).max() <= TOL * np.abs(full).max()
    )


def test_identification_from_states_recovers_the_base_parameters(rss: StewartRobot) -> None:
    from stewart_pin.parameters import identify
    from stewart_pin.parameters.identification import Measurements, validation_error

    bp = _numerical(rss)
    N = 60
    T, V, A = rss.sample_states(N, rng=4)
    spin, rate = _spin(N, seed=13)
    # noise-free efforts and spin accelerations of the reference path
    res = rss.chain_dynamics.inverse_dynamics(T, V, A, details=True, idle=(spin, rate))
    m = Measurements(0.01 * np.arange(N), T, V, A, res.gamma)
    idle = (spin, rate, res.idle_accel)
    for weighted in (False, True):
        result = identify(rss, m, bp, weighted, idle=idle)
        err = np.abs(result.estimate - bp.values).max()
        assert err <= 1e-9 * np.abs(bp.values).max()
    assert validation_error(result, rss, m, idle=idle) <= 1e-9
    assert (
        np.abs(
            result.predict(T[:2], V[:2], A[:2], idle=tuple(x[:2] for x in idle)) - res.gamma[:2]
        ).max()
        <= 1e-9 * np.abs(res.gamma).max()
    )
    with pytest.raises(InputError, match="idle freedoms"):
        identify(rss, m, bp)
    with pytest.raises(InputError, match="idle values"):
        identify(rss, m, bp, idle=(spin[:3], rate, res.idle_accel))


def test_the_spin_equations_vanish_with_the_trees_spin_accelerations(rss: StewartRobot) -> None:
    T, V, A = rss.sample_states(3, rng=6)
    spin, rate = _spin(3, seed=14)
    _, sigma = _tree(rss, T, V, A, spin, rate)
    chi = standard_parameters(rss.description)
    S = rss.chain_dynamics.spin_regressor(T, V, A, idle=(spin, rate, sigma))
    scale = np.abs(S * chi).max()  # the largest single term of the spin equations
    assert np.abs(S @ chi).max() <= TOL * scale
    # other spin accelerations break them, leg by leg
    wrong = sigma + np.eye(6)[2]
    bad = rss.chain_dynamics.spin_regressor(T, V, A, idle=(spin, rate, wrong)) @ chi
    assert (
        np.abs(bad[:, 2]).min() > 1e-6 * scale
        and np.abs(bad[:, [0, 1, 3, 4, 5]]).max() <= TOL * scale
    )
    # the idle joints' own terms: zero columns of W, seen by the spin equations only
    from stewart_pin.dynamics.regressor import standard_parameter_names

    names = standard_parameter_names(rss.description)
    spin_terms = [
        k
        for k, x in enumerate(names)
        if x[:2] in ("IA", "FV", "FC", "K_", "OF") and x.endswith("_4")
    ]
    assert len(spin_terms) == 30
    W = rss.regressor(T, V, A, idle=(spin, rate, sigma))
    assert not np.any(W[..., spin_terms])
    assert np.all(
        np.abs(S[..., spin_terms]).max(axis=(0, 1))[[0, 1, 3, 4]] > 0
    )  # IA FV K OF leg 1 (FC: sign)
    with pytest.raises(InputError, match="no spin equations"):
        other = StewartRobot(mixed_chain_robot(seed=2))
        other.chain_dynamics.spin_regressor(
            other.description.home_pose, np.zeros(6), np.zeros(6), None
        )
