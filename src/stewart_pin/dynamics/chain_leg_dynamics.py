"""Inverse and direct dynamics of robots with chain legs (any 1-dof joints, ball or weld
closure; Khalil & Ibrahim 2007, ``docs/legs.md`` "Chain legs and welds").

Each leg's joint-space dynamics come from Pinocchio on its own serial model (CRBA with the
armature, ``model.armature``; nonlinear effects with gravity) plus the joint terms:

    H_i = A_i qddot_i + h_i,   h_i = nle(q, qdot) + (Fv + D) qdot + Fc sign(qdot) + K (q - q0)

(``sign`` with :data:`~stewart_pin.description.leg_architecture.COULOMB_DEAD_BAND`). With
the leg kinematics of :mod:`stewart_pin.kinematics.chain_legs` (``J_i`` c x n, ``G_i``,
``K_i = J_i^-1 G_i``, ``k_i = J_i^-1 (d_i - Jdot_i qdot_i)``, so ``qddot_i = K_i Vdot +
k_i``):

- IDM: ``Jp^-T Gamma = F_p + sum_i G_i^T J_i^-T H_i`` (the leg's wrench on the platform
  at P_i: ball a force, weld a force and a moment), ``Jp^-1`` rows ``e_a^T K_i``;
- DDM: ``(Ip + sum G_i^T J_i^-T A_i K_i) Vdot = Jp^-T Gamma - bias - sum G_i^T J_i^-T
  (A_i k_i + h_i)``, solved by Cholesky (the matrix is symmetric positive definite:
  ``G^T J^-T A J^-1 G``).

Batches: poses (N, 4, 4), twists and classical accelerations (N, 6) in F0; efforts are
the actuated joints', joint side [N or N m].
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from stewart_pin._checks import check_array, check_poses, check_states
from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin.description import RobotDescription
from stewart_pin.description.chain_leg import ChainLeg
from stewart_pin.description.inertia import KHALIL_NAMES, PIN_TO_KHALIL
from stewart_pin.description.leg_architecture import coulomb_sign
from stewart_pin.dynamics.closed_loop import (
    check_finite,
    closure_direct_dynamics,
    platform_energy,
    platform_terms,
)
from stewart_pin.exceptions import InputError
from stewart_pin.kinematics import chain_legs as kin
from stewart_pin.kinematics.jacobians import MAX_CONDITION
from stewart_pin.models.chain_legs import build_chain_leg


def chain_parameters(desc: RobotDescription) -> tuple[np.ndarray, tuple[str, ...]]:
    """The standard parameters ``chi`` of a robot with chain legs and their names, in the
    order of :meth:`ChainDynamics.regressor_batch`'s columns: each leg's links (Khalil's
    ``XX XY XZ YY YZ ZZ MX MY MZ M``, link j of leg i named ``XX_i_j``...), the platform's
    (``XX_P``...), each leg joint's ``IA FV FC K OF`` (armature, viscous + damper,
    Coulomb, stiffness, ``-K q0``)."""
    legs = kin.chain_legs_of(desc)
    khalil = KHALIL_NAMES
    values: list[float] = []
    names: list[str] = []
    for i, leg in enumerate(legs, start=1):
        for j in range(leg.n_joints):
            values += leg.inertia[j].tolist()
            names += [f"{p}_{i}_{j + 1}" for p in khalil]
    values += desc.platform_inertia.tolist()
    names += [f"{p}_P" for p in khalil]
    for i, leg in enumerate(legs, start=1):
        for j, joint in enumerate(leg.joints, start=1):
            d = joint.dynamics
            values += [
                d.total_armature,
                d.viscous + d.damping,
                d.coulomb,
                d.stiffness,
                -d.stiffness * d.rest_position,
            ]
            names += [f"{p}_{i}_{j}" for p in ("IA", "FV", "FC", "K", "OF")]
    return np.array(values), tuple(names)


def leg_model(desc: RobotDescription, k: int) -> pin.Model:
    """Leg k's serial Pinocchio model: fixed base at frame 0k, joints RZ / PZ placed by
    their MDH transforms, links' inertia, ``model.armature``, the robot's gravity
    (:func:`~stewart_pin.models.chain_legs.build_chain_leg`)."""
    return build_chain_leg(desc, k)


def compensated_model(model: pin.Model, leg: ChainLeg) -> pin.Model | None:
    """A copy of leg ``model`` (:func:`leg_model`) whose link j has its mass and first
    moments scaled by its gravity compensation ``c_j`` (``leg.gravcomp``): its generalized
    gravity is the joint efforts of the forces ``c_j m_j g`` at the centres of mass, its
    potential energy theirs. ``None`` when no link has a compensation."""
    if not np.any(leg.gravcomp):
        return None
    out = pin.Model(model)
    for j, c in enumerate(leg.gravcomp):
        I = out.inertias[j + 1]
        out.inertias[j + 1] = pin.Inertia(float(c) * I.mass, I.lever, float(c) * I.inertia)
    return out


@dataclass(frozen=True)
class ChainJointTerms:
    """One leg's joint terms (n,) each: viscous + damper, Coulomb, spring and its rest
    position, transmission ratio."""

    viscous: np.ndarray
    coulomb: np.ndarray
    stiffness: np.ndarray
    rest: np.ndarray
    ratio: np.ndarray

    @classmethod
    def of(cls, leg: ChainLeg) -> ChainJointTerms:
        d = [j.dynamics for j in leg.joints]
        return cls(
            np.array([x.viscous + x.damping for x in d]),
            np.array([x.coulomb for x in d]),
            np.array([x.stiffness for x in d]),
            np.array([x.rest_position for x in d]),
            np.array([x.transmission_ratio for x in d]),
        )

    def efforts(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """(N, n) friction, damper and spring efforts [N m or N]."""
        return (
            self.viscous * qdot
            + self.coulomb * coulomb_sign(qdot)
            + self.stiffness * (q - self.rest)
        )


class ChainLegModels:
    """The six legs' Pinocchio models and joint terms."""

    def __init__(self, desc: RobotDescription) -> None:
        self.desc = desc
        self.legs = kin.chain_legs_of(desc)
        self.models = [leg_model(desc, k) for k in range(6)]
        self.datas = [m.createData() for m in self.models]
        self.terms = [ChainJointTerms.of(leg) for leg in self.legs]
        #: each leg's model with its links' compensated weights (or None without any)
        self.compensated = [
            compensated_model(m, leg) for m, leg in zip(self.models, self.legs, strict=True)
        ]
        self._compensated_datas = [None if m is None else m.createData() for m in self.compensated]

    def compensation_efforts(self, k: int, q: np.ndarray) -> np.ndarray:
        """``g_c`` (N, n) [N m or N]: the joint efforts of leg k's links' gravity
        compensation (module docstring), zeros when no link has one."""
        model, data = self.compensated[k], self._compensated_datas[k]
        if model is None:
            return np.zeros(q.shape)
        return np.array([pin.computeGeneralizedGravity(model, data, x) for x in q])

    def mass_and_bias(
        self, k: int, q: np.ndarray, qdot: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Leg k's ``A_k`` (N, n, n) (armature included) and ``h_k`` (N, n) (joint terms
        included, less the links' gravity compensation)."""
        model, data = self.models[k], self.datas[k]
        N, n = q.shape
        M, h = np.empty((N, n, n)), np.empty((N, n))
        for s in range(N):
            m = pin.crba(model, data, q[s])
            M[s] = np.triu(m) + np.triu(m, 1).T
            h[s] = pin.nonLinearEffects(model, data, q[s], qdot[s])
        h += self.terms[k].efforts(q, qdot)
        if self.compensated[k] is not None:
            h -= self.compensation_efforts(k, q)
        return M, h

    def energy(self, k: int, q: np.ndarray, qdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Leg k's kinetic (armature included) and potential (gravity less its
        compensation, springs) energy, each (N,) [J]."""
        model, data = self.models[k], self.datas[k]
        M, _ = self.mass_and_bias(k, q, np.zeros_like(qdot))
        kinetic = 0.5 * np.einsum("ni,nij,nj->n", qdot, M, qdot)
        potential = np.array([pin.computePotentialEnergy(model, data, x) for x in q])
        compensated, cdata = self.compensated[k], self._compensated_datas[k]
        if compensated is not None:
            potential -= [pin.computePotentialEnergy(compensated, cdata, x) for x in q]
        t = self.terms[k]
        return kinetic, potential + 0.5 * ((q - t.rest) ** 2) @ t.stiffness


@dataclass(frozen=True)
class ChainInverseDynamics:
    """The inverse model with its terms (batches).

    Attributes:
        gamma: (N, 6) actuated efforts, joint side [N or N m].
        motor: (N, 6) ``gamma / ratio``.
        H: six (N, n_i) each leg's joint efforts (joint terms included).
        wrenches: (N, 6, 6) each leg's wrench on the platform about O_p in F0 ``[f, m]``
            [N, N m] (``-G_i^T J_i^-T (H_i - e_a gamma_i)``).
        F_p: (N, 6) the platform's own ``Ip Vdot + bias``.
        J_inv: (N, 6, 6) ``Jp^-1``.
        legs: the leg states.
        idle_accel: (N, 6) the idle joints' accelerations [rad/s^2 or m/s^2] (0 for a leg
        without one).
    """

    gamma: np.ndarray
    motor: np.ndarray
    H: list[np.ndarray]
    wrenches: np.ndarray
    F_p: np.ndarray
    J_inv: np.ndarray
    legs: list[kin.ChainLegState]
    idle_accel: np.ndarray


@dataclass(frozen=True)
class ChainCartesianDynamics:
    """``A_robot Vdot + h_robot = Jp^-T Gamma``: A_robot (N, 6, 6), h_robot (N, 6), J_inv
    (N, 6, 6), legs (qddot zero); idle legs: ``idle_gain`` (N, 6, 6) and ``idle_bias``
    (N, 6) give the idle joints' accelerations ``idle_gain Vdot + idle_bias``."""

    A_robot: np.ndarray
    h_robot: np.ndarray
    J_inv: np.ndarray
    legs: list[kin.ChainLegState]
    idle_gain: np.ndarray
    idle_bias: np.ndarray


