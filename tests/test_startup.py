"""Start-up (issue 24, item 4): ``import stewart_pin`` and the command's argument parsing
import no heavy library; every public name still resolves (lazily); a compiled library's
cache key comes from the description and the generator's version, is the same in every
process, changes with any number baked into the C and with the generator's code, and a
new process finds its library without generating the C source.

The times themselves are measured by ``scripts/bench_startup.py``, not here."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from conftest import get_robot

import stewart_pin
from stewart_pin.codegen import _identity as identity

SRC = str(Path(__file__).resolve().parents[1] / "src")
PACKAGE = Path(SRC) / "stewart_pin"
HEAVY = ("pinocchio", "casadi", "scipy", "matplotlib", "mujoco", "meshcat")
#: The subpackages whose public names are imported on first use.
LAZY_PACKAGES = (
    "stewart_pin",
    "stewart_pin.codegen",
    "stewart_pin.parameters",
    "stewart_pin.check",
    "stewart_pin.motion",
    "stewart_pin.formats",
)


def _python(code: str, **env: str) -> str:
    """Run ``code`` in a fresh interpreter with this checkout first on the path; its stdout."""
    environ = {**os.environ, "PYTHONPATH": os.pathsep.join([SRC, *sys.path]), **env}
    run = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=environ,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    return run.stdout


def _heavy_after(code: str) -> list[str]:
    out = _python(
        textwrap.dedent(code)
        + f"\nimport sys\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    return json.loads(out.strip().splitlines()[-1].replace("'", '"'))


# ---------------------------------------------------------------------------- lazy imports
def test_import_stewart_pin_imports_no_heavy_library():
    assert _heavy_after("import stewart_pin") == []


def test_command_help_imports_no_heavy_library():
    """The command parses its arguments (``--help`` of the command and of every
    subcommand) before importing what a command needs."""
    code = """
    import contextlib, io
    from stewart_pin.cli import build_parser
    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    assert len(commands) > 10, list(commands)
    for argv in (["--help"], *([name, "--help"] for name in commands)):
        with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
            parser.parse_args(argv)
    """
    assert _heavy_after(code) == []


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_every_public_name_resolves(package):
    """Every name of ``__all__`` resolves in a fresh process, to the object its defining
    module holds (a star import too), and ``dir()`` lists it."""
    code = f"""
    import importlib, inspect
    pkg = importlib.import_module({package!r})
    names = list(pkg.__all__)
    assert len(names) == len(set(names))
    for name in names:
        value = getattr(pkg, name)
        home = getattr(value, "__module__", None)
        if home and home.startswith("stewart_pin") and not inspect.ismodule(value):
            assert getattr(importlib.import_module(home), name, value) is value, name
    assert set(names) <= set(dir(pkg))
    star = {{}}
    exec(f"from {package} import *", star)
    assert set(names) <= set(star), set(names) - set(star)
    print("ok", len(names))
    """
    assert _python(code).split()[0] == "ok"


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        stewart_pin.no_such_name  # noqa: B018
    assert stewart_pin.StewartRobot.__name__ == "StewartRobot"
    assert not hasattr(stewart_pin.codegen, "no_such_name")


# ---------------------------------------------------------------------------- cache key
KEY_CODE = """
from stewart_pin.description.presets import preset
from stewart_pin.codegen._identity import library_identity
import hashlib
print(hashlib.sha256(library_identity(preset({name!r}), "models").encode()).hexdigest())
"""


@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_key_is_the_same_in_every_process(name):
    a = _python(KEY_CODE.format(name=name), PYTHONHASHSEED="1")
    b = _python(KEY_CODE.format(name=name), PYTHONHASHSEED="2")
    assert a == b and len(a.strip()) == 64


def _with(desc, **changes):
    copy = desc.replace()
    for field, value in changes.items():
        object.__setattr__(copy, field, value)
    return copy


def test_key_changes_with_every_baked_number():
    """A mass, a gravity component, a joint term of a leg, a leg attachment point each
    give another key; the name alone does not (no text enters the C)."""
    ups = get_robot("simulator").description
    key = identity.library_identity(ups, "models")
    assert key == identity.library_identity(ups.replace(), "models")
    assert key == identity.library_identity(_with(ups, name="another name"), "models")
    heavier = np.array(ups.platform_inertia, dtype=float)
    heavier[-1] *= 1.0 + 1e-12  # the platform's mass (Khalil's order: m last)
    assert key != identity.library_identity(_with(ups, platform_inertia=heavier), "models")
    gravity = np.array(ups.gravity, dtype=float)
    gravity[2] = np.nextafter(gravity[2], 0.0)
    assert key != identity.library_identity(_with(ups, gravity=gravity), "models")
    points = np.array(ups.base_points, dtype=float)
    points[3, 1] += 1e-9
    assert key != identity.library_identity(_with(ups, base_points=points), "models")
    assert key != identity.library_identity(ups, "derivatives")
    # Something that has no exact serialisation: no identity (the C source is keyed).
    assert identity.library_identity(_with(ups, source=object()), "models") is None

    rus = get_robot("rus").description
    base = identity.library_identity(rus, "models")
    legs = list(rus.legs)
    joint = legs[2].joints[0]
    viscous = dataclasses.replace(joint.dynamics, viscous=joint.dynamics.viscous * 1.001)
    joints = (dataclasses.replace(joint, dynamics=viscous), *legs[2].joints[1:])
    legs[2] = dataclasses.replace(legs[2], joints=joints)
    assert base != identity.library_identity(_with(rus, legs=tuple(legs)), "models")
    assert base == identity.library_identity(_with(rus, legs=tuple(rus.legs)), "models")


def test_generator_version_follows_the_generator_source(tmp_path):
    """The digest covers the generator's modules (a byte of the C template changes it) and
    skips the layers the generator cannot import (the command line)."""
    copy = tmp_path / "stewart_pin"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    digest = identity.source_digest(copy)
    assert digest == identity.source_digest(PACKAGE)
    cli = copy / "cli" / "__init__.py"
    cli.write_text(cli.read_text() + "\n# a comment\n")
    assert identity.source_digest(copy) == digest
    template = copy / "codegen" / "_csource.py"
    template.write_text(template.read_text() + "\n# a comment\n")
    assert identity.source_digest(copy) != digest
    (copy / "kinematics" / "new_module.py").write_text("X = 1\n")
    assert identity.source_digest(copy) not in (digest, identity.source_digest(PACKAGE))


def test_generator_imports_nothing_left_out_of_its_digest():
    """What the digest skips is never imported by the generator (else a change there could
    reuse a stale library)."""
    code = """
    import sys
    import stewart_pin.codegen.compiled, stewart_pin.codegen.derivatives
    import stewart_pin.codegen.leg_chain_symbolic, stewart_pin.codegen.opcount
    from stewart_pin.codegen._identity import _NOT_GENERATOR
    skipped = {"stewart_pin." + n.removesuffix(".py") for n in _NOT_GENERATOR}
    print(sorted(m for m in sys.modules if m in skipped or m.rpartition(".")[0] in skipped))
    """
    assert _python(code).strip() == "[]"


# ---------------------------------------------------------------------------- reuse
FIRST_CALL = """
import warnings
import numpy as np
import stewart_pin
from stewart_pin.codegen import compiled, symbolic

