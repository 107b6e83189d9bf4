"""The reference path of each architecture (:mod:`stewart_pin.architectures`, issue 19):
chosen once when a robot is built, so that the facade asks no architecture question; a
pickle holds no path.

References: the source text of ``robot.py`` (no branch on the architecture), the
description's own flag, the original robot's results (a pickled copy)."""

from __future__ import annotations

import ast
import pickle
from pathlib import Path

import pytest

import stewart_pin
from stewart_pin import StewartRobot
from stewart_pin.architectures import IdealUpsPath, LegChainPath, reference_path
from stewart_pin.description.presets import preset


def test_the_facade_asks_no_architecture_question():
    """``robot.py`` has no ``if``/conditional expression on ``is_ideal_ups`` or
    ``is_general``: each method calls the path chosen when the robot is built."""
    tree = ast.parse((Path(stewart_pin.__file__).parent / "robot.py").read_text())
    tests = [n.test for n in ast.walk(tree) if isinstance(n, (ast.If, ast.IfExp))]
    asked = [ast.unparse(t) for t in tests if "is_ideal_ups" in ast.unparse(t)]
    asked += [ast.unparse(t) for t in tests if "is_general" in ast.unparse(t)]
    assert asked == []


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("simulator", IdealUpsPath),
        ("paper", IdealUpsPath),
        ("rus", LegChainPath),
        ("pus", LegChainPath),
        ("ups-offset", LegChainPath),
    ],
)
def test_the_path_follows_the_architecture(name, kind):
    """The ideal 6-UPS (the paper's closed forms) and every other robot (leg chains)."""
    desc = preset(name)
    assert type(reference_path(desc)) is kind
    assert reference_path(desc).is_ideal_ups == desc.is_ideal_ups


@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_a_pickled_robot_chooses_its_path_again(name):
    """A pickle holds no path (one written before the paths existed, without ``_kind``,
    loads too); the copy's results are the original's."""
    robot = StewartRobot.from_preset(name)
    state = robot.__getstate__()
    assert "_kind" not in state
    copy = pickle.loads(pickle.dumps(robot))
    assert copy._kind is reference_path(robot.description)
    old = StewartRobot.__new__(StewartRobot)
    old.__setstate__(state)
    T = robot.home_pose
    assert (old.actuator_positions(T) == robot.actuator_positions(T)).all()
    assert (copy.inverse_jacobian(T) == robot.inverse_jacobian(T)).all()


@pytest.mark.parametrize("name", ["simulator", "ups-offset", "rus", "pus", "random-custom-0"])
def test_admissible_poses_is_the_decision_of_the_checked_calls(name):
    """``robot.admissible_poses`` (the whole batch at once, no exception) against the
    raising calls state by state: the inverse geometry with limits, then the measure."""
    import numpy as np

    from stewart_pin.exceptions import StewartPinError

    robot = StewartRobot.from_preset(name)
    rng = np.random.default_rng(7)
    T = robot.sample_poses(40, rng)
    wide = np.tile(robot.home_pose, (60, 1, 1))  # mostly outside the limits
    wide[:, :3, 3] += rng.uniform(-1.0, 1.0, (60, 3)) * robot.description.size
    T = np.concatenate([T, wide])
    bound = 0.5 * robot.max_condition

    def checked(pose):
        try:
            robot.inverse_geometry(pose, check_limits=True)
            return bool(robot.condition_number(pose) <= bound)
        except StewartPinError:
            return False

    expected = np.array([checked(p) for p in T])
    assert 0 < expected.sum() < len(T)  # both kinds of pose are met
    assert np.array_equal(robot.admissible_poses(T, bound), expected)
    assert robot.admissible_poses(T[0]).shape == (1,)


# ---------------------------------------------------------------------------- issue 19, item 2
#: The modules (or folders) that may read the architecture flags: the paths, codegen's
#: one table, the description (which defines ``is_ideal_ups``), the independent check
#: (its own trees, sharing nothing with what it checks) and a deprecated alias module.
ALLOWED_FILES = (
    "architectures.py",
    "codegen/_architecture.py",
    "formats/general_urdf.py",
    "description/",
    "check/",
)
#: Functions that may read them anywhere: a property exposing the flag
#: (``StewartRobot.is_ideal_ups``, ``formats.urdf.is_general``) and the model files' one
#: choice of form per writer (``_form`` in formats/urdf.py, mjcf.py, xacro.py).
ALLOWED_FUNCTIONS = {"is_ideal_ups", "is_general", "_form"}
FLAGS = {"is_ideal_ups", "is_general"}


