"""Promised outputs of documentation snippets (`# → OUTPUT`), matched against what ran.

Imported by tests/test_snippets.py, and by each Python snippet it runs as a script: the line
``EXPR  # → OUTPUT`` is run as ``__expect__((EXPR), "OUTPUT", "README.md:42")``.
"""

from __future__ import annotations

import json
import os
import re
from typing import Any

# `…` (or `...`) in a promised output stands for text, a value, or the remaining keys or items.
ELLIPSIS = re.compile(r"…|\.\.\.")
_ANY = "⟨any⟩"  # a JSON value
_MORE = "⟨more⟩"  # remaining keys of an object or items of a list


def shown(value: Any) -> str:
    """What a value shows, as the docs write it: its repr, numpy scalars as Python numbers."""
    if getattr(value, "shape", None) == () and hasattr(value, "item"):
        value = value.item()
    return repr(value)


def text_matches(text: str, promised: str) -> bool:
    """``text`` equals ``promised`` up to surrounding white space, `…` matching any text."""
    pattern = ".*".join(re.escape(part) for part in ELLIPSIS.split(promised.strip()))
    return re.fullmatch(pattern, text.strip(), flags=re.DOTALL) is not None


def json_pattern(promised: str) -> Any:
    """A promised JSON document with `…` placeholders, as JSON with sentinels: ``{…}``, ``[…]`` or a
    lone ``…`` value is any value; ``, …`` before ``}`` or ``]`` is more keys or items."""
    text = ELLIPSIS.sub("…", promised)
    text = re.sub(r"\{\s*…\s*\}|\[\s*…\s*\]", f'"{_ANY}"', text)
    text = re.sub(r",\s*…\s*(?=\})", f', "{_MORE}": 0', text)
    text = re.sub(r",\s*…\s*(?=\])", f', "{_MORE}"', text)
    text = re.sub(r"(?<=[:\[,])\s*…", f' "{_ANY}"', text)
    return json.loads(text)


def json_matches(value: Any, pattern: Any) -> bool:
    """``value`` (decoded JSON) has the shape and values of ``pattern`` (from ``json_pattern``):
    objects hold exactly the keys shown (or more, with ``…``), lists the items shown."""
    if pattern == _ANY:
        return True
    if isinstance(pattern, dict):
        keys = set(pattern) - {_MORE}
        if not isinstance(value, dict) or not keys <= set(value):
            return False
        if _MORE not in pattern and set(value) != keys:
            return False
        return all(json_matches(value[k], pattern[k]) for k in keys)
    if isinstance(pattern, list):
        more = bool(pattern) and pattern[-1] == _MORE
        items = pattern[:-1] if more else pattern
        if not isinstance(value, list) or len(value) < len(items) or (not more and len(value) != len(items)):
            return False
        return all(json_matches(v, p) for v, p in zip(value, items, strict=False))
    return type(value) is type(pattern) and value == pattern or (
        isinstance(value, int | float) and isinstance(pattern, int | float) and value == pattern
    )


def output_matches(text: str, promised: str) -> bool:
    """A printed output against its promise: a JSON promise (``{`` or ``[``) by ``json_matches``,
    any other by ``text_matches``."""
    if promised.lstrip().startswith(("{", "[")):
        try:
            return json_matches(json.loads(text), json_pattern(promised))
        except json.JSONDecodeError:
            return False
    return text_matches(text, promised)


def expect(value: Any, promised: str, where: str, printed: bool = False, items: bool = False) -> Any:
    """The line at ``where`` evaluated to ``value`` (``printed``: prints it; ``items``: a tuple
    written without parentheses, ``a, b  # → 1, 2``, shows its items joined by ", "): it must
    show ``promised``. Each line checked is appended to the file ``$SNIPPET_EXPECT_LOG``, so
    that the test sees every promise was reached. Returns ``value``."""
    text = str(value) if printed else ", ".join(map(shown, value)) if items else shown(value)
    if not text_matches(text, promised):
        raise AssertionError(f"{where}: the docs promise `{promised}`, the line gives `{text}`")
    if log := os.environ.get("SNIPPET_EXPECT_LOG"):
        with open(log, "a") as fh:
            fh.write(where + "\n")
    return value
