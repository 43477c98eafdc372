"""Import graph of the Python packages, read from the source with `ast`.

Every import statement counts, module-level or inside a function (a lazy
import hides a dependency from the top of the file but not from the graph).
Relative imports and `from pkg import mod` (where `mod` is a submodule) are
resolved to module names; `from pkg import NAME` depends on pkg/__init__.py. Cycles are the strongly connected components with
more than one module (a module importing itself is not a cycle).

`modules_under(root, package)` maps the files below a package folder to module
names, so the same walker runs on the real tree and on a copy in tmp_path.
"""

from __future__ import annotations

import ast
from pathlib import Path


def modules_under(root: Path, package: str) -> dict[str, Path]:
    """Module name -> file for every .py below `root`, which is `package`."""
    out: dict[str, Path] = {}
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).with_suffix("")
        parts = [package, *rel.parts]
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imported(node: ast.AST, module: str, is_pkg: bool,
              modules: dict[str, Path]) -> list[str]:
    """Module names one import statement depends on.

    `from pkg import name` depends on the submodule pkg.name when there is
    one, else on pkg itself (the name is defined in pkg/__init__.py). The
    implicit import of a module's parent packages is not an edge: Python
    always runs them first, it is no design choice of the importing module.
    """
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    assert isinstance(node, ast.ImportFrom)
    if node.level:
        base = module.split(".") if is_pkg else module.split(".")[:-1]
        up = node.level - 1
        base = base[: len(base) - up] if up else base
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    out = []
    for a in node.names:
        sub = f"{target}.{a.name}"
        out.append(sub if sub in modules else target)
    return out


def _imports(tree: ast.AST, lazy: bool):
    """The import statements of a module; with lazy=False only those that run
    when the module is imported (not inside a function or lambda)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        for child in ast.iter_child_nodes(node):
            if lazy or not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                todo.append(child)


def import_graph(modules: dict[str, Path], lazy: bool = True) -> dict[str, set[str]]:
    """Module -> set of modules of `modules` it imports (lazy ones included,
    unless lazy=False: then only what importing the module runs)."""
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for mod, path in modules.items():
        is_pkg = path.name == "__init__.py"
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:  # a module another test planted for a moment (test_build) and removed
            graph.pop(mod)
            continue
        tree = ast.parse(text, filename=str(path))
        for node in _imports(tree, lazy):
            for name in _imported(node, mod, is_pkg, modules):
                # `import a.b.c` also imports a and a.b; the edge that matters
                # is the deepest module of the graph it names.
                while name and name not in modules:
                    name = name.rpartition(".")[0]
                if name and name != mod:
                    graph[mod].add(name)
    for m in graph:
        graph[m] &= set(graph)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def package_of(module: str, depth: int = 1) -> str:
    return ".".join(module.split(".")[:depth])


def package_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """Top-level package -> top-level packages it imports."""
    out: dict[str, set[str]] = {}
    for m, deps in graph.items():
        p = package_of(m)
        out.setdefault(p, set())
        for d in deps:
            q = package_of(d)
            out.setdefault(q, set())
            if q != p:
                out[p].add(q)
    return out
