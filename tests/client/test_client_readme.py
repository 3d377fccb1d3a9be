"""The client's README documents every public method: each public method of each client class
that zeromode_client exports (``__all__``) has a row in the README's method table."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import zeromode_client

README = Path(__file__).parents[2] / "clients" / "python" / "README.md"


def client_classes() -> list[type]:
    """The exported classes with a ``base_url``: the clients."""
    exported = (getattr(zeromode_client, name) for name in zeromode_client.__all__)
    return [c for c in exported if inspect.isclass(c) and isinstance(getattr(c, "base_url", None), property)]


def public_methods(cls: type) -> set[str]:
    return {name for name, member in inspect.getmembers(cls, inspect.isfunction) if not name.startswith("_")}


def table_methods(text: str) -> set[str]:
    """The method names of the table under "## Methods": every `name(` in each row's first cell."""
    section = text.split("## Methods", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    return {name for row in rows for name in re.findall(r"`(\w+)\(", row.split("|")[1])}


def test_the_clients_are_found():
    assert {c.__name__ for c in client_classes()} == {"Client", "AsyncClient"}


def test_every_public_client_method_has_a_row_in_the_readme_table():
    documented = table_methods(README.read_text(encoding="utf-8"))
    for cls in client_classes():
        missing = sorted(public_methods(cls) - documented)
        assert not missing, f"{cls.__name__} methods missing from {README.name}'s method table: {missing}"


def test_the_table_names_no_method_the_clients_lack():
    documented = table_methods(README.read_text(encoding="utf-8"))
    every = set().union(*(public_methods(c) for c in client_classes()))
    assert documented <= every, sorted(documented - every)
