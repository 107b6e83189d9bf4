"""Platform states from an actuator log: filter, differentiate, forward geometry, and the
parallel decimation of both sides of ``Gamma = W chi`` (Gautier 1990, 1991).

A robot measures its six actuated joint positions ``q_a`` (encoders) and efforts
``Gamma``; the regressor needs the platform's pose, twist and classical acceleration.
Per log (uniformly sampled at ``fs = 1 / step`` [Hz]):

1. **Bandwidth** of the excitation (:func:`excitation_bandwidth`): the frequency below
   which :data:`BANDWIDTH_FRACTION` (99.9 %) of the power of the actuator positions lies
   (mean and linear trend removed, Hann window, largest over the six actuators).
2. **State filter** (:class:`FilterDesign`): the positions are low-pass filtered with a
   zero-phase filter of cut-off ``fc = CUTOFF_FACTOR * bandwidth`` (10 times, at most
   ``0.4 fs``): a Butterworth filter of order 4 run forward and backward
   (``scipy.signal.sosfiltfilt``: gain ``1 / (1 + (f / fc)^8)``, no phase lag; 1 - 3e-8
   at a tenth of ``fc``), then differentiated by second-order central differences
   (``qdot_k = (q_(k+1) - q_(k-1)) / 2 step``, ``qddot_k = (q_(k+1) - 2 q_k + q_(k-1)) /
   step^2``; relative error ``(2 pi f step)^2 / 6`` at frequency f, 7e-6 for 1 Hz at
   1 kHz). Or ``method="savgol"``: Savitzky-Golay smoothing and derivatives (cubic,
   window from ``fc``: ``window = (4 fs / fc + 4.6) / 3.2``, Schafer 2011). The first and
   last :attr:`FilterDesign.edge` samples (five periods of ``fc``; half a window) carry the
   filter's start-up transient and are not used.
3. **Pose** per sample (:func:`track_poses`): the forward geometry of the filtered
   positions by Newton's method on SE(3), warm-started from the previous sample: blocks
   of :data:`TRACK_BLOCK` samples are solved together from a first-order prediction
   ``T_k = exp(Jp (q_k - q_prev)) T_prev`` off the previous block's last pose (the
   continuation keeps the assembly mode of the first sample, solved from the tracker's
   pose or the home pose); a block that does not converge is solved sample by sample.
4. **Twist and acceleration** (:func:`platform_states`): ``V = Jp qdot_a`` and the
   classical ``A = Jp (qddot_a - b(T, V))``, ``b`` the actuated joints' accelerations at
   zero platform acceleration (the second-order kinematics): exact for every
   architecture.
5. **Both sides through the same filters.** The state filter acts on ``W`` through the
   states (``W`` of filtered states is, to first order, the filtered ``W``: it is linear
   in the accelerations, smooth in the rest), so the efforts go through it too
   (:func:`smooth`); the one column it cannot reproduce is Coulomb friction's
   ``sign(qdot)``, whose jump the filtered velocity shifts by a fraction of ``1 / fc``
   (the kink a friction flip puts in the velocity): the actuated joints' Coulomb columns
   are therefore the signs of the unfiltered velocities (fourth-order differences of the
   raw positions; for held efforts, their mean over each sample's interval, which places
   a reversal to a fraction of a step) passed through the state filter
   (:func:`raw_velocity_signs`). On a simulated RUS robot under computed-torque control
   at 200 Hz this brings the equations' mismatch with the true parameters from 0.3 % to
   a few 1e-4 of the efforts' RMS (the tests bound it).
   **Parallel decimation** (:class:`FilterDesign`, :func:`fir_decimate`): the regressor
   ``W`` computed at every sample and the efforts are then filtered by the same
   linear-phase FIR low-pass filter (Hamming window, ``16 D + 1`` taps, cut-off 0.8 times
   the decimated Nyquist frequency ``fs / 2D``, unit DC gain) and kept every D samples,
   with D the largest factor whose FIR cut-off keeps 2.5 times the excitation bandwidth
   (:data:`DECIMATION_BANDWIDTH`; and at least ``0.8 fs / fc``, so the FIR filter stops
   well before the state filter bends): both sides see the same linear operator, so
   ``F Gamma = (F W) chi`` holds exactly, the effort noise above the excitation band is
   removed, and the frequencies where ``W`` of the filtered states differs from that of
   the true states are cut from both (what remains is near velocity reversals, where
   the passive joints' Coulomb columns still come from filtered velocities). Only
   outputs whose
   whole FIR window lies inside the used samples are kept (no end effects). The
   decimated noise is slightly coloured: its long-run variance is ``kappa``
   (:func:`noise_correlation`, about 1.33) times its variance, and the least-squares
   covariance is multiplied by ``kappa``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal

from stewart_pin._so3 import so3_exp
from stewart_pin.description.actuator_convention import actuator_convention_of
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.exceptions import (
    InputError,
    LogError,
    LogTimeError,
    StewartPinError,
)
from stewart_pin.parameters.logs import ActuatorLog, check_log
from stewart_pin.protocols import RobotLike

#: Fraction of the positions' power below the excitation bandwidth.
BANDWIDTH_FRACTION = 0.999
#: State filter cut-off = this times the excitation bandwidth.
CUTOFF_FACTOR = 10.0
#: The state filter's cut-off is at most this fraction of the sample rate.
MAX_CUTOFF = 0.4
#: Order of the Butterworth state filter (run forward and backward: twice this).
BUTTERWORTH_ORDER = 4
#: Polynomial order of the Savitzky-Golay state filter.
SAVGOL_ORDER = 3
#: Cut-off periods of the state filter dropped at each end of the log (start-up transient).
EDGE_PERIODS = 5.0
#: Half-length of the decimation FIR filter in units of the decimation factor D.
FIR_HALF = 8
#: FIR cut-off as a fraction of the decimated Nyquist frequency (Gautier's 0.8).
FIR_CUTOFF = 0.8
#: The decimation FIR filter keeps this many times the excitation bandwidth: D is the
#: largest factor with ``0.8 fs / 2D >= 2.5 * bandwidth``, but at least ``0.8 fs / fc``
#: (the FIR cut-off at most half the state filter's).
DECIMATION_BANDWIDTH = 2.5
#: Samples solved together by the forward-geometry continuation.
TRACK_BLOCK = 128
#: Tolerance of the forward geometry on the actuated joint values [m or rad].
TRACK_TOLERANCE = 1e-12
#: Newton iterations per block before falling back to one sample at a time.
TRACK_ITERATIONS = 30
#: Butterworth, Savitzky-Golay.
METHODS = ("butterworth", "savgol")


# ====================================================================== bandwidth, design


def excitation_bandwidth(
    positions: np.ndarray, step: float, fraction: float = BANDWIDTH_FRACTION
) -> float:
    """The frequency [Hz] below which ``fraction`` of the positions' power lies.

    Each column of ``positions`` (N, 6) [m or rad] sampled every ``step`` [s] has its mean
    and linear trend removed and a Hann window applied; the bandwidth is the largest over
    the columns that move.

    Raises:
        LogError: no column moves (nothing excites the dynamics).
    """
    q = np.asarray(positions, dtype=float)
    n = q.shape[0]
    if n < 8:
        raise LogError(f"{n} samples: too few to find the excitation bandwidth (8 or more)")
    detrended = scipy.signal.detrend(q, axis=0, type="linear")
    power = np.abs(np.fft.rfft(detrended * np.hanning(n)[:, None], axis=0)) ** 2
    freqs = np.fft.rfftfreq(n, step)
    total = power.sum(axis=0)
    best = 0.0
    moving = total > 0
    if not np.any(moving):
        raise LogError(
            "the actuator positions do not move: no excitation to identify from (run an "
            "exciting trajectory)"
        )
    cumulative = np.cumsum(power[:, moving], axis=0) / total[moving]
    for c in range(cumulative.shape[1]):
        k = int(np.searchsorted(cumulative[:, c], fraction))
        best = max(best, float(freqs[min(k, len(freqs) - 1)]))
    return best


def noise_correlation(taps: np.ndarray, decimation: int) -> float:
    """``kappa = sum_l sum_k h_k h_(k + l D) / sum_k h_k^2``: the long-run variance of
    white noise filtered by ``taps`` and kept every ``decimation`` samples, over its
    variance (1 for no filter)."""
    h = np.asarray(taps, dtype=float)
    full = np.correlate(h, h, mode="full")  # lags -(L-1)..(L-1)
    centre = len(h) - 1
    lags = np.arange(-(centre // decimation), centre // decimation + 1) * decimation + centre
    return float(full[lags].sum() / full[centre])


@dataclass(frozen=True)
class FilterDesign:
    """The filters of a log (module docstring).

    Attributes:
        sample_rate: ``fs`` [Hz], 1 / the median step.
        bandwidth: the excitation bandwidth [Hz] it was designed from.
        cutoff: the state filter's cut-off ``fc`` [Hz].
        method: ``"butterworth"`` or ``"savgol"``.
        order: Butterworth order (applied twice) or Savitzky-Golay polynomial order.
        window: the Savitzky-Golay window [samples] (0 for Butterworth).
        edge: samples dropped at each end (the state filter's transient).
        decimation: D, the decimation factor (1: none).
        taps: the decimation FIR filter, shape (16 D + 1,), unit DC gain (``[1.0]`` for
            D = 1).
        kappa: the decimated noise's long-run variance over its variance.
    """

    sample_rate: float
    bandwidth: float
    cutoff: float
    method: str
    order: int
    window: int
    edge: int
    decimation: int
    taps: np.ndarray
    kappa: float

    @property
    def half(self) -> int:
        """Half the FIR length [samples]."""
        return (len(self.taps) - 1) // 2

    @property
    def decimated_rate(self) -> float:
        """Rate of the decimated equations [Hz]."""
        return self.sample_rate / self.decimation

    def describe(self) -> str:
        """One paragraph for reports."""
        if self.method == "butterworth":
            state = (
                f"Butterworth order {self.order} forward and backward, cut-off "
                f"{self.cutoff:.4g} Hz"
            )
        else:
            state = (
                f"Savitzky-Golay order {self.order}, window {self.window} samples (cut-off "
                f"~{self.cutoff:.4g} Hz)"
            )
        dec = (
            f"parallel decimation by {self.decimation} ({len(self.taps)}-tap FIR, cut-off "
            f"{FIR_CUTOFF * self.decimated_rate / 2:.4g} Hz; noise correlation factor "
            f"{self.kappa:.4g})"
            if self.decimation > 1
            else "no decimation"
        )
        return (
            f"sample rate {self.sample_rate:.6g} Hz; excitation bandwidth "
            f"{self.bandwidth:.4g} Hz; state filter: {state}; {self.edge} samples dropped "
            f"at each end; {dec}"
        )


def design_filters(
    log: ActuatorLog,
    cutoff: float | None = None,
    decimation: int | None = None,
    method: str = "butterworth",
) -> FilterDesign:
    """The filters for ``log`` (module docstring): the cut-off from the excitation
    bandwidth unless given [Hz], the decimation factor from the cut-off unless given.

    Raises:
        InputError: an unknown method, a cut-off outside (0, Nyquist), or a decimation
            factor whose filter (``2 FIR_HALF D + 1`` samples) is longer than the log less
            the state filter's edges (no decimated equation; a factor of 100 000 would
            otherwise design a filter of 1.6 million taps).
        LogError: a log without excitation."""
    if method not in METHODS:
        raise InputError(f"unknown filter method {method!r}: one of {METHODS}")
    fs = log.sample_rate
    bandwidth = excitation_bandwidth(log.positions, 1.0 / fs)
    if cutoff is None:
        fc = min(CUTOFF_FACTOR * bandwidth, MAX_CUTOFF * fs)
    else:
        fc = float(cutoff)
        if not (math.isfinite(fc) and 0 < fc < 0.5 * fs):
            raise InputError(
                f"cutoff must be in (0, {0.5 * fs:.6g}) Hz (below the Nyquist frequency of "
                f"the log), got {cutoff}"
            )
    if fc <= 0:
        raise LogError(f"{log.source}: zero excitation bandwidth; nothing to identify from")
    if decimation is None:
        D = max(
            math.floor(FIR_CUTOFF * fs / (2 * DECIMATION_BANDWIDTH * bandwidth)),
            math.ceil(FIR_CUTOFF * fs / fc - 1e-9),
            1,
        )
    else:
        if isinstance(decimation, bool) or int(decimation) != decimation or decimation < 1:
            raise InputError(f"decimation must be a positive integer, got {decimation!r}")
        D = int(decimation)
    if method == "butterworth":
        order, window = BUTTERWORTH_ORDER, 0
        edge = math.ceil(EDGE_PERIODS * fs / fc)
    else:
        order = SAVGOL_ORDER
        window = round((4.0 * fs / fc + 4.6) / 3.2)
        window = max(window + (window + 1) % 2, order + 2 + (order + 1) % 2)  # odd, > order
        edge = window // 2 + 1
    span = 2 * FIR_HALF * D + 1  # the decimation filter's window [samples]
    usable = len(log) - 2 * edge  # what the state filter leaves
    if span > usable:
        longest = max((usable - 1) // (2 * FIR_HALF), 0)
        given = "" if decimation is None else " given"
        raise InputError(
            f"{log.source}: decimation factor {D}{given} needs a decimation filter of "
            f"{span} samples (2 x {FIR_HALF} x {D} + 1), more than the {max(usable, 0)} the "
            f"log's {len(log)} samples leave after the state filter's {edge} at each end: "
            + (
                f"give a decimation factor of {longest} or less"
                if longest >= 1
                else "the log is too short for this cut-off (record longer)"
            )
        )
    if D > 1:
        taps = scipy.signal.firwin(2 * FIR_HALF * D + 1, FIR_CUTOFF / D, window="hamming")
        taps = taps / taps.sum()
    else:
        taps = np.ones(1)
    return FilterDesign(
        sample_rate=fs,
        bandwidth=bandwidth,
        cutoff=fc,
        method=method,
        order=order,
        window=window,
        edge=edge,
        decimation=D,
        taps=taps,
        kappa=noise_correlation(taps, D),
    )


# ====================================================================== filtering


def filter_positions(
    design: FilterDesign, positions: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, qdot, qddot)`` (N, 6) each: the positions filtered by the state filter, and
    their first and second derivatives [per s, per s^2] (module docstring, step 2)."""
    q = np.asarray(positions, dtype=float)
    dt = 1.0 / design.sample_rate
    if q.shape[0] <= 2 * design.edge + 2:
        raise LogError(
            f"{q.shape[0]} samples: the state filter drops {design.edge} at each end; the log "
            "is too short for this cut-off (record longer, or raise the cut-off)"
        )
    if design.method == "butterworth":
        sos = scipy.signal.butter(design.order, design.cutoff, fs=design.sample_rate, output="sos")
        pad = min(q.shape[0] - 1, 3 * design.edge)
        qf = scipy.signal.sosfiltfilt(sos, q, axis=0, padtype="odd", padlen=pad)
        qd = np.empty_like(qf)
        qdd = np.empty_like(qf)
        # Fourth-order central differences (the first and last two samples are in the
        # dropped edges: copied from their neighbours).
        qd[2:-2] = (qf[:-4] - 8 * qf[1:-3] + 8 * qf[3:-1] - qf[4:]) / (12 * dt)
        qdd[2:-2] = (-qf[:-4] + 16 * qf[1:-3] - 30 * qf[2:-2] + 16 * qf[3:-1] - qf[4:]) / (
            12 * dt**2
        )
        for x in (qd, qdd):
            x[:2], x[-2:] = x[2], x[-3]
        return qf, qd, qdd
    args = {"window_length": design.window, "polyorder": design.order, "axis": 0}
    qf = scipy.signal.savgol_filter(q, **args)
    qd = scipy.signal.savgol_filter(q, deriv=1, delta=dt, **args)
    qdd = scipy.signal.savgol_filter(q, deriv=2, delta=dt, **args)
    return qf, qd, qdd


