"""Sphinx configuration of the musclecell docs site.

The topic pages are Markdown (MyST); the API reference is generated at build time from the
docstrings: :func:`write_api_pages` walks the packages ``cell``, ``envs`` and ``controllers``
and writes one page per package into ``docs/api/`` (not committed, emptied at the start of
each build so that a removed module leaves no stale page), whose ``automodule`` directives
import the real modules. A docstring or a cross-reference that no longer resolves fails the
build (``sphinx-build -W``, run by ``scripts/test.sh``). One page per package rather than per
module keeps the build short: the theme's navigation is computed for every page from every
other.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import shutil
import sys
from pathlib import Path

from sphinx.domains.python import PythonDomain
from sphinx.util import logging

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
# Importing the package renders nothing, but MuJoCo reads the GL backend on import.
os.environ.setdefault("MUJOCO_GL", "egl")

GENERATED = DOCS / "api"
logger = logging.getLogger(__name__)
API_PACKAGES = ("cell", "envs", "controllers")


def _heading(text: str, underline: str) -> str:
    return f"{text}\n{underline * len(text)}\n"


def _public(name: str) -> bool:
    return not any(part.startswith("_") for part in name.split("."))


def write_api_pages(packages: tuple[str, ...] = API_PACKAGES, folder: Path = GENERATED) -> None:
    """One reStructuredText page per package into ``folder``: the package's docstring, a
    table of its modules, each module's documentation, and its sub-packages' pages."""
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    pending = list(packages)
    while pending:
        name = pending.pop()
        package = importlib.import_module(name)
        children = [(info.name, info.ispkg)
                    for info in pkgutil.iter_modules(package.__path__, f"{name}.")
                    if _public(info.name)]
        modules = [child for child, ispkg in children if not ispkg]
        subpackages = [child for child, ispkg in children if ispkg]
        pending += subpackages
        lines = [_heading(name, "="), f".. automodule:: {name}\n"]
        if subpackages:
            lines += [".. toctree::", "   :caption: Sub-packages", "   :maxdepth: 1", ""]
            lines += [f"   {child}" for child in subpackages] + [""]
        if modules:
            lines += [".. rubric:: Modules", "", ".. autosummary::", ""]
            lines += [f"   {child.rsplit('.', 1)[1]}" for child in modules] + [""]
        for child in modules:
            lines += [_heading(child, "-"), f".. automodule:: {child}\n"]
        (folder / f"{name}.rst").write_text("\n".join(lines) + "\n", encoding="utf-8")


write_api_pages()

project = "musclecell"
author = "musclecell contributors"
copyright = "musclecell contributors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

# MyST: anchors for the headings so pages can link to a section (`page.md#section`).
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence", "deflist"]

# The API reference: the modules' public members documented from the docstrings; autosummary
# makes the tables of modules on the packages' pages (its stubs are not used).
autosummary_generate = False
# Each object is documented once, in the module that defines it: a package's ``__all__``
# re-exports are not described again on the package's page.
autodoc_default_options = {
    "members": True,
    "show-inheritance": True,
    "ignore-module-all": True,
}
autodoc_member_order = "bysource"
# The pages' tables of contents list sections, not every class and function: each page's
# navigation is a copy of the whole site's, and with the objects in it copying it took a third
# of the build.
toc_object_entries = False
autodoc_typehints = "signature"
# Google-style docstrings ("Args:", "Returns:", "Attributes:", "Example:"); each attribute of
# an "Attributes:" section becomes an entry of its own that ``:attr:`` references can reach
# (autodoc itself leaves a dataclass's fields out: no ``undoc-members``).
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = False
napoleon_attr_annotations = True

html_theme = "furo"
html_title = "musclecell"


def _drop_object_base(app, name, obj, options, bases: list) -> None:
    """``Bases: object`` says nothing: shown only where a class has a base of its own."""
    if bases == [object]:
        bases.clear()


def _warn_unresolved_role(app, env, node, contnode) -> None:
    """A Python cross-reference written as a role that finds no target is a warning, so that
    ``-W`` fails the build: on the topic pages (``{py:class}`...```) every one, in the
    docstrings those into the project's own packages (``:class:`~cell.tissue.Foo```). The
    references autodoc makes from type annotations carry no source text and stay quiet, as do
    the docstrings' short names and names outside the project, which Sphinx leaves unlinked."""
    if node.get("refdomain") != "py" or not node.rawsource:
        return
    on_topic_page = not node.get("refdoc", "").startswith("api/")
    if on_topic_page or node["reftarget"].startswith(tuple(f"{p}." for p in API_PACKAGES)):
        logger.warning("unresolved reference %s", node.rawsource, location=node,
                       type="ref", subtype="py")


class IndexedPythonDomain(PythonDomain):
    """Sphinx's Python domain, whose search for a short name (a docstring's argument types,
    its ``Raises:``) first asks an index of every object's dotted endings: Sphinx scans every
    object for each such reference, three times for a class it does not find (``float``,
    ``np.ndarray``), which took a fifth of the build. Names the index holds are searched as
    Sphinx does; the others find nothing either way."""

    _endings: tuple[int, frozenset[str]] = (-1, frozenset())

    def find_obj(self, env, modname, classname, name, type, searchmode=0):
        if searchmode == 1 and name.removesuffix("()") not in self._known_endings():
            return []
        return super().find_obj(env, modname, classname, name, type, searchmode)

    def _known_endings(self) -> frozenset[str]:
        # The objects only grow while the pages are read; the references resolve after.
        if self._endings[0] != len(self.objects):
            parts = (name.split(".") for name in self.objects)
            self._endings = (len(self.objects), frozenset(
                ".".join(p[i:]) for p in parts for i in range(len(p))))
        return self._endings[1]


def setup(app) -> None:
    app.add_domain(IndexedPythonDomain, override=True)
    app.connect("autodoc-process-bases", _drop_object_base)
    app.connect("missing-reference", _warn_unresolved_role)
