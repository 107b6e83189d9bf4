"""The viewer and the HTML animation of robots with general three-joint legs (``rus``,
``pus``): the scene tree names one node per leg link, the animated link poses equal the
legs' chains computed here from the MDH parameters (independent of
``kinematics.leg_chains``), the rods end on P_i of the platform pose and keep their
length, and headless Chromium shows the cranks, rails, slides and rods in their colours
where the camera puts them."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from stewart_pin.description.leg_chain_presets import (
    pus_preset,
    random_hexapod,
    rus_preset,
    ups_offset_preset,
)
from stewart_pin.exceptions import InputError, LegReachError

meshcat = pytest.importorskip("meshcat")
matplotlib = pytest.importorskip("matplotlib")

from test_viz import CHROMIUM_NAMES, commands, screenshot  # noqa: E402

from stewart_pin.viz import CameraView, Viewer  # noqa: E402
from stewart_pin.viz.leg_scene import (  # noqa: E402
    CRANK_RED,
    PLATFORM_ORANGE,
    RAIL_PURPLE,
    ROD_BLUE,
    SLIDE_GREEN,
    LegScene,
    general_robot,
)
from stewart_pin.viz.viewer import CAMERA_FOV  # noqa: E402

ROOT = "/meshcat/stewart_pin"
#: A 1 s motion, 11 samples: heave by 4 % of the size and a yaw of 0.1 rad.
TIMES = np.linspace(0.0, 1.0, 11)
#: Positions in the page: meshcat keyframes are float64 through msgpack [m].
ATOL = 1e-12
ROBOTS = {"rus": rus_preset, "pus": pus_preset}


def motion(robot) -> np.ndarray:
    poses = np.tile(robot.home_pose, (len(TIMES), 1, 1))
    poses[:, 2, 3] += 0.04 * robot.size * np.sin(np.pi * TIMES)
    for T, t in zip(poses, TIMES, strict=True):
        T[:3, :3] = pin.exp3(np.array([0.0, 0.0, 0.1 * t])) @ T[:3, :3]
    return poses


def mdh(alpha: float, d: float, theta: float, r: float) -> np.ndarray:
    """``Rx(alpha) Tx(d) Rz(theta) Tz(r)``, written here from the definition."""
    Rx = np.eye(4)
    Rx[1:3, 1:3] = [[math.cos(alpha), -math.sin(alpha)], [math.sin(alpha), math.cos(alpha)]]
    Tx = np.eye(4)
    Tx[0, 3] = d
    Rz = np.eye(4)
    Rz[0:2, 0:2] = [[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]]
    Tz = np.eye(4)
    Tz[2, 3] = r
    return Rx @ Tx @ Rz @ Tz


def chain(robot, i: int, q: np.ndarray) -> list[np.ndarray]:
    """Frames 1i, 2i, 3i of leg i in F0 at joint values q (3,), from the MDH parameters."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = robot.leg_base_rotations[i], robot.base_points[i]
    out = []
    for joint, qj in zip(robot.legs[i].joints, q, strict=True):
        theta, r = (joint.theta + qj, joint.r) if joint.revolute else (joint.theta, joint.r + qj)
        T = T @ mdh(joint.alpha, joint.d, theta, r)
        out.append(T)
    return out


def quaternion_matrix(q_xyzw) -> np.ndarray:
    x, y, z, w = q_xyzw
    return pin.Quaternion(w, x, y, z).toRotationMatrix()


def clip_samples(anim: dict, node: str) -> dict[str, np.ndarray]:
    """Keyframe values (K, n) by track (``position``, ``quaternion``, ``scale``) of node."""
    (clip,) = [a["clip"] for a in anim["animations"] if a["path"] == f"{ROOT}/{node}"]
    out = {}
    for track in clip["tracks"]:
        times = np.array([k["time"] for k in track["keys"]]) / clip["fps"]
        np.testing.assert_allclose(times, TIMES, rtol=0, atol=1e-12)
        out[track["name"].lstrip(".")] = np.array([k["value"] for k in track["keys"]])
    return out


