"""No import circles in the package: every import statement (at module level, inside
functions, under ``TYPE_CHECKING``) is an edge of the graph of rths3d's modules, and that
graph has no cycle. The graph is read from the source with :mod:`ast` (nothing is
imported), and the finder is checked on a small package with circles written here."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def module_graph(root: Path, package: str, runtime_only: bool = False
                 ) -> dict[str, set[str]]:
    """``{module: modules it imports}`` over the ``.py`` files of ``root/package``; an
    import of a name from a package counts as an import of the submodule of that name when
    there is one, else of the package. ``runtime_only``: leave out the imports under
    ``if TYPE_CHECKING:`` (annotations only)."""
    mods: dict[str, tuple[Path, bool]] = {}
    for p in (root / package).rglob("*.py"):
        parts = list(p.relative_to(root).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        mods[".".join(parts)] = (p, is_pkg)
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, (p, is_pkg) in mods.items():
        here = m.split(".") if is_pkg else m.split(".")[:-1]
        tree = ast.parse(p.read_text(encoding="utf-8"))
        typing_only: set[int] = set()
        if runtime_only:
            for node in ast.walk(tree):
                if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                    typing_only.update(id(n) for b in node.body for n in ast.walk(b))
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here[: len(here) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    if sub in mods:
                        graph[m].add(sub)
                    elif target in mods:
                        graph[m].add(target)
            elif isinstance(node, ast.Import):
                graph[m].update(a.name for a in node.names if a.name in mods)
        graph[m].discard(m)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
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
    return out


def test_the_finder_sees_circles_through_deferred_and_relative_imports(tmp_path) -> None:
    """A package written here: a ↔ b through an import inside a function, c → d → e → c
    through relative imports of names, f alone under TYPE_CHECKING to g, g → f; h imports
    a package's name that is not a submodule (no edge to a submodule)."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    files = {
        "__init__.py": "",
        "a.py": "def f():\n    from .b import x\n    return x\n",
        "b.py": "from pkg import a\nx = 1\n",
        "c.py": "from .sub.d import y\n",
        "sub/__init__.py": "VALUE = 1\n",
        "sub/d.py": "from ..e import z\ny = 2\n",
        "e.py": "import pkg.c\nz = 3\n",
        "f.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .g import G\n",
        "g.py": "from . import f\nG = 1\n",
        "h.py": "from .sub import VALUE\n",
    }
    for name, text in files.items():
        (pkg / name).write_text(text)
    graph = module_graph(tmp_path, "pkg")
    assert graph["pkg.h"] == {"pkg.sub"}
    assert sorted(circles(graph)) == [["pkg.a", "pkg.b"], ["pkg.c", "pkg.e", "pkg.sub.d"],
                                      ["pkg.f", "pkg.g"]]


def test_the_package_has_no_import_circle() -> None:
    """rths3d's modules (every import statement, deferred ones included) form no circle."""
    graph = module_graph(ROOT, "rths3d")
    assert len(graph) > 100 and "rths3d.diagnose.rounds" in graph["rths3d.diagnose.engine"]
    assert circles(graph) == []


LAYERS: tuple[tuple[str, ...], ...] = (
    # the data flow, bottom up (docs/architecture.md): a module imports its own layer or lower
    ("errors", "kernels", "jit", "record", "figures", "plausibility"),
    ("config",),
    ("lti", "effects", "network.simapp"),
    ("numerical", "experiment", "compensation", "safety", "stepping"),
    ("platform",),
    ("transfer",),
    ("bench",),
    ("scene", "scene_bench", "scene_checks", "metadata", "reference"),
    ("metrics._signals", "metrics.tracking", "metrics.reference"),
    ("surrogate",),
    ("metrics", "loop"),
    ("_lifeline", "dataset", "ann", "community", "rthsbench", "network"),
    ("diagnose",),
    ("viz", "cli", "__init__", "__main__"),
)
"""Each module's layer: the longest of these prefixes (after ``rths3d.``) that names it or
its package."""

PLUGINS = ("transfer.stewart", "transfer.legs", "transfer.remote", "compensation.inverse",
           "experiment.marths_frame", "numerical.opensees")
"""Registered components (a transfer system, a compensator, a part, a numerical kind) that
join a lower layer through its registry and may use what sits above it: the Stewart
platform's transfer system builds benches, the remote one speaks the network protocol, the
maRTHS frame part is the benchmark's, the OpenSees substructure records signals."""


def _layer(module: str) -> int:
    name = module.removeprefix("rths3d.") if module != "rths3d" else "__init__"
    best, depth = -1, -1
    for i, prefixes in enumerate(LAYERS):
        for p in prefixes:
            if (name == p or name.startswith(p + ".")) and len(p) > depth:
                best, depth = i, len(p)
    assert best >= 0, f"{module} is in no layer of LAYERS"
    return best


def test_no_module_imports_upward_except_a_plugin() -> None:
    """Every import (deferred ones included; type-only imports under TYPE_CHECKING aside)
    goes to the importer's layer or a lower one, except from a registered plug-in."""
    graph = module_graph(ROOT, "rths3d", runtime_only=True)
    up = sorted(f"{m} -> {t}" for m, ts in graph.items() for t in ts
                if _layer(t) > _layer(m)
                and not any(m == f"rths3d.{p}" for p in PLUGINS))
    assert up == []


def test_the_layer_check_sees_an_upward_import() -> None:
    """A lower layer's module importing a higher one is reported (the check can fail)."""
    assert _layer("rths3d.platform.sim") < _layer("rths3d.loop")
    assert _layer("rths3d.metrics.fidelity") > _layer("rths3d.surrogate.estimator")
    graph = {"rths3d.platform.sim": {"rths3d.loop"}, "rths3d.loop": {"rths3d.platform.sim"}}
    assert [(m, t) for m, ts in graph.items() for t in ts if _layer(t) > _layer(m)] == [
        ("rths3d.platform.sim", "rths3d.loop")]
    assert _layer("rths3d.metrics.tracking") < _layer("rths3d.surrogate.estimator")
