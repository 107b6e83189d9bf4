"""A simulated lab experiment (issue 13, "what shows it is done"): an exciting trajectory
run on a robot with friction and armature (the ``ups-offset`` and ``rus`` presets: UPS
legs with offset U-joints and screw-driven slides; RUS legs with geared cranks) under
computed-torque control, integrated by the direct model (``stewart_pin.simulate``,
efforts held over each 5 ms control period), logged as a lab would: the actuator
positions quantised by encoders (1 um, 2^-16 rad) and the efforts with Gaussian noise of
2 % of their RMS, nothing else.

The identified model: the analytic base parameters without springs and offsets and
without passive-joint friction (``base_without(..., ["K", "OF", "FV@passive",
"FC@passive"])``: the presets have no springs and frictionless (rus) or nearly
frictionless (ups-offset: 1e-3) passive joints), 100 and 106 parameters.

References: the true parameters' base projection (the presets' values), the sampling
distribution of least squares over repeated noise seeds (coverage), the true
parameters' own prediction error on the validation log (the noise, plus the equations'
mismatch: the state filter's and the digital control's, 0.3 % of the efforts), and the
description's physical check.

The simulations are the slow part (about 10 s each on an idle core on the reference path,
under 2 s compiled): one identification run (3 s) and one validation run (1.5 s) per
robot, shared by the tests.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from stewart_pin import StewartRobot, simulate
from stewart_pin.description.inertia import check_physical
from stewart_pin.dynamics.regressor import (
    parameter_groups,
    standard_parameters,
    with_standard_parameters,
)
from stewart_pin.motion.control import ComputedTorqueController
from stewart_pin.parameters.base import base_parameters
from stewart_pin.parameters.identification import (
    base_without,
    exciting_trajectory,
    identify_log,
    log_equations,
    log_prediction_error,
)
from stewart_pin.parameters.least_squares import StackedLeastSquares
from stewart_pin.parameters.logs import ActuatorLog
from stewart_pin.parameters.physical import physically_consistent
from stewart_pin.parameters.state_estimation import (
    decimation_centres,
    design_filters,
    fir_decimate,
    smooth,
)

RATE = 200.0  # the controller's and the log's rate [Hz]
NOISE = 0.02  # effort noise, a fraction of each actuator's RMS effort
MODEL = ["K", "OF", "FV@passive", "FC@passive"]  # the lab's model: no springs...
ENCODER = {"ups-offset": 1e-6, "rus": 2.0**-16}  # [m], [rad]
SEEDS = 20


class Lab:
    """One robot's experiment: the simulated runs, the model, the logs."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.robot = robot = StewartRobot.from_preset(name)
        self.base = base_without(base_parameters(robot), MODEL)
        kw = {"base": self.base, "base_frequency": 1.0, "n_harmonics": 3, "n_grid": 20}
        traj, _ = exciting_trajectory(robot, seed=0, max_evaluations=30, n_candidates=3, **kw)
        check, _ = exciting_trajectory(robot, seed=1, optimise=False, **kw)
        self.run = self._simulate(traj.fourier, 3.0)
        self.check = self._simulate(check.fourier, 1.5)
        self.rms = np.sqrt(np.mean(self.run.gammas**2, axis=0))

    def _simulate(self, motion, duration: float):
        T0, V0, _ = motion(0.0)
        control = ComputedTorqueController(self.robot, motion)
        dt = 1.0 / RATE
        return simulate(
            self.robot,
            duration,
            T0,
            V0,
            forces=control,
            dt=dt,
            control_period=dt,
            output_dt=dt,
        )

    @functools.cached_property
    def identified(self):
        """``identify_log`` on the identification run's log of noise seed 0 (both tests
        start from it)."""
        return identify_log(self.robot, self.log(self.run, 0), self.base)

    def log(self, run, seed: int | None, noise: float = NOISE) -> ActuatorLog:
        """What the lab logs: quantised positions, noisy held efforts."""
        return ActuatorLog.from_simulation(
            run, ENCODER[self.name], noise * self.rms, seed=seed, effort_hold=True
        )


_LABS: dict[str, Lab] = {}


@pytest.fixture(scope="module", params=["ups-offset", "rus"])
def lab(request: pytest.FixtureRequest) -> Lab:
    if request.param not in _LABS:
        # the experiment on the user's default backend (auto: the compiled models and the
        # C simulator, 3 s instead of 25 s once the robot is built; the suite's default is
        # the reference path): the lab's data, as a user's simulation makes it
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("STEWART_PIN_BACKEND", "auto")
            _LABS[request.param] = Lab(request.param)
    return _LABS[request.param]


