"""The robot in meshcat, through Pinocchio's ``MeshcatVisualizer``: live display, playback
of a motion, and a standalone HTML animation.

The viewer shows the 24-dof tree (``robot.tree.model``) with the visual geometry of the
generated URDF (cylinders, spheres and discs with the URDF materials). A platform pose
0Tp is drawn through :func:`tree_configuration`, which solves the legs by inverse
geometry, so every drawn leg tip lies on its platform joint (the six loops are closed).

The meshcat server is meshcat's own (``meshcat.servers.zmqserver``), started as a child
process listening on 127.0.0.1 only (see :mod:`stewart_pin.viz._meshcat_server`: meshcat
0.3.2 alone would listen on every interface) and stopped by :meth:`Viewer.close`, by
``with Viewer(robot) as viewer:``, or at garbage collection / interpreter exit.
:meth:`Viewer.export_html` uses a private server of its own, stopped before it returns.

meshcat's camera orbits about the world origin (its controls aim at (0, 0, 0) whatever
the camera's parent transform), so the viewer shifts the scene instead: the robot, grid
and axes are translated by ``-target`` and the camera sits at ``eye - target``.

Robots with general three-joint legs (a description with ``legs`` that are not all plain
``ups`` legs, e.g. ``rus``, ``pus``, ``ups-offset``, or a
:class:`~stewart_pin.description.leg_chain_hexapod.GeneralHexapod` itself) are drawn by
:class:`~stewart_pin.viz.leg_scene.LegScene` instead: cranks, rails and slides, universal
joints, rods and the plates placed from the legs' joint frames at the inverse geometry's
joint values (no URDF). The 6-UPS robots keep the URDF drawing above.
"""

from __future__ import annotations

import contextlib
import io
import os
import selectors
import subprocess
import sys
import threading
import time
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from stewart_pin._checks import (
    check_array,
    check_increasing_times,
    check_pose,
    check_poses,
    check_scalar,
)
from stewart_pin._extras import install_hint, require
from stewart_pin._io import write_text_atomic
from stewart_pin.exceptions import InputError, ViewerError
from stewart_pin.formats.urdf import VisualSizes
from stewart_pin.kinematics.geometry import platform_points_in_base
from stewart_pin.viz.leg_scene import LegScene, general_robot

if TYPE_CHECKING:
    from stewart_pin.robot import StewartRobot

#: Install hint of the optional viewer dependencies.
INSTALL_HINT = install_hint("viz")
#: Node under ``/meshcat`` holding the robot.
ROOT_NODE = "stewart_pin"
#: meshcat's default perspective camera: vertical field of view [deg].
CAMERA_FOV = 75.0
#: Default viewing direction (from the target towards the eye), in F0.
VIEW_DIRECTION = (1.0, -0.55, 0.65)
#: Background gradient, top and bottom colours (RGB in [0, 1]); meshcat's default blue
#: gradient would hide the blue cylinders.
BACKGROUND = ((1.0, 1.0, 1.0), (0.78, 0.80, 0.84))
#: Seconds allowed for the meshcat server to start.
SERVER_TIMEOUT = 30.0
#: Seconds a meshcat request may take before the server counts as dead [s].
REQUEST_TIMEOUT = 120.0


def require_meshcat() -> Any:
    """The ``meshcat`` module, or :class:`~stewart_pin.exceptions.MissingDependencyError`
    with the install hint (the command line checks it before the work that ends in a
    viewer or an HTML animation)."""
    meshcat, _ = require(
        "the viewer and the HTML animations", "viz", "meshcat", "meshcat.animation"
    )
    from pinocchio.visualize import MeshcatVisualizer  # noqa: F401

    return meshcat


