"""Size limits checked at request time against the serving app's Settings.

``Annotated[list[...], Limited("max_nodes")]`` refuses (422 ``invalid_request``, naming the field
and the limit) a list with more items than the current settings allow; ``AtMost("...")`` does
the same for a number. The check runs before the items are parsed, so an oversized list costs
one ``len``. ``limit_text`` states the limit and its default for the OpenAPI descriptions.
"""

from __future__ import annotations

from pydantic import BeforeValidator

from zeromode.service.settings import Settings, current_settings


def limit_text(setting: str) -> str:
    """'≤ max_nodes (default 100000)': how a description names a limit."""
    return f"≤ {setting} (default {Settings.model_fields[setting].default:g})"


def Limited(setting: str) -> BeforeValidator:
    """At most ``settings.<setting>`` items in a list."""

    def check(value):
        bound = getattr(current_settings(), setting)
        if isinstance(value, list | tuple) and len(value) > bound:
            raise ValueError(f"at most {bound} items are allowed ({setting}), got {len(value)}")
        return value

    return BeforeValidator(check)


def AtMost(setting: str) -> BeforeValidator:
    """A number no larger than ``settings.<setting>``."""

    def check(value):
        bound = getattr(current_settings(), setting)
        if isinstance(value, int | float) and not isinstance(value, bool) and value > bound:
            raise ValueError(f"must be at most {bound:g} ({setting}), got {value:g}")
        return value

    return BeforeValidator(check)
