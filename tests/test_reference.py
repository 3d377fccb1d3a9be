"""The library reference (docs/reference/library.md): mkdocstrings renders each ``::: path`` from
the docstrings as griffe reads them from the source, and griffe finds ``zeromode.solver`` (and the
other packages pyproject.toml installs from folders of their own) through
docs/griffe_package_dirs.py. Checked here without a build (the strict build renders them): each
path the page names is found by griffe, has a docstring, and is what Python imports at that path.
"""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import griffe
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "reference" / "library.md"
PATHS = re.findall(r"^::: (\S+)$", PAGE.read_text(encoding="utf-8"), flags=re.MULTILINE)


@pytest.fixture(scope="module")
def zeromode_package() -> griffe.Module:
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        from griffe_package_dirs import PackageDirs
    finally:
        sys.path.remove(str(ROOT / "docs"))
    loader = griffe.GriffeLoader(search_paths=[ROOT], extensions=griffe.load_extensions(PackageDirs()))
    package = loader.load("zeromode")
    loader.resolve_aliases()
    return package


def python_object(path: str):
    """The object Python imports at a dotted path (a module, or an attribute of one)."""
    try:
        return importlib.import_module(path)
    except ImportError:
        module, _, name = path.rpartition(".")
        return getattr(importlib.import_module(module), name)


def test_the_page_documents_the_solver_results():
    assert {"zeromode.Frame", "zeromode.Result", "zeromode.solver.analysis.rigidity.Analysis"} <= set(PATHS)
    assert sum(p.startswith("zeromode.solver.") for p in PATHS) >= 10


@pytest.mark.parametrize("path", PATHS)
def test_each_path_is_found_with_its_docstring(zeromode_package, path):
    found = zeromode_package.modules_collection[path]
    target = found.final_target if found.is_alias else found
    assert target.docstring is not None and target.docstring.value.strip(), path
    imported = python_object(path)
    if target.is_module:
        assert imported.__name__ == target.path
    else:  # where Python defines it is where griffe read it
        assert f"{imported.__module__}.{imported.__qualname__}" == target.path, path


def test_every_public_name_is_on_the_page():
    # Each name of zeromode.__all__ is rendered: a function as a member of the page's
    # ``::: zeromode`` block, a class or module by a ``::: zeromode.<name>`` of its own.
    import zeromode

    text = PAGE.read_text(encoding="utf-8")
    block = re.search(r"^::: zeromode\n((?:    .*\n)+)", text, flags=re.MULTILINE)
    assert block is not None
    members = set(re.findall(r"^\s+- (\w+)$", block.group(1), flags=re.MULTILINE))
    own = {p.removeprefix("zeromode.") for p in PATHS if p.count(".") == 1}
    assert set(zeromode.__all__) - members - own == set()
