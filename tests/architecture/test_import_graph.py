"""mpmsim's modules import one another without a circle.

The graph has an edge a -> b for every import of b in a's source, at module level or inside a
function (a lazy import hides a circle from Python's import machinery, not from a reader), and
for `from package import name` an edge to the submodule when `name` is one, else to the
package's __init__. A circle (a strongly connected component of more than one module) means
two modules that cannot be read, tested or moved apart.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "mpmsim"
BENCH = Path(__file__).resolve().parents[2] / "bench"


def modules(package: Path = PACKAGE) -> dict[str, tuple[Path, bool]]:
    """{dotted name: (file, is a package's __init__)}."""
    out = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


def import_graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    mods = modules(package)
    root = package.name
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, (path, is_package) in mods.items():
        here = name.split(".") if is_package else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = here[:len(here) - node.level + 1] if node.level else []
                target = ".".join(base + ([node.module] if node.module else []))
                if target.split(".")[0] != root:
                    continue
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    graph[name].add(sub if sub in mods else target)
            elif isinstance(node, ast.Import):
                graph[name] |= {a.name for a in node.names if a.name in mods}
    for targets in graph.values():
        targets.intersection_update(mods)
    return graph


def script_graph(folder: Path = BENCH) -> dict[str, set[str]]:
    """The import graph of a folder of scripts run as `python folder/x.py` (bench/): each file is
    a top-level module named by its stem, and `import y` or `from y import z` (at any depth in
    the file) is an edge to y when y is a script of the same folder."""
    scripts = {path.stem: path for path in sorted(folder.glob("*.py"))}
    graph: dict[str, set[str]] = {name: set() for name in scripts}
    for name, path in scripts.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and not node.level and node.module:
                graph[name].add(node.module.split(".")[0])
            elif isinstance(node, ast.Import):
                graph[name] |= {a.name.split(".")[0] for a in node.names}
        graph[name].intersection_update(scripts)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, edges = work[-1]
            w = next(edges, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


@pytest.mark.architecture
def test_no_module_imports_itself_through_others():
    graph = import_graph()
    assert len(graph) > 120 and sum(map(len, graph.values())) > 350  # the whole package was read
    assert circles(graph) == []


@pytest.mark.architecture
def test_no_bench_script_imports_itself_through_others():
    graph = script_graph()
    assert len(graph) > 25 and sum(map(len, graph.values())) >= 10  # the whole folder was read
    assert circles(graph) == []


@pytest.mark.architecture
def test_the_script_graph_sees_a_circle_through_a_lazy_import(tmp_path):
    (tmp_path / "a.py").write_text("from b import f\n")
    (tmp_path / "b.py").write_text("def f():\n    import a\n    return a\n")
    (tmp_path / "c.py").write_text("import numpy\nfrom a import f\n")
    graph = script_graph(tmp_path)
    assert graph == {"a": {"b"}, "b": {"a"}, "c": {"a"}}
    assert circles(graph) == [["a", "b"]]


@pytest.mark.architecture
def test_the_circle_finder_finds_a_circle_through_a_lazy_import(tmp_path):
    pkg = tmp_path / "mpmsim"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .a import f\n")
    (pkg / "sub" / "a.py").write_text("def f():\n    from .b import g\n    return g\n")
    (pkg / "sub" / "b.py").write_text("from . import a\n")
    (pkg / "c.py").write_text("from .sub import f\n")
    graph = import_graph(pkg)
    assert graph["mpmsim.sub.b"] == {"mpmsim.sub.a"} and graph["mpmsim.c"] == {"mpmsim.sub"}
    assert circles(graph) == [["mpmsim.sub.a", "mpmsim.sub.b"]]
