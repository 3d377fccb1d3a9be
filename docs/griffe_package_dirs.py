"""A griffe extension for the guide's library reference (mkdocs.yml, mkdocstrings): the packages
pyproject.toml installs under the zeromode namespace from folders of their own (``package-dir``:
``zeromode.solver`` from ``solver/``, ``zeromode.viz`` from ``viz/``, …).

griffe reads the source tree, where ``zeromode/`` holds none of them, so ``zeromode.solver`` was
not found (nor a setuptools editable install's mapping, which griffe reads only for top-level
packages). When griffe has loaded the ``zeromode`` package, each such folder is loaded as its
submodule of the same name, by the same loader (so an import ``from zeromode.solver.frame import
Frame`` anywhere resolves to it and it is documented at its public path).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import griffe

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "zeromode"


def package_dirs() -> dict[str, Path]:
    """{submodule name: folder} of every ``zeromode.<name>`` that pyproject.toml maps onto a
    folder other than ``zeromode/<name>``."""
    mapping = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["package-dir"]
    dirs = {}
    for name, folder in mapping.items():
        parent, _, sub = name.rpartition(".")
        if parent == PACKAGE and Path(folder) != Path(PACKAGE, sub):
            dirs[sub] = ROOT / folder
    return dirs


class PackageDirs(griffe.Extension):
    """Graft the mapped folders onto the ``zeromode`` package as griffe loads it."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        if pkg.name != PACKAGE:
            return
        for sub, folder in package_dirs().items():
            # griffe's own step for a submodule (GriffeLoader has no public call that loads a
            # folder under a given parent): the folder's package and its submodules, visited.
            module = loader._load_module(sub, folder / "__init__.py", submodules=True, parent=pkg)
            pkg.set_member(sub, module)
            loader.expand_exports(module)
