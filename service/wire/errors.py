"""Error bodies: every failure leaves as a 4xx with {"detail": {"code": ..., "message": ...}};
a domain failure that found a best result carries its body as detail.best. The REST layer
(service/rest/errors.py) and the job engine (service/jobs/tasks.py) answer the same bodies."""

from __future__ import annotations

from zeromode.solver.errors import DomainError


def error_body(code: str, message: str, **extra) -> dict:
    return {"detail": {"code": code, "message": message, **extra}}


def with_best(exc: DomainError, best: dict | None) -> DomainError:
    """``exc`` carrying the body of the best result found (None: no attempt could be built),
    which its 422 answers as detail.best; the library's caller still gets ``exc`` itself."""
    exc.best_body = best
    return exc


def failure_detail(exc: DomainError) -> dict:
    """The 422 detail of a domain failure: its code and message, and ``best`` where the
    operation that failed attached one (``with_best``)."""
    detail = {"code": exc.code, "message": exc.message}
    if hasattr(exc, "best_body"):
        detail["best"] = exc.best_body
    return detail


def _location(loc) -> str:
    parts = [str(p) for p in loc if p not in ("body",)]
    return ".".join(parts) if parts else "body"


def invalid_request_body(errors: list) -> dict:
    """The 422 body of a request its schema refused (pydantic errors, locations from "body"):
    the first error as the message, up to 20 listed."""
    first = errors[0] if errors else {"loc": ("body",), "msg": "invalid request"}
    message = f"{_location(first.get('loc', ()))}: {first.get('msg', 'invalid value')}."
    slim = [{"loc": [str(p) for p in e.get("loc", ())], "msg": e.get("msg", "")} for e in errors[:20]]
    return error_body("invalid_request", message, errors=slim)
