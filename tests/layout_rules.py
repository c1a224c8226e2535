"""The house rules of the source tree, as data and checks the layout tests run.

Each package of the library stands on a layer and imports only from the layers below it (and
from itself): the data flow of the design, bottom to top.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

#: The project's packages that the rules know, bottom layer first.
BASE = ("cell.errors", "cell.io", "cell.config", "cell.collision", "cell.polyline", "cell.memory",
        "cell.assets", "cell.extras")
ALLOWED: dict[str, tuple[str, ...]] = {
    "cell.robots": BASE,
    "cell.tissue": BASE,
    "cell.perception": (*BASE, "cell.robots", "cell.tissue"),
    "cell.rheology": (*BASE, "cell.tissue.curves", "cell.tissue.material",
                      "cell.tissue.springlaw", "cell.tissue.lattice", "cell.tissue.tetmesh"),
    "controllers": (*BASE, "cell.robots", "cell.tissue", "cell.perception"),
    "cell.sim": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "controllers"),
    "envs": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "controllers", "cell.sim"),
    "cell.learning": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "controllers",
                      "cell.sim", "envs"),
    "cell.scale": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "cell.rheology",
                   "controllers", "cell.sim", "envs", "cell.learning"),
    "cell.bench": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "cell.rheology",
                   "controllers", "cell.sim", "envs", "cell.learning", "cell.scale"),
    "cell.cli": (*BASE, "cell.robots", "cell.tissue", "cell.perception", "cell.rheology",
                 "controllers", "cell.sim", "envs", "cell.learning", "cell.scale",
                 "cell.bench"),
}
#: Modules that must not import a module they would otherwise be allowed: the diagnosis side
#: never reads the synthetic generator, its answer key.
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "cell.rheology.diagnosis": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.causes": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.specimen": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.measured": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.report": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.fitting": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.causeplots": ("cell.rheology.synthetic", "cell.rheology.truth"),
    "cell.rheology.acceptance": ("cell.rheology.synthetic", "cell.rheology.truth"),
}
PROJECT_PACKAGES = ("cell", "controllers", "envs", "tests")
MAX_MODULE_LINES = 500
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


def imported_modules(path: Path, module: str) -> list[tuple[int, str]]:
    """(line, module) of every project import in ``path``: top level, in functions and under
    ``TYPE_CHECKING`` alike, relative imports resolved."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            # ``from cell.rheology import synthetic`` imports the module cell.rheology.synthetic
            found += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
            found.append((node.lineno, base))
    return [(line, name) for line, name in found
            if name.split(".")[0] in PROJECT_PACKAGES]


def import_violations(root: Path) -> list[Violation]:
    """Every import in the library that reaches up or sideways past its layer."""
    violations = []
    for top in ("cell", "controllers", "envs"):
        for path in sorted((root / top).rglob("*.py")):
            module = module_name(root, path)
            layer = _layer(module)
            for line, target in imported_modules(path, module):
                where = f"{path.relative_to(root)}:{line}"
                if target.split(".")[0] == "tests":
                    violations.append(Violation(where, f"the library imports {target}"))
                    continue
                if any(_within(target, bad) for bad in FORBIDDEN.get(module, ())):
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
    for top in ("cell", "controllers", "envs"):
        for path in sorted((root / top).rglob("*.py")):
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
