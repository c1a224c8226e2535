"""The house rules of the source tree, as data and checks the layout tests run.

Each package of the library stands on a layer and imports only from the layers below it (and
from itself): the data flow of the design, bottom to top. Inside a layer, too, no module
imports one that imports it back, by any path: not at the top, not in a function, not under
``TYPE_CHECKING``.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

#: The project's packages that the rules know, bottom layer first.
BASE = ("cell.errors", "cell.io", "cell.folders", "cell.outputs", "cell.config",
        "cell.collision", "cell.polyline", "cell.memory", "cell.assets", "cell.scenarios",
        "cell.extras", "cell.options", "cell.progress", "cell.profiling", "cell.moved",
        "cell.cores", "cell.rayconnect")
#: The MuJoCo-free part of the tissue that a diagnosis simulates with.
TISSUE_LAWS = ("cell.tissue.curves", "cell.tissue.material", "cell.tissue.materialfile",
               "cell.tissue.cutmodel", "cell.tissue.edgestate", "cell.tissue.springlaw",
               "cell.tissue.packedlaw", "cell.tissue.lattice", "cell.tissue.tetmesh")
_CELL = (*BASE, "cell.robots", "cell.tissue", "cell.perception", "controllers", "cell.measure")
ALLOWED: dict[str, tuple[str, ...]] = {
    "cell.robots": BASE,
    "cell.tissue": BASE,
    "cell.measure": BASE,
    "cell.perception": (*BASE, "cell.robots", "cell.tissue"),
    "cell.diagnosis": (*BASE, "cell.measure", *TISSUE_LAWS),
    # The engine serves every family of causes and knows none of them.
    "cell.diagnosis.engine": (*BASE, "cell.measure", *TISSUE_LAWS),
    "cell.robotlog": (*BASE, "cell.measure"),
    "controllers": (*BASE, "cell.robots", "cell.tissue", "cell.perception"),
    "cell.sim": _CELL,
    "cell.cuttest": (*_CELL, "cell.sim"),
    "envs": (*_CELL, "cell.sim"),
    "cell.logs": (*_CELL, "cell.sim", "cell.diagnosis"),
    "cell.learning": (*_CELL, "cell.sim", "envs"),
    "cell.synthetic": (*_CELL, "cell.sim", "cell.diagnosis", "cell.cuttest", "cell.logs"),
    "cell.scale": (*_CELL, "cell.sim", "cell.diagnosis", "cell.logs", "envs", "cell.learning"),
    "cell.bench": (*_CELL, "cell.sim", "cell.diagnosis", "cell.cuttest", "cell.logs",
                   "cell.synthetic", "envs", "cell.learning", "cell.scale"),
    "cell.cli": (*_CELL, "cell.sim", "cell.diagnosis", "cell.cuttest", "cell.logs",
                 "cell.robotlog", "envs", "cell.learning", "cell.scale", "cell.bench"),
}
#: The hidden-effect generators, the diagnoses' answer key: only these packages may read it.
ANSWER_KEY = "cell.synthetic"
READS_ANSWER_KEY = (ANSWER_KEY, "cell.bench")
PROJECT_PACKAGES = ("cell", "controllers", "envs", "tests")
#: The library's top-level packages, whose modules the rules check.
LIBRARY = ("cell", "controllers", "envs")
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80
#: What a long function's docstring says to explain its length.
LONG_FUNCTION_REASON = "long because"


@dataclass(frozen=True)
class Violation:
    """One broken rule: ``where`` (file:line) and what is wrong."""

    where: str
    message: str

    def __str__(self) -> str:
        return f"{self.where}: {self.message}"


def module_name(root: Path, path: Path) -> str:
    """The dotted module name of ``path`` under ``root``."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _within(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def _layer(module: str) -> str | None:
    """The package whose rule governs ``module`` (the longest matching prefix)."""
    matches = [prefix for prefix in (*ALLOWED, *BASE, "cell") if _within(module, prefix)]
    return max(matches, key=len) if matches else None