# ---------------------------------------------------------------------- configurations
def tree_configuration(robot: StewartRobot, pose: Any, check_limits: bool = False) -> np.ndarray:
    """The tree configuration ``q`` drawing the robot at platform pose ``pose``.

    The free-flyer part is ``pin.SE3ToXYZQUAT(0Tp)`` (at ``robot.tree.platform_q_index``)
    and the leg joints ``q1i, q2i [rad], q3i [m]`` come from the inverse geometry (at
    ``robot.tree.leg_q_index``), so the six loop closures hold.

    Args:
        robot: the robot.
        pose: 0Tp, (4, 4) / ``pin.SE3``, or a batch (N, 4, 4).
        check_limits: raise when a leg leaves its stroke or a U-joint its limits (off by
            default: the viewer draws any pose the legs can reach).

    Returns:
        q, shape (nq,) = (25,), or (N, 25) for a batch.
    """
    T, batched = check_poses(pose)
    tree = robot.tree
    legs = robot.inverse_geometry(T, check_limits=check_limits)
    q = np.tile(pin.neutral(tree.model), (len(T), 1))
    for qn, Tn in zip(q, T, strict=True):
        qn[tree.platform_q_index] = pin.SE3ToXYZQUAT(pin.SE3(Tn))
    q[:, tree.leg_q_index] = legs
    return q if batched else q[0]


def visual_model(robot: StewartRobot) -> pin.GeometryModel:
    """The visual geometry of the generated URDF on ``robot.tree.model`` (URDF colours in
    each object's ``meshColor``)."""
    return pin.buildGeomFromUrdfString(robot.tree.model, robot.urdf(), pin.GeometryType.VISUAL)


