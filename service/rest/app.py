"""The FastAPI application: routers, error handlers, limits and security middleware."""

from __future__ import annotations

import itertools
import logging
import os
import re
import secrets
import threading
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.middleware.gzip import GZipMiddleware
from fastapi.responses import JSONResponse
from starlette.datastructures import Headers, MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from zeromode.service import __version__
from zeromode.service.jobs.manager import jobs_of_app
from zeromode.service.rest.body import BodyRefusal, read_checked_body, replay
from zeromode.service.rest.errors import install_error_handlers
from zeromode.service.rest.offload import Offload
from zeromode.service.rest.routes import (
    analyze,
    certify,
    design,
    examples,
    export,
    health,
    jobs,
    lattice,
    motion,
    multistable,
    plot,
    sequential,
    sweeps,
    viewer,
)
from zeromode.service.wire.errors import error_body
from zeromode.service.wire.settings import Settings, settings_scope
from zeromode.solver.analysis.rigidity import warm_up
from zeromode.solver.budget import time_budget

log = logging.getLogger("zeromode")
# A caller's request id is kept only if it is this kind of token (no control characters in logs).
_REQUEST_ID = re.compile(r"[A-Za-z0-9._:-]{1,64}")
# Responses smaller than this are sent uncompressed (gzip's header would outweigh the saving).
GZIP_MINIMUM_BYTES = 1024
# A job engine that could not start at startup is tried again after this wait, doubled after each
# failure up to the maximum (a database or Dask cluster that comes up later is found within it).
ENGINE_RETRY_FIRST_S, ENGINE_RETRY_MAX_S = 1.0, 30.0
# At shutdown, an engine start under way is waited for this long before the engine is closed.
START_WAIT_S = 30.0


def _request_id(given: str | None) -> str:
    """The caller's X-Request-Id when it is a short token (it goes into logs and headers),
    otherwise a fresh one."""
    if given is not None and _REQUEST_ID.fullmatch(given):
        return given
    return uuid.uuid4().hex[:16]


class LimitsAndAuth:
    """Pure ASGI middleware (no per-request task, unlike BaseHTTPMiddleware): body-size limit on
    the bytes received (service/rest/body.py: gzip, UTF-8, JSON depth), optional API key, the app's
    settings as the current settings and the per-request time budget, and a request id echoed in
    the response and the log."""

    def __init__(self, app: ASGIApp, settings: Settings):
        self.app = app
        self.settings = settings

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        settings = self.settings
        headers = Headers(scope=scope)
        request_id = _request_id(headers.get("x-request-id"))
        length = headers.get("content-length")
        refusal = None
        header_bytes = sum(len(name) + len(value) + 4 for name, value in scope["headers"])
        if header_bytes > settings.max_header_bytes:
            # h11 bounds only headers that arrive incomplete; a complete oversized block is refused here.
            refusal = BodyRefusal(431, "headers_too_large", f"the request headers have {header_bytes} bytes; the limit is {settings.max_header_bytes}.")
        elif length is not None and length.isdigit() and int(length) > settings.max_body_bytes:
            refusal = BodyRefusal(413, "body_too_large", f"the request body has {length} bytes; the limit is {settings.max_body_bytes}.")
        elif (
            settings.api_key
            and scope["path"].startswith("/v1/")
            and not secrets.compare_digest(headers.get("x-api-key", ""), settings.api_key)
        ):
            refusal = BodyRefusal(401, "unauthorized", "a valid X-API-Key header is required.")
        elif scope["method"] in ("POST", "PUT", "PATCH"):
            # Counted as received: a chunked body, or a Content-Length that lies, cannot pass.
            try:
                receive = replay(await read_checked_body(scope, receive, settings.max_body_bytes), receive)
            except BodyRefusal as error:
                refusal = error
        if refusal is not None:
            response = JSONResponse(status_code=refusal.status, content=error_body(refusal.code, refusal.message))
            response.headers["x-request-id"] = request_id
            log.info("request_id=%s %s %s -> %s", request_id, scope["method"], scope["path"], refusal.status)
            await response(scope, receive, send)
            return
        status_seen = []

        async def send_with_id(message: Message) -> None:
            if message["type"] == "http.response.start":
                status_seen.append(message["status"])
                MutableHeaders(scope=message).append("x-request-id", request_id)
            await send(message)

        with settings_scope(settings), time_budget(settings.time_budget_s):
            await self.app(scope, receive, send_with_id)
        log.info(
            "request_id=%s %s %s -> %s", request_id, scope["method"], scope["path"], status_seen[0] if status_seen else "-"
        )


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    """At startup, in the background (the service answers at once): the rigidity analysis's
    compiled kernels are loaded, or compiled in a fresh environment (``/health`` says which:
    ``kernels``; a request that needs one first waits for it, not charged to its time budget,
    solver/analysis/compiled.py), and the job engine starts when heavy requests are offloaded to it, the
    store holds unfinished work to adopt or is a database server that replicas share, tried
    again until it starts; at shutdown the engine gives its lease up and closes its cluster."""
    threading.Thread(target=_warm_up, args=(app,), name="zeromode-warm-up", daemon=True).start()
    stopping = threading.Event()
    starter = threading.Thread(target=_start_engine, args=(app, stopping), name="zeromode-adopt", daemon=True)
    starter.start()
    yield
    stopping.set()
    starter.join(timeout=START_WAIT_S)  # a start under way is closed below, not left running
    jobs, app.state.jobs = app.state.jobs, None  # a later start opens them again
    if jobs is not None:
        jobs.close()