if {forbid!r}:
    def forbidden(*args, **kwargs):
        raise AssertionError("the C source or the models were generated")

    compiled.c_source = compiled.generate_models = symbolic.generate_models = forbidden
warnings.simplefilter("error")
robot = stewart_pin.StewartRobot.from_preset({name!r})
gamma = robot.inverse_dynamics(robot.home_pose, np.zeros(6), np.zeros(6))
backend = robot._stewart_pin_auto_backend[1]
print(backend.kind, backend.compiled_now, backend.library.parent.name, gamma.tolist())
"""


@pytest.mark.skipif(
    __import__("stewart_pin.codegen.compiled", fromlist=["find_compiler"]).find_compiler() is None,
    reason="no C compiler on this machine",
)
@pytest.mark.parametrize("name", ["simulator", "rus"])
def test_new_process_reuses_the_library_without_generating(tmp_path, name):
    env = {"STEWART_PIN_CACHE": str(tmp_path / "cache"), "STEWART_PIN_BACKEND": "auto"}
    first = _python(FIRST_CALL.format(name=name, forbid=False), **env).split(maxsplit=3)
    assert first[:2] == ["compiled", "True"]
    again = _python(FIRST_CALL.format(name=name, forbid=True), **env).split(maxsplit=3)
    assert again[:3] == ["compiled", "False", first[2]]
    reference = get_robot(name).inverse_dynamics(
        get_robot(name).home_pose, np.zeros(6), np.zeros(6), backend="pinocchio"
    )
    gamma = np.array(json.loads(again[3]))
    assert np.max(np.abs(gamma - reference)) <= 1e-9 * np.max(np.abs(reference))
