"""The FastAPI application: routers, error handlers, limits and security middleware."""

from __future__ import annotations

import logging
import secrets
import uuid

from fastapi import FastAPI, Request
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import JSONResponse

from zeromode.service import __version__
from zeromode.service.errors import error_body, install_error_handlers
from zeromode.service.routes import (
    analyze,
    certify,
    design,
    examples,
    health,
    jobs,
    lattice,
    motion,
    plot,
)
from zeromode.service.settings import SETTINGS, Settings
from zeromode.solver.budget import time_budget

log = logging.getLogger("zeromode")


def create_app(settings: Settings = SETTINGS) -> FastAPI:
    app = FastAPI(
        title="zeromode",
        version=__version__,
        description=(
            "Inverse design of bar-and-joint (Maxwell) frames whose only non-rigid zero modes "
            "are the motions you specify (Kim, Lu, Strogatz & Bassett)."
        ),
    )
    install_error_handlers(app)
    app.state.settings = settings  # the job store reads its directory and limits here
    for module in (health, analyze, certify, design, examples, lattice, plot, motion, jobs):
        app.include_router(module.router)

    @app.middleware("http")
    async def limits_and_auth(request: Request, call_next):
        request_id = request.headers.get("x-request-id") or uuid.uuid4().hex[:16]
        length = request.headers.get("content-length")
        if length is not None and length.isdigit() and int(length) > settings.max_body_bytes:
            return JSONResponse(
                status_code=413,
                content=error_body(
                    "body_too_large",
                    f"the request body has {length} bytes; the limit is {settings.max_body_bytes}.",
                ),
            )
        if length is None and request.method in ("POST", "PUT", "PATCH"):
            # A chunked body has no Content-Length and would slip past the size limit above.
            return JSONResponse(
                status_code=411,
                content=error_body(
                    "length_required", "a request body needs a Content-Length header (no chunked bodies)."
                ),
            )
        if settings.api_key and request.url.path.startswith("/v1/"):
            given = request.headers.get("x-api-key", "")
            if not secrets.compare_digest(given, settings.api_key):
                return JSONResponse(
                    status_code=401,
                    content=error_body("unauthorized", "a valid X-API-Key header is required."),
                )
        with time_budget(settings.time_budget_s):
            response = await call_next(request)
        response.headers["x-request-id"] = request_id
        log.info("request_id=%s %s %s -> %s", request_id, request.method, request.url.path, response.status_code)
        return response

    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware, allow_origins=list(settings.cors_origins), allow_methods=["GET", "POST"]
        )
    return app


app = create_app()
