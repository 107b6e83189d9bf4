"""Drawing a payload (a robot on the platform) in meshcat, and the viewer of a hexapod
carrying one.

:class:`PayloadScene` draws the payload's visual geometry from its URDF (the meshes of
example-robot-data: DAE, STL or OBJ files, and URDF boxes, cylinders and spheres), each
object a node ``/meshcat/stewart_pin/payload/visual<k>`` placed at
``0Tp T_p_b oMi[parent] placement`` (the platform's pose, the mount, Pinocchio's forward
kinematics of the payload at ``q``) with a child ``shape`` holding the mesh and its
constant scale. Without a URDF (a ``pin.Model``), or when its meshes cannot be read, or
with ``meshes=False`` (a much smaller HTML page), it draws simple shapes instead: a
sphere at each joint, a cylinder from each joint to its children's joints (and to the
body's centre of mass at a leaf), a flat disc for the mount.

:class:`PayloadViewer` is :class:`~stewart_pin.viz.viewer.Viewer` with the payload drawn
on the platform: ``display(pose, q)``, ``play(poses, times, q)``,
``export_html(path, poses, times, q)``, ``q`` the payload's configurations (default its
home configuration, held).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import check_poses
from stewart_pin.exceptions import InputError
from stewart_pin.models.payload import Payload
from stewart_pin.protocols import PayloadRobotLike
from stewart_pin.viz.viewer import ROOT_NODE, CameraView, Viewer

__all__ = ["PayloadScene", "PayloadViewer"]

#: Colours of the simple shapes (RGB in [0, 1]).
ARM_GREY = (0.62, 0.64, 0.68)
JOINT_BLUE = (0.15, 0.30, 0.60)
#: Three.js cylinders lie along y; coal's along z.
_Z_TO_Y = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])


def _hex(rgb: tuple[float, float, float]) -> int:
    r, g, b = (round(255 * c) for c in rgb)
    return (r << 16) | (g << 8) | b


def _rows(q: Any, nq: int, n: int) -> np.ndarray:
    """Configurations ``q`` as rows (K, nq); a payload without joints (``nq = 0``, a fixed
    tool) has ``n`` empty rows."""
    arr = np.asarray(q, dtype=float)
    return arr.reshape(-1, nq) if nq else arr.reshape(n, 0) if arr.size == 0 else arr


def _along_y(end: np.ndarray) -> np.ndarray:
    """A rotation (4, 4) whose y axis points along ``end`` (non-zero, (3,))."""
    y = end / np.linalg.norm(end)
    other = np.array([1.0, 0.0, 0.0]) if abs(y[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    z = other - (other @ y) * y
    z /= np.linalg.norm(z)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2] = np.cross(y, z), y, z
    return M


@dataclass(frozen=True)
class _Visual:
    """One drawn object: on joint ``joint`` at ``placement`` (4, 4) in the joint's frame;
    ``shape`` (4, 4) the child's constant transform (mesh scale, cylinder axis);
    ``geometry`` a meshcat geometry; ``colour`` (RGB) and ``opacity``."""

    joint: int
    placement: np.ndarray
    shape: np.ndarray
    geometry: Any
    colour: tuple[float, float, float]
    opacity: float


def _mesh_geometry(path: str) -> Any:
    import meshcat.geometry as g

    suffix = Path(path).suffix.lower()
    loaders = {
        ".dae": g.DaeMeshGeometry,
        ".stl": g.StlMeshGeometry,
        ".obj": g.ObjMeshGeometry,
    }
    if suffix not in loaders:
        return None
    return loaders[suffix].from_file(path)


def _primitive(obj: Any) -> tuple[Any, np.ndarray] | None:
    """A meshcat geometry and its transform for a coal primitive (box, cylinder,
    sphere), or ``None``."""
    import meshcat.geometry as g

    kind = type(obj).__name__
    if kind == "Box":
        return g.Box(list(2.0 * np.asarray(obj.halfSide))), np.eye(4)
    if kind == "Sphere":
        return g.Sphere(float(obj.radius)), np.eye(4)
    if kind in ("Cylinder", "Capsule"):
        return g.Cylinder(2.0 * float(obj.halfLength), float(obj.radius)), _Z_TO_Y
    return None


class PayloadScene:
    """The meshcat drawing of a payload (module docstring).

    Args:
        payload: the payload (its model, URDF, placement ``T_p_b``).
        meshes: draw the URDF's visual geometry when it can be read (else, or with
            ``False``, simple shapes).
    """

    def __init__(self, payload: Payload, meshes: bool = True) -> None:
        self.payload = payload
        self.model = payload.model
        self.data = self.model.createData()
        self.size = self._size()
        visuals = self._from_urdf() if meshes else []
        #: Whether the URDF's meshes are drawn (else simple shapes).
        self.meshes = bool(visuals)
        self.visuals = visuals or self._shapes()

    # ------------------------------------------------------------------ geometry
    def _size(self) -> float:
        """The payload's extent [m] at its home configuration (joint origins and centres
        of mass from the base), at least 1 cm."""
        pin.forwardKinematics(self.model, self.data, self.payload.home_configuration())
        pts = [np.zeros(3)]
        for j in range(self.model.njoints):
            M = self.data.oMi[j]
            pts += [M.translation, M.act(self.model.inertias[j].lever)]
        return max(float(np.linalg.norm(np.array(pts), axis=1).max()), 0.01)

    def _from_urdf(self) -> list[_Visual]:
        geom = self.payload.visual_model()
        if geom is None:
            return []
        out = []
        for obj in geom.geometryObjects:
            colour = tuple(float(c) for c in np.asarray(obj.meshColor)[:3])
            opacity = float(np.asarray(obj.meshColor)[3])
            scale = np.diag([*np.asarray(obj.meshScale, dtype=float), 1.0])
            geometry: Any = None
            try:
                if obj.meshPath and Path(obj.meshPath).is_file():
                    geometry = _mesh_geometry(obj.meshPath)
                    shape = scale
                if geometry is None:
                    prim = _primitive(obj.geometry)
                    if prim is not None:
                        geometry, shape = prim[0], prim[1]
            except (OSError, ValueError):
                geometry = None
            if geometry is None:
                continue
            out.append(
                _Visual(
                    int(obj.parentJoint),
                    np.asarray(obj.placement.homogeneous),
                    shape,
                    geometry,
                    (colour[0], colour[1], colour[2]),
                    opacity if opacity > 0 else 1.0,
                )
            )
        return out

    def _shapes(self) -> list[_Visual]:
        """Spheres at the joints, cylinders between them, a disc for the mount."""
        import meshcat.geometry as g

        model, r = self.model, 0.035 * self.size
        out = [
            _Visual(0, np.eye(4), _Z_TO_Y, g.Cylinder(0.6 * r, 2.5 * r), ARM_GREY, 1.0)
        ]  # the mount: a disc on Fb's xy plane
        children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
        for j in range(1, model.njoints):
            children[model.parents[j]].append(j)
            out.append(_Visual(j, np.eye(4), np.eye(4), g.Sphere(1.3 * r), JOINT_BLUE, 1.0))
        for j in range(model.njoints):
            ends = [np.asarray(model.jointPlacements[c].translation) for c in children[j]]
            if not ends and j > 0:  # a leaf: to twice its centre of mass
                ends = [2.0 * np.asarray(model.inertias[j].lever)]
            for end in ends:
                if np.linalg.norm(end) < 1e-9:
                    continue
                shape = np.diag([1.0, float(np.linalg.norm(end)), 1.0, 1.0])
                cyl = np.eye(4)
                cyl[1, 3] = 0.5  # the unit cylinder from y = 0 to y = 1
                out.append(
                    _Visual(j, _along_y(end), shape @ cyl, g.Cylinder(1.0, r), ARM_GREY, 1.0)
                )
        return out

    def placements(self, poses: Any, q: Any) -> np.ndarray:
        """Each object's rigid transform in F0 over K frames, (len(visuals), K, 4, 4), at
        platform poses (K, 4, 4) and payload configurations (K, nq)."""
        T, _ = check_poses(poses, "poses")
        Q, _ = self.payload.check_configurations(_rows(q, self.payload.nq, len(T)))
        if len(Q) != len(T):
            raise InputError(f"q has {len(Q)} configurations but poses has {len(T)}")
        base = T @ np.asarray(self.payload.placement)
        out = np.empty((len(self.visuals), len(T), 4, 4))
        for k in range(len(T)):
            pin.forwardKinematics(self.model, self.data, Q[k])
            joints = [self.data.oMi[j].homogeneous for j in range(self.model.njoints)]
            for i, v in enumerate(self.visuals):
                out[i, k] = base[k] @ joints[v.joint] @ v.placement
        return out

    def extent_points(self, poses: Any, q: Any) -> np.ndarray:
        """Points (M, 3) in F0 the drawing spans: the objects' origins and the joints,
        padded by the payload's size along z."""
        M = self.placements(poses, q)
        pts = M[..., :3, 3].reshape(-1, 3)
        return np.concatenate([pts, pts + np.array([0.0, 0.0, 0.05 * self.size])])

    # ------------------------------------------------------------------ meshcat
    def node(self, i: int, root: str = ROOT_NODE) -> str:
        return f"{root}/payload/visual{i}"

    def load(self, visualizer: Any, root: str = ROOT_NODE) -> None:
        """Create every object under ``root/payload``."""
        import meshcat.geometry as g

        for i, v in enumerate(self.visuals):
            material = g.MeshPhongMaterial(
                color=_hex(v.colour), opacity=v.opacity, transparent=v.opacity < 1.0
            )
            shape = visualizer[self.node(i, root)]["shape"]
            shape.set_object(v.geometry, material)
            shape.set_transform(v.shape)

    def display(self, visualizer: Any, pose: Any, q: Any, root: str = ROOT_NODE) -> None:
        """Place the objects at one platform pose and payload configuration."""
        M = self.placements(np.asarray(pose, float)[None], np.reshape(q, (1, -1)))
        for i in range(len(self.visuals)):
            visualizer[self.node(i, root)].set_transform(M[i, 0])

    def animate(
        self,
        animation: Any,
        visualizer: Any,
        poses: Any,
        q: Any,
        times: np.ndarray,
        fps: float,
        root: str = ROOT_NODE,
    ) -> None:
        """Keyframes (``t * fps``) of every object at poses (K, 4, 4), q (K, nq)."""
        M = self.placements(poses, q)
        for k, tk in enumerate(times):
            with animation.at_frame(visualizer, float(tk) * fps) as frame:
                for i in range(len(self.visuals)):
                    frame[f"{root}/payload/visual{i}"].set_transform(M[i, k])


