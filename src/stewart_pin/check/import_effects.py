"""The effect of an import's approximations on the efforts (``docs/importing.md``).

The importer approximates in a few places (the inertia of nearly massless bodies dropped,
axes a file rounds made parallel, an asymmetric rod's spin removed, loops assembled from
a residual); :attr:`ImportReport.approximations` lists them. :func:`import_effects` says
what they do to the efforts: the inverse dynamics at the home pose (at rest, and for a
unit platform acceleration along each of the six axes) of

- the file's own physics: Pinocchio's model of the file's kinematic tree as read
  (:class:`FileTree`: every body with its joint and inertia, the joints' armatures and
  springs, the loops as hard point or weld constraints) at the file's reference
  configuration, in an exact KKT solve;
- the imported robot: the constrained-tree reference of :mod:`.constrained_dynamics`
  (:func:`~.constrained_dynamics.reference_actuator_efforts`), its efforts put in the
  file's joint directions (``description.source``);

and gives the largest difference relative to the largest effort, e.g. "12 massless
links assumed: 3.1 % on IDM at home". Neither path uses the project's dynamics.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from stewart_pin.check.constrained_dynamics import reference_actuator_efforts
from stewart_pin.description.leg_architecture import PRISMATIC, REVOLUTE
from stewart_pin.exceptions import InputError
from stewart_pin.importers.build import ImportResult
from stewart_pin.importers.tree import BALL, FREE, KinematicModel
from stewart_pin.protocols import RobotLike


def _inertia(params: np.ndarray) -> pin.Inertia:
    """Khalil's parameters (10,) about a body's origin as a Pinocchio inertia."""
    m = float(params[9])
    I_O = np.array(
        [
            [params[0], params[1], params[2]],
            [params[1], params[3], params[4]],
            [params[2], params[4], params[5]],
        ]
    )
    if m <= 0.0:
        return pin.Inertia(0.0, np.zeros(3), I_O)
    c = params[6:9] / m
    return pin.Inertia(m, c, I_O - m * (c @ c * np.eye(3) - np.outer(c, c)))


def _frame(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


class FileTree:
    """Pinocchio's model of a file's kinematic tree (module docstring).

    Attributes:
        model, data: the Pinocchio model (one joint per file joint; bodies fixed to a
            joint's body appended to it) and its data.
        q: the file's reference configuration (nq,).
        frames: body name -> the id of a frame at that body's origin.
    """

    def __init__(self, tree: KinematicModel) -> None:
        model = pin.Model()
        model.gravity.linear = np.asarray(tree.gravity, dtype=float)
        where: dict[int, tuple[int, np.ndarray]] = {0: (0, np.eye(4))}  # body -> joint, X
        self.tree = tree
        self._joint_of: dict[str, int] = {}
        self._springs: list[tuple[int, float, float]] = []
        children: dict[int, list[int]] = {}
        for b, body in enumerate(tree.bodies[1:], start=1):
            children.setdefault(body.parent, []).append(b)
        order: list[int] = []  # depth first: Pinocchio's algorithms need each subtree's
        stack = list(reversed(children.get(0, [])))  # velocities contiguous
        while stack:
            b = stack.pop()
            order.append(b)
            stack.extend(reversed(children.get(b, [])))
        for b in order:
            body = tree.bodies[b]
            parent_joint, X_parent = where[body.parent]
            parent_pose = tree.bodies[body.parent].pose
            J = body.joint
            if J is None:
                jid, X = parent_joint, X_parent @ np.linalg.inv(parent_pose) @ body.pose
            else:
                R = body.pose[:3, :3]
                if J.kind == REVOLUTE:
                    F = _frame(R, J.anchor)
                    jm = pin.JointModelRevoluteUnaligned(R.T @ J.axis)
                elif J.kind == PRISMATIC:
                    F = body.pose
                    jm = pin.JointModelPrismaticUnaligned(R.T @ J.axis)
                elif J.kind == BALL:
                    F = _frame(R, J.anchor)
                    jm = pin.JointModelSpherical()
                else:  # FREE: the joint frame is F0's
                    F = np.eye(4)
                    jm = pin.JointModelFreeFlyer()
                placement = X_parent @ np.linalg.inv(parent_pose) @ F
                jid = model.addJoint(parent_joint, jm, pin.SE3(placement), J.name)
                X = np.linalg.inv(F) @ body.pose
                self._joint_of[J.name] = jid
                if J.one_dof:
                    model.armature[model.joints[jid].idx_v] = J.armature
                    if J.stiffness:
                        self._springs.append((jid, J.stiffness, J.rest))
            where[b] = (jid, X)
            if np.any(body.inertia):
                model.appendBodyToJoint(jid, _inertia(body.inertia), pin.SE3(X))
        self._where = where
        self.model = model
        self.frames = {}
        for b, body in enumerate(tree.bodies):
            if b == 0 or not body.virtual:
                self.frames[tree.body_label(b)] = self._add_frame(f"body {b}", b, np.eye(4))
        self._loops: list[tuple[int, int, int]] = []  # (frame 1, frame 2, rows 3 or 6)
        for k, c in enumerate(tree.closures):
            if c.kind == "point":
                f1 = self._add_frame(f"loop {k} a", c.body1, _frame(np.eye(3), c.point1))
                f2 = self._add_frame(f"loop {k} b", c.body2, _frame(np.eye(3), c.point2))
                self._loops.append((f1, f2, 3))
            else:
                f1 = self._add_frame(f"loop {k} a", c.body1, c.T_1_2)
                f2 = self._add_frame(f"loop {k} b", c.body2, np.eye(4))
                self._loops.append((f1, f2, 6))
        # bodies with gravity compensation: (a frame at the centre of mass, the fraction
        # of the weight compensated, the mass [kg])
        self._gravcomp: list[tuple[int, float, float]] = []
        for b, body in enumerate(tree.bodies):
            mass = float(body.inertia[9])
            if b and body.gravcomp and mass > 0.0:
                com = _frame(np.eye(3), body.inertia[6:9] / mass)
                self._gravcomp.append(
                    (self._add_frame(f"com {b}", b, com), float(body.gravcomp), mass)
                )
        self.data = model.createData()
        self.q = self._reference()

    def _add_frame(self, name: str, body: int, offset: np.ndarray) -> int:
        jid, X = self._where[body]
        frame = pin.Frame(name, jid, 0, pin.SE3(X @ offset), pin.FrameType.OP_FRAME)
        return int(self.model.addFrame(frame))

    def _reference(self) -> np.ndarray:
        q = pin.neutral(self.model)
        for body in self.tree.bodies[1:]:
            J = body.joint
            if J is None:
                continue
            idx = self.model.joints[self._joint_of[J.name]].idx_q
            if J.one_dof:
                q[idx] = self.tree.values.get(J.name, 0.0)
            elif J.kind == BALL:
                R = self.tree.balls.get(J.name, np.eye(3))
                q[idx : idx + 4] = pin.Quaternion(R).coeffs()
            elif J.kind == FREE:
                M = self.tree.free.get(J.name, body.pose) @ np.linalg.inv(body.pose)
                q[idx : idx + 7] = pin.SE3ToXYZQUAT(pin.SE3(M))
        return q

    def inverse_dynamics_at_rest(
        self, platform: str, actuated: list[str], accels: np.ndarray
    ) -> np.ndarray:
        """The actuated joints' efforts (N, len(actuated)) [N or N m, along the file's
        joint axes] at the reference configuration at rest, the frame of body
        ``platform`` given the classical accelerations ``accels`` (N, 6) ``[a of its
        origin, dw/dt]`` in F0: a KKT solve with the loops as hard constraints; each
        body's compensated weight (``gravcomp`` times its weight, at its centre of mass)
        removed."""
        m, d, q = self.model, self.data, self.q
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        rows = [
            (pin.getFrameJacobian(m, d, f1, world) - pin.getFrameJacobian(m, d, f2, world))[:n]
            for f1, f2, n in self._loops
        ]
        Jc = np.vstack(rows) if rows else np.zeros((0, m.nv))
        Jp = pin.getFrameJacobian(m, d, self.frames[platform], world)
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        c = pin.rnea(m, d, q, np.zeros(m.nv), np.zeros(m.nv)).copy()
        g = np.asarray(m.gravity.linear)
        for frame, gravcomp, mass in self._gravcomp:  # the compensated weights removed
            J_com = pin.getFrameJacobian(m, d, frame, world)[:3]
            c += gravcomp * mass * (J_com.T @ g)
        for jid, k, rest in self._springs:
            c[m.joints[jid].idx_v] += k * (q[m.joints[jid].idx_q] - rest)
        S = np.zeros((len(actuated), m.nv))
        for u, name in enumerate(actuated):
            S[u, m.joints[self._joint_of[name]].idx_v] = 1.0
        nv, nr, nu = m.nv, len(Jc), len(actuated)
        K = np.zeros((nv + nr + 6, nv + nu + nr))
        K[:nv, :nv], K[:nv, nv : nv + nu], K[:nv, nv + nu :] = M, -S.T, -Jc.T
        K[nv : nv + nr, :nv], K[nv + nr :, :nv] = Jc, Jp
        out = []
        for A in np.atleast_2d(accels):
            rhs = np.r_[-c, np.zeros(nr), A]
            x = np.linalg.lstsq(K, rhs, rcond=None)[0]  # redundant weld rows: least squares
            out.append(x[nv : nv + nu])
        return np.array(out)


#: The accelerations the effect is measured with: at rest, then 1 m/s^2 and 1 rad/s^2
#: along each axis of F0.
ACCELERATIONS = np.vstack([np.zeros(6), np.eye(6)])


def effect_on_efforts(result: ImportResult, robot: RobotLike) -> float:
    """The largest difference between the imported robot's efforts and the file's at
    home (module docstring), relative to the largest of the file's efforts."""
    if result.model is None:
        raise InputError("the import result carries no file tree")
    desc = result.description
    if desc.chain_legs is not None:
        return _chain_effect(result, robot)
    source = desc.source
    if source is None:
        raise InputError(
            "the import result's description carries no source (the file's record of its "
            "joints, description.source): compare an importer's result"
        )
    actuated = (
        [3] * 6 if desc.legs is None else [leg.actuated for leg in desc.legs]
    )  # the ideal 6-UPS actuates its slides
    names = [leg.joints[a - 1] for leg, a in zip(source.legs, actuated, strict=True)]
    tree = FileTree(result.model)
    file_efforts = tree.inverse_dynamics_at_rest(source.platform, names, ACCELERATIONS)
    n = len(ACCELERATIONS)
    home = np.broadcast_to(desc.home_pose, (n, 4, 4))
    ours = reference_actuator_efforts(robot, home, np.zeros((n, 6)), ACCELERATIONS)
    ours = source.file_efforts(ours, actuated)
    scale = float(np.abs(file_efforts).max())
    return float(np.abs(ours - file_efforts).max() / scale) if scale > 0 else 0.0