def flag_reads(source: str) -> list[tuple[int, str]]:
    """``(line, text)`` of each read of an architecture flag in ``source`` outside the
    allowed functions: an attribute ``x.is_ideal_ups``, a name ``is_general(...)``, or the
    flag's name as a string (``getattr(desc, "is_ideal_ups")``); imports do not count."""
    found: list[tuple[int, str]] = []

    def visit(node: ast.AST, allowed: bool) -> None:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            allowed = allowed or node.name in ALLOWED_FUNCTIONS
        if not allowed and (
            (isinstance(node, ast.Attribute) and node.attr in FLAGS)
            or (isinstance(node, ast.Name) and node.id in FLAGS)
            or (isinstance(node, ast.Constant) and node.value in FLAGS)
        ):
            found.append((node.lineno, ast.unparse(node)))
        for child in ast.iter_child_nodes(node):
            visit(child, allowed)

    visit(ast.parse(source), False)
    return found


def test_flag_reads_finds_every_kind_of_read():
    """The scan itself, on a source whose reads are known."""
    source = (
        "def f(desc, robot):\n"
        "    a = desc.is_ideal_ups\n"
        "    b = is_general(desc)\n"
        "    c = getattr(desc, 'is_ideal_ups', None)\n"
        "    return a, b, c\n"
        "def _form(desc):\n"
        "    return is_general(desc)\n"
        "class R:\n"
        "    @property\n"
        "    def is_ideal_ups(self):\n"
        "        return self._kind.is_ideal_ups\n"
    )
    assert [line for line, _ in flag_reads(source)] == [2, 3, 4]


def test_no_module_above_the_architecture_layer_asks_which_architecture_it_holds():
    """Only the allowed modules read ``is_ideal_ups`` / ``is_general`` (issue 19: what
    makes an architecture special lives in one place per architecture, chosen there)."""
    root = Path(stewart_pin.__file__).parent
    reads = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(ALLOWED_FILES):
            continue
        reads += [f"{rel}:{line}: {text}" for line, text in flag_reads(path.read_text())]
    assert reads == []


def test_limit_margin_of_the_ideal_6ups_is_its_stroke_margin():
    """``robot.limit_margin`` on the ideal 6-UPS (the simulator's event location): the
    smallest distance of a leg length |B_i P_i| (by hand) to the stroke ends, over the
    stroke's longest length, and the leg it names."""
    import numpy as np
    from helpers import leg_lengths_by_hand

    robot = StewartRobot.from_preset("simulator")
    lo, hi = robot.description.stroke
    for T in robot.sample_poses(5, 3):
        lengths = leg_lengths_by_hand(robot.description, T)
        per_leg = np.minimum(lengths - lo, hi - lengths)
        margin, what = robot.limit_margin(T)
        assert margin == pytest.approx(per_leg.min() / hi, rel=1e-12, abs=1e-15)
        assert what.startswith(f"leg {int(np.argmin(per_leg)) + 1} length ")


def test_the_pinocchio_models_are_chosen_by_the_path():
    """``robot.tree`` / ``leg_models`` / ``legs_model`` (the paths' builders) are the
    24-dof tree with six 3D closures, six 3-dof legs and an 18-dof model for both paths;
    the former names in ``models.leg_chains`` warn and give the same models."""
    import warnings

    import numpy as np

    import stewart_pin.architectures as arch
    from stewart_pin.models import leg_chains

    for name in ("simulator", "rus"):
        robot = StewartRobot.from_preset(name)
        tree = robot.tree
        assert (tree.model.nq, tree.model.nv, len(tree.constraints)) == (25, 24, 6)
        assert [m.nv for m in robot.leg_models] == [3] * 6
        model, index = robot.legs_model
        assert model.nv == 18 and np.array_equal(np.sort(index.ravel()), np.arange(18))
        with pytest.warns(DeprecationWarning, match="stewart_pin.architectures.closed_loop_tree"):
            old = leg_chains.closed_loop_tree(robot.description)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            new = arch.closed_loop_tree(robot.description)
        assert (
            [n for n in old.model.names] == [n for n in new.model.names] == list(tree.model.names)
        )