def import_statements(path: Path, module: str) -> list[tuple[int, str, tuple[str, ...]]]:
    """(line, module, names) of every import in ``path``, top level, in functions and under
    ``TYPE_CHECKING`` alike, relative imports resolved: ``import a.b`` gives ``("a.b", ())``,
    ``from a import b, c`` gives ``("a", ("b", "c"))``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name, ()) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            found.append((node.lineno, base, tuple(alias.name for alias in node.names)))
    return found


def imported_modules(path: Path, module: str) -> list[tuple[int, str]]:
    """(line, module) of every project import in ``path`` (:func:`import_statements`); a name
    imported from a module counts as both ``module.name`` and ``module``."""
    found = []
    for line, base, names in import_statements(path, module):
        # ``from cell.synthetic import specimen`` imports the module cell.synthetic.specimen
        found += [(line, f"{base}.{name}") for name in names]
        found.append((line, base))
    return [(line, name) for line, name in found
            if name.split(".")[0] in PROJECT_PACKAGES]


def library_modules(root: Path) -> dict[str, Path]:
    """Every module of the library under ``root``, by dotted name."""
    return {module_name(root, path): path
            for top in LIBRARY for path in sorted((root / top).rglob("*.py"))}


def import_violations(root: Path) -> list[Violation]:
    """Every import in the library that reaches up or sideways past its layer."""
    violations = []
    for module, path in library_modules(root).items():
        layer = _layer(module)
        for line, target in imported_modules(path, module):
            where = f"{path.relative_to(root)}:{line}"
            if target.split(".")[0] == "tests":
                violations.append(Violation(where, f"the library imports {target}"))
                continue
            if _within(target, ANSWER_KEY) and not any(_within(module, reader)
                                                        for reader in READS_ANSWER_KEY):
                violations.append(Violation(where, f"{module} must not import {target}"))
                continue
            if _within(target, layer or module):
                continue
            allowed = BASE if layer in BASE else ALLOWED.get(layer or "", ())
            if not any(_within(target, ok) or _within(ok, target) for ok in allowed):
                violations.append(Violation(where, f"{module} ({layer}) imports {target}"))
    return violations


def size_violations(root: Path) -> list[Violation]:
    """Modules over :data:`MAX_MODULE_LINES` and functions over :data:`MAX_FUNCTION_LINES`
    whose docstring does not say why (:data:`LONG_FUNCTION_REASON`)."""
    violations = []
    for path in library_modules(root).values():
        text = path.read_text()
        name = str(path.relative_to(root))
        if text.count("\n") > MAX_MODULE_LINES:
            violations.append(Violation(name, f"{text.count(chr(10))} lines"))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                doc = ast.get_docstring(node) or ""
                if length > MAX_FUNCTION_LINES and LONG_FUNCTION_REASON not in doc:
                    violations.append(Violation(f"{name}:{node.lineno}",
                                                f"{node.name} is {length} lines"))
    return violations


def import_graph(root: Path) -> dict[str, dict[str, int]]:
    """Which library modules each library module imports, with the line of the first import:
    every import counts (:func:`import_statements`), each resolved to the module that holds
    it (``from cell.sim.episode import Episode``: ``cell.sim.episode``; ``from cell.synthetic
    import specimen``: ``cell.synthetic.specimen``; ``from envs import SeparationEnv``:
    ``envs``). A package's ``__init__`` counts only where a name is imported from it, not as
    the parent that Python runs first: that one is in ``sys.modules`` before its modules run."""
    modules = library_modules(root)

    def holder(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, dict[str, int]] = {}
    for module, path in modules.items():
        edges = graph.setdefault(module, {})
        for line, base, names in import_statements(path, module):
            targets = ([f"{base}.{n}" if f"{base}.{n}" in modules else holder(base)
                        for n in names] if names else [holder(base)])
            for target in targets:
                if target is not None and target != module:
                    edges.setdefault(target, line)
    return graph


def import_cycles(root: Path) -> list[Violation]:
    """Every import circle in the library (:func:`import_graph`), one per strongly connected
    set of modules, shown as its shortest path from the set's first module back to itself."""
    graph = import_graph(root)
    modules = library_modules(root)
    violations = []
    for component in _strongly_connected(graph):
        if len(component) < 2:
            continue
        start = min(component)
        path = _shortest_cycle(graph, start, set(component))
        first = modules[start].relative_to(root)
        message = "import circle: " + " -> ".join(path)
        if len(component) > len(path) - 1:
            message += f" (one of the circles among {', '.join(component)})"
        violations.append(Violation(f"{first}:{graph[start][path[1]]}", message))
    return violations


def _strongly_connected(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """Tarjan's strongly connected components of ``graph``, iteratively (no recursion limit)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, {}))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph.get(child, {})))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return sorted(components)


def _shortest_cycle(graph: dict[str, dict[str, int]], start: str, within: set[str]) -> list[str]:
    """The shortest path of imports from ``start`` back to ``start`` inside ``within``."""
    came_from: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for child in sorted(graph.get(node, {})):
                if child == start:
                    path = [start]
                    while node != start:
                        path.append(node)
                        node = came_from[node]
                    return [start, *reversed(path[1:]), start]
                if child in within and child not in came_from:
                    came_from[child] = node
                    following.append(child)
        frontier = following
    raise ValueError(f"{start} is on no import circle")
