"""Data the code reads, shipped inside the package as ``cell.assets`` (this folder): the default
material, the synthetic cutting-force curve, the example measurement set.

Example:
    >>> asset_path("materials/beef_default.toml").name
    'beef_default.toml'
"""

from importlib.resources import files
from pathlib import Path


def asset_path(relative: str) -> Path:
    """The file ``relative`` (to this folder, ``/``-separated) as a path on disk.

    It works the same from a source checkout, an editable and a regular install.
    """
    return Path(str(files(__name__).joinpath(*relative.split("/"))))
