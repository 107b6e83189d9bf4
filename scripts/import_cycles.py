"""The import cycles of ``src/stewart_pin`` (issue 19, item 4).

Every import statement counts, wherever it stands (module level or inside a function:
an import deferred into a function still ties the two modules together, it only hides
the cycle from the interpreter), except those under ``if TYPE_CHECKING:``. The module
graph is grimp's (installed with import-linter); a cycle is a strongly connected
component of more than one module (Tarjan's algorithm), listed with the import
statements that close it (file line and text).

Usage: ``python scripts/import_cycles.py`` (prints the cycles and their count; exit code
0). ``tests/test_layout.py`` holds the count to its recorded ceiling.
"""

from __future__ import annotations

import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def import_graph(package: str = "stewart_pin") -> dict[str, set[str]]:
    """``module -> the package's modules it imports`` (TYPE_CHECKING imports left out),
    built from this checkout's ``src`` (no cache)."""
    import grimp

    if str(SRC) not in sys.path:
        sys.path.insert(0, str(SRC))
    graph = grimp.build_graph(package, exclude_type_checking_imports=True, cache_dir=None)
    return {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}


def strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of a directed graph (iterative), each a
    sorted list of nodes; the components sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    out.append(sorted(component))
    return sorted(out)


def import_cycles(package: str = "stewart_pin") -> list[list[str]]:
    """The package's import cycles: each a sorted list of the modules of one strongly
    connected component of more than one module."""
    return [c for c in strongly_connected(import_graph(package)) if len(c) > 1]


def main() -> None:
    import grimp

    if str(SRC) not in sys.path:
        sys.path.insert(0, str(SRC))
    graph = grimp.build_graph("stewart_pin", exclude_type_checking_imports=True, cache_dir=None)
    cycles = import_cycles()
    for k, cycle in enumerate(cycles, start=1):
        print(f"cycle {k}: {' <-> '.join(cycle)}")
        members = set(cycle)
        for a in cycle:
            for b in sorted(members & set(graph.find_modules_directly_imported_by(a))):
                for d in graph.get_import_details(importer=a, imported=b):
                    print(f"  {a}:{d['line_number']}: {d['line_contents']}")
    print(f"{len(cycles)} import cycle(s) in src/stewart_pin")


if __name__ == "__main__":
    main()