def _warm_up(app: FastAPI) -> None:
    try:
        warm_up()
    except Exception:
        log.exception("the kernels could not be compiled ahead (each request compiles what it needs)")
    app.state.kernels_ready.set()


def _start_engine(app: FastAPI, stopping: threading.Event) -> None:
    """Open the store and start the engine if there is work for it; a failure (the database or
    the Dask cluster not reachable yet) is logged and tried again after ``ENGINE_RETRY_FIRST_S``,
    the wait doubling up to ``ENGINE_RETRY_MAX_S``, until it starts or the app stops. (Left to
    the next request, a replica that lost its start would adopt nothing from a stopped peer.)"""
    settings = app.state.settings
    if not settings.offload and settings.database_url.startswith("sqlite:///") and not os.path.exists(
        settings.database_url[len("sqlite:///"):]
    ):
        return  # no store yet: nothing was ever submitted here, nothing to adopt
    # A database server (not a SQLite file) is shared by replicas: each takes a lease at once, so
    # that it adopts a stopped peer's work even if no request ever reaches it.
    replicated = not settings.database_url.startswith("sqlite")
    wait = ENGINE_RETRY_FIRST_S
    for attempt in itertools.count(1):
        try:
            jobs = jobs_of_app(app.state)
            if jobs.has_orphans() or settings.offload or replicated:
                jobs.engine.start()  # heavy requests need it soon: ready before the first
            return
        except Exception:
            log.exception("the job engine could not start (attempt %d); trying again in %g s", attempt, wait)
        if stopping.wait(wait):
            return
        wait = min(2 * wait, ENGINE_RETRY_MAX_S)


def create_app(settings: Settings | None = None) -> FastAPI:
    """The service for ``settings`` (default: read from the ZEROMODE_* environment). Every
    limit of a request is taken from these settings while it is served."""
    settings = Settings() if settings is None else settings
    app = FastAPI(
        title="zeromode",
        lifespan=lifespan,
        # No slash redirects: starlette builds their URL from the Host header (an open redirect).
        redirect_slashes=False,
        version=__version__,
        description=(
            "Inverse design of bar-and-joint (Maxwell) frames whose only non-rigid zero modes "
            "are the motions you specify (Kim, Lu, Strogatz & Bassett)."
        ),
    )
    install_error_handlers(app)
    app.state.settings = settings  # the job store reads its database, limits and settings here
    app.state.jobs = None
    app.state.kernels_ready = threading.Event()  # set by the warm-up the lifespan starts
    for module in (health, analyze, certify, design, multistable, examples, lattice, plot, export, motion, sequential, jobs,
                   sweeps, viewer):
        app.include_router(module.router)

    app.add_middleware(Offload, settings=settings)  # inside the limits: sees checked bodies
    app.add_middleware(LimitsAndAuth, settings=settings)
    app.add_middleware(GZipMiddleware, minimum_size=GZIP_MINIMUM_BYTES)
    describe = app.openapi

    def openapi() -> dict:
        """The document states this app's limits (maxItems, maximum): built under its settings."""
        with settings_scope(settings):
            return describe()

    app.openapi = openapi

    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=list(settings.cors_origins),
            allow_methods=["GET", "POST", "DELETE"],
            # A browser client must be able to send its key and a compressed JSON body.
            allow_headers=["x-api-key", "content-type", "content-encoding", "x-request-id"],
            expose_headers=["x-request-id"],
        )
    return app


app = create_app()
