"""The rest of the library with a payload on the platform (issue 15, item 4): the
payload's joint motion, simulation under computed torque while the arm runs its own
trajectory, the viewer and HTML animation, the command line.

Independent references: finite differences of the joint trajectories on the
configuration manifold (``pin.difference``); the whole constrained tree
(``stewart_pin.check.payload``) at the simulated states; Pinocchio's forward kinematics
and geometry placements of the payload for the drawn objects; Chromium's rendering.
"""

from __future__ import annotations

import base64
import re
import shutil
import subprocess

import numpy as np
import pinocchio as pin
import pytest
from conftest import needs_example_robot_data

from stewart_pin import FileFormatError, InputError, PayloadError, StewartRobot
from stewart_pin.check import payload as check
from stewart_pin.check.constrained_dynamics import relative_error
from stewart_pin.cli import main
from stewart_pin.models.payload import Payload
from stewart_pin.motion.payload import (
    JointMotion,
    PayloadComputedTorque,
    PayloadSimulation,
    payload_path,
    simulate_payload,
)
from stewart_pin.motion.simulation import SimulationError

pytestmark = needs_example_robot_data()

_ROBOTS: dict[tuple[str, str], object] = {}


def carrier(preset: str, arm: str):
    if (preset, arm) not in _ROBOTS:
        _ROBOTS[preset, arm] = StewartRobot.from_preset(preset).with_payload(arm)
    return _ROBOTS[preset, arm]


# ---------------------------------------------------------------------------- joint motion
def _check_derivatives(motion: JointMotion, times) -> None:
    """qd and qdd against central differences (h = 1e-5 s) on the manifold."""
    model, h = motion.payload.model, 1e-5
    for t in times:
        q, qd, qdd = motion(t)
        (qm, qdm, _), (qp, qdp, _) = motion(t - h), motion(t + h)
        fd = np.asarray(pin.difference(model, qm, qp)) / (2 * h)
        scale = max(np.abs(qd).max(), 1.0)
        np.testing.assert_allclose(qd, fd, rtol=0, atol=1e-7 * scale)
        np.testing.assert_allclose(qdd, (qdp - qdm) / (2 * h), rtol=0, atol=1e-5 * scale)
        assert q.shape == (model.nq,)


@pytest.mark.parametrize("arm", ("panda", "kinova"))
def test_joint_motions_are_consistent_with_their_derivatives(arm):
    p = carrier("simulator", arm).payload
    times = np.linspace(0.05, 0.95, 7)
    _check_derivatives(JointMotion.sinusoid(p, 0.2, 0.7), times)
    _check_derivatives(JointMotion.sweep(p, 0.5, 0.8), times)
    goal = p.random_configurations(1, 4)[0]
    ptp = JointMotion.point_to_point(p, p.home_configuration(), goal, 0.9, hold=0.1)
    _check_derivatives(ptp, times)
    q0, qd0, qdd0 = ptp(0.0)
    q1, qd1, qdd1 = ptp(1.0)
    np.testing.assert_allclose(pin.difference(p.model, q0, p.home_configuration()), 0, atol=1e-14)
    np.testing.assert_allclose(pin.difference(p.model, q1, goal), 0, atol=1e-12)
    assert np.abs(np.concatenate([qd0, qdd0, qd1, qdd1])).max() == 0.0
    assert ptp.duration == pytest.approx(1.0)


def test_sweep_stays_within_the_joint_limits_and_a_large_sinusoid_is_refused():
    p = carrier("simulator", "panda").payload
    motion = JointMotion.sweep(p, 1.0, 0.5)
    motion.check_limits()
    q = motion.sample(np.linspace(0, 0.5, 101))[0]
    lo, hi = np.asarray(p.model.lowerPositionLimit), np.asarray(p.model.upperPositionLimit)
    assert np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12)
    with pytest.raises(PayloadError, match=r"joint .panda_.* outside its limits"):
        JointMotion.sinusoid(p, 3.0, 1.0).check_limits()
    with pytest.raises(InputError, match="fraction"):
        JointMotion.sweep(p, 1.5)


