"""The viewer and the figures: tree configurations closing the loops, the standalone HTML
animation (self-contained, animation embedded, rendered and played by headless Chromium),
the live server's address and clean-up, and the figures' data."""

from __future__ import annotations

import base64
import contextlib
import http.server
import json
import os
import re
import shutil
import signal
import subprocess
import threading
import time
import warnings
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from helpers import points_in_base, tip_frame
from helpers import tree_configuration as tree_configuration_by_hand

from stewart_pin import StewartRobot
from stewart_pin.exceptions import InputError, MissingDependencyError, ViewerError
from stewart_pin.formats.urdf import VisualSizes, plate_visual
from stewart_pin.motion.simulation import simulate

meshcat = pytest.importorskip("meshcat")
matplotlib = pytest.importorskip("matplotlib")

from stewart_pin.viz import (  # noqa: E402
    Viewer,
    actuator_work,
    plot_energy,
    plot_forces,
    plot_lengths,
    plot_tracking_error,
    reference_poses,
    save_figures,
    tree_configuration,
)
from stewart_pin.viz.viewer import BACKGROUND  # noqa: E402

PRESETS = ("simulator", "desktop", "paper")
#: Names Chromium goes by on the PATH (Debian: chromium; Ubuntu and others: chromium-browser).
CHROMIUM_NAMES = ("chromium", "chromium-browser")
#: Headless Chromium on a closed network, software WebGL (SwiftShader).
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=800,600",
)
#: Seconds one Chromium run may take (2-4 s seen).
CHROMIUM_TIMEOUT = 60.0
#: Seconds the live viewer's test waits for Chromium's page to connect (the load gate
#: lets the page end at 30 s at the latest).
BROWSER_WAIT = 40.0
#: URDF materials: cylinder_blue and platform_orange.
BLUE, ORANGE = (0.20, 0.40, 0.80), (0.95, 0.55, 0.15)

# A 4 s motion at 30 samples per second: x ramps up by 15 % of the robot size and the
# platform turns about its vertical axis.
TIMES = np.linspace(0.0, 4.0, 121)
RAMP = 0.15
YAW = 0.2


def ramp_motion(robot: StewartRobot) -> np.ndarray:
    poses = np.tile(robot.home_pose, (len(TIMES), 1, 1))
    poses[:, 0, 3] += RAMP * robot.description.size * TIMES / TIMES[-1]
    for T, t in zip(poses, TIMES, strict=True):
        T[:3, :3] = pin.exp3(np.array([0.0, 0.0, YAW * t / TIMES[-1]])) @ T[:3, :3]
    return poses


def child_pids() -> set[int]:
    """Processes whose parent is this one (Linux /proc)."""
    me, out = os.getpid(), set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                status = (entry / "status").read_text()
            except OSError:
                continue
            if re.search(rf"^PPid:\s+{me}$", status, re.M):
                out.add(int(entry.name))
    return out


# ---------------------------------------------------------------------- Chromium
@pytest.fixture(scope="session")
def chromium() -> str:
    """Chromium's path; the test skips when no browser is on the PATH (tests install no
    system packages: ``.ci/run`` installs Debian's ``chromium`` once when it is missing)."""
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path is not None:
            return path
    pytest.skip(f"no Chromium on the PATH (looked for {', '.join(CHROMIUM_NAMES)})")


def run_chromium(
    chromium: str, url: str, tmp: Path, *args: str, budget_ms: int | None = None
) -> subprocess.CompletedProcess:
    """Run headless Chromium on ``url`` with a fresh profile; it returns after the page's
    load event, or after ``budget_ms`` of virtual time when given. On a time-out its whole
    process group (Chromium and its helpers, started here) is killed."""
    profile = tmp / f"profile-{len(list(tmp.glob('profile-*')))}"
    budget = [] if budget_ms is None else [f"--virtual-time-budget={budget_ms}"]
    cmd = [chromium, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *budget, *args, url]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        out, err = proc.communicate(timeout=CHROMIUM_TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"chromium took more than {CHROMIUM_TIMEOUT} s on {url}")
    assert proc.returncode == 0, err[-2000:]
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def screenshot(chromium: str, url: str, tmp: Path, budget_ms: int | None = None) -> np.ndarray:
    """The rendered page as an (H, W, 3) float array in [0, 1]."""
    import matplotlib.image

    png = tmp / f"shot-{len(list(tmp.glob('shot-*')))}.png"
    run_chromium(chromium, url, tmp, f"--screenshot={png}", budget_ms=budget_ms)
    return matplotlib.image.imread(png)[..., :3]