# ---------------------------------------------------------------------------- issue 19, item 1
#: The same question in other spellings: ``legs is None`` (the ideal 6-UPS stores no leg
#: chains) and a ``general`` flag or object tested for truth or ``None``. Where they may
#: stay: the description (it defines the two forms), the independent check (its own
#: trees), the regressor (below the paths: the standard-parameter layout, the paper's
#: 190 or the chains' 280 with joint terms), the viewer's one choice of drawing
#: (``drawing_for``: the URDF tree with its visuals or the leg chains, from the path's
#: ``urdf_visuals``), and in ``general_robot`` the duck-typed objects that are no
#: description (a foreign object without ``legs`` is drawn from its URDF tree).
IDENTITY_ALLOWED_FILES = (
    "description/",
    "check/",
    "dynamics/regressor.py",
    # the per-architecture layer (the paths and codegen's strategies)
    "architectures.py",
    "codegen/_architecture.py",
    # the chain legs' own kinematics (below the layer: the path calls it)
    "kinematics/chain_legs.py",
)
IDENTITY_ALLOWED_FUNCTIONS = {
    ("viz/leg_scene.py", "general_robot"),
    ("viz/viewer.py", "drawing_for"),
}
IDENTITY_NAMES = {"legs", "general", "chain_legs"}


def identity_checks(source: str, rel: str = "") -> list[tuple[int, str]]:
    """``(line, text)`` of each identity check in ``source``: ``x.legs is None`` /
    ``legs is not None`` (any ``is``/``is not`` ``None`` on a ``legs`` or ``general``
    name or attribute), and a ``legs`` / ``general`` name or attribute used as a truth
    value (``if``, conditional expression, ``while``, ``and``/``or``, ``not``); outside
    the functions of :data:`IDENTITY_ALLOWED_FUNCTIONS` for file ``rel``."""

    def named(n: ast.AST) -> bool:
        return (isinstance(n, ast.Attribute) and n.attr in IDENTITY_NAMES) or (
            isinstance(n, ast.Name) and n.id in IDENTITY_NAMES
        )

    found: list[tuple[int, str]] = []

    def visit(node: ast.AST, allowed: bool) -> None:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            allowed = allowed or (rel, node.name) in IDENTITY_ALLOWED_FUNCTIONS
        if not allowed:
            truth: list[ast.AST] = []
            if isinstance(node, (ast.If, ast.IfExp, ast.While)):
                truth.append(node.test)
            elif isinstance(node, ast.BoolOp):
                truth += node.values
            elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
                truth.append(node.operand)
            elif (
                isinstance(node, ast.Compare)
                and named(node.left)
                and all(isinstance(op, (ast.Is, ast.IsNot)) for op in node.ops)
                and any(isinstance(c, ast.Constant) and c.value is None for c in node.comparators)
            ):
                found.append((node.lineno, ast.unparse(node)))
            found.extend((t.lineno, ast.unparse(t)) for t in truth if named(t))
        for child in ast.iter_child_nodes(node):
            visit(child, allowed)

    visit(ast.parse(source), False)
    return sorted(set(found))


def test_identity_checks_finds_every_spelling():
    """The scan itself, on a source whose checks are known (data reads are no checks)."""
    source = (
        "def f(desc, self, legs, general):\n"
        "    if desc.legs is None:\n"
        "        return 1\n"
        "    a = 2 if self.general else 3\n"
        "    b = legs is not None and general\n"
        "    c = not self.general\n"
        "    d = [leg.name for leg in desc.legs]\n"
        "    e = robot.general.legs\n"
        "    return a, b, c, d, e\n"
        "def general_robot(robot):\n"
        "    return None if robot.legs is None else robot\n"
    )
    assert [line for line, _ in identity_checks(source)] == [2, 4, 5, 5, 6, 11]
    assert [line for line, _ in identity_checks(source, "viz/leg_scene.py")] == [2, 4, 5, 5, 6]


def test_no_module_above_the_architecture_layer_asks_in_another_spelling():
    """No ``legs is None`` / ``general`` check outside the allowed places: the modules ask
    their architecture's path or codegen strategy for behaviour (issue 19)."""
    root = Path(stewart_pin.__file__).parent
    checks = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(IDENTITY_ALLOWED_FILES):
            continue
        checks += [f"{rel}:{n}: {text}" for n, text in identity_checks(path.read_text(), rel)]
    assert checks == []
