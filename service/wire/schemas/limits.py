"""Size limits checked at request time against the serving app's Settings.

``Annotated[list[...], Limited("max_nodes")]`` refuses (422 ``invalid_request``, naming the field
and the limit) a list with more items than the current settings allow; ``AtMost("...")`` does
the same for a number. The check runs before the items are parsed, so an oversized list costs
one ``len``. The bound is read from ``current_settings()`` when a request is validated (the
middleware of ``create_app`` makes the app's settings current), never when a class is defined.

The same annotations state the limit in the OpenAPI document: ``maxItems`` / ``maximum`` with
the value of the app that serves the document (``create_app`` builds it under its settings), and
``limit_text`` names the limit and its default in a field's description.

Only request models carry these annotations: what the service answers is never refused for its
size (a design of 4 specified nodes under ``max_nodes=4`` answers a larger frame).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydantic import GetCoreSchemaHandler, GetJsonSchemaHandler
from pydantic_core import core_schema

from zeromode.service.wire.settings import Settings, current_settings


def limit_text(setting: str) -> str:
    """'≤ max_nodes (default 100000)': how a description names a limit."""
    default = Settings.model_fields[setting].default
    shown = f"{default:g}" if isinstance(default, float) else default
    return f"≤ {setting} (default {shown})"


def _length(value: Any) -> int | None:
    return len(value) if isinstance(value, list | tuple) else None


def _number(value: Any) -> float | None:
    return value if isinstance(value, int | float) and not isinstance(value, bool) else None


@dataclass(frozen=True)
class _Limit:
    """``measure(value) ≤ settings.<setting>``, the bound read each time a request is validated.
    A value ``measure`` cannot size (None) is left to the type check that follows."""

    setting: str
    measure: Callable[[Any], float | None]
    refusal: str  # formatted with bound, size and setting
    keyword: str  # the JSON Schema keyword stating the bound

    def check(self, value: Any) -> Any:
        bound = getattr(current_settings(), self.setting)
        size = self.measure(value)
        if size is not None and size > bound:
            raise ValueError(self.refusal.format(bound=bound, size=size, setting=self.setting))
        return value

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler):
        return core_schema.no_info_before_validator_function(self.check, handler(source))

    def __get_pydantic_json_schema__(self, schema, handler: GetJsonSchemaHandler):
        return {**handler(schema), self.keyword: getattr(current_settings(), self.setting)}


def Limited(setting: str) -> _Limit:
    """At most ``settings.<setting>`` items in a list."""
    return _Limit(setting, _length, "at most {bound} items are allowed ({setting}), got {size}", "maxItems")


def AtMost(setting: str) -> _Limit:
    """A number no larger than ``settings.<setting>``."""
    return _Limit(setting, _number, "must be at most {bound:g} ({setting}), got {size:g}", "maximum")
