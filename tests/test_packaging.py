"""What ships: the core dependencies are what the library imports, the model files are
package data read through importlib.resources, the wheel holds every module and model file,
and the version is written in one place."""

from __future__ import annotations

import ast
import importlib.resources
import os
import re
import shutil
import subprocess
import sys
import textwrap
import tomllib
import zipfile
from pathlib import Path

import pinocchio as pin
import pytest

import stewart_pin
from stewart_pin.formats.robot_files import MODEL_FILES_PACKAGE, model_files
from stewart_pin.models.pinocchio_models import load_tree

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "stewart_pin"
MODELS = ROOT / "models"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
#: Import names of the distributions whose name differs.
IMPORT_NAMES = {"pin": "pinocchio"}


def requirement_names(requirements: list[str]) -> set[str]:
    """The import names of ``requirements`` (``"pin>=4.1,<5"`` -> ``pinocchio``)."""
    names = {re.split(r"[<>=!~;\[ ]", r, maxsplit=1)[0].strip().lower() for r in requirements}
    return {IMPORT_NAMES.get(n, n.replace("-", "_")) for n in names}


def third_party_imports(module_level_only: bool) -> dict[str, set[str]]:
    """Top-level names of the non-stdlib modules imported by src/, by file; only the
    imports run when the module is imported (not in functions, nor under TYPE_CHECKING)
    when ``module_level_only``."""
    found: dict[str, set[str]] = {}
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text())
        nodes = list(ast.iter_child_nodes(tree)) if module_level_only else list(ast.walk(tree))
        while nodes:
            node = nodes.pop()
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                if module_level_only and isinstance(node, ast.If | ast.Try):
                    if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                        continue
                    nodes.extend(ast.iter_child_nodes(node))
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names and top not in {"stewart_pin", "__future__"}:
                    found.setdefault(top, set()).add(str(path.relative_to(SRC)))
    return found


def test_the_core_dependencies_are_what_the_library_imports():
    core = requirement_names(PYPROJECT["project"]["dependencies"])
    loaded = third_party_imports(module_level_only=True)
    outside = {name: files for name, files in loaded.items() if name not in core}
    assert not outside, f"imported when the library loads, but no core dependency: {outside}"
    unused = core - set(third_party_imports(module_level_only=False))
    assert not unused, f"core dependencies src/ never imports: {unused}"


def test_optional_imports_are_in_an_extra():
    extras = PYPROJECT["project"]["optional-dependencies"]
    viz = requirement_names(extras["viz"])
    assert {"meshcat", "matplotlib"} <= viz  # the viewer, HTML export and figures
    assert "example_robot_data" in requirement_names(extras["payload"])
    anywhere = set(third_party_imports(module_level_only=False))
    # zmq and tornado come with meshcat; mujoco is optional in the benchmark (test extra)
    allowed = requirement_names(PYPROJECT["project"]["dependencies"]) | viz | {"zmq", "tornado"}
    assert anywhere - allowed <= requirement_names(extras["test"])


def test_the_test_extra_holds_the_viz_extra():
    extras = PYPROJECT["project"]["optional-dependencies"]
    assert set(extras["viz"]) <= set(extras["test"])


def shipped_model_files() -> list[str]:
    """The files under models/ that ship (everything but Python files and caches)."""
    return sorted(
        str(p.relative_to(MODELS))
        for p in MODELS.rglob("*")
        if p.is_file() and p.suffix not in {".py", ".pyc"} and "__pycache__" not in p.parts
    )


def test_model_files_are_the_committed_files():
    files = shipped_model_files()
    assert {"package.xml", "urdf/stewart.urdf.xacro", "urdf/paper.urdf"} <= set(files)
    assert "examples/servo_head.xml" in files  # docs/importing.md's worked example
    folder = model_files()
    for name in files:
        assert (folder / name).read_bytes() == (MODELS / name).read_bytes(), name
    assert sorted(p.name for p in (folder / "urdf").iterdir() if p.is_file()) == sorted(
        p.name for p in (MODELS / "urdf").iterdir() if p.is_file()
    )


def test_a_shipped_urdf_loads_with_its_closures():
    urdf = model_files() / "urdf" / "paper.urdf"
    with importlib.resources.as_file(urdf) as path:
        model = pin.buildModelFromUrdf(str(path))
        tree = load_tree(path)  # with paper.closures.json beside it
    assert (model.nq, model.nv) == (25, 24)
    assert (tree.model.nq, tree.model.nv, len(tree.constraints)) == (25, 24, 6)


def test_the_version_is_written_once():
    assert "version" in PYPROJECT["project"]["dynamic"]
    assert "version" not in PYPROJECT["project"]
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "stewart_pin.__version__"
    }
    package_xml = (MODELS / "package.xml").read_text()
    assert f"<version>{stewart_pin.__version__}</version>" in package_xml


