"""Every failure leaves as a 4xx with {"detail": {"code": ..., "message": ...}}; never a stack trace."""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from zeromode.solver.errors import DomainError

log = logging.getLogger("zeromode")


def error_body(code: str, message: str, **extra) -> dict:
    return {"detail": {"code": code, "message": message, **extra}}


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


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(DomainError)
    async def domain_error(_: Request, exc: DomainError):
        return JSONResponse(status_code=422, content=error_body(exc.code, exc.message))

    @app.exception_handler(RequestValidationError)
    async def validation_error(_: Request, exc: RequestValidationError):
        return JSONResponse(status_code=422, content=invalid_request_body(exc.errors()))

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        if isinstance(exc.detail, dict):
            return JSONResponse(status_code=exc.status_code, content={"detail": exc.detail})
        sentences = {
            404: ("not_found", f"there is no endpoint at {request.url.path}; see /docs."),
            405: ("method_not_allowed", f"{request.method} is not allowed on {request.url.path}."),
        }
        code, message = sentences.get(exc.status_code, ("http_error", str(exc.detail)))
        return JSONResponse(
            status_code=exc.status_code, content=error_body(code, message), headers=exc.headers
        )

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        # A bug: log it with the request id, answer without internals.
        log.exception("unhandled error on %s", request.url.path)
        return JSONResponse(
            status_code=500, content=error_body("internal_error", "an unexpected error occurred.")
        )