def check_motion(poses: Any, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate a motion: poses (K, 4, 4) and strictly increasing times (K,) [s]."""
    T, batched = check_poses(poses, "poses")
    if not batched:
        raise InputError("poses must be a batch (K, 4, 4) of platform poses, got one pose")
    t = check_array(times, (None,), "times")
    if len(t) != len(T):
        raise InputError(f"times has {len(t)} values but poses has {len(T)}: give one per pose")
    check_increasing_times(t)
    return T, t


def frame_indices(times: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the samples kept for an animation at most ``fps`` frames per second:
    the first, every sample at least ``1 / fps`` [s] after the last kept one, the last."""
    keep = [0]
    gap = 1.0 / fps - 1e-12
    for k in range(1, len(times)):
        if times[k] - times[keep[-1]] >= gap:
            keep.append(k)
    if keep[-1] != len(times) - 1:
        keep.append(len(times) - 1)
    return np.array(keep)


# ---------------------------------------------------------------------- camera
@dataclass(frozen=True)
class CameraView:
    """Where the camera looks from: ``eye`` and ``target`` in F0 [m]."""

    eye: np.ndarray
    target: np.ndarray

    @classmethod
    def fit(
        cls,
        robot: StewartRobot,
        poses: Any = None,
        direction: Any = VIEW_DIRECTION,
        margin: float = 0.85,
        extra_points: Any = None,
    ) -> CameraView:
        """A view of the whole robot at every pose of ``poses`` (default the home pose).

        The target is the centre of the box around the base and platform joints and
        plates (and ``extra_points`` (M, 3) in F0, e.g. a payload's); the eye lies along
        ``direction`` at the distance where the bounding sphere of that box fills
        meshcat's vertical field of view, times ``margin``.
        """
        points, pad = drawing_for(robot).extent(poses)
        if extra_points is not None:
            points = np.concatenate([points, check_array(extra_points, (None, 3), "points")])
        lo, hi = points.min(axis=0) - pad, points.max(axis=0) + pad
        target = (lo + hi) / 2
        radius = float(np.linalg.norm(hi - lo) / 2)
        d = check_array(direction, (3,), "direction")
        d = d / np.linalg.norm(d)
        distance = margin * radius / np.sin(np.radians(CAMERA_FOV) / 2)
        return cls(eye=target + distance * d, target=target)


def _translation(p: np.ndarray, scale: float = 1.0) -> np.ndarray:
    M = np.diag([scale, scale, scale, 1.0])
    M[:3, 3] = p
    return M


# ---------------------------------------------------------------------- server
class _Server:
    """meshcat's server in a child process on 127.0.0.1, and a client connected to it."""

    def __init__(self, quiet: bool = False, timeout: float = SERVER_TIMEOUT):
        meshcat = require_meshcat()

        script = Path(__file__).with_name("_meshcat_server.py")
        env = dict(os.environ)
        meshcat_dir = str(Path(meshcat.__file__).resolve().parents[1])
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [meshcat_dir, env.get("PYTHONPATH")]))
        # The server dies with this process (see _meshcat_server.die_with_parent).
        env["STEWART_PIN_VIEWER_PARENT"] = str(os.getpid())
        main_thread = threading.current_thread() is threading.main_thread()
        env["STEWART_PIN_VIEWER_PDEATHSIG"] = "1" if main_thread else "0"
        self.process = subprocess.Popen(
            [sys.executable, "-u", str(script)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )
        self._windows: list[Any] = []  # the client, closed with the server
        self._finalizer = weakref.finalize(self, _stop, self.process, self._windows)
        lines = self._read_lines(2, timeout)
        urls = dict(line.split("=", 1) for line in lines)
        self.zmq_url, self.web_url = urls["zmq_url"], urls["web_url"]
        out = io.StringIO() if quiet else sys.stdout
        with contextlib.redirect_stdout(out):
            self.visualizer = meshcat.Visualizer(zmq_url=self.zmq_url)
        self._windows.append(self.visualizer.window)
        self._set_timeout(REQUEST_TIMEOUT)

    def _set_timeout(self, seconds: float | None) -> None:
        """Receive time-out of the client's requests (``None``: wait forever)."""
        import zmq

        socket = self.visualizer.window.zmq_socket
        # (zmq's option is an int of milliseconds: about 24 days at most)
        ms = -1 if seconds is None else max(1, min(int(seconds * 1000), 2**31 - 1))
        socket.setsockopt(zmq.RCVTIMEO, ms)
        socket.setsockopt(zmq.LINGER, 0)

    def wait_for_browser(self, timeout: float | None = None) -> bool:
        """Block until a browser is connected (meshcat's ``wait``), at most ``timeout``
        seconds (``None``: as long as it takes); whether one connected. The server answers
        nothing else until a browser connects, so after a time-out it is stuck: the caller
        stops it."""
        import zmq

        self._set_timeout(timeout)
        try:
            self.visualizer.wait()
        except zmq.Again:
            return False
        self._set_timeout(REQUEST_TIMEOUT)
        return True

    def _read_lines(self, n: int, timeout: float) -> list[str]:
        """The server's first ``n`` ``key=value`` lines (unbuffered reads, so that the
        selector sees every byte)."""
        buffer = b""
        deadline = time.monotonic() + timeout
        assert self.process.stdout is not None  # started with stdout=PIPE
        fd = self.process.stdout.fileno()
        with selectors.DefaultSelector() as sel:
            sel.register(fd, selectors.EVENT_READ)
            while buffer.count(b"\n") < n:
                left = deadline - time.monotonic()
                if left <= 0 or not sel.select(left):
                    self.close()
                    raise ViewerError(f"the meshcat server did not start within {timeout} s")
                chunk = os.read(fd, 4096)
                if not chunk:
                    code = self.process.wait()
                    self.close()
                    raise ViewerError(f"the meshcat server exited early with code {code}")
                buffer += chunk
        lines = buffer.decode("utf-8").splitlines()
        return [line.strip() for line in lines if "=" in line][:n]

    @property
    def alive(self) -> bool:
        return self._finalizer.alive and self.process.poll() is None

    def close(self) -> None:
        self._finalizer()

    def __enter__(self) -> _Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _stop(process: subprocess.Popen, windows: list[Any]) -> None:
    for window in windows:
        window.zmq_socket.close(linger=0)
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    if process.stdout is not None:
        process.stdout.close()


# ---------------------------------------------------------------------- viewer
class Viewer:
    """The robot in meshcat.

    Args:
        robot: the robot to draw.
        camera: the initial view (default :meth:`CameraView.fit` at the home pose, with
            room for motions around it).

    Example::

        with Viewer(robot) as viewer:
            print(viewer.start())          # the URL to open
            viewer.play(result.poses, result.t)
        Viewer(robot).export_html("motion.html", result.poses, result.t)
    """

    #: The URDF tree and its visuals (a robot drawn from them: the ideal 6-UPS).
    model: pin.Model
    visual_model: pin.GeometryModel

    def __init__(self, robot: StewartRobot | Any, camera: CameraView | None = None):
        require_meshcat()
        self.robot = robot
        self._drawing = drawing_for(robot)
        #: The leg chains when the robot is drawn by :class:`LegScene`, else None.
        self.general = self._drawing.chains
        self._drawing.attach(self)  # the URDF tree's: ``model``, ``visual_model``
        self.home_pose = self._drawing.home_pose
        self.camera = camera or CameraView.fit(robot, margin=1.0)
        self._server: _Server | None = None
        self._viz: Any = None

    # ------------------------------------------------------------------ server
    def start(self, open: bool = False) -> str:
        """Start the local meshcat server (if not running), draw the robot at the home
        pose, and return the URL to open (``http://127.0.0.1:<port>/static/``)."""
        if self._server is None or not self._server.alive:
            self._server = _Server()
            self._viz = self._load(self._server.visualizer, self.camera)
            self._show(self.home_pose)
        if open:
            import webbrowser

            webbrowser.open(self._server.web_url, new=2)
        return self._server.web_url

    def wait(self, timeout: float | None = None) -> None:
        """Block until a browser has the viewer's page open (starts the server if needed);
        the server sends it the whole scene as it connects.

        Args:
            timeout: the most seconds to wait (a positive number), or ``None`` (default)
                to wait as long as it takes.

        Raises:
            ViewerError: no browser connected within ``timeout``. Until a browser
                connects, meshcat's server answers no other request, so the server is
                stopped first; the next :meth:`start`, :meth:`display` or :meth:`wait`
                starts a new one (at a new URL).
            InputError: ``timeout`` is not a positive number or ``None``.
        """
        if timeout is not None:
            timeout = check_scalar(timeout, "timeout", positive=True, unit="s")
        self.start()
        assert self._server is not None  # start() sets it
        if not self._server.wait_for_browser(timeout):
            self.close()
            raise ViewerError(
                f"no browser opened the viewer's page within {timeout:g} s; its server "
                "was stopped (meshcat's server answers nothing else until a browser "
                "connects) and the next call starts a new one"
            )

    @property
    def url(self) -> str | None:
        """The URL of the running server, ``None`` when stopped."""
        return self._server.web_url if self._server is not None and self._server.alive else None

    def close(self) -> None:
        """Stop the meshcat server (no-op when stopped)."""
        if self._server is not None:
            self._server.close()
        self._server, self._viz = None, None

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _load(self, visualizer: Any, camera: CameraView, poses: Any = None) -> Any:
        """Draw the robot in ``visualizer`` and set the scene; returns Pinocchio's
        visualiser (6-UPS) or ``visualizer`` itself (general legs; ``poses`` (K, 4, 4)
        set the drawn range of rails without limits)."""
        viz = self._drawing.load(self, visualizer, poses)
        _set_scene(visualizer, camera, self.robot)
        return viz

    def set_camera(self, camera: CameraView) -> None:
        """Move the view (applied at once when the server runs, else at :meth:`start`)."""
        self.camera = camera
        if self._server is not None and self._server.alive:
            _set_scene(self._server.visualizer, camera, self.robot)

    # ------------------------------------------------------------------ live
    def _show(self, pose: np.ndarray) -> None:
        """Draw at one validated pose (the server runs)."""
        self._drawing.show(self._viz, self._drawing.frames(pose[None])[0])

    def display(self, pose: Any) -> None:
        """Draw the robot at platform pose ``pose`` (0Tp, (4, 4) or ``pin.SE3``)."""
        T = check_pose(pose)
        frames = self._drawing.frames(T[None])  # reach errors before the server starts
        self.start()
        self._drawing.show(self._viz, frames[0])
        self._extra_display(T)

    def general_joint_values(self, poses: np.ndarray) -> np.ndarray:
        """Joint values (K, 6, 3) the general-leg drawing uses at poses (K, 4, 4)
        (:class:`InputError` for a robot drawn from its URDF tree)."""
        return self._drawing.joint_values(poses)

    def play(self, poses: Any, times: Any, speed: float = 1.0) -> None:
        """Play a motion live, in real time divided by ``speed``; samples the display
        cannot keep up with are skipped (the last one is always drawn).

        Args:
            poses: (K, 4, 4) platform poses 0Tp; times: (K,) increasing [s].
            speed: playback rate (2.0 plays twice as fast).
        """
        T, t = check_motion(poses, times)
        if not speed > 0:
            raise InputError(f"speed must be positive, got {speed}")
        frames = self._drawing.frames(T)  # reach errors before anything is drawn
        self.start()
        show = self._drawing.shower(self._viz, frames)
        due = (t - t[0]) / speed
        t0 = time.perf_counter()
        for k in range(len(T)):
            now = time.perf_counter() - t0
            if k + 1 < len(T) and now >= due[k + 1]:
                continue
            if due[k] > now:
                time.sleep(due[k] - now)
            show(k)
            self._extra_frame(T[k], k)

    # ------------------------------------------------------------------ export
    def export_html(
        self,
        path: str | Path,
        poses: Any,
        times: Any,
        fps: float = 30.0,
        loop: bool = True,
        camera: CameraView | None = None,
    ) -> Path:
        """Write a standalone HTML page playing the motion (no server needed to view it).

        The page is meshcat's static scene (viewer script, geometry and a three.js
        animation clip embedded as data) from a private meshcat server, stopped before
        this returns.

        Args:
            path: the ``.html`` file to write.
            poses: (K, 4, 4) platform poses 0Tp; times: (K,) increasing [s].
            fps: most keyframes per second kept (samples closer than ``1 / fps`` are
                dropped; three.js interpolates between keyframes).
            loop: repeat the animation forever (else play it once).
            camera: the view (default :meth:`CameraView.fit` over ``poses``).

        Returns:
            the path written.
        """
        T, t = check_motion(poses, times)
        if not fps > 0:
            raise InputError(f"fps must be positive, got {fps}")
        keep = frame_indices(t, fps)
        frames = self._drawing.frames(T[keep])  # reach errors before the server starts
        camera = camera or CameraView.fit(self.robot, T)
        with _Server(quiet=True) as server:
            vis = server.visualizer
            viz = self._load(vis, camera, T[keep])
            animation = self._drawing.animate(self, vis, viz, frames, t[keep] - t[0], fps)
            self._extra_animation(animation, vis, T, keep, t[keep] - t[0], fps)
            vis.set_animation(animation, play=True, repetitions=_repetitions(loop))
            html = vis.static_html()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, html)
        return path

    # Hooks drawing more than the hexapod (a payload on the platform:
    # stewart_pin.viz.payload_scene.PayloadViewer); nothing here.
    def _extra_display(self, pose: np.ndarray) -> None:
        """After :meth:`display` drew the robot at ``pose``."""

    def _extra_frame(self, pose: np.ndarray, k: int) -> None:
        """After :meth:`play` drew sample ``k`` (at ``pose``)."""

    def _extra_animation(
        self,
        animation: Any,
        visualizer: Any,
        poses: np.ndarray,
        keep: np.ndarray,
        times: np.ndarray,
        fps: float,
    ) -> None:
        """Before :meth:`export_html` sets ``animation`` (the kept samples ``poses[keep]``
        at ``times`` [s])."""

    def animation(self, visualizer: Any, q: np.ndarray, times: np.ndarray, fps: float) -> Any:
        """A ``meshcat.animation.Animation`` moving each visual object of the robot through
        the configurations ``q`` (K, nq) at ``times`` (K,) [s] (keyframes ``t * fps``)."""
        from meshcat.animation import Animation

        animation = Animation(default_framerate=fps)
        data, gdata = self.model.createData(), self.visual_model.createData()
        moving = [
            (k, f"{ROOT_NODE}/visuals/{g.name}", np.append(g.meshScale, 1.0))
            for k, g in enumerate(self.visual_model.geometryObjects)
            if g.parentJoint != 0
        ]
        for qk, tk in zip(q, times, strict=True):
            pin.forwardKinematics(self.model, data, qk)
            pin.updateGeometryPlacements(self.model, data, self.visual_model, gdata)
            with animation.at_frame(visualizer, float(tk) * fps) as frame:
                for k, node, scale in moving:
                    frame[node].set_transform(gdata.oMg[k].homogeneous * scale)
        return animation


