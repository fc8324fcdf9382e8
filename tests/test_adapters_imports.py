"""Issue 39: the harness's roles split so that harness and sandbox do not import each other.
The adapters package's import graph, read with ast from every module's source (imports inside
functions included: a cycle must not hide behind one), has no cycle."""

from __future__ import annotations

import ast
from pathlib import Path

import adapters

PACKAGE = Path(adapters.__file__).parent


def import_graph(folder: Path, package: str) -> dict[str, set[str]]:
    """{module: the package's modules it imports anywhere in its source} for the modules of
    `folder` (package `package`): ``import package.x``, ``from package.x import ...``, ``from
    package import x``, ``from .x import ...`` and ``from . import x``."""
    modules = {p.stem for p in folder.glob("*.py") if p.stem != "__init__"}
    graph = {}
    for m in sorted(modules):
        edges = set()
        for node in ast.walk(ast.parse((folder / f"{m}.py").read_text())):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    parts = alias.name.split(".")
                    if parts[0] == package and len(parts) > 1:
                        edges.add(parts[1])
            elif isinstance(node, ast.ImportFrom):
                if node.level == 1 or (node.level == 0 and node.module and node.module.split(".")[0] == package):
                    parts = (node.module or "").split(".")
                    target = parts[0] if node.level == 1 else (parts[1] if len(parts) > 1 else "")
                    if target:
                        edges.add(target)
                    else:  # from . import x / from package import x: x may be a module
                        edges |= {a.name for a in node.names if a.name in modules}
        graph[m] = edges & modules - {m}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every elementary cycle found by a depth-first search from each module (as module lists)."""
    found = []

    def walk(path):
        for nxt in sorted(graph.get(path[-1], ())):
            if nxt == path[0]:
                found.append(path + [nxt])
            elif nxt not in path and nxt > path[0]:  # each cycle once, from its smallest module
                walk(path + [nxt])

    for start in sorted(graph):
        walk([start])
    return found


def test_the_scan_finds_a_cycle_hidden_inside_a_function(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .b import x\n")
    (pkg / "b.py").write_text("def f():\n    from pkg import c\n")
    (pkg / "c.py").write_text("import os\n\ndef g():\n    import pkg.a\n")
    assert cycles(import_graph(pkg, "pkg")) == [["a", "b", "c", "a"]]


def test_the_adapters_package_has_no_import_cycle():
    graph = import_graph(PACKAGE, "adapters")
    assert {"harness", "sandbox", "sandbox_worker", "budgeted"} <= set(graph)
    assert "sandbox" in graph["harness"]  # run(isolated=True) dispatches to the sandbox ...
    assert "harness" not in graph["sandbox"] and "harness" not in graph["sandbox_worker"]  # ... never back
    assert {"harness", "sandbox", "sandbox_worker"}.isdisjoint(graph["budgeted"])
    assert cycles(graph) == []