def _wheel_builder_or_skip() -> None:
    """Skip unless the wheel can be built here without downloads (the test extra installs
    setuptools >= 68, the pyproject's build requirement, and wheel)."""
    setuptools = pytest.importorskip("setuptools", reason="the test extra installs setuptools")
    pytest.importorskip("wheel", reason="the test extra installs wheel")
    major = int(setuptools.__version__.split(".")[0])
    if major < 68:
        pytest.skip(f"setuptools {setuptools.__version__} < 68 (the test extra installs it)")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of the sources (the checkout stays clean)."""
    _wheel_builder_or_skip()
    tmp = tmp_path_factory.mktemp("wheel")
    tree, out = tmp / "tree", tmp / "dist"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    for folder in ("src", "models"):
        shutil.copytree(ROOT / folder, tree / folder, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, tree / name)
    script = "import sys, setuptools.build_meta as b; print(b.build_wheel(sys.argv[1]))"
    done = subprocess.run(
        [sys.executable, "-c", script, str(out)],
        cwd=tree,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return out / done.stdout.strip().splitlines()[-1]


def test_the_wheel_ships_every_module_and_the_model_files(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    modules = {f"stewart_pin/{p.relative_to(SRC)}" for p in SRC.rglob("*.py")}
    assert modules - names == set(), "modules missing from the wheel (pyproject's packages)"
    assert "stewart_pin/py.typed" in names
    data = {f"stewart_pin/model_files/{name}" for name in shipped_model_files()}
    assert data - names == set(), "model files missing from the wheel (package-data)"
    (entry_points,) = (n for n in names if n.endswith(".dist-info/entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "stewart-pin = stewart_pin.cli:main" in text


def test_the_installed_wheel_reads_its_model_files(wheel, tmp_path):
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)  # what an installer puts in site-packages
    check = textwrap.dedent(
        f"""
        import importlib.metadata, importlib.resources, sys
        from pathlib import Path
        import pinocchio as pin
        import stewart_pin
        from stewart_pin.formats.robot_files import model_files

        site = Path(sys.argv[1]).resolve()
        assert Path(stewart_pin.__file__).resolve().is_relative_to(site), stewart_pin.__file__
        folder = importlib.resources.files({MODEL_FILES_PACKAGE!r})
        assert Path(str(folder)).resolve().is_relative_to(site), folder
        assert str(model_files()) == str(folder)
        assert importlib.metadata.version("stewart-pin") == stewart_pin.__version__
        with importlib.resources.as_file(folder / "urdf" / "paper.urdf") as path:
            print(pin.buildModelFromUrdf(str(path)).nq)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(site)}
    done = subprocess.run(
        [sys.executable, "-c", check, str(site)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.split() == ["25"]


def _module_of(path: Path) -> str:
    return ".".join(path.relative_to(SRC.parent).with_suffix("").parts).removesuffix(".__init__")


def _is_module(dotted: str) -> bool:
    """True when ``dotted`` (``stewart_pin.x.y``) is a module or package of src/."""
    parts = dotted.split(".")[1:]
    target = SRC.joinpath(*parts) if parts else SRC
    return target.with_suffix(".py").is_file() or (target / "__init__.py").is_file()


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_names_read_across_modules() -> list[str]:
    """Every ``from stewart_pin.m import _name`` (``_name`` not a module: private modules
    such as ``_checks``, ``_so3``, ``formats._xml`` hold public names) and every
    ``module._name`` on a stewart_pin module bound by an import, in another module."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        here = _module_of(path)
        package = here if path.name == "__init__.py" else here.rpartition(".")[0]
        tree = ast.parse(path.read_text())
        modules: set[str] = set()  # local names bound to stewart_pin modules
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                if not base.startswith("stewart_pin"):
                    continue
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    if _is_module(full):
                        modules.add(alias.asname or alias.name)
                    elif _private(alias.name) and base != here:
                        found.append(f"{here}:{node.lineno}: from {base} import {alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("stewart_pin") and alias.asname:
                        modules.add(alias.asname)
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in modules
                and _private(node.attr)
            ):
                found.append(f"{here}:{node.lineno}: {node.value.id}.{node.attr}")
    return found


def test_no_module_reads_another_modules_private_names():
    """House rule (issue 10): a name shared between modules is public, in the module that
    owns it or a private module of the package (``_xml``, ``_checks``...)."""
    assert private_names_read_across_modules() == []


def test_the_private_name_scan_finds_a_private_import(tmp_path, monkeypatch):
    """The scan above is not vacuous: a planted ``from ... import _name`` is reported."""
    fake = tmp_path / "stewart_pin"
    (fake / "formats").mkdir(parents=True)
    (fake / "__init__.py").write_text("")
    (fake / "formats" / "__init__.py").write_text("")
    (fake / "formats" / "_xml.py").write_text("def num(x): return x\n")
    (fake / "formats" / "a.py").write_text("def _helper(): pass\n")
    (fake / "formats" / "b.py").write_text(
        "from stewart_pin.formats._xml import num\n"
        "from stewart_pin.formats import _xml, a\n"
        "from stewart_pin.formats.a import _helper\n"
        "from . import a as alias\n"
        "alias._helper()\n"
    )
    monkeypatch.setattr(sys.modules[__name__], "SRC", fake)
    assert private_names_read_across_modules() == [
        "stewart_pin.formats.b:3: from stewart_pin.formats.a import _helper",
        "stewart_pin.formats.b:5: alias._helper",
    ]


def test_the_summary_names_every_leg_architecture():
    """The package's one-line description said "(6-UPS) hexapods"."""
    for summary in (PYPROJECT["project"]["description"], stewart_pin.__doc__.splitlines()[0]):
        for architecture in ("6-UPS", "6-RUS", "6-PUS"):
            assert architecture in summary, summary


def test_the_citation_file_cites_the_software_and_the_paper():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert {"message", "title", "authors"} <= set(cff)
    assert cff["version"] == stewart_pin.__version__
    assert cff["license"] == PYPROJECT["project"]["license"]["text"]
    (paper,) = cff["references"]
    assert paper["title"] == "Inverse and direct dynamic modeling of Gough-Stewart robots"
    assert [a["family-names"] for a in paper["authors"]] == ["Khalil", "Guegan"]
    assert (paper["journal"], paper["volume"], paper["issue"], paper["year"]) == (
        "IEEE Transactions on Robotics",
        20,
        4,
        2004,
    )
