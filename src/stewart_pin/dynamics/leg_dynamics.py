"""Each leg's own dynamics, from Pinocchio: ``H_i``, ``A_i``, ``h_i`` (paper eq. 20, 33).

The six 3-dof legs are evaluated as one 18-dof fixed-base Pinocchio model (the chains
share no body, so one RNEA / CRBA call on it *is* the six legs' RNEA / CRBA, with
block-diagonal mass matrix). Nothing acts at the leg tips here: ``H_i`` is the joint
force vector leg i needs to follow ``(q_i, qdot_i, qddot_i)`` on its own, gravity included.
"""

from __future__ import annotations

import numpy as np

from stewart_pin._lazy import pinocchio as pin  # imported on first use
from stewart_pin._typing import FloatArray, JointValues
from stewart_pin.description import RobotDescription
from stewart_pin.models.pinocchio_models import build_legs_model


class LegDynamics:
    """Pinocchio's RNEA / CRBA / nonlinear effects on the six legs, for batches of states.

    All arrays are (N, 6, 3) for joint vectors (columns q1i, q2i, q3i) and (N, 6, 3, 3)
    for the leg mass matrices.
    """

    def __init__(self, desc: RobotDescription) -> None:
        self._attach(*build_legs_model(desc))

    def _attach(self, model: pin.Model, v_index: np.ndarray) -> None:
        """Use ``model``, six 3-dof chains whose joint j of leg i has velocity index
        ``v_index[i, j]`` (the general legs' chains share this class's loops)."""
        self.model = model
        self.data = self.model.createData()
        # Revolute and prismatic joints have nq == nv, so q and v share the index.
        self.index = v_index.ravel()
        self.blocks = v_index  # (6, 3): velocity index of each leg joint

    def pack(self, x: FloatArray) -> FloatArray:
        """Leg values (6, 3) -> the legs model's configuration or velocity vector (18,)."""
        out = np.empty(18)
        out[self.index] = x.ravel()
        return out

    def _unpack(self, x: FloatArray) -> FloatArray:
        return x[self.index].reshape(6, 3)

    def inverse_dynamics(
        self, q: JointValues, qdot: JointValues, qddot: JointValues
    ) -> FloatArray:
        """``H_i = A_i qddot_i + h_i`` (N, 6, 3) [N m for q1, q2; N for q3] by RNEA."""
        m, d = self.model, self.data
        out = np.empty(q.shape)
        for n in range(q.shape[0]):
            tau = pin.rnea(m, d, self.pack(q[n]), self.pack(qdot[n]), self.pack(qddot[n]))
            out[n] = self._unpack(tau)
        return out

    def mass_and_bias(self, q: JointValues, qdot: JointValues) -> tuple[FloatArray, FloatArray]:
        """``(A_i (N, 6, 3, 3), h_i (N, 6, 3))``: CRBA and the nonlinear effects (Coriolis,
        centrifugal, gravity)."""
        m, d = self.model, self.data
        A = np.empty((*q.shape, 3))
        h = np.empty(q.shape)
        rows = self.blocks[:, :, None]
        cols = self.blocks[:, None, :]
        for n in range(q.shape[0]):
            qn, vn = self.pack(q[n]), self.pack(qdot[n])
            M = pin.crba(m, d, qn)
            A[n] = M[rows, cols]
            h[n] = self._unpack(pin.nonLinearEffects(m, d, qn, vn))
        return A, h

    def energy(self, q: JointValues, qdot: JointValues) -> tuple[FloatArray, FloatArray]:
        """Kinetic and potential energy of the six legs together, each (N,) [J]; the
        potential is zero with every link's centre of mass at the origin of F0."""
        m, d = self.model, self.data
        kinetic, potential = np.empty(q.shape[0]), np.empty(q.shape[0])
        for n in range(q.shape[0]):
            qn = self.pack(q[n])
            kinetic[n] = pin.computeKineticEnergy(m, d, qn, self.pack(qdot[n]))
            potential[n] = pin.computePotentialEnergy(m, d, qn)
        return kinetic, potential
