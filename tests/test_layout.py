"""The layout of the package (issue 19, item 4): its import cycles, counted by
``scripts/import_cycles.py`` (every import statement outside ``if TYPE_CHECKING:``,
function-level ones included), never more than the recorded ceiling, which each session
that removes one lowers: none is left (the last three, each a module and its ``general_x``
twin, were broken by merging the format writers and by moving what the two symbolic
generators share into ``codegen/_sx_common.py``)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

pytest.importorskip("grimp", reason="grimp comes with import-linter (the dev extra)")

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "import_cycles.py"
#: The ceiling: 4 strongly connected pairs before issue 19's layout work, 3 after the
#: presets' pair was broken (description/symmetric_presets.py), 1 after the URDF and
#: MJCF writers each became one module for every leg architecture, 0 after the symbolic
#: generators' shared pieces moved below both (codegen/_sx_common.py).
MAX_IMPORT_CYCLES = 0
#: The cycles tolerated for now: none.
KNOWN: set[tuple[str, ...]] = set()


def _script():
    spec = importlib.util.spec_from_file_location("import_cycles", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("import_cycles", module)
    spec.loader.exec_module(module)
    return module


def test_tarjan_finds_the_cycles_of_a_small_graph():
    """The counting itself, on a graph whose cycles are known: a -> b -> c -> a (one
    component of three), d <-> e, and f alone (its edge to a closes no cycle)."""
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d"}, "f": {"a"}}
    components = _script().strongly_connected(edges)
    assert [c for c in components if len(c) > 1] == [["a", "b", "c"], ["d", "e"]]


def test_import_cycles_stay_at_or_below_the_recorded_ceiling():
    cycles = _script().import_cycles()
    found = {tuple(c) for c in cycles}
    assert len(cycles) <= MAX_IMPORT_CYCLES, f"new import cycles: {sorted(found - KNOWN)}"
    assert found <= KNOWN, f"new import cycles: {sorted(found - KNOWN)}"
