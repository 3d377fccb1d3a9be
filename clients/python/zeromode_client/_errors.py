"""Exceptions: one base class, so ``except ZeromodeError`` catches every failure of a call."""

from __future__ import annotations

from typing import Any


class ZeromodeError(Exception):
    """The service answered with an error status, or could not be reached.

    ``status`` is the HTTP status (``None`` when no answer arrived), ``code`` the service's
    fixed snake_case error code (e.g. ``"self_loop"``, ``"no_solution"``, ``"unauthorized"``),
    ``message`` its one-sentence explanation and ``detail`` the whole ``detail`` object.
    """

    def __init__(
        self,
        message: str,
        *,
        code: str,
        status: int | None = None,
        detail: dict[str, Any] | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.code = code
        self.status = status
        self.detail = detail if detail is not None else {"code": code, "message": message}

    def __str__(self) -> str:
        where = f"HTTP {self.status} " if self.status is not None else ""
        return f"{where}[{self.code}] {self.message}"


class ZeromodeConnectionError(ZeromodeError):
    """No connection could be made (or it broke) after ``attempts`` tries."""

    def __init__(self, message: str, *, attempts: int) -> None:
        super().__init__(message, code="connection_error")
        self.attempts = attempts


class ZeromodeTimeoutError(ZeromodeError):
    """The service took longer than the configured timeout to answer (not retried)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, code="timeout")
