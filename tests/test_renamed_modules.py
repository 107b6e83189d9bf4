"""The ``general_*`` twins renamed after what they hold (issue 19, item 4): each old module
path keeps working as an alias whose every name is the new module's object and warns
(``DeprecationWarning``) naming the new place.

References: the new modules themselves (identity of the objects)."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

import stewart_pin

#: Old module -> (its new module, a public name both must give).
RENAMED = {
    "stewart_pin.dynamics.general_legs": (
        "stewart_pin.dynamics.leg_chain_dynamics",
        "GeneralDynamics",
    ),
    "stewart_pin.check.general_legs": ("stewart_pin.check.leg_chain_tree", "GeneralTreeSolver"),
    "stewart_pin.description.general_hexapod": (
        "stewart_pin.description.leg_chain_hexapod",
        "general_from_description",
    ),
    "stewart_pin.description.general_presets": (
        "stewart_pin.description.leg_chain_presets",
        "random_hexapod",
    ),
    "stewart_pin.parameters.general_base": (
        "stewart_pin.parameters.leg_chain_base",
        "general_grouping",
    ),
    "stewart_pin.codegen.general_symbolic": (
        "stewart_pin.codegen.leg_chain_symbolic",
        "build_general_models",
    ),
}


@pytest.mark.parametrize("old", sorted(RENAMED))
def test_old_module_path_warns_and_gives_the_new_object(old):
    new, name = RENAMED[old]
    alias, module = importlib.import_module(old), importlib.import_module(new)
    with pytest.warns(DeprecationWarning, match=f"{new}.{name}"):
        value = getattr(alias, name)
    assert value is getattr(module, name)
    with pytest.warns(DeprecationWarning, match=new):
        exec(f"from {old} import {name} as imported", {})  # the import statement warns too
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        alias.not_a_name  # noqa: B018


def test_no_general_module_but_the_aliases():
    """Every ``general_*`` module left in the package is a deprecated alias (the renamed
    twins here, the merged format writers in ``formats/``)."""
    src = Path(stewart_pin.__file__).parent
    left = sorted(
        str(p.relative_to(src.parent)).removesuffix(".py").replace("/", ".")
        for p in src.rglob("general_*.py")
    )
    formats = {"stewart_pin.formats.general_mjcf", "stewart_pin.formats.general_urdf"}
    assert set(left) == set(RENAMED) | formats
    for name in left:
        assert "Deprecated" in (importlib.import_module(name).__doc__ or ""), name
