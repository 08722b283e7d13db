"""The example scenarios, shipped as package data and reachable by name.

``shipradar examples`` lists them; ``shipradar run --example raid`` runs one.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["example_names", "example_path"]


def _folder() -> Path:
    return Path(str(resources.files(__name__)))


def example_names() -> list[str]:
    """Names of the shipped example scenarios (file stems), sorted."""
    return sorted(p.stem for p in _folder().glob("*.yaml"))


def example_path(name: str) -> Path:
    """Path of the shipped example ``name`` (with or without ``.yaml``).

    Raises
    ------
    KeyError
        Unknown name; the message lists the known ones.
    """
    stem = name[:-5] if name.endswith(".yaml") else name
    path = _folder() / f"{stem}.yaml"
    if not path.is_file():
        raise KeyError(f"--example: no example named {name!r}; "
                       f"known: {', '.join(example_names())}")
    return path