def test_identification_covers_the_true_base_parameters(lab):
    """Over 20 effort-noise seeds, each base parameter's estimate lies within 2 (3)
    standard deviations of its true value for >= 88 % (>= 97 %) of the (seed, parameter)
    pairs (95.4 % and 99.7 % for exact standard deviations; measured 96 % and 99.9 %),
    and the Mahalanobis distance of the estimate averages below twice nb (measured 1.2
    and 1.5 nb: the equations' mismatch, 0.3 % of the efforts against the 0.7 % of the
    decimated noise, shows there).

    The regressor side does not depend on the effort noise, so the 20 fits share it:
    each adds the filtered and decimated noise to the noise-free equations (the first
    seed checked against ``identify_log`` on the same log to 1e-9)."""
    robot, base = lab.robot, lab.base
    clean = lab.log(lab.run, None, noise=0.0)
    first = lab.identified
    design = first.design
    W, g0 = [], []
    for _, Wd, gd, _ in log_equations(robot, clean, base, design):
        W.append(Wd)
        g0.append(gd)
    W, g0 = np.concatenate(W), np.concatenate(g0)
    centres = decimation_centres(design, len(clean))
    z, mahalanobis = [], []
    for seed in range(SEEDS):
        noise = lab.log(lab.run, seed).effort_samples(0, len(clean)) - clean.effort_samples(
            0, len(clean)
        )
        acc = StackedLeastSquares(len(base), base.names)
        acc.add(W, g0 + fir_decimate(smooth(design, noise), design.taps, centres, 0))
        sol = acc.solve(noise_correlation=design.kappa)
        if seed == 0:
            np.testing.assert_allclose(
                sol.estimate, first.result.estimate, rtol=0, atol=1e-9 * first.result.std.max()
            )
        d = sol.estimate - base.values
        z.append(d / np.sqrt(np.diag(sol.covariance)))
        mahalanobis.append(d @ np.linalg.solve(sol.covariance, d))
    z = np.abs(np.array(z))
    assert np.mean(z < 2) >= 0.88, np.mean(z < 2)
    assert np.mean(z < 3) >= 0.97, np.mean(z < 3)
    assert np.mean(mahalanobis) <= 2 * len(base), np.mean(mahalanobis)
    # Some are well excited by so short a run (relative std below 20 %: 5 and 11).
    assert np.sum(first.result.relative_std < 20) >= 3


def _prior(lab: Lab):
    """A CAD model 30 % off: every body's parameters x 1.3, every joint term x 0.7."""
    desc = lab.robot.description
    chi = standard_parameters(desc).copy()
    groups = parameter_groups(desc)
    for body in groups.bodies:
        chi[body.index] *= 1.3
    for joint in groups.joints:
        chi[joint.index] *= 0.7
    return with_standard_parameters(desc, chi)


def test_physically_consistent_estimate_predicts_the_validation_efforts(lab, tmp_path):
    """On the validation run (another trajectory, another noise seed):

    - the physically consistent estimate (from a prior 30 % off, which alone predicts
      the efforts to ~20 %) predicts the decimated efforts to within twice the true
      parameters' own error (the noise and the equations' mismatch);
    - the least-squares estimate's error is what its covariance says: within 3 times
      the root of the noise's share plus the trace of its covariance mapped through the
      validation regressor (a short log leaves poorly determined directions that
      another trajectory excites);
    - every body passes the description's physical check, joint terms are
      non-negative, and the physical fit raises the weighted residual sum of squares by
      less than 60 % (the stated fraction; 35-45 % here, i.e. the residual's RMS by
      less than 26 %: the least-squares estimate's poorly determined directions are
      far from any realisable robot);
    - the identified robot is written as a description, URDF and MJCF that load back.
    """
    robot, base = lab.robot, lab.base
    ident = lab.identified
    prior = _prior(lab)
    est = physically_consistent(robot, ident, prior=prior)
    check = lab.log(lab.check, 100)
    design = ident.design
    err_true = log_prediction_error(robot, check, base.values, base, design)
    err_phys = log_prediction_error(robot, check, est.base_values, base, design)
    err_prior = log_prediction_error(
        robot, check, base.K @ standard_parameters(prior), base, design
    )
    assert err_phys <= 2.0 * err_true, (err_phys, err_true)
    assert err_prior >= 10 * err_phys  # the data, not the prior, did it
    # The least-squares estimate's own error, against its covariance.
    W, g = [], []
    for _, Wd, gd, _ in log_equations(robot, check, base, design):
        W.append(Wd.reshape(-1, len(base)))
        g.append(gd.reshape(-1))
    W, g = np.concatenate(W), np.concatenate(g)
    cov = ident.result.covariance
    expected = np.sqrt(err_true**2 + np.trace(W @ cov @ W.T) / (g @ g))
    err_ls = log_prediction_error(robot, check, ident.result.estimate, base, design)
    assert err_ls <= 3 * expected, (err_ls, expected)
    # Realisable, and at a stated cost in fit.
    groups = parameter_groups(robot.description)
    for body in groups.bodies:
        check_physical(est.standard[body.index], body.name)
    assert np.all(est.standard[groups.nonnegative] >= 0)
    assert 0 <= est.fit_loss <= 0.6, est.fit_loss
    # Written and read back.
    from stewart_pin import RobotDescription
    from stewart_pin.formats.mjcf import write_mjcf
    from stewart_pin.formats.urdf import write_urdf

    back = RobotDescription.read(est.description.write(tmp_path / "identified.toml"))
    np.testing.assert_allclose(standard_parameters(back), est.standard, rtol=1e-12, atol=1e-15)
    urdf, _ = write_urdf(est.description, tmp_path / "identified.urdf")
    mujoco = pytest.importorskip("mujoco")
    mujoco.MjModel.from_xml_path(str(write_mjcf(est.description, tmp_path / "identified.xml")))
    assert urdf.exists()


def test_design_follows_the_excitation(lab):
    """The filters come from the log: cut-off 10 times the bandwidth of a 3-harmonic
    1 Hz excitation (3-6 Hz with the legs' nonlinearity), decimation keeping 2.5 times it."""
    design = design_filters(lab.log(lab.run, 0))
    assert 3.0 <= design.bandwidth <= 6.5
    assert design.cutoff == pytest.approx(min(10 * design.bandwidth, 0.4 * RATE))
    assert 0.4 * RATE / design.decimation >= 2.5 * design.bandwidth
    assert design.kappa == pytest.approx(1.33, abs=0.02)