def _chain_effect(result: ImportResult, robot: RobotLike) -> float:
    """:func:`effect_on_efforts` of chain legs (the file's joint values and directions):
    the imported robot's efforts from the chain legs' constrained tree
    (:class:`~stewart_pin.check.chain_legs_tree.ChainTreeSolver`, idle joints at rest)."""
    from stewart_pin.check.chain_legs_tree import ChainTreeSolver

    assert result.model is not None
    desc = result.description
    names = [leg.joints[leg.actuated - 1] for leg in result.report.legs]
    tree = FileTree(result.model)
    file_efforts = tree.inverse_dynamics_at_rest(result.report.platform, names, ACCELERATIONS)
    solver = ChainTreeSolver(desc)
    q_legs = robot.inverse_geometry(desc.home_pose, check_limits=False)
    ours = np.array(
        [
            solver.inverse_idle_one(desc.home_pose, np.zeros(6), a, q_legs, np.zeros(6))[0]
            for a in ACCELERATIONS
        ]
    )
    scale = float(np.abs(file_efforts).max())
    return float(np.abs(ours - file_efforts).max() / scale) if scale > 0 else 0.0


def import_effects(result: ImportResult, robot: RobotLike) -> list[str]:
    """The lines "<approximations>: x % on IDM at home" for the import's approximations
    (none: an empty list), also added to ``result.report.effects``."""
    report = result.report
    if not report.approximations:
        return []
    effect = effect_on_efforts(result, robot)
    line = f"{'; '.join(report.approximations)}: {100.0 * effect:.3g} % on IDM at home"
    report.effects.append(line)
    return [line]


__all__ = ["ACCELERATIONS", "FileTree", "effect_on_efforts", "import_effects"]
