"""Optional libraries, imported when a feature first needs them.

The mesher (``tetgen``), the convex decomposition (``coacd``) and the DeepMind environment
API (``dm_env``) are extras: a user who never reads a scan or a CAD tool need not install
them, and one who does gets an error that names the extra.

Example:
    >>> optional("json", "mesh", "a demo").__name__
    'json'
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from cell.errors import MissingExtraError


def optional(module: str, extra: str, feature: str) -> ModuleType:
    """Import ``module``, or raise :class:`MissingExtraError` saying to install ``extra``
    for ``feature``."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(module.split(".")[0], extra, feature) from None


def require(module: str, extra: str, feature: str) -> None:
    """Raise :class:`MissingExtraError` now, before a long run whose end needs ``module``
    (plots after a sweep or a diagnosis), when it is not installed; nothing is imported."""
    if importlib.util.find_spec(module) is None:
        raise MissingExtraError(module, extra, feature)