# ---------------------------------------------------------------------------- simulation
@pytest.mark.parametrize("preset", ("paper", "rus"))
def test_simulated_accelerations_are_the_whole_trees_under_the_applied_efforts(preset):
    """What the simulator integrates is the whole constrained tree's motion: at every
    recorded state, the tree's KKT solve (payload joints prescribed) under the recorded
    efforts gives the recorded platform acceleration and the recorded joint torques."""
    robot = carrier(preset, "panda" if preset == "paper" else "so101")
    joints = JointMotion.sweep(robot.payload, 0.3, 0.4)
    T0 = robot.home_pose
    hold = PayloadComputedTorque(robot, lambda t: (T0, np.zeros(6), np.zeros(6)), joints=joints)
    sim = simulate_payload(robot, 0.06, joints, forces=hold, dt=2e-3, control_period=2e-3)
    r = sim.result
    solver = check.PayloadTreeSolver(robot.robot, robot.payload)
    k = np.arange(0, len(r.t), 6)
    accel, tau = check.reference_prescribed_dynamics(
        solver, r.poses[k], r.twists[k], r.gammas[k], sim.q[k], sim.qd[k], sim.qdd[k]
    )
    # relative to the batch's scale: the first state is held still (accel ~ 1e-14)
    assert np.abs(r.accels[k] - accel).max() < 1e-9 * np.abs(accel).max()
    assert relative_error(sim.tau[k], tau) < 1e-9


def test_compensating_the_arm_keeps_its_base_still():
    """Computed torque with the coupled model holds the platform (the arm's base) while
    the arm moves fast; a controller that takes the arm for still cannot."""
    robot = carrier("paper", "panda")
    joints = JointMotion.sweep(robot.payload, 0.2, 1.0)  # up to 23 rad/s^2
    T0 = robot.home_pose

    def reference(t):
        return T0, np.zeros(6), np.zeros(6)

    def run(model_joints):
        ctl = PayloadComputedTorque(robot, reference, joints=model_joints)
        sim = simulate_payload(robot, 0.25, joints, forces=ctl, dt=2e-3, control_period=2e-3)
        return np.abs(sim.result.poses[:, :3, 3] - T0[:3, 3]).max()

    compensated = run(joints)
    ignorant = run(JointMotion.still(robot.payload, joints.q0))
    assert compensated < 1e-5  # m: the zero-order hold of a 2 ms controller (3.2 um seen)
    assert ignorant > 50 * compensated  # 0.26 mm seen (80 times; from the Panda's ready pose)


@pytest.mark.parametrize(("preset", "arm"), [("simulator", "ur5"), ("rus", "so101")])
def test_the_c_loop_runs_the_payload_as_the_python_loop(
    preset, arm, monkeypatch, shared_compile_cache
):
    """The payload's compiled prescribed direct model in the compiled simulator (rk4, the
    joints sampled at every stage time): the trajectories equal the Python loop's (same
    model, one call per stage) to 1e-10, with the payload's computed torque per control
    period (a Python function), a force table, and ``output_dt`` off the grid; the
    adaptive method stays on the Python loop and ``integrator="compiled"`` says why."""
    from stewart_pin.codegen import compiled as compiled_module
    from stewart_pin.motion import simulation
    from stewart_pin.motion.force_tables import ForceTable

    monkeypatch.setenv("STEWART_PIN_BACKEND", "auto")  # the payload's compiled models
    monkeypatch.setenv(compiled_module.CACHE_ENV, str(shared_compile_cache))
    robot = StewartRobot.from_preset(preset).with_payload(arm)  # no backend chosen yet
    joints = JointMotion.sweep(robot.payload, 0.3, 0.4)
    T0 = robot.home_pose
    hold = PayloadComputedTorque(robot, lambda t: (T0, np.zeros(6), np.zeros(6)), joints=joints)
    g = robot.inverse_dynamics(T0, np.zeros(6), np.zeros(6), *joints(0.0)).gamma
    table = ForceTable([0.0, 0.03, 0.06], [g, 1.01 * g, 0.99 * g], "linear")
    cases = {
        "hold": {"forces": hold, "control_period": 2e-3},
        "table": {"forces": table},
        "table, output_dt": {"forces": table, "output_dt": 7e-3},
    }
    for case, kwargs in cases.items():
        got = {}
        for integrator in ("python", "compiled"):
            got[integrator] = simulate_payload(
                robot, 0.06, joints, dt=2e-3, integrator=integrator, **kwargs
            )
        a, b = got["python"], got["compiled"]
        np.testing.assert_array_equal(a.result.t, b.result.t)
        for name in ("poses", "twists", "accels", "gammas", "lengths"):
            x, y = getattr(a.result, name), getattr(b.result, name)
            assert np.abs(x - y).max() <= 1e-10 * max(1.0, float(np.abs(x).max())), (case, name)
        np.testing.assert_allclose(b.tau, a.tau, rtol=0, atol=1e-10 * np.abs(a.tau).max())
        # what the C loop integrates is the whole constrained tree's motion (independent)
        r, k = b.result, np.arange(0, len(b.result.t), 5)
        accel, _ = check.reference_prescribed_dynamics(
            check.PayloadTreeSolver(robot.robot, robot.payload),
            *(r.poses[k], r.twists[k], r.gammas[k], b.q[k], b.qd[k], b.qdd[k]),
        )
        assert np.abs(r.accels[k] - accel).max() < 1e-9 * np.abs(accel).max(), case
    # the C loop took the steps (rows it wrote), not the Python loop
    run = simulation.prepare_run(
        robot.robot,
        0.06,
        dt=2e-3,
        forces=table,
        dynamics=simulation_dynamics(robot, joints),
        integrator="compiled",
    )
    run.go()
    assert not any(isinstance(r, simulation._State) for r in run.rows)
    with pytest.raises(InputError, match="payload on the adaptive method"):
        simulate_payload(robot, 0.01, joints, method="adaptive", integrator="compiled")
    # unpowered, the platform falls to a stroke end (joint limit): both loops stop alike
    errors = []
    for integrator in ("python", "compiled"):
        with pytest.raises(SimulationError) as e:
            simulate_payload(robot, 3.0, joints, dt=2e-3, output_dt=6e-3, integrator=integrator)
        errors.append(e.value)
    a, b = errors
    assert str(a) == str(b) and a.time == b.time and a.result.t.size > 5
    np.testing.assert_array_equal(a.result.t, b.result.t)
    for name in ("poses", "twists", "accels", "gammas"):
        x, y = getattr(a.result, name), getattr(b.result, name)
        assert np.abs(x - y).max() <= 1e-10 * max(1.0, float(np.abs(x).max())), name