# ---------------------------------------------------------------------- the two drawings
class _TreeDrawing:
    """The robot's URDF tree with its visuals (Pinocchio's ``MeshcatVisualizer``); its
    frames are tree configurations (K, nq)."""

    chains = None

    def __init__(self, robot: Any) -> None:
        self.robot = robot

    @property
    def home_pose(self) -> np.ndarray:
        return np.asarray(self.robot.home_pose)

    def attach(self, viewer: Viewer) -> None:
        viewer.model = self.robot.tree.model
        viewer.visual_model = visual_model(self.robot)

    def extent(self, poses: Any) -> tuple[np.ndarray, float]:
        """Points (M, 3) in F0 the view holds at ``poses`` (default home), and a pad [m]."""
        T, _ = check_poses(self.robot.home_pose if poses is None else poses, "poses")
        desc = self.robot.description
        points = np.concatenate(
            [desc.base_points, platform_points_in_base(desc, T).reshape(-1, 3)]
        )
        return points, 3.0 * VisualSizes.for_robot(desc).joint_radius

    def grid(self) -> tuple[float, VisualSizes, float]:
        """The grid's scale, the visual sizes, the lowest drawn height [m]."""
        desc = self.robot.description
        scale = float(np.clip(desc.size / 2.5, 1e-3, 1e3))
        return scale, VisualSizes.for_robot(desc), float(desc.base_points[:, 2].min())

    def frames(self, T: np.ndarray) -> np.ndarray:
        """What each pose (K, 4, 4) is drawn from; raises the reach errors."""
        return tree_configuration(self.robot, T)

    def joint_values(self, poses: np.ndarray) -> np.ndarray:
        raise InputError("this robot is drawn from its URDF tree: it has no leg-chain drawing")

    def load(self, viewer: Viewer, visualizer: Any, poses: Any) -> Any:
        from pinocchio.visualize import MeshcatVisualizer

        viz = MeshcatVisualizer(viewer.model, None, viewer.visual_model)
        viz.initViewer(viewer=visualizer)
        viz.loadViewerModel(rootNodeName=ROOT_NODE)
        return viz

    def show(self, viz: Any, frame: np.ndarray) -> None:
        viz.display(frame)

    def shower(self, viz: Any, frames: np.ndarray) -> Any:
        def show(k: int) -> None:
            viz.display(frames[k])

        return show

    def animate(
        self,
        viewer: Viewer,
        vis: Any,
        viz: Any,
        frames: np.ndarray,
        times: np.ndarray,
        fps: float,
    ) -> Any:
        """The keyframes of ``frames`` at ``times`` [s] in ``vis`` (meshcat's visualiser;
        ``viz`` what :meth:`load` returned), the first one drawn."""
        viz.display(frames[0])
        return viewer.animation(vis, frames, times, fps)