class PayloadViewer(Viewer):
    """The hexapod and the payload on its platform, in meshcat.

    Args:
        robot: the hexapod with its payload (a
            :class:`~stewart_pin.payload_robot.PayloadRobot`).
        camera: the initial view (default: fitted to hexapod and payload at home).
        meshes: draw the payload's URDF meshes (``False``: simple shapes, a much smaller
            HTML page).

    Example::

        arm = StewartRobot.from_preset("simulator").with_payload("ur5")
        PayloadViewer(arm).export_html("arm.html", sim.result.poses, sim.result.t, sim.q)
    """

    def __init__(
        self, robot: PayloadRobotLike, camera: CameraView | None = None, meshes: bool = True
    ) -> None:
        self.carrier = robot
        self.scene = PayloadScene(robot.payload, meshes)
        self.q_home = robot.payload.home_configuration()
        home = np.asarray(robot.robot.home_pose)
        camera = camera or self.fit(home[None], self.q_home[None], margin=1.0)
        super().__init__(robot.robot, camera)
        self._q: np.ndarray | None = None  # the configurations of the motion being drawn
        self._keep: np.ndarray | None = None

    def fit(self, poses: Any, q: Any, margin: float = 0.85) -> CameraView:
        """A view of hexapod and payload at ``poses`` (K, 4, 4) and ``q`` (K, nq)."""
        hexapod: Any = self.carrier.robot
        return CameraView.fit(
            hexapod,
            poses,
            margin=margin,
            extra_points=self.scene.extent_points(poses, q),
        )

    def _configurations(self, n: int, q: Any) -> np.ndarray:
        nq = self.carrier.payload.nq
        if q is None:
            return np.tile(self.q_home, (n, 1))
        Q = _rows(q, nq, n)
        if len(Q) != n:
            raise InputError(f"q has {len(Q)} configurations but poses has {n}: one per pose")
        return self.carrier.payload.check_configurations(Q)[0]

    # ------------------------------------------------------------------ the hooks
    def _load(self, visualizer: Any, camera: CameraView, poses: Any = None) -> Any:
        viz = super()._load(visualizer, camera, poses)
        self.scene.load(visualizer)
        return viz

    def _show(self, pose: np.ndarray) -> None:
        super()._show(pose)
        if self._server is not None:
            self.scene.display(self._server.visualizer, pose, self.q_home)

    def _extra_display(self, pose: np.ndarray) -> None:
        assert self._server is not None  # the viewer's display started it
        q = self.q_home if self._q is None else self._q[0]
        self.scene.display(self._server.visualizer, pose, q)

    def _extra_frame(self, pose: np.ndarray, k: int) -> None:
        assert self._server is not None and self._q is not None
        self.scene.display(self._server.visualizer, pose, self._q[k])

    def _extra_animation(
        self,
        animation: Any,
        visualizer: Any,
        poses: np.ndarray,
        keep: np.ndarray,
        times: Any,
        fps: float,
    ) -> None:
        assert self._q is not None
        self.scene.display(visualizer, poses[keep[0]], self._q[keep[0]])
        self.scene.animate(animation, visualizer, poses[keep], self._q[keep], times, fps)

    # ------------------------------------------------------------------ the API
    def display(self, pose: Any, q: Any = None) -> None:
        """Draw the robot at platform pose ``pose`` with the payload at ``q`` (nq,)
        (default its home configuration)."""
        self._q = self._configurations(1, q)
        try:
            super().display(pose)
        finally:
            self._q = None

    def play(  # type: ignore[override]
        self, poses: Any, times: Any, q: Any = None, speed: float = 1.0
    ) -> None:
        """Play a motion live (see :meth:`Viewer.play`); ``q`` (K, nq) the payload's
        configurations at the poses (default home, held)."""
        self._q = self._configurations(len(np.reshape(poses, (-1, 4, 4))), q)
        try:
            super().play(poses, times, speed)
        finally:
            self._q = None

    def export_html(  # type: ignore[override]
        self,
        path: str | Path,
        poses: Any,
        times: Any,
        q: Any = None,
        fps: float = 30.0,
        loop: bool = True,
        camera: CameraView | None = None,
    ) -> Path:
        """A standalone HTML animation (see :meth:`Viewer.export_html`) with the payload
        at ``q`` (K, nq) (default home, held); the default camera frames both."""
        T, _ = check_poses(poses, "poses")
        self._q = self._configurations(len(T), q)
        try:
            camera = camera or self.fit(T, self._q)
            return super().export_html(path, T, times, fps=fps, loop=loop, camera=camera)
        finally:
            self._q = None