@pytest.mark.parametrize("arm", ("panda", "kinova"))
def test_the_joints_sampled_at_once_equal_one_call_per_time(arm):
    """The compiled simulator samples the joints at every stage time in array operations
    (the displacement broadcast over the times, ``q0`` integrated joint by joint, the
    Kinova's unbounded revolute joints as ``(cos, sin)``): equal to ``joints(t)``
    (Pinocchio's ``integrate``) to round-off; a displacement that does not broadcast
    (minimum jerk) or ignores the times (still) is sampled one call per time."""
    from stewart_pin.motion.payload import _joints_at_once, _PrescribedJoints

    robot = carrier("simulator", arm)
    p = robot.payload
    times = np.linspace(0.0, 2.0, 801)
    goal = p.random_configurations(1, 5)[0]
    motions = {
        "sweep": JointMotion.sweep(p, 0.6, 0.7),
        "sinusoid": JointMotion.sinusoid(p, 0.3, 0.5),
        "point_to_point": JointMotion.point_to_point(p, p.home_configuration(), goal, 1.0),
        "still": JointMotion.still(p),
    }
    for name, motion in motions.items():
        ref = np.hstack(motion.sample(times))
        once = _joints_at_once(motion, times)
        assert (once is None) == (name in ("point_to_point", "still")), name
        if once is not None:
            np.testing.assert_allclose(once, ref, rtol=0, atol=1e-15 * np.abs(ref).max())
        got = _PrescribedJoints(robot, motion).joints_at(times)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-15 * np.abs(ref).max())


def simulation_dynamics(robot, joints):
    """``simulate_payload``'s direct model, for a run prepared here."""
    from stewart_pin.motion.payload import _PrescribedJoints

    return _PrescribedJoints(robot, joints)


def test_payload_simulation_saves_the_joints_beside_the_result(tmp_path):
    robot = carrier("simulator", "ur5")
    joints = JointMotion.sweep(robot.payload, 0.2, 0.5)
    sim = simulate_payload(robot, 0.01, joints, dt=5e-3)
    result, side = sim.save(tmp_path / "run.csv")
    assert side == payload_path(result) == tmp_path / "run.payload.npz"
    t, q = PayloadSimulation.load_joints(result, robot.payload)
    np.testing.assert_array_equal(t, sim.result.t)
    np.testing.assert_array_equal(q, sim.q)
    with pytest.raises(FileFormatError, match="missing"):
        PayloadSimulation.load_joints(tmp_path / "other.csv", robot.payload)
    with pytest.raises(InputError, match="this robot's payload"):
        simulate_payload(carrier("simulator", "panda"), 0.01, joints)