class LoadGate:
    """A local HTTP server (127.0.0.1) whose ``/wait`` answers only once the gate is open
    (a request to ``/open``, or :meth:`open`; at the latest after 30 s): an
    ``<img src=".../wait">`` holds a page's load event, so that Chromium's ``--dump-dom``
    and ``--screenshot`` wait, in real time, for the gate."""

    def __init__(self) -> None:
        gate = self._gate = threading.Event()

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                if self.path == "/open":
                    gate.set()
                else:
                    gate.wait(30.0)
                self.send_response(204)
                self.end_headers()

            def log_message(self, *args: object) -> None:
                pass

        self._server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self._server.server_address[1]}"
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()

    def open(self) -> None:
        self._gate.set()

    def close(self) -> None:
        self._gate.set()
        self._server.shutdown()
        self._server.server_close()
        self._thread.join()


@contextlib.contextmanager
def load_gate() -> Iterator[LoadGate]:
    gate = LoadGate()
    try:
        yield gate
    finally:
        gate.close()


def robot_colour_masks(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels of the blue cylinders and of the orange platform (hue, shaded or lit)."""
    from matplotlib.colors import rgb_to_hsv

    hsv = rgb_to_hsv(img)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    blue_hue, orange_hue = rgb_to_hsv(np.array(BLUE))[0], rgb_to_hsv(np.array(ORANGE))[0]
    blue = (np.abs(h - blue_hue) < 0.05) & (s > 0.4) & (v > 0.2)
    orange = (np.abs(h - orange_hue) < 0.04) & (s > 0.5) & (v > 0.3)
    return blue, orange


def check_robot_in_view(img: np.ndarray) -> None:
    H, W, _ = img.shape
    # meshcat's background: a vertical gradient from BACKGROUND[0] (top) to [1] (bottom).
    top, bottom = (np.array(c) for c in BACKGROUND)
    rows = np.linspace(0.0, 1.0, H)[:, None, None]
    background = top + rows * (bottom - top)
    centre = (slice(H // 4, 3 * H // 4), slice(W // 4, 3 * W // 4))
    differs = np.abs(img - background).max(axis=-1) > 0.15
    assert differs[centre].mean() > 0.3, "the centre of the page shows mostly background"
    blue, orange = robot_colour_masks(img)
    assert blue.mean() > 0.004, f"too few blue (cylinder) pixels: {blue.mean():.4f}"
    assert orange.mean() > 0.02, f"too few orange (platform) pixels: {orange.mean():.4f}"
    # The whole robot is in view: its coloured pixels stay clear of the image border and
    # gather around the image centre.
    ys, xs = np.nonzero(blue | orange)
    margin = 0.02
    assert ys.min() > margin * H and ys.max() < (1 - margin) * H, (ys.min(), ys.max())
    assert xs.min() > margin * W and xs.max() < (1 - margin) * W, (xs.min(), xs.max())
    assert abs(xs.mean() / W - 0.5) < 0.15 and abs(ys.mean() / H - 0.5) < 0.2


# ---------------------------------------------------------------------- configurations
def test_tree_configuration_closes_every_loop(any_robot, rng):
    """Pinocchio's forward kinematics puts every leg tip (origin of frame 3i) on P_i, and
    the free-flyer at 0Tp; a batch gives the single results row by row."""
    robot = any_robot
    model = robot.tree.model
    data = model.createData()
    poses = robot.sample_poses(5, rng)
    q_batch = tree_configuration(robot, poses)
    assert q_batch.shape == (5, model.nq)
    for T, qb in zip(poses, q_batch, strict=True):
        q = tree_configuration(robot, pin.SE3(T))
        np.testing.assert_array_equal(q, qb)
        by_hand = tree_configuration_by_hand(model, T, robot.inverse_geometry(T))
        np.testing.assert_allclose(q, by_hand, rtol=0, atol=1e-15)
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        P = points_in_base(robot.description, T)
        for i in range(6):
            tip = data.oMf[model.getFrameId(tip_frame(i))].translation
            np.testing.assert_allclose(tip, P[i], rtol=0, atol=1e-12)
        platform = data.oMi[robot.tree.platform_joint].homogeneous
        np.testing.assert_allclose(platform, T, rtol=0, atol=1e-12)


def test_visual_model_keeps_the_urdf_colours(simulator):
    viewer = Viewer(simulator)
    colours = {g.name: g.meshColor[:3] for g in viewer.visual_model.geometryObjects}
    np.testing.assert_allclose(colours["platform_0"], ORANGE, atol=1e-6)
    for i in range(1, 7):
        np.testing.assert_allclose(colours[f"leg{i}_link2_0"], BLUE, atol=1e-6)
    assert len(colours) == 26  # base, 6 x (sphere, cylinder, rod, sphere), platform


# ---------------------------------------------------------------------- HTML export
@pytest.fixture(scope="module")
def exported(simulator, tmp_path_factory) -> Path:
    """The simulator preset's ramp motion, exported; no process may outlive the export."""
    before = child_pids()
    path = Viewer(simulator).export_html(
        tmp_path_factory.mktemp("html") / "motion.html", ramp_motion(simulator), TIMES
    )
    assert child_pids() <= before, "the meshcat server outlived the export"
    return path


def commands(html: str) -> list[dict]:
    """meshcat's drawing commands embedded in a static page (msgpack in data URLs)."""
    import umsgpack

    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([^"]+)"\)', html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def test_exported_html_is_self_contained(exported):
    html = exported.read_text(encoding="utf-8")
    assert html.lstrip().lower().startswith("<!doctype html>")
    assert "MeshCat.Viewer" in html
    # Nothing fetched from a server: no external scripts, styles or frames, and every
    # fetch() reads a data: URL.
    assert not re.search(r"<(script|link|iframe|img)\b[^>]*\b(src|href)\s*=", html, re.I)
    assert not re.search(r"@import", html)
    fetches = re.findall(r"fetch\(\s*([\"'`])(.{0,40})", html)
    assert fetches, "no embedded commands"
    assert all(url.startswith("data:") for _, url in fetches), {u for _, u in fetches}
    # The only URLs: XML namespace names (never fetched) and the websocket of meshcat's
    # Viewer.connect(), which the static page never calls.
    urls = set(re.findall(r"(?:https?|wss?)://[^\s\"'`<>)]+", html))
    assert urls <= {"http://www.w3.org/1999/xhtml", "ws://${location.host}"}, urls
    page_script = html[html.index("new MeshCat.Viewer(") :]
    assert ".connect(" not in page_script


def test_exported_html_embeds_the_animation(exported, simulator):
    """One set_animation command: 25 moving objects (all but the base), 121 keyframes at
    the motion's times, looping forever; each leg tip sphere's keys lie on P_i."""
    cmds = commands(exported.read_text(encoding="utf-8"))
    assert {c["type"] for c in cmds} >= {"set_object", "set_transform", "set_animation"}
    (anim,) = [c for c in cmds if c["type"] == "set_animation"]
    assert anim["options"] == {"play": True, "repetitions": float("inf")}
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    assert len(clips) == 25
    assert not any("base_link" in p for p in clips)
    poses = ramp_motion(simulator)
    for i in range(6):
        clip = clips[f"/meshcat/stewart_pin/visuals/leg{i + 1}_link3_1"]
        tracks = {t["name"]: t for t in clip["tracks"]}
        keys = tracks[".position"]["keys"]
        times = np.array([k["time"] for k in keys]) / clip["fps"]
        np.testing.assert_allclose(times, TIMES, rtol=0, atol=1e-12)
        tips = np.array([k["value"] for k in keys])
        expected = np.array([points_in_base(simulator.description, T)[i] for T in poses])
        np.testing.assert_allclose(tips, expected, rtol=0, atol=1e-9)


def test_export_input_errors(simulator, tmp_path):
    viewer = Viewer(simulator)
    poses = ramp_motion(simulator)
    with pytest.raises(InputError, match="times has 3 values"):
        viewer.export_html(tmp_path / "x.html", poses, TIMES[:3])
    with pytest.raises(InputError, match="strictly increasing"):
        viewer.export_html(tmp_path / "x.html", poses, TIMES[::-1])
    with pytest.raises(InputError, match="fps"):
        viewer.export_html(tmp_path / "x.html", poses, TIMES, fps=0)
    with pytest.raises(InputError, match="speed"):
        viewer.play(poses, TIMES, speed=0)
    assert not (tmp_path / "x.html").exists()


def test_exported_frames_are_thinned_to_fps(simulator, tmp_path):
    """A 1 kHz motion exports at most ``fps`` keyframes per second, the last included."""
    t = np.arange(0.0, 0.5005, 1e-3)
    poses = np.tile(simulator.home_pose, (len(t), 1, 1))
    poses[:, 2, 3] += 0.05 * t
    path = Viewer(simulator).export_html(tmp_path / "m.html", poses, t, fps=20, loop=False)
    (anim,) = [c for c in commands(path.read_text()) if c["type"] == "set_animation"]
    assert anim["options"]["repetitions"] == 1
    clip = anim["animations"][0]["clip"]
    times = np.array([k["time"] for k in clip["tracks"][0]["keys"]]) / clip["fps"]
    np.testing.assert_allclose(times, np.linspace(0.0, 0.5, 11), atol=1e-9)


# ---------------------------------------------------------------------- in Chromium
def test_chromium_plays_the_exported_animation(exported, simulator, chromium, tmp_path):
    """In the browser, the animation runs: the platform disc's position follows the
    motion at the animation's clock (probed from the page's own viewer object).

    The probe steps meshcat's animator itself (``update()`` reads the animation clock,
    as meshcat's requestAnimationFrame loop does) three times, 0.4 s of real time apart
    at least, then opens the load gate so that Chromium dumps the DOM. The animation
    loops (4 s long), so on a busy machine its clock may wrap between two probes: the
    clock's advance is compared with the page's real time modulo the duration.
    """
    probe = """<script>
    var probes = [];
    function probe() {
      const a = viewer.animator;
      a.update();
      const node = viewer.scene_tree.find(["meshcat", "stewart_pin", "visuals", "platform_0"]);
      const p = node.object.position;
      probes.push({playing: a.playing, duration: a.duration, actions: a.actions.length,
                   time: a.time, now: performance.now() / 1000, position: [p.x, p.y, p.z]});
      document.body.setAttribute("data-probe", JSON.stringify(probes));
      if (probes.length < 3) setTimeout(probe, 400);
      else new Image().src = "GATE/open";
    }
    setTimeout(probe, 300);
    </script><img src="GATE/wait" alt=""></body>"""
    page = tmp_path / "probe.html"
    with load_gate() as gate:
        html = exported.read_text(encoding="utf-8")
        page.write_text(html.replace("</body>", probe.replace("GATE", gate.url)))
        dom = run_chromium(chromium, page.as_uri(), tmp_path, "--dump-dom").stdout
    found = re.search(r'data-probe="([^"]*)"', dom)
    assert found, "the probe did not run"
    probes = json.loads(found.group(1).replace("&quot;", '"'))
    assert len(probes) == 3
    assert all(p["playing"] and p["actions"] == 25 for p in probes)
    assert all(p["duration"] == pytest.approx(TIMES[-1]) for p in probes)
    times = np.array([p["time"] for p in probes])
    now = np.array([p["now"] for p in probes])
    assert np.all(np.diff(now) >= 0.39), now
    assert np.all((times >= 0) & (times <= TIMES[-1])), times
    # The clock runs at real speed: between probes it advances by the real time elapsed,
    # modulo the looping duration (to 0.1 s: a frame or two of slack either side).
    lag = np.diff(times) - np.diff(now)
    wrapped = (lag + TIMES[-1] / 2) % TIMES[-1] - TIMES[-1] / 2
    assert np.all(np.abs(wrapped) < 0.1), f"the animation clock does not run: {times}, {now}"
    # The disc centre in the robot frame: on the platform's axis, so the yaw leaves it
    # where the ramp puts it. three.js interpolates keyframes linearly, in float32.
    desc = simulator.description
    xyz = plate_visual(desc.platform_points, VisualSizes.for_robot(desc), 1.0)[0]
    for p in probes:
        T = simulator.home_pose
        T[0, 3] += RAMP * desc.size * p["time"] / TIMES[-1]
        np.testing.assert_allclose(p["position"], T[:3, :3] @ xyz + T[:3, 3], atol=1e-5)


@pytest.mark.parametrize("name", PRESETS)
def test_chromium_renders_the_whole_robot(name, chromium, tmp_path, exported):
    """Each preset's page shows the robot in its URDF colours, whole and centred."""
    robot = StewartRobot.from_preset(name) if name != "simulator" else None
    if robot is None:
        page = exported
    else:
        page = Viewer(robot).export_html(tmp_path / f"{name}.html", ramp_motion(robot), TIMES)
    check_robot_in_view(screenshot(chromium, page.as_uri(), tmp_path))


def listening_addresses(pid: int) -> set[str]:
    """Local addresses of the TCP sockets process ``pid`` listens on (Linux /proc)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        target = os.readlink(fd)
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out = set()
    for table in ("tcp", "tcp6"):
        for line in Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                hex_ip = fields[1].split(":")[0]
                raw = bytes.fromhex(hex_ip)
                words = [raw[k : k + 4][::-1] for k in range(0, len(raw), 4)]
                out.add(
                    ".".join(str(b) for b in words[0])
                    if table == "tcp"
                    else ":".join(w.hex() for w in words)
                )
    return out


def test_live_viewer_listens_on_localhost_only(paper, chromium, tmp_path):
    """The live server listens on 127.0.0.1 and nowhere else, a browser on its URL shows
    the displayed robot, and close() ends the server."""
    before = child_pids()
    with Viewer(paper) as viewer:
        url = viewer.start()
        assert url.startswith("http://127.0.0.1:")
        (pid,) = child_pids() - before
        assert listening_addresses(pid) == {"127.0.0.1"}
        T = paper.home_pose
        T[:3, 3] += [0.02, -0.03, 0.05]
        viewer.display(T)
        viewer.play(ramp_motion(paper)[::20], TIMES[::20], speed=20.0)
        viewer.display(T)
        # The page gets the scene over its websocket after its load event, and virtual
        # time (--virtual-time-budget) can hang with a websocket open: show the page in
        # an iframe of a wrapper page whose load the gate holds until the viewer's browser
        # is connected and has had time to draw (3 s: with 1.5 s, the first try found no
        # platform pixels in most runs of the suite on 2 cores). On a busy machine
        # the browser may not have drawn every mesh in that time, or not have
        # connected before the gate's own 30 s: a new page, given longer, up to three
        # times (the robot must be in view on one of them). The wait is bounded: a
        # browser that never connects is a failure, not a hung suite.
        failed: list[str] = []
        for attempt, draw_time in enumerate((3.0, 6.0, 10.0)):
            # Each retry on a new server (and URL, the robot at home): a browser of a new
            # page did not connect in 40 s to a server whose earlier browser had gone
            # (meshcat's, seen on a busy machine; noted on issue 24).
            if attempt:
                viewer.close()
            url = viewer.start()
            with load_gate() as gate, ThreadPoolExecutor(1) as pool:
                wrapper = tmp_path / f"live-{attempt}.html"
                wrapper.write_text(
                    '<!DOCTYPE html><html><body style="margin:0; overflow:hidden">'
                    f'<iframe src="{url}" style="border:0; width:800px; height:600px; '
                    'display:block"></iframe>'
                    f'<img src="{gate.url}/wait" alt="" style="display:none"></body></html>'
                )
                shot = pool.submit(screenshot, chromium, wrapper.as_uri(), tmp_path)
                started = time.monotonic()
                try:
                    viewer.wait(timeout=BROWSER_WAIT)
                    connected = True
                except ViewerError:
                    connected = False
                else:
                    time.sleep(draw_time)
                waited = time.monotonic() - started
                gate.open()
                img = shot.result()
            try:
                assert connected, f"chromium did not connect within {BROWSER_WAIT} s"
                check_robot_in_view(img)
                break
            except AssertionError as e:
                failed.append(f"try {attempt} after {waited:.1f} s: {str(e).splitlines()[0]}")
                if attempt == 2:
                    raise
    if failed:  # passed on a later try: said in the run's warnings summary (CI's log)
        tries = "; ".join(failed)
        warnings.warn(f"the live viewer passed after failed tries: {tries}", stacklevel=1)
    assert viewer.url is None
    assert child_pids() <= before


def test_waiting_for_a_browser_that_never_comes_times_out_and_stops_the_server(paper):
    """meshcat's server answers nothing until a browser connects: a wait with a time-out
    raises ViewerError in about that time, stops the stuck server, and the viewer starts
    a new one that answers."""
    before = child_pids()
    with Viewer(paper) as viewer:
        viewer.start()
        t0 = time.monotonic()
        with pytest.raises(ViewerError, match=r"within 0\.5 s"):
            viewer.wait(timeout=0.5)
        assert 0.4 < time.monotonic() - t0 < 20.0
        assert viewer.url is None
        assert child_pids() <= before
        second = viewer.start()  # a new server process, listening on 127.0.0.1
        (pid,) = child_pids() - before
        assert listening_addresses(pid) == {"127.0.0.1"}
        assert second.startswith("http://127.0.0.1:")
        viewer.display(paper.home_pose)  # the new server answers requests
    assert child_pids() <= before


@pytest.mark.parametrize("timeout", [0.0, -1.0, float("nan"), float("inf"), "5", True])
def test_wait_refuses_a_timeout_that_is_not_a_positive_number(paper, timeout):
    with Viewer(paper) as viewer, pytest.raises(InputError, match="timeout"):
        viewer.wait(timeout=timeout)


def test_missing_meshcat_gives_the_install_hint(simulator, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "meshcat", None)
    with pytest.raises(MissingDependencyError, match=re.escape('pip install "stewart-pin[viz]"')):
        Viewer(simulator)


# ---------------------------------------------------------------------- figures
def line_data(ax) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(np.asarray(ln.get_xdata()), np.asarray(ln.get_ydata())) for ln in ax.lines]


def save_png(fig, path: Path) -> None:
    fig.savefig(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_forces_and_lengths(simulator, rng, tmp_path):
    t = np.linspace(0.0, 1.0, 50)
    gammas, lengths = rng.normal(size=(50, 6)), 2.4 + 0.1 * rng.normal(size=(50, 6))
    fig = plot_forces(t, gammas)
    lines = line_data(fig.axes[0])
    assert len(lines) == 6
    for i, (x, y) in enumerate(lines):
        np.testing.assert_array_equal(x, t)
        np.testing.assert_array_equal(y, gammas[:, i])
    save_png(fig, tmp_path / "forces.png")

    stroke = simulator.description.stroke
    fig = plot_lengths(t, lengths, stroke)
    lines = line_data(fig.axes[0])
    assert len(lines) == 8
    for i, (_, y) in enumerate(lines[:6]):
        np.testing.assert_array_equal(y, lengths[:, i])
    assert [tuple(y) for _, y in lines[6:]] == [(stroke[0],) * 2, (stroke[1],) * 2]
    save_png(fig, tmp_path / "lengths.png")
    assert len(plot_lengths(t, lengths).axes[0].lines) == 6
    with pytest.raises(InputError, match="gammas"):
        plot_forces(t, gammas[:, :5])


def test_plot_tracking_error_units(simulator, tmp_path):
    """A known offset (1, 2, -3) mm and rotation exp(w) show as those values in mm, deg."""
    t = np.linspace(0.0, 1.0, 20)
    reference = ramp_motion(simulator)[:20]
    w = np.radians([0.5, -0.2, 0.1])
    poses = reference.copy()
    poses[:, :3, 3] += [1e-3, 2e-3, -3e-3]
    poses[:, :3, :3] = pin.exp3(w) @ reference[:, :3, :3]
    fig = plot_tracking_error(t, poses, reference)
    ax_p, ax_r = fig.axes
    for ax, expected in ((ax_p, [1.0, 2.0, -3.0]), (ax_r, np.degrees(w))):
        lines = line_data(ax)
        assert len(lines) == 4
        for (x, y), e in zip(lines, [*expected, np.linalg.norm(expected)], strict=True):
            np.testing.assert_array_equal(x, t)
            np.testing.assert_allclose(y, e, rtol=1e-9, atol=1e-12)
    assert "mm" in ax_p.get_ylabel() and "deg" in ax_r.get_ylabel()
    save_png(fig, tmp_path / "tracking.png")


def test_plot_energy(tmp_path):
    t = np.linspace(0.0, 1.0, 30)
    energy = 10.0 + 1e-3 * np.sin(t)
    fig = plot_energy(t, energy)
    ((x, y),) = line_data(fig.axes[0])
    np.testing.assert_array_equal(x, t)
    np.testing.assert_array_equal(y, energy)
    save_png(fig, tmp_path / "energy.png")


@pytest.mark.parametrize(("name", "rtol"), [("desktop", 1e-12), ("rus", 1e-5)])
def test_the_energy_figure_of_a_driven_motion_is_the_work_energy_balance(
    name, rtol, tmp_path, monkeypatch
):
    """Under computed torque the energy changes by the actuators' work (and the joints'
    losses on the friction of the RUS preset): ``energy.png`` said "max |E - E(0)| = 0.049
    J", a failed conservation check to the eye. It plots the balance, whose residual is the
    integration error: ~1e-15 of the work for the frictionless 6-UPS (RK4, efforts held
    exactly over each step), ~1e-6 with the losses (trapezoid over the samples)."""
    from stewart_pin.motion.control import ComputedTorqueController
    from stewart_pin.motion.trajectories import standard_motion
    from stewart_pin.viz import plots

    robot = StewartRobot.from_preset(name)
    motion = standard_motion(robot, "sinusoid", 0.3)
    control = ComputedTorqueController(robot, motion, backend="pinocchio")
    T0, V0, _ = motion(0.0)
    result = simulate(
        robot, 0.3, T0, V0, control, dt=1e-3, control_period=1e-3, backend="pinocchio"
    )
    seen = {}
    balance = plots.plot_energy_balance
    monkeypatch.setattr(plots, "plot_energy_balance", lambda *a: seen.setdefault("f", balance(*a)))
    plots.save_figures(result, tmp_path, robot=robot)
    top, bottom = seen["f"].axes
    (_, change), (_, work), *_ = line_data(top)
    ((_, residual),) = line_data(bottom)
    assert np.abs(change).max() > 0.04 and np.abs(work).max() > 0.04  # a driven motion
    assert np.abs(residual).max() < rtol * np.abs(work).max()
    assert top.get_title().startswith("Work-energy balance: max |E - E(0) + losses - work|\n= ")


def test_actuator_work_of_constant_forces_is_force_times_displacement():
    gammas = np.array([[2.0, 0, 0, 0, 0, -1.0], [5.0, 0, 0, 0, 0, 3.0], [0.0] * 6])
    positions = np.array([[0.0] * 6, [0.5, 0, 0, 0, 0, 0.25], [0.5, 0, 0, 0, 0, 1.25]])
    np.testing.assert_allclose(
        actuator_work(gammas, positions), [0.0, 2 * 0.5 - 0.25, 2 * 0.5 - 0.25 + 3.0], rtol=1e-15
    )


def test_save_figures(desktop, tmp_path):
    result = simulate(desktop, 0.05, dt=1e-3)
    paths = save_figures(result, tmp_path / "figs")
    assert set(paths) == {"forces", "lengths"}
    ref = result.poses.copy()
    paths = save_figures(result, tmp_path / "figs", reference=ref, robot=desktop)
    assert set(paths) == {"forces", "lengths", "tracking_error", "energy"}
    for p in paths.values():
        assert p.is_file() and p.read_bytes()[:4] == b"\x89PNG"
    home = desktop.home_pose
    paths = save_figures(result, tmp_path / "callable", reference=lambda t: home)
    assert paths["tracking_error"].is_file()


def test_reference_poses_forms(desktop):
    """Poses, a function of t giving a pose or (T, V, A), or a motion with sample()."""
    t = TIMES[:5]
    poses = ramp_motion(desktop)[:5]
    at = dict(zip(t, poses, strict=True))

    class Motion:
        def sample(self, times):
            return type("Sampled", (), {"poses": np.array([at[x] for x in times])})

    for reference in (poses, lambda x: at[x], lambda x: (at[x], None, None), Motion()):
        np.testing.assert_array_equal(reference_poses(reference, t), poses)
    with pytest.raises(InputError, match="4 poses for 5 times"):
        reference_poses(poses[:4], t)


def test_missing_matplotlib_gives_the_install_hint(monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "matplotlib.figure", None)
    with pytest.raises(MissingDependencyError, match=re.escape('pip install "stewart-pin[viz]"')):
        plot_energy([0.0, 1.0], [1.0, 1.0])
