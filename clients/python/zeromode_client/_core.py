"""What Client and AsyncClient share: calls, JSON encoding, answer decoding and the retry policy.

Nothing here does I/O, so the sync and async clients differ only in how they send a request
and how they sleep between attempts.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from typing import Any, Generic, TypeVar

import httpx
import numpy as np

from zeromode_client._errors import ZeromodeConnectionError, ZeromodeError, ZeromodeTimeoutError
from zeromode_client._models import Frame

T = TypeVar("T")

try:
    VERSION = version("zeromode-client")
except PackageNotFoundError:  # imported from a source tree that was never installed
    VERSION = "0+unknown"

DEFAULT_TIMEOUT = httpx.Timeout(120.0, connect=10.0)
"""Design and certification can take tens of seconds; a refused connection should fail fast."""


@dataclass(frozen=True)
class Call(Generic[T]):
    """One endpoint call: what to send and how to read a successful answer — its decoded JSON,
    or with ``raw`` the httpx response itself (pictures and files)."""

    method: str
    path: str
    body: dict[str, Any] | None
    parse: Callable[[Any], T]
    raw: bool = False


def jsonable(value: Any) -> Any:
    """``value`` with every Frame, numpy array and numpy scalar turned into plain JSON types."""
    if isinstance(value, Frame):
        return value.to_json()
    if hasattr(value, "raw") and isinstance(value.raw, Mapping):  # a result: its JSON answer
        return jsonable(value.raw)
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return value


def build_request(http: httpx.Client | httpx.AsyncClient, call: Call[Any]) -> httpx.Request:
    try:
        return http.build_request(call.method, call.path, json=call.body)
    except ValueError as exc:  # json.dumps(allow_nan=False): the API accepts finite numbers only
        raise ValueError(f"{call.path}: every number in a request must be finite ({exc}).") from exc


def error_from_response(response: httpx.Response) -> ZeromodeError:
    """The service's ``{"detail": {"code", "message"}}`` as an exception (any status ≥ 400)."""
    try:
        body = response.json()
    except ValueError:
        body = None
    detail = body.get("detail") if isinstance(body, dict) else None
    if isinstance(detail, dict) and "code" in detail:
        code, message = str(detail["code"]), str(detail.get("message", ""))
    elif isinstance(detail, str):
        code, message, detail = "http_error", detail, None
    else:
        code, detail = "http_error", None
        message = response.text[:200] or response.reason_phrase
    return ZeromodeError(message, code=code, status=response.status_code, detail=detail)


def parse(call: Call[T], response: httpx.Response) -> T:
    if response.status_code >= 400:
        raise error_from_response(response)
    try:
        return call.parse(response if call.raw else response.json())
    except (ValueError, KeyError, TypeError) as exc:  # not JSON, or not the contract's shape
        raise ZeromodeError(
            f"{call.path} answered with a body this client cannot read ({type(exc).__name__}: {exc}).",
            code="invalid_response",
            status=response.status_code,
        ) from exc


@dataclass(frozen=True)
class Retry:
    """Retry a call whose connection failed, waiting backoff·2^(attempt−1) s before each retry.

    Only failures to connect are retried: the request never reached the service, so sending it
    again cannot run a computation twice. Error answers (4xx, 5xx) and read timeouts are not.
    """

    retries: int
    backoff: float
    max_backoff: float = 10.0

    def __post_init__(self) -> None:
        if self.retries < 0 or self.backoff < 0:
            raise ValueError("retries and backoff must be non-negative.")

    def delay_after(self, exc: httpx.TransportError, request: httpx.Request, attempt: int) -> float:
        """Seconds to wait before attempt ``attempt + 1``; raises ZeromodeError when giving up."""
        if isinstance(exc, httpx.ConnectError | httpx.ConnectTimeout) and attempt <= self.retries:
            return float(min(self.backoff * 2 ** (attempt - 1), self.max_backoff))
        if isinstance(exc, httpx.TimeoutException) and not isinstance(exc, httpx.ConnectTimeout):
            raise ZeromodeTimeoutError(
                f"{request.method} {request.url} timed out ({type(exc).__name__})."
            ) from exc
        raise ZeromodeConnectionError(
            f"{request.method} {request.url} failed after {attempt} attempt(s): "
            f"{type(exc).__name__}: {exc}",
            attempts=attempt,
        ) from exc