# ---------------------------------------------------------------------------- drawing
class Recorder:
    """A stand-in for a meshcat visualizer: records set_object and set_transform."""

    def __init__(self, log=None, path=()):
        self.log = [] if log is None else log
        self.path = path

    def __getitem__(self, key):
        return Recorder(self.log, (*self.path, key))

    def set_object(self, geometry, material=None):
        self.log.append(("object", "/".join(self.path), geometry))

    def set_transform(self, matrix):
        self.log.append(("transform", "/".join(self.path), np.array(matrix)))


def test_the_arm_is_drawn_with_its_meshes_where_pinocchio_places_them():
    from stewart_pin.viz.payload_scene import PayloadScene

    robot = carrier("simulator", "ur5")
    scene = PayloadScene(robot.payload)
    geom = robot.payload.visual_model()
    assert scene.meshes and len(scene.visuals) == geom.ngeoms
    rec = Recorder()
    scene.load(rec, "root")
    objects = [e for e in rec.log if e[0] == "object"]
    assert len(objects) == geom.ngeoms
    assert all(o[2].mesh_format == "dae" for o in objects)  # the UR5's visual meshes
    # placements: 0Tp T_p_b oMg of Pinocchio's geometry placements
    T = robot.home_pose
    T[:3, 3] += [0.01, -0.02, 0.03]
    q = robot.payload.random_configurations(1, 2)[0]
    model, data, gdata = robot.payload.model, robot.payload.model.createData(), geom.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geom, gdata)
    rec = Recorder()
    scene.display(rec, T, q, root="root")
    placed = {path: M for kind, path, M in rec.log if kind == "transform"}
    for k in range(geom.ngeoms):
        expected = T @ robot.payload.placement @ gdata.oMg[k].homogeneous
        np.testing.assert_allclose(placed[f"root/payload/visual{k}"], expected, atol=1e-12)


def test_a_model_without_a_urdf_is_drawn_with_simple_shapes():
    from stewart_pin.viz.payload_scene import PayloadScene

    payload = Payload.from_model(carrier("simulator", "panda").payload.model)
    scene = PayloadScene(payload)
    assert not scene.meshes
    model = payload.model
    # one sphere per joint, centred on it
    q = payload.home_configuration()
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    T = np.eye(4)
    M = scene.placements(T[None], q[None])[:, 0]
    spheres = [i for i, v in enumerate(scene.visuals) if type(v.geometry).__name__ == "Sphere"]
    assert len(spheres) == model.njoints - 1
    for i, j in zip(spheres, range(1, model.njoints), strict=True):
        np.testing.assert_allclose(M[i][:3, 3], data.oMi[j].translation, atol=1e-12)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """An HTML animation of the paper hexapod carrying a Panda (simple shapes)."""
    from stewart_pin.viz.payload_scene import PayloadViewer

    robot = carrier("paper", "panda")
    joints = JointMotion.sweep(robot.payload, 0.3, 1.0)
    t = np.linspace(0.0, 1.0, 31)
    poses = np.tile(robot.home_pose, (len(t), 1, 1))
    poses[:, 2, 3] += 0.02 * np.sin(2 * np.pi * t)
    q = joints.sample(t)[0]
    viewer = PayloadViewer(robot, meshes=False)
    path = tmp_path_factory.mktemp("html") / "arm.html"
    return viewer.export_html(path, poses, t, q), viewer, poses, t, q