class _ChainDrawing:
    """The leg chains (:class:`LegScene`); its frames are the poses (K, 4, 4)."""

    def __init__(self, chains: Any) -> None:
        self.chains = chains
        self.scene: LegScene | None = None

    @property
    def home_pose(self) -> np.ndarray:
        return np.asarray(self.chains.home_pose)

    def attach(self, viewer: Viewer) -> None:
        """Nothing: the scene is built when loaded."""

    def extent(self, poses: Any) -> tuple[np.ndarray, float]:
        T, _ = check_poses(self.chains.home_pose if poses is None else poses, "poses")
        scene = LegScene(self.chains, T)
        return scene.extent_points(T), 3.0 * scene.sizes.joint_radius

    def grid(self) -> tuple[float, VisualSizes, float]:
        scene = LegScene(self.chains)
        scale = float(np.clip(self.chains.size / 2.5, 1e-3, 1e3))
        low = min(
            self.chains.base_points[:, 2].min(),
            scene.extent_points(self.chains.home_pose[None])[:, 2].min(),
        )
        return scale, scene.sizes, float(low)

    def frames(self, T: np.ndarray) -> np.ndarray:
        self.joint_values(T)  # the reach errors
        return T

    def joint_values(self, poses: np.ndarray) -> np.ndarray:
        from stewart_pin.kinematics.leg_chains import inverse_geometry_batch

        return inverse_geometry_batch(self.chains, poses, check_limits=False)

    def load(self, viewer: Viewer, visualizer: Any, poses: Any) -> Any:
        self.scene = LegScene(self.chains, poses)
        self.scene.load(visualizer, ROOT_NODE)
        return visualizer

    def show(self, viz: Any, frame: np.ndarray) -> None:
        assert self.scene is not None  # set by load
        self.scene.display(viz, ROOT_NODE, frame)

    def shower(self, viz: Any, frames: np.ndarray) -> Any:
        assert self.scene is not None
        placed = self.scene.placements(frames)

        def show(k: int) -> None:
            for node in placed.matrices:
                viz[f"{ROOT_NODE}/{node}"].set_transform(placed.scaled(node, k))

        return show

    def animate(
        self,
        viewer: Viewer,
        vis: Any,
        viz: Any,
        frames: np.ndarray,
        times: np.ndarray,
        fps: float,
    ) -> Any:
        from meshcat.animation import Animation

        assert self.scene is not None
        self.scene.display(vis, ROOT_NODE, frames[0])
        animation = Animation(default_framerate=fps)
        self.scene.animate(animation, vis, ROOT_NODE, frames, times, fps)
        return animation