def smooth(design: FilterDesign, x: np.ndarray) -> np.ndarray:
    """``x`` (N, ...) through the state filter alone (no derivative): the same zero-phase
    Butterworth (or Savitzky-Golay smoothing) the positions see."""
    x = np.asarray(x, dtype=float)
    if design.method == "butterworth":
        sos = scipy.signal.butter(design.order, design.cutoff, fs=design.sample_rate, output="sos")
        pad = min(x.shape[0] - 1, 3 * design.edge)
        return np.asarray(scipy.signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=pad))
    return np.asarray(
        scipy.signal.savgol_filter(x, window_length=design.window, polyorder=design.order, axis=0)
    )


def raw_velocity_signs(
    design: FilterDesign, positions: np.ndarray, box: bool = False
) -> np.ndarray:
    """``sign(qdot)`` (N, 6) of the unfiltered positions' velocities (fourth-order central
    differences; the two samples at each end copied from their neighbours).

    ``box=False``: the sign at each sample (a log whose efforts are samples).
    ``box=True``: the mean of the sign over ``[t_k - step/2, t_k + step/2]``, the velocity
    taken linear between samples, so a reversal inside that interval gives the fraction
    of it spent on each side (a log of held efforts: the held values' half-sample shift
    makes the efforts such averages, and a Coulomb flip that a digital controller only
    answers at its next sample would otherwise be placed up to half a step off)."""
    q = np.asarray(positions, dtype=float)
    v = np.empty_like(q)
    v[2:-2] = (q[:-4] - 8 * q[1:-3] + 8 * q[3:-1] - q[4:]) * (design.sample_rate / 12)
    v[:2], v[-2:] = v[2], v[-3]
    if not box:
        return np.asarray(coulomb_sign(v), dtype=float)
    mid = np.empty_like(v)  # the velocity at t_k - step/2
    mid[1:] = 0.5 * (v[1:] + v[:-1])
    mid[0] = v[0]
    after = np.empty_like(v)  # at t_k + step/2
    after[:-1] = mid[1:]
    after[-1] = v[-1]
    return 0.5 * (_mean_sign(mid, v) + _mean_sign(v, after))