def _commands(html: str) -> list[dict]:
    import umsgpack

    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([^"]+)"\)', html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def test_exported_animation_moves_the_arm_with_the_platform(exported):
    path, viewer, poses, _, q = exported
    (anim,) = [c for c in _commands(path.read_text()) if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    arm = [p for p in clips if "/payload/visual" in p]
    assert len(arm) == len(viewer.scene.visuals)
    expected = viewer.scene.placements(poses, q)  # (objects, K, 4, 4)
    for path_ in arm:
        i = int(path_.rsplit("visual", 1)[1])
        tracks = {tr["name"]: tr for tr in clips[path_]["tracks"]}
        pos = np.array([k["value"] for k in tracks[".position"]["keys"]])
        np.testing.assert_allclose(pos, expected[i, :, :3, 3], atol=1e-9)


def test_chromium_draws_the_arm_on_the_platform(exported, tmp_path):
    """The page with the arm differs from the hexapod alone, seen from the same camera,
    in the region above the platform. Both pages hold one state (the animation's first):
    a screenshot is taken whenever the page is ready, and a moving arm covers more or
    less of the page from one frame to the next."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("no Chromium on the PATH")
    import matplotlib.image

    from stewart_pin.viz.viewer import Viewer

    _, viewer, poses, t, q = exported
    poses, q = np.repeat(poses[:1], len(t), axis=0), np.repeat(q[:1], len(t), axis=0)
    camera = viewer.fit(poses, q)
    path = viewer.export_html(tmp_path / "held.html", poses, t, q, camera=camera)
    alone = Viewer(viewer.robot).export_html(tmp_path / "alone.html", poses, t, camera=camera)
    shots = []
    for page in (path, alone):
        png = tmp_path / f"{page.stem}.png"
        subprocess.run(
            [
                chromium,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--enable-unsafe-swiftshader",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--window-size=600,450",
                f"--user-data-dir={tmp_path / ('profile-' + page.stem)}",
                f"--screenshot={png}",
                page.as_uri(),
            ],
            check=True,
            timeout=90,
            capture_output=True,
        )
        shots.append(matplotlib.image.imread(png)[..., :3])
    differs = np.abs(shots[0] - shots[1]).max(axis=-1) > 0.15
    assert differs.mean() > 0.01, f"the arm covers {differs.mean():.4f} of the page"
    rows = np.flatnonzero(differs.any(axis=1))
    assert rows.min() < 0.4 * differs.shape[0]  # it stands up, above the platform


# ---------------------------------------------------------------------------- command line
def test_cli_simulate_and_animate_with_a_payload(tmp_path, capsys):
    out = tmp_path / "run.npz"
    args = ["--preset", "rus", "--payload", "so101", "--duration", "0.05", "--dt", "5e-3"]
    assert (
        main(["simulate", *args, "--control-period", "5e-3", "-o", str(out), "--no-progress"]) == 0
    )
    text = capsys.readouterr().out
    assert "rus+so101" in text and "tracking error" in text
    assert payload_path(out).is_file()
    html = tmp_path / "run.html"
    animate = ["animate", "--preset", "rus", "--payload", "so101", "--payload-shapes"]
    assert main([*animate, "--result", str(out), "-o", str(html)]) == 0
    assert "/payload/visual" in "".join(str(c) for c in _commands(html.read_text()))
    # a result without its payload sidecar: the arm at home, with a note
    payload_path(out).unlink()
    assert main([*animate, "--result", str(out), "-o", str(html)]) == 0
    assert "drawn at home" in capsys.readouterr().out


def test_cli_payload_placement_needs_a_payload(capsys):
    code = main(
        ["validate", "--preset", "desktop", "--payload-placement", "0", "0", "0", "0", "0", "0"]
    )
    assert code == 2 and "--payload-placement needs --payload" in capsys.readouterr().err
    # the payload's motion and drawing options without a payload: refused, not ignored
    for argv in (
        ["simulate", "--payload-fraction", "0.5", "--duration", "0.01"],
        ["animate", "--payload-period", "2"],
        ["view", "--payload-shapes", "--no-wait"],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{argv[1]} needs --payload" in err, err


def test_cli_payload_fraction_above_one_names_the_option(capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--payload", "so101", "--payload-fraction", "1.5"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "--payload-fraction: expected a number in (0, 1], got '1.5'" in err


# ---------------------------------------------------------------------------- the demo
def test_payload_demo_compensates_the_arm_and_writes_its_files(tmp_path, capsys):
    from stewart_pin.apps.payload_demo import reach_motion, run_payload_demo

    files = run_payload_demo(
        "paper", "panda", tmp_path, animation=False, duration=0.3, hold=0.06, dt=3e-3
    )
    assert files["figure"].stat().st_size > 10_000
    data = np.load(files["arrays"])
    t, moving, still = data["t"], data["gamma_moving"], data["gamma_still"]
    assert t[-1] == pytest.approx(0.36)
    # while the arm holds its goal, its motion takes nothing more; during the move, a lot
    held = t > 0.3 + 1e-9
    np.testing.assert_allclose(moving[held], still[held], rtol=1e-12, atol=1e-9)
    assert np.abs(moving - still).max() > 0.2 * np.abs(still).max()
    assert data["base_error"].max() < 0.05 * data["base_error_ignorant"].max()
    assert "compensates" in capsys.readouterr().out
    # the reach motion stays within the joint limits
    reach_motion(carrier("paper", "panda").payload, 0.3).check_limits()