def _transpose_solve(J: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``J^-T x`` for batches J (N, m, m), x (N, m)."""
    return np.asarray(np.linalg.solve(np.swapaxes(J, 1, 2), x[..., None])[..., 0])


def _vec(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Batched ``x y``: (N, a, b) times (N, b)."""
    return np.einsum("nij,nj->ni", x, y)


class ChainDynamics:
    """The dynamic models of a robot with chain legs, for one state or a batch.

    A leg with an idle joint (``ChainLeg.idle_joint``, e.g. an R-S-S rod's spin) adds that
    joint's value and rate to the robot's state: give them as ``idle=(values, rates)``,
    each (6,) or (N, 6) (entries of legs without one ignored), to every model below; the
    inverse model returns the idle accelerations (``details=True``: ``idle_accel``), the
    direct model too (:meth:`direct_dynamics_idle`). Such a robot's models refuse to run
    without ``idle`` (:class:`InputError`): no silent assumption about the spin; a robot
    without idle joints refuses one (:class:`InputError`: it would be ignored).

    Args:
        desc: a description with ``chain_legs``. max_condition: the parallel singularity
            threshold. check_limits: refuse states with a joint outside its limits.
    """

    def __init__(
        self,
        desc: RobotDescription,
        max_condition: float = MAX_CONDITION,
        check_limits: bool = False,
    ) -> None:
        self.desc = desc
        self.max_condition = max_condition
        self.check_limits = check_limits
        self.legs = ChainLegModels(desc)
        self.actuated = np.array([leg.actuated - 1 for leg in self.legs.legs])
        self.ratio = np.array(
            [t.ratio[a] for t, a in zip(self.legs.terms, self.actuated, strict=True)]
        )
        self.idle_legs = [k for k, leg in enumerate(self.legs.legs) if leg.idle_joint is not None]

    def _idle(self, idle: Any, n: int) -> kin.IdleState | None:
        return self.idle_state(idle, n)

    def idle_state(self, idle: Any, n: int) -> kin.IdleState | None:
        """The idle state for a batch of n states from ``idle`` ``(values, rates)``, each
        (6,) or (n, 6) [rad or m, /s] (:class:`InputError` when required and missing,
        given to a robot without idle joints, of the wrong shape or not finite); ``None``
        for a robot without idle joints."""
        if not self.idle_legs:
            if idle is not None:
                raise InputError(
                    f"robot '{self.desc.name}' has no idle joints (ChainLeg.idle_joint): "
                    "give idle=None (its state is the pose and twist only)"
                )
            return None
        if idle is None:
            legs = ", ".join(
                f"leg {k + 1} joint {self.legs.legs[k].idle_joint}" for k in self.idle_legs
            )
            raise InputError(
                f"robot '{self.desc.name}' has idle freedoms ({legs}): their values and rates "
                "are part of the robot's state; give idle=(values, rates), each (6,) or "
                "(N, 6) [rad or m, /s], to robot.chain_dynamics' models (simulation: "
                "stewart_pin.motion.idle_simulation.simulate_idle)"
            )
        if isinstance(idle, kin.IdleState):
            return idle
        try:
            values, rates = idle
        except (TypeError, ValueError) as e:
            raise InputError("idle must be (values, rates), each (6,) or (N, 6)") from e
        out = []
        for name, x in (("idle values", values), ("idle rates", rates)):
            a = np.asarray(x, dtype=float)
            a = np.broadcast_to(a, (n, 6)) if a.shape == (6,) else check_array(a, (n, 6), name)
            if not np.all(np.isfinite(a)):
                raise InputError(f"{name} must be finite")
            out.append(np.array(a))
        return kin.IdleState(out[0], out[1])

    # ------------------------------------------------------------------ kinematics
    def states(
        self,
        T: np.ndarray,
        V: np.ndarray,
        A: np.ndarray | None,
        idle: kin.IdleState | None = None,
    ) -> tuple[list[kin.ChainLegState], np.ndarray]:
        legs = kin.leg_states(self.desc, T, V, A, self.check_limits, idle)
        J_inv = kin.inverse_jacobian(self.desc, legs)
        kin.check_parallel(self.desc, J_inv, self.max_condition)
        return legs, J_inv

    # ------------------------------------------------------------------ batches
    def inverse_batch(
        self, T: np.ndarray, V: np.ndarray, A: np.ndarray, idle: Any = None
    ) -> ChainInverseDynamics:
        legs, J_inv = self.states(T, V, A, self._idle(idle, T.shape[0]))
        plat = platform_terms(self.desc, T, V)
        F_p = _vec(plat.inertia, A) + plat.bias
        total = F_p.copy()
        H_all, parts = [], []
        idle_accel = np.zeros((T.shape[0], 6))
        for k, s in enumerate(legs):
            M, h = self.legs.mass_and_bias(k, s.q, s.qdot)
            qddot = s.qddot
            if s.null is not None:  # the idle joint's acceleration: null^T H = 0
                sigma = -np.einsum("ni,ni->n", s.null, _vec(M, qddot) + h) / np.einsum(
                    "ni,nij,nj->n", s.null, M, s.null
                )
                qddot = qddot + s.null * sigma[:, None]
                idle_accel[:, k] = sigma
            H = _vec(M, qddot) + h
            w = _vec(np.swapaxes(s.KG, 1, 2), H)  # G^T J^-T H
            total += w
            H_all.append(H)
            parts.append(w)
        gamma = check_finite(_transpose_solve(J_inv, total), "inverse dynamics Gamma")
        # each leg's wrench on the platform: -G^T J^-T (H - e_a gamma)
        wrenches = -np.stack(parts, 1) + np.einsum("nki,nk->nki", J_inv, gamma)
        return ChainInverseDynamics(
            gamma, gamma / self.ratio, H_all, wrenches, F_p, J_inv, legs, idle_accel
        )

    def cartesian_batch(
        self, T: np.ndarray, V: np.ndarray, idle: Any = None
    ) -> ChainCartesianDynamics:
        legs, J_inv = self.states(T, V, None, self._idle(idle, T.shape[0]))
        plat = platform_terms(self.desc, T, V)
        A_robot, h_robot = plat.inertia.copy(), plat.bias.copy()
        N = T.shape[0]
        idle_gain, idle_bias = np.zeros((N, 6, 6)), np.zeros((N, 6))
        for k, s in enumerate(legs):
            M, h = self.legs.mass_and_bias(k, s.q, s.qdot)
            K = s.KG  # (N, n, 6)
            kk = _vec(s.J_inv, s.platform_drift - s.drift)
            if s.null is not None:
                # the idle acceleration sigma = -(null^T M (K Vdot + k) + null^T h) / m
                # eliminated: qddot = P (K Vdot + k) - null null^T h / m, P = I - null null^T M / m
                Mn = _vec(M, s.null)  # (N, n)
                m = np.einsum("ni,ni->n", s.null, Mn)
                idle_gain[:, k] = -np.einsum("ni,nij->nj", Mn, K) / m[:, None]
                nh = np.einsum("ni,ni->n", s.null, h)
                idle_bias[:, k] = -(np.einsum("ni,ni->n", Mn, kk) + nh) / m
                MP = M - np.einsum("ni,nj->nij", Mn, Mn) / m[:, None, None]
                hP = h - Mn * (nh / m)[:, None]
            else:
                MP, hP = M, h
            KT = np.swapaxes(K, 1, 2)  # G^T J^-T (N, 6, n)
            A_robot += KT @ MP @ K
            h_robot += _vec(KT, _vec(MP, kk) + hP)
        A_robot = 0.5 * (A_robot + np.swapaxes(A_robot, 1, 2))
        return ChainCartesianDynamics(A_robot, h_robot, J_inv, legs, idle_gain, idle_bias)

    # ------------------------------------------------------------------ the models
    def inverse_dynamics(
        self,
        pose: Any,
        twist: Any,
        accel: Any,
        details: bool = False,
        motor: bool = False,
        idle: Any = None,
    ) -> Any:
        """Actuated efforts (6,) or (N, 6) [N or N m], joint side (``motor``: motor side);
        ``details``: the :class:`ChainInverseDynamics`; ``idle``: the idle joints' state
        (class docstring)."""
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        r = self.inverse_batch(T, V, A, idle)
        if details:
            return r
        out = r.motor if motor else r.gamma
        return out if batched else out[0]

    def direct_dynamics_idle(
        self, pose: Any, twist: Any, gamma: Any, idle: Any = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The platform's classical acceleration (6,) or (N, 6) and the idle joints'
        accelerations (6,) or (N, 6) (0 for legs without one) under the actuated joint-side
        efforts ``gamma``."""
        batched, T, V, G = check_states(pose, (twist, "twist"), (gamma, "gamma"))
        cd = self.cartesian_batch(T, V, idle)
        out = closure_direct_dynamics(cd.A_robot, cd.h_robot, cd.J_inv, G)
        sigma = _vec(cd.idle_gain, out) + cd.idle_bias
        return (out, sigma) if batched else (out[0], sigma[0])

    def direct_dynamics(self, pose: Any, twist: Any, gamma: Any, idle: Any = None) -> np.ndarray:
        """The platform's classical acceleration (6,) or (N, 6) under the actuated
        joint-side efforts ``gamma`` (idle joints: :meth:`direct_dynamics_idle`)."""
        return self.direct_dynamics_idle(pose, twist, gamma, idle)[0]

    def cartesian_dynamics(
        self, pose: Any, twist: Any, idle: Any = None
    ) -> ChainCartesianDynamics:
        _, T, V = check_states(pose, (twist, "twist"))
        return self.cartesian_batch(T, V, idle)

    def energy(self, pose: Any, twist: Any, idle: Any = None) -> tuple[Any, Any]:
        """Kinetic (armature included) and potential (gravity, springs) energy [J] of the
        robot: floats or (N,) arrays."""
        batched, T, V = check_states(pose, (twist, "twist"))
        legs = kin.leg_states(self.desc, T, V, idle=self._idle(idle, T.shape[0]))
        k, u = platform_energy(self.desc, T, V)
        for i, s in enumerate(legs):
            ki, ui = self.legs.energy(i, s.q, s.qdot)
            k, u = k + ki, u + ui
        return (k, u) if batched else (float(k[0]), float(u[0]))

    def dissipated_power(self, pose: Any, twist: Any, idle: Any = None) -> Any:
        """Power lost in friction and dampers [W]: float or (N,)."""
        batched, T, V = check_states(pose, (twist, "twist"))
        legs = kin.leg_states(self.desc, T, V, idle=self._idle(idle, T.shape[0]))
        p = sum(
            (
                t.viscous @ (s.qdot**2).T + t.coulomb @ np.abs(s.qdot).T
                for t, s in zip(self.legs.terms, legs, strict=True)
            ),
            np.zeros(T.shape[0]),
        )
        return p if batched else float(p[0])

    def idle_regressor_state(self, idle: Any, n: int) -> kin.IdleState | None:
        """The idle state of the regressor for n states from ``idle`` ``(values, rates,
        accelerations)``, each (6,) or (n, 6) [rad or m, /s, /s^2]: with the spin
        accelerations given, each idle leg's joint accelerations are known and the efforts
        are linear in the parameters. :class:`InputError` when required and missing, given
        to a robot without idle joints, not three arrays, of the wrong shape or not
        finite; ``None`` for a robot without idle joints."""
        if not self.idle_legs:
            return self.idle_state(idle, n)  # None, or the refusal of a given one
        if idle is None:
            legs = ", ".join(
                f"leg {k + 1} joint {self.legs.legs[k].idle_joint}" for k in self.idle_legs
            )
            raise InputError(
                f"robot '{self.desc.name}' has idle freedoms ({legs}): its regressor needs "
                "their state, idle=(values, rates, accelerations), each (6,) or (N, 6) "
                "[rad or m, /s, /s^2] (the spin accelerations given make the efforts "
                "linear in the parameters)"
            )
        try:
            values, rates, accels = idle
        except (TypeError, ValueError) as e:
            raise InputError(
                "idle must be (values, rates, accelerations) for the regressor, each (6,) "
                "or (N, 6)"
            ) from e
        out = []
        for name, x in (
            ("idle values", values),
            ("idle rates", rates),
            ("idle accelerations", accels),
        ):
            try:
                a = np.asarray(x, dtype=float)
            except (TypeError, ValueError) as e:
                raise InputError(f"{name} must be numbers, (6,) or (N, 6)") from e
            a = np.broadcast_to(a, (n, 6)) if a.shape == (6,) else check_array(a, (n, 6), name)
            if not np.all(np.isfinite(a)):
                raise InputError(f"{name} must be finite")
            out.append(np.array(a))
        return kin.IdleState(out[0], out[1], out[2])

    def regressor_batch(
        self, T: np.ndarray, V: np.ndarray, A: np.ndarray, idle: Any = None
    ) -> np.ndarray:
        """The regressor ``W`` (N, 6, n_p) with ``Gamma = W chi`` (:func:`chain_parameters`
        gives ``chi`` and its names): per leg link its 10 parameters (Pinocchio's
        ``computeJointTorqueRegressor`` on the leg's chain, Khalil's order), the
        platform's 10 (``F_p`` is linear in them), per leg joint ``IA FV FC K OF``
        (``[qddot, qdot, sign(qdot), q, 1]``); each leg's columns through ``K_i^T``, then
        ``Jp^T``.

        Legs with an idle joint: ``idle=(values, rates, accelerations)`` (each (6,) or
        (N, 6), :meth:`idle_regressor_state`), required. With the spin accelerations
        ``sigma`` given (measured, or a simulation's), each leg's joint accelerations are
        ``qddot = qddot_particular + null sigma`` (as in :meth:`inverse_batch`) and Gamma
        is linear in ``chi``; ``W chi`` is the inverse model's Gamma when ``sigma`` is the
        one it returns. The spin joints' own equations ``null^T H_i = 0`` are not rows of
        ``W`` (:meth:`spin_regressor_batch`)."""
        idle_state = self.idle_regressor_state(idle, T.shape[0])
        legs, J_inv = self.states(T, V, A, idle_state)
        N = T.shape[0]
        leg_cols, term_cols = [], []
        for s, (Y, terms) in zip(legs, self._joint_regressors(legs), strict=True):
            KT = np.swapaxes(s.KG, 1, 2)  # (N, 6, n)
            leg_cols.append(KT @ Y)
            term_cols.append(KT @ terms)
        platform = np.empty((N, 6, 10))
        for j in range(10):
            unit = SimpleNamespace(
                platform_inertia=np.eye(10)[j],
                gravity=self.desc.gravity,
                platform_gravcomp=self.desc.platform_gravcomp,
            )
            plat = platform_terms(unit, T, V)  # type: ignore[arg-type] # duck-typed
            platform[:, :, j] = _vec(plat.inertia, A) + plat.bias
        columns = np.concatenate([*leg_cols, platform, *term_cols], axis=2)
        return np.linalg.solve(np.swapaxes(J_inv, 1, 2), columns)

    def _joint_regressors(
        self, legs: list[kin.ChainLegState]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each leg's joint efforts ``H_i`` per parameter: its links' (N, n, 10 n)
        (Pinocchio's ``computeJointTorqueRegressor``, Khalil's order, each link's gravity
        columns scaled by ``1 - c_j``) and its joint terms' (N, n, 5 n)."""
        khalil = PIN_TO_KHALIL
        out = []
        for k, s in enumerate(legs):
            model, data = self.legs.models[k], self.legs.datas[k]
            N, n = s.q.shape
            cols = np.concatenate([10 * j + khalil for j in range(n)])
            # each link's gravity columns (the regressor at rest) scaled by 1 - c_j: its
            # weight (1 - c_j) m_j g (the efforts stay linear in the same parameters)
            c = np.repeat(self.legs.legs[k].gravcomp, 10)
            zero = np.zeros(n)
            Y = np.empty((N, n, 10 * n))
            for m in range(N):
                y = pin.computeJointTorqueRegressor(model, data, s.q[m], s.qdot[m], s.qddot[m])
                Y[m] = y[:, cols]
                if np.any(c):
                    yg = pin.computeJointTorqueRegressor(model, data, s.q[m], zero, zero)
                    Y[m] -= c * yg[:, cols]
            terms = np.zeros((N, n, 5 * n))
            for j in range(n):
                terms[:, j, 5 * j : 5 * j + 5] = np.stack(
                    [
                        s.qddot[:, j],
                        s.qdot[:, j],
                        coulomb_sign(s.qdot[:, j]),
                        s.q[:, j],
                        np.ones(N),
                    ],
                    axis=1,
                )
            out.append((Y, terms))
        return out

    def spin_regressor_batch(
        self, T: np.ndarray, V: np.ndarray, A: np.ndarray, idle: Any
    ) -> np.ndarray:
        """The idle joints' own equations ``S chi = 0`` (N, 6, n_p), columns as
        :meth:`regressor_batch`'s: row i is ``null_i^T H_i`` per parameter (``null_i``
        leg i's idle motion, :meth:`inverse_batch`), zero for a leg without an idle joint.
        With ``idle=(values, rates, accelerations)`` (:meth:`idle_regressor_state`),
        ``S chi = 0`` when the accelerations are the spins' true ones; stacked with ``W``
        (with zero measured values) they make the idle joints' own terms ``IA FV FC K OF``
        identifiable, whose columns of ``W`` are zero. Refused (:class:`InputError`) on a
        robot without idle joints."""
        if not self.idle_legs:
            raise InputError(
                f"robot '{self.desc.name}' has no idle joints (ChainLeg.idle_joint): it has "
                "no spin equations"
            )
        idle_state = self.idle_regressor_state(idle, T.shape[0])
        legs, _ = self.states(T, V, A, idle_state)
        n_links = sum(s.q.shape[1] for s in legs)
        S = np.zeros((T.shape[0], 6, 10 * n_links + 10 + 5 * n_links))
        link, term = 0, 10 * n_links + 10
        for k, (s, (Y, terms)) in enumerate(zip(legs, self._joint_regressors(legs), strict=True)):
            n = s.q.shape[1]
            if s.null is not None:
                S[:, k, link : link + 10 * n] = np.einsum("ni,nic->nc", s.null, Y)
                S[:, k, term : term + 5 * n] = np.einsum("ni,nic->nc", s.null, terms)
            link, term = link + 10 * n, term + 5 * n
        return S

    def spin_regressor(self, pose: Any, twist: Any, accel: Any, idle: Any) -> np.ndarray:
        """:meth:`spin_regressor_batch` for one state (6, n_p) or a batch (N, 6, n_p)."""
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        S = self.spin_regressor_batch(T, V, A, idle)
        return S if batched else S[0]

    def regressor(self, pose: Any, twist: Any, accel: Any, idle: Any = None) -> np.ndarray:
        """:meth:`regressor_batch` for one state (6, n_p) or a batch (N, 6, n_p)."""
        batched, T, V, A = check_states(pose, (twist, "twist"), (accel, "accel"))
        W = self.regressor_batch(T, V, A, idle)
        return W if batched else W[0]

    def gravity_compensation(self, pose: Any, idle: Any = None) -> np.ndarray:
        T, batched = check_poses(pose)
        zero = np.zeros((T.shape[0], 6))
        g = self.inverse_batch(T, zero, zero, idle).gamma
        return g if batched else g[0]


__all__ = [
    "ChainCartesianDynamics",
    "ChainDynamics",
    "ChainInverseDynamics",
    "ChainJointTerms",
    "ChainLegModels",
    "chain_parameters",
    "compensated_model",
    "leg_model",
]