def _mean_sign(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The mean of ``sign`` over a segment on which the value goes linearly from ``a`` to
    ``b`` (elementwise)."""
    sa, sb = coulomb_sign(a), coulomb_sign(b)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.abs(a) / (np.abs(a) + np.abs(b))  # where the zero is, from a
    crossing = (sa * sb) < 0
    return np.where(crossing, sa * z + sb * (1.0 - z), 0.5 * (sa + sb))


def decimation_centres(design: FilterDesign, n: int) -> np.ndarray:
    """Indices of the samples the decimated equations are centred on: every D-th sample
    whose FIR window lies inside ``[edge, n - edge)``."""
    first = design.edge + design.half
    last = n - design.edge - design.half - 1
    if last < first:
        return np.zeros(0, dtype=np.int64)
    return np.arange(first, last + 1, design.decimation, dtype=np.int64)


def fir_decimate(x: np.ndarray, taps: np.ndarray, centres: np.ndarray, offset: int) -> np.ndarray:
    """``y_m = sum_j h_j x[c_m + j - half - offset]``: the FIR filter ``taps`` (symmetric,
    length 2 half + 1) applied along axis 0 of ``x`` and evaluated at the sample indices
    ``centres`` (of the full log; ``x`` starts at sample ``offset``). Exact: the same
    numbers as filtering the whole log, for every centre whose window ``x`` covers."""
    half = (len(taps) - 1) // 2
    idx = np.asarray(centres) - offset
    if idx.size and (idx[0] - half < 0 or idx[-1] + half >= x.shape[0]):
        raise InputError("fir_decimate: x does not cover the FIR windows of the centres")
    if half == 0:
        return np.array(x[idx] * taps[0])
    out = np.zeros((len(idx), *x.shape[1:]))
    for j, h in enumerate(taps):
        out += h * x[idx + (j - half)]
    return out


# ====================================================================== poses and states


def _actuated(robot: RobotLike) -> tuple[np.ndarray, np.ndarray]:
    """``(index (6,) of the actuated joint in each leg, revolute (6,))``."""
    legs = robot.description.leg_architectures
    a = np.array([leg.actuated - 1 for leg in legs])
    revolute = np.array([leg.joints[leg.actuated - 1].revolute for leg in legs])
    return a, revolute


def _wrap(x: np.ndarray) -> np.ndarray:
    return np.asarray((x + math.pi) % (2 * math.pi) - math.pi, dtype=float)


def _step(T: np.ndarray, dV: np.ndarray) -> np.ndarray:
    """``p += dv``, ``R <- exp(dw) R`` for batches (N, 4, 4), (N, 6)."""
    out = T.copy()
    out[:, :3, 3] += dV[:, :3]
    out[:, :3, :3] = so3_exp(dV[:, 3:]) @ T[:, :3, :3]
    return out


def _newton_block(
    robot: RobotLike, targets: np.ndarray, guesses: np.ndarray, revolute: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Batched Newton on SE(3): ``(poses, converged (B,))``."""
    T = guesses.copy()
    done = np.zeros(len(T), dtype=bool)
    for _ in range(TRACK_ITERATIONS + 1):
        todo = np.flatnonzero(~done)
        if todo.size == 0:
            break
        try:
            qa = robot.actuator_positions(T[todo])
            error = targets[todo] - qa
            error = np.where(revolute, _wrap(error), error)
            ok = np.all(np.abs(error) <= TRACK_TOLERANCE, axis=1)
            done[todo[ok]] = True
            todo, error = todo[~ok], error[~ok]
            if todo.size == 0:
                break
            J_inv = robot.inverse_jacobian(T[todo])
            dV = np.linalg.solve(J_inv, error[..., None])[..., 0]
        except (StewartPinError, np.linalg.LinAlgError):
            return T, done
        if not np.all(np.isfinite(dV)):
            return T, done
        T[todo] = _step(T[todo], dV)
    return T, done


def track_poses(
    robot: RobotLike,
    positions: np.ndarray,
    start: np.ndarray,
    lines: np.ndarray | None = None,
    source: str = "log",
) -> np.ndarray:
    """The poses (N, 4, 4) whose actuated joint values are ``positions`` (N, 6), by the
    continuation of the module docstring (step 3), starting from the pose ``start``
    (4, 4), which must solve ``positions[0]`` or lie close to it.

    Raises:
        LogError: the forward geometry fails at a sample (the message names its line,
            ``lines[k]`` or ``k + 2``; the cause is chained).
    """
    q = np.asarray(positions, dtype=float)
    n = q.shape[0]
    _, revolute = _actuated(robot)
    out = np.empty((n, 4, 4))

    def line(k: int) -> int:
        return int(lines[k]) if lines is not None else k + 2

    def one(k: int, guess: np.ndarray) -> np.ndarray:
        try:
            return np.asarray(robot.forward_geometry(q[k], guess), dtype=float)
        except StewartPinError as e:
            raise LogError(
                f"{source}, line {line(k)}: the forward geometry of the actuator positions "
                f"{q[k].tolist()} failed ({type(e).__name__}: {e}); the positions do not "
                "assemble near the previous pose (an encoder jump, a wrong offset, or a "
                "description that does not match the robot)",
                line=line(k),
            ) from e

    out[0] = _first_pose(robot, q[0], np.asarray(start, dtype=float), one)
    k = 1
    while k < n:
        stop = min(n, k + TRACK_BLOCK)
        T_prev = out[k - 1]
        try:
            J_inv = robot.inverse_jacobian(T_prev)
            dV = np.linalg.solve(J_inv, (q[k:stop] - q[k - 1]).T).T
        except (StewartPinError, np.linalg.LinAlgError):
            dV = np.zeros((stop - k, 6))
        dV = np.where(np.isfinite(dV), dV, 0.0)
        guesses = _step(np.broadcast_to(T_prev, (stop - k, 4, 4)), dV)
        T, ok = _newton_block(robot, q[k:stop], guesses, revolute)
        if ok.all() and _continuous(out[k - 1], T, dV):
            out[k:stop] = T
        else:
            for j in range(k, stop):
                out[j] = one(j, out[j - 1])
        k = stop
    return out


def _first_pose(robot: RobotLike, q0: np.ndarray, guess: np.ndarray, one: Any) -> np.ndarray:
    """The pose of the first sample: Newton from ``guess``; if that fails, a homotopy from
    the home pose, its actuator positions moved to ``q0`` in 8, then 64 steps, each
    solved from the previous (the assembly mode of the home pose)."""
    try:
        return np.asarray(robot.forward_geometry(q0, guess), dtype=float)
    except StewartPinError:
        pass
    home = np.asarray(robot.home_pose, dtype=float)
    q_home = np.asarray(robot.actuator_positions(home), dtype=float)
    _, revolute = _actuated(robot)
    delta = np.where(revolute, _wrap(q0 - q_home), q0 - q_home)
    for steps in (8, 64):
        T = home
        try:
            for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
                T = np.asarray(robot.forward_geometry(q_home + s * delta, T), dtype=float)
            return T
        except StewartPinError:
            continue
    return np.asarray(one(0, guess), dtype=float)  # raises the named error


def _continuous(T_prev: np.ndarray, T: np.ndarray, dV: np.ndarray) -> bool:
    """Whether the block's poses stay near the first-order prediction (no jump to another
    assembly mode): each position within 10 times the predicted motion, plus 1 um."""
    predicted = T_prev[:3, 3] + dV[:, :3]
    moved = np.linalg.norm(dV[:, :3], axis=1)
    off = np.linalg.norm(T[:, :3, 3] - predicted, axis=1)
    return bool(np.all(off <= 10.0 * moved + 1e-6))


def platform_states(
    robot: RobotLike, poses: np.ndarray, qdot: np.ndarray, qddot: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(twists, accels)`` (N, 6) each from the poses and the actuated joints' rates and
    accelerations: ``V = Jp qdot_a``, ``A = Jp (qddot_a - b(T, V))`` (classical
    ``[dv/dt, dw/dt]`` in F0; ``b`` the actuated joints' accelerations at zero platform
    acceleration)."""
    a, _ = _actuated(robot)
    J_inv = robot.inverse_jacobian(poses)
    V = np.linalg.solve(J_inv, qdot[..., None])[..., 0]
    _, _, qdd0 = robot.leg_kinematics(poses, V, np.zeros_like(V))
    assert qdd0 is not None
    # the legs' joint values are the description's: b in the robot's actuator convention
    b = actuator_convention_of(robot).rates_from_description(qdd0[:, np.arange(6), a])
    A = np.linalg.solve(J_inv, (qddot - b)[..., None])[..., 0]
    return V, A


@dataclass(frozen=True, eq=False)
class EstimatedStates:
    """Platform states estimated from a log, on the samples the filters leave.

    Attributes:
        times: shape (N,) [s].
        poses: shape (N, 4, 4), 0Tp.
        twists: shape (N, 6).
        accels: shape (N, 6), classical.
        efforts: shape (N, 6), as logged, or the held efforts' averages
            (:meth:`~stewart_pin.parameters.logs.ActuatorLog.effort_samples`).
        index: shape (N,), the samples of the log they are.
        design: the filters.
    """

    times: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    accels: np.ndarray
    efforts: np.ndarray
    index: np.ndarray
    design: FilterDesign

    def __len__(self) -> int:
        return int(self.times.shape[0])


def start_pose(robot: RobotLike, log: ActuatorLog, k: int) -> np.ndarray:
    """The forward geometry's first guess for sample ``k``: the tracker's pose, else the
    home pose."""
    if log.tracker_poses is not None:
        return np.array(log.tracker_poses[k])
    return np.asarray(robot.home_pose, dtype=float)


def estimate_states(
    robot: RobotLike, log: ActuatorLog, design: FilterDesign | None = None
) -> EstimatedStates:
    """The platform states of every sample the state filter leaves (module docstring,
    steps 1-4; no decimation), after :func:`~stewart_pin.parameters.logs.check_log`.
    Memory grows with the log: for long logs use
    :func:`stewart_pin.parameters.identification.identify_log`, which works in chunks."""
    check_log(log, robot)
    design = design or design_filters(log)
    q, qd, qdd = filter_positions(design, log.positions)
    sl = slice(design.edge, len(log) - design.edge)
    index = np.arange(len(log))[sl]
    lines = np.arange(len(log)) + 2 if log.lines is None else log.lines
    poses = track_poses(robot, q[sl], start_pose(robot, log, design.edge), lines[sl], log.source)
    twists, accels = platform_states(robot, poses, qd[sl], qdd[sl])
    efforts = log.effort_samples(design.edge, len(log) - design.edge)
    return EstimatedStates(log.times[sl], poses, twists, accels, efforts, index, design)


class StateStream:
    """The states of a long log batch by batch, for the parallel decimation.

    The filtered positions, their derivatives, the filtered efforts and velocity signs
    are kept for the whole log (6 floats a sample each); :meth:`batches` solves the poses
    of consecutive runs of samples (each pose once, the continuation carried across
    batches) and yields their states.
    """

    def __init__(self, robot: RobotLike, log: ActuatorLog, design: FilterDesign) -> None:
        self.robot, self.log, self.design = robot, log, design
        if len(log) < 2:
            raise LogTimeError(f"{log.source}: too few samples")
        self.q, self.qd, self.qdd = filter_positions(design, log.positions)
        # Both sides through the state filter: the efforts, and the signs of the raw
        # velocities (the actuated joints' Coulomb columns).
        self.efforts = smooth(design, log.effort_samples(0, len(log)))
        signs = raw_velocity_signs(design, log.positions, box=log.effort_hold)
        self.signs = smooth(design, signs)
        self.centres = decimation_centres(design, len(log))
        self.lines = np.arange(len(log)) + 2 if log.lines is None else log.lines

    def batches(
        self, start: int, stop: int, size: int
    ) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Yield ``(a, poses, twists, accels, efforts, signs)`` for consecutive runs
        ``a : a + len(poses)`` of at most ``size`` samples covering ``start:stop``: the
        states, and the efforts and actuated joints' velocity signs through the state
        filter."""
        q, lines, src = self.q, self.lines, self.log.source
        previous: np.ndarray | None = None
        for a in range(start, stop, max(int(size), 1)):
            b = min(stop, a + size)
            if previous is None:
                first = start_pose(self.robot, self.log, a)
                poses = track_poses(self.robot, q[a:b], first, lines[a:b], src)
            else:  # continued from the previous batch's last pose
                poses = track_poses(self.robot, q[a - 1 : b], previous, lines[a - 1 : b], src)
                poses = poses[1:]
            previous = poses[-1]
            V, A = platform_states(self.robot, poses, self.qd[a:b], self.qdd[a:b])
            yield a, poses, V, A, self.efforts[a:b], self.signs[a:b]


class PolyphaseDecimator:
    """The FIR filter ``taps`` evaluated at ``centres`` on a signal that arrives in
    consecutive batches: ``y_m = sum_j h_j x[c_m + j - half]``, each input sample used
    once (no overlap recomputed); outputs are released as soon as their window is
    complete. The same numbers as :func:`fir_decimate` on the whole signal."""

    def __init__(self, taps: np.ndarray, centres: np.ndarray) -> None:
        self.h = np.asarray(taps, dtype=float)
        self.half = (len(self.h) - 1) // 2
        self.centres = np.asarray(centres, dtype=np.int64)
        self.next = 0  # first output not yet released
        self.open: dict[int, list[np.ndarray]] = {}

    def push(self, a: int, *signals: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Add samples ``a : a + n`` of each signal (n, ...); return the indices of the
        outputs completed (into ``centres``) and their values, one array per signal."""
        n = signals[0].shape[0]
        b = a + n
        c, h, half = self.centres, self.h, self.half
        m0 = int(np.searchsorted(c, a - half, side="left"))  # ends >= a
        m1 = int(np.searchsorted(c, b + half, side="left"))  # starts < b
        for m in range(max(m0, self.next), m1):
            if m not in self.open:
                self.open[m] = [np.zeros(x.shape[1:]) for x in signals]
            lo, hi = max(a, int(c[m]) - half), min(b, int(c[m]) + half + 1)
            taps = h[lo - (int(c[m]) - half) : hi - (int(c[m]) - half)]
            for acc, x in zip(self.open[m], signals, strict=True):
                acc += np.tensordot(taps, x[lo - a : hi - a], axes=1)
        done = int(np.searchsorted(c, b - half, side="left"))  # windows ending before b
        idx = np.arange(self.next, max(done, self.next))
        finished = [self.open.pop(int(m)) for m in idx]
        values = [
            np.array([f[k] for f in finished]).reshape(len(idx), *x.shape[1:])
            for k, x in enumerate(signals)
        ]
        self.next = max(self.next, done)
        return idx, values


__all__ = [
    "BANDWIDTH_FRACTION",
    "CUTOFF_FACTOR",
    "EstimatedStates",
    "FilterDesign",
    "PolyphaseDecimator",
    "StateStream",
    "decimation_centres",
    "design_filters",
    "estimate_states",
    "excitation_bandwidth",
    "filter_positions",
    "fir_decimate",
    "noise_correlation",
    "platform_states",
    "raw_velocity_signs",
    "smooth",
    "track_poses",
]