def segment_ends(s: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (K, 3) of a segment node: origin, origin + R (0, scale_y, 0)."""
    R = np.array([quaternion_matrix(q) for q in s["quaternion"]])
    return s["position"], s["position"] + R[:, :, 1] * s["scale"][:, 1:2]


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def exported(request, tmp_path_factory):
    robot = ROBOTS[request.param]()
    path = Viewer(robot).export_html(
        tmp_path_factory.mktemp("html") / f"{request.param}.html", motion(robot), TIMES
    )
    return request.param, robot, commands(path.read_text(encoding="utf-8"))


def test_scene_tree_names_every_leg_link(exported):
    """One node per leg link: rus (axis, crank, U joint, rod, tip), pus (rail, slide, U
    joint, rod, tip), the base and the platform; the moving ones animated, in colour."""
    name, _, cmds = exported
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    per_leg = {
        "rus": {"axis", "crank/shape", "ujoint", "rod/shape", "tip"},
        "pus": {"rail/shape", "slide", "ujoint", "rod/shape", "tip"},
    }[name]
    expected = {f"{ROOT}/legs/leg{i}/{p}" for i in range(1, 7) for p in per_leg}
    assert set(objects) == expected | {f"{ROOT}/base", f"{ROOT}/platform"}
    colour = {
        "crank/shape": CRANK_RED,
        "rail/shape": RAIL_PURPLE,
        "slide": SLIDE_GREEN,
        "rod/shape": ROD_BLUE,
    }
    for path, obj in objects.items():
        part = path.split("/", 5)[-1] if "/legs/" in path else path.rsplit("/", 1)[-1]
        want = PLATFORM_ORANGE if part == "platform" else colour.get(part)
        if want is not None:
            rgb = [(obj["materials"][0]["color"] >> s) & 255 for s in (16, 8, 0)]
            np.testing.assert_allclose(np.array(rgb) / 255, want, atol=0.5 / 255)
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    moving = {"rus": ("crank", "ujoint", "rod", "tip"), "pus": ("slide", "ujoint", "rod", "tip")}
    animated = {a["path"] for a in anim["animations"]}
    assert animated == {f"{ROOT}/legs/leg{i}/{p}" for i in range(1, 7) for p in moving[name]} | {
        f"{ROOT}/platform"
    }
    assert anim["options"] == {"play": True, "repetitions": float("inf")}


def test_link_poses_follow_the_chains(exported):
    """At every keyframe: the U joint and the crank tip (rus) or the slide frame (pus) are
    the MDH chain's frames at the inverse geometry's joint values; independently of any
    joint value, the crank starts on B_i with the crank's length, and the rod runs from
    the U joint to P_i = 0Rp p_i + 0tp with the rod's length."""
    from stewart_pin.kinematics.leg_chains import inverse_geometry

    name, robot, cmds = exported
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    poses = motion(robot)
    q = inverse_geometry(robot, poses)  # (K, 6, 3)
    P = np.einsum("kij,nj->kni", poses[:, :3, :3], robot.platform_points) + poses[:, None, :3, 3]
    transforms = {c["path"]: c["matrix"] for c in cmds if c["type"] == "set_transform"}
    for i, leg in enumerate(robot.legs):
        n = f"legs/leg{i + 1}"
        frames = [chain(robot, i, qk[i]) for qk in q]
        O2 = np.array([f[1][:3, 3] for f in frames])
        ujoint = clip_samples(anim, f"{n}/ujoint")["position"]
        np.testing.assert_allclose(ujoint, O2, rtol=0, atol=ATOL)
        if name == "rus":
            start, end = segment_ends(clip_samples(anim, f"{n}/crank"))
            np.testing.assert_allclose(
                start, np.tile(robot.base_points[i], (len(TIMES), 1)), atol=ATOL
            )
            np.testing.assert_allclose(end, O2, rtol=0, atol=ATOL)
            crank = leg.joints[1].d
            np.testing.assert_allclose(np.linalg.norm(end - start, axis=1), crank, atol=ATOL)
        else:
            slide = clip_samples(anim, f"{n}/slide")
            F1 = np.array([f[0] for f in frames])
            np.testing.assert_allclose(slide["position"], F1[:, :3, 3], rtol=0, atol=ATOL)
            R = np.array([quaternion_matrix(x) for x in slide["quaternion"]])
            np.testing.assert_allclose(R, F1[:, :3, :3], rtol=0, atol=1e-12)
            # The fixed rail: along z1 through every slide position, over [lower, upper].
            M = np.array(transforms[f"{ROOT}/{n}/rail"], float).reshape(4, 4).T
            a, axis = M[:3, 3], M[:3, 1]
            z1 = F1[0, :3, 2]
            np.testing.assert_allclose(np.cross(axis, z1), 0.0, atol=1e-12)
            s = (F1[:, :3, 3] - a) @ axis / (axis @ axis)
            np.testing.assert_allclose(F1[:, :3, 3], a + s[:, None] * axis, rtol=0, atol=ATOL)
            assert np.all((s > 0) & (s < 1))
            lo, hi = leg.joints[0].lower, leg.joints[0].upper
            assert np.linalg.norm(axis) >= hi - lo
        start, end = segment_ends(clip_samples(anim, f"{n}/rod"))
        np.testing.assert_allclose(start, O2, rtol=0, atol=ATOL)
        np.testing.assert_allclose(end, P[:, i], rtol=0, atol=ATOL)
        rod = np.linalg.norm(leg.tip)
        np.testing.assert_allclose(np.linalg.norm(end - start, axis=1), rod, atol=1e-12)
        np.testing.assert_allclose(clip_samples(anim, f"{n}/tip")["position"], P[:, i], atol=ATOL)
    platform = clip_samples(anim, "platform")
    R = np.array([quaternion_matrix(x) for x in platform["quaternion"]])
    # The disc's axis (y of the three.js cylinder) is the platform plane's normal.
    normal = np.linalg.svd(robot.platform_points - robot.platform_points.mean(0))[2][2]
    np.testing.assert_allclose(
        np.abs(np.einsum("kij,j->ki", poses[:, :3, :3], normal) @ np.eye(3)),
        np.abs(R[:, :, 1]),
        atol=1e-12,
    )


@pytest.mark.parametrize(
    "robot",
    [ups_offset_preset(), random_hexapod("custom", 1), random_hexapod("pus", 2)],
    ids=["ups-offset", "custom", "pus-random"],
)
def test_other_legs_end_on_the_platform(robot):
    """Every general leg (offset U joints, custom chains, inclined rails) is drawn: each
    rod ends on P_i, the U-joint sphere, crank and middle link on the chain's frame
    origins; ups-offset has its offset as a crank, custom chains their middle links."""
    from stewart_pin.kinematics.leg_chains import inverse_geometry

    scene = LegScene(robot)
    poses = robot.home_pose[None]
    placed = scene.placements(poses)
    if robot.legs[0].name == "ups-offset":
        assert all(f"legs/leg{i}/crank" in placed.lengths for i in range(1, 7))
        np.testing.assert_allclose(placed.lengths["legs/leg1/crank"], 0.004, atol=1e-15)
    q = inverse_geometry(robot, poses, check_limits=False)[0]
    P = poses[0, :3, :3] @ robot.platform_points.T + poses[0, :3, 3:]
    for i in range(6):
        M = placed.scaled(f"legs/leg{i + 1}/rod", 0)
        np.testing.assert_allclose(M[:3, 3] + M[:3, 1], P[:, i], atol=1e-12)
        O1, O2, O3 = (F[:3, 3] for F in chain(robot, i, q[i]))
        for link, (a, b) in {"crank": (O1, O2), "link2": (O2, O3)}.items():
            node = f"legs/leg{i + 1}/{link}"
            if node in placed.matrices:
                M = placed.scaled(node, 0)
                np.testing.assert_allclose(M[:3, 3], a, atol=1e-12)
                np.testing.assert_allclose(M[:3, 3] + M[:3, 1], b, atol=1e-12)
        np.testing.assert_allclose(
            placed.matrices[f"legs/leg{i + 1}/ujoint"][0, :3, 3], O2, atol=1e-12
        )


def test_dispatch_keeps_6ups_on_the_urdf_path(simulator):
    """A 6-UPS StewartRobot keeps today's drawing; a robot with general legs, or a
    description-like object carrying them, takes the leg scene."""
    assert general_robot(simulator) is None
    rus = rus_preset()
    assert general_robot(rus) is rus

    class Facade:  # a robot whose description carries general legs
        description = rus

    assert general_robot(Facade()) is rus
    viewer = Viewer(Facade())
    assert viewer.general is rus
    assert isinstance(viewer.camera, CameraView)


def test_unreachable_pose_is_refused_before_drawing(tmp_path):
    robot = rus_preset()
    poses = np.tile(robot.home_pose, (2, 1, 1))
    poses[1, 2, 3] += 1.0  # a metre up: cranks of 3 cm and rods of 10 cm cannot reach
    with pytest.raises(LegReachError):
        Viewer(robot).export_html(tmp_path / "x.html", poses, [0.0, 1.0])
    with pytest.raises(InputError, match="times has 1 values"):
        Viewer(robot).export_html(tmp_path / "x.html", poses, [0.0])
    assert not (tmp_path / "x.html").exists()


# ---------------------------------------------------------------------- in Chromium
@pytest.fixture(scope="session")
def chromium() -> str:
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path is not None:
            return path
    pytest.skip(f"no Chromium on the PATH (looked for {', '.join(CHROMIUM_NAMES)})")


def project(camera: CameraView, points: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixel coordinates (M, 2) ``(column, row)`` of points in F0 under meshcat's default
    camera: at ``eye`` looking at ``target`` (the viewer shifts the scene so that the orbit
    centre is the target), world z up, vertical field of view ``CAMERA_FOV``."""
    f = camera.target - camera.eye
    f = f / np.linalg.norm(f)
    right = np.cross(f, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    rel = points - camera.eye
    depth = rel @ f
    t = math.tan(math.radians(CAMERA_FOV) / 2)
    x = (rel @ right) / (depth * t * width / height)
    y = (rel @ up) / (depth * t)
    return np.column_stack([(x + 1) / 2 * width, (1 - y) / 2 * height])


def colour_mask(img: np.ndarray, rgb) -> np.ndarray:
    """Pixels of that hue, lit or shaded."""
    from matplotlib.colors import rgb_to_hsv

    hsv = rgb_to_hsv(img)
    hue = rgb_to_hsv(np.array(rgb))[0]
    dh = np.abs(hsv[..., 0] - hue)
    dh = np.minimum(dh, 1 - dh)
    return (dh < 0.04) & (hsv[..., 1] > 0.4) & (hsv[..., 2] > 0.15)


def segment_distance(pixels: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance [px] of pixels (N, 2) to the 2-D segments a -> b (S, 2): (N, S)."""
    ab = b - a
    t = np.clip(((pixels[:, None] - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
    return np.linalg.norm(pixels[:, None] - (a + t[..., None] * ab), axis=-1)


def link_segments(page: Path, scene: LegScene, poses: np.ndarray, link: str) -> np.ndarray:
    """Ends (6, 2, 3) of one link kind in F0 at the page's still pose: the segment of a
    crank, rod or rail, a slide's extent along its rail."""
    placed = scene.placements(poses[:1])
    static = {
        c["path"]: np.array(c["matrix"], float).reshape(4, 4).T
        for c in commands(page.read_text(encoding="utf-8"))
        if c["type"] == "set_transform"
    }
    ends = []
    for i in range(6):
        node = f"legs/leg{i + 1}/{link}"
        if link == "rail":
            M = static[f"{ROOT}/{node}"]
            ends.append([M[:3, 3], M[:3, 3] + M[:3, 1]])
        elif link == "slide":
            M = placed.matrices[node][0]
            half = 1.5 * scene.sizes.cylinder_radius * M[:3, 2]
            ends.append([M[:3, 3] - half, M[:3, 3] + half])
        else:
            M = placed.scaled(node, 0)
            ends.append([M[:3, 3], M[:3, 3] + M[:3, 1]])
    return np.array(ends)


def test_chromium_shows_cranks_rails_and_rods(chromium, tmp_path):
    """The pages of a still rus and pus robot at home: each link kind's colour (cranks for
    rus, rails and slides for pus, rods for both) shows along the links projected by the
    page's camera: nearly all its pixels within a few pixels of one of those links, and
    pixels of it along most links (a link may hide behind the platform)."""
    found = {}
    for name, make in ROBOTS.items():
        robot = make()
        poses = np.tile(robot.home_pose, (2, 1, 1))
        page = Viewer(robot).export_html(tmp_path / f"{name}.html", poses, [0.0, 1.0])
        img = screenshot(chromium, page.as_uri(), tmp_path)
        H, W, _ = img.shape
        camera = CameraView.fit(robot, poses)  # the export's default view
        scene = LegScene(robot, poses)
        links = {"rus": {"crank": CRANK_RED}, "pus": {"slide": SLIDE_GREEN, "rail": RAIL_PURPLE}}
        for link, rgb in {**links[name], "rod": ROD_BLUE}.items():
            mask = colour_mask(img, rgb)
            rows, cols = np.nonzero(mask)
            pixels = np.column_stack([cols, rows]).astype(float)
            ends = link_segments(page, scene, poses, link)
            a = project(camera, ends[:, 0], W, H)
            b = project(camera, ends[:, 1], W, H)
            d = segment_distance(pixels, a, b)  # (N, 6)
            near = d.min(axis=1) < 12.0
            legs_seen = int(((d < 6.0).sum(axis=0) >= 5).sum())
            found[f"{name}/{link}"] = (len(pixels), float(near.mean()), legs_seen)
    for count, precision, legs_seen in found.values():
        assert count > 100, found
        assert precision > 0.97, found
        assert legs_seen >= 4, found


def test_live_viewer_draws_general_legs(tmp_path):
    """The live viewer starts, displays and plays a pus robot and stops its server."""
    from test_viz import child_pids

    robot = pus_preset()
    before = child_pids()
    with Viewer(robot) as viewer:
        assert viewer.start().startswith("http://127.0.0.1:")
        T = robot.home_pose.copy()
        T[2, 3] += 0.01
        viewer.display(T)
        viewer.play(motion(robot)[::5], TIMES[::5], speed=20.0)
        with pytest.raises(LegReachError):
            T[0, 3] += 2.0  # sideways: rods of 0.45 m from rails 0.8 m apart cannot reach
            viewer.display(T)
    assert viewer.url is None
    assert child_pids() <= before


def test_save_figures_of_general_legs(tmp_path, monkeypatch):
    """With a general-leg robot, the actuator plot has no stroke lines and says so."""
    from types import SimpleNamespace

    import matplotlib.image

    from stewart_pin.viz import plots

    t = np.linspace(0.0, 1.0, 5)
    result = SimpleNamespace(
        t=t,
        gammas=np.ones((5, 6)),
        lengths=np.zeros((5, 6)),
        poses=np.tile(np.eye(4), (5, 1, 1)),
        twists=np.zeros((5, 6)),
    )
    from stewart_pin import preset

    robot = SimpleNamespace(
        description=preset("rus"),
        energy=lambda poses, twists: np.ones(5),
        dissipated_power=lambda poses, twists: np.zeros(5),
    )
    seen = {}
    save = plots.plot_lengths

    def spy(t, lengths, stroke=None):
        seen["stroke"] = stroke
        fig = save(t, lengths, stroke)
        seen["fig"] = fig
        return fig

    monkeypatch.setattr(plots, "plot_lengths", spy)
    forces = plots.plot_forces
    monkeypatch.setattr(plots, "plot_forces", lambda *a: seen.setdefault("forces", forces(*a)))
    paths = plots.save_figures(result, tmp_path, robot=robot)
    assert seen["stroke"] is None
    (ax,) = seen["fig"].axes
    assert ax.get_title() == "Actuator positions" and len(ax.lines) == 6
    # RUS cranks: torques [N m] through angles [rad] (the torques were labelled [N])
    assert ax.get_ylabel() == "actuated joint [rad]"
    (ax,) = seen["forces"].axes
    assert ax.get_ylabel() == "actuator torque [N m]" and ax.get_title() == "Actuator torques"
    assert set(paths) == {"forces", "lengths", "energy"}
    assert matplotlib.image.imread(paths["lengths"]).shape[2] in (3, 4)