def drawing_for(robot: Any) -> _TreeDrawing | _ChainDrawing:
    """How the viewer draws ``robot``: the one choice, from :func:`general_robot` (the
    architecture's path for a description)."""
    general = general_robot(robot)
    return _TreeDrawing(robot) if general is None else _ChainDrawing(general)


def _repetitions(loop: bool) -> float:
    # three.js LoopRepeat: Infinity repeats forever (msgpack carries the float).
    return float("inf") if loop else 1


def _set_scene(visualizer: Any, camera: CameraView, robot: StewartRobot | Any) -> None:
    """Set the background, shift the scene by ``-target``, put the camera at
    ``eye - target``.

    meshcat's camera node ``/Cameras/default/rotated/<object>`` lives in a frame rotated
    from F0 by +90 deg about x (three.js is y-up): F0 ``(x, y, z)`` is ``(x, z, -y)`` there.
    """
    top, bottom = BACKGROUND
    visualizer["/Background"].set_property("top_color", list(top))
    visualizer["/Background"].set_property("bottom_color", list(bottom))
    target = np.asarray(camera.target, float)
    d = np.asarray(camera.eye, float) - target
    shift = _translation(-target)
    visualizer[ROOT_NODE].set_transform(shift)
    # meshcat's grid: 20 m, cells of 0.5 m; scaled to cells of about a fifth of the robot,
    # and lowered under the base plate.
    scale, vs, low = drawing_for(robot).grid()
    floor = low - vs.plate_thickness - 1.5 * vs.joint_radius
    visualizer["/Grid"].set_transform(_translation([0, 0, floor] - target, scale))
    visualizer["/Axes"].set_transform(_translation(-target, scale))
    visualizer["/Cameras/default"].set_transform(np.eye(4))
    visualizer["/Cameras/default/rotated/<object>"].set_property(
        "position", [float(d[0]), float(d[2]), float(-d[1])]
    )
