"""The app's error handlers: every failure leaves as a 4xx (or, for a bug, a 500) with the wire
format's error body (service/wire/errors.py); never a stack trace."""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from zeromode.service.wire.errors import error_body, failure_detail, invalid_request_body
from zeromode.solver.errors import DomainError

log = logging.getLogger("zeromode")


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(DomainError)
    async def domain_error(_: Request, exc: DomainError):
        return JSONResponse(status_code=422, content={"detail": failure_detail(exc)})

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
