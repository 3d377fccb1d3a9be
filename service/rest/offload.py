"""Heavy requests answered by the job engine's worker processes instead of the service's own.

A request that can take long (``heavy``) is validated here exactly as its endpoint validates it
(schema and up-front checks, service/jobs/tasks.py ``validated``), then run on a Dask worker of the
engine (service/jobs/engine.py), while the service's event loop stays free (``/health`` answers at
once) and several requests use several cores. Two things only a separate process allows:

- **The time budget holds.** The worker checks the budget cooperatively between steps; if it
  has not answered when the budget is spent (a long library call), the answer is 422
  ``too_expensive`` and its process is restarted.
- **Work stops when the client leaves.** A disconnect cancels the task and restarts the worker
  running it.

Everything else (an invalid request, a cheap one, an engine not started yet or unavailable)
goes to the route as usual, so answers and error bodies are the endpoint's own either way.

Which requests are heavy is service/jobs/heavy.py's decision.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
from collections.abc import Callable
from functools import cache
from typing import Any

from fastapi.routing import APIRoute
from pydantic import ValidationError
from starlette.types import ASGIApp, Receive, Scope, Send

from zeromode.operations.endpoints import OPERATIONS
from zeromode.service.jobs.heavy import heavy
from zeromode.service.jobs.tasks import (
    RequestRefused,
    error_detail,
    error_status,
    execute_request,
    settings_of,
    validated,
)
from zeromode.service.rest.body import replay
from zeromode.service.wire.errors import error_body, invalid_request_body
from zeromode.service.wire.settings import Settings, settings_scope
from zeromode.solver.budget import remaining, time_budget

log = logging.getLogger("zeromode")

# Bodies larger than this are validated by the worker, inside the budget it is stopped at, rather
# than by the service before it takes them (uninterruptible: a 5 MB frame of 10⁵ nodes took up to 1.2 s).
VALIDATE_HERE_BYTES = 1_000_000
# The routes that answer a file rather than an operation's JSON body (every other heavy request
# runs its endpoint's operation, OPERATIONS, as the route and a job do): answered by a worker
# through ``execute_file_route``.
FILE_ROUTES = frozenset({"/v1/plot", "/v1/export"})
JSON_HEADERS = [("content-type", "application/json")]


@cache
def _route(path: str) -> APIRoute:
    """The POST route of ``path`` among FILE_ROUTES."""
    from zeromode.service.rest.routes import export, plot

    return next(r for module in (export, plot) for r in module.router.routes
                if isinstance(r, APIRoute) and r.path == path and "POST" in r.methods)


def _body_model(route: APIRoute):
    (param,) = route.dependant.body_params
    return param.field_info.annotation


def execute_file_route(path: str, request: dict[str, Any], settings_json: str,
                       budget_s: float) -> tuple[int, bytes, list[tuple[str, str]]]:
    """The Dask task of a heavy request to one of FILE_ROUTES: (HTTP status, body, headers) as
    the route answers, under the request's time budget (as tasks.execute_request for the
    operations)."""
    try:
        settings = settings_of(settings_json)
        route = _route(path)
        with settings_scope(settings), time_budget(budget_s, settings.time_budget_s):
            out = route.endpoint(_body_model(route).model_validate(request))
        kept = [(k, v) for k, v in out.headers.items() if k in ("content-type", "content-disposition")]
        return out.status_code, bytes(out.body), kept
    except Exception as exc:  # noqa: BLE001 — every failure is the route's error answer
        return error_status(exc), json.dumps({"detail": error_detail(exc)}, separators=(",", ":")).encode(), JSON_HEADERS


def execute_unvalidated(endpoint: str, request: dict[str, Any], settings_json: str,
                        budget_s: float) -> tuple:
    """The Dask task of a heavy request whose body the service did not validate (past
    VALIDATE_HERE_BYTES): its schema checked here first, a refusal answered as the route's
    (invalid_request, the errors listed), then answered by ``execute_request`` (an operation)
    or ``execute_file_route``."""
    model = OPERATIONS[endpoint].request_model if endpoint in OPERATIONS else _body_model(_route(endpoint))
    try:
        with settings_scope(settings_of(settings_json)):
            model.model_validate(request)
    except ValidationError as exc:
        errors = [{**e, "loc": ("body", *e["loc"])} for e in exc.errors(include_url=False, include_context=False)]
        return 422, json.dumps(invalid_request_body(errors), separators=(",", ":")).encode()
    task = execute_request if endpoint in OPERATIONS else execute_file_route
    return task(endpoint, request, settings_json, budget_s)


class Offload:
    """Pure ASGI middleware (inside the body limits): heavy POSTs run on the engine's workers."""

    def __init__(self, app: ASGIApp, settings: Settings):
        self.app = app
        self.settings = settings
        self._planning = asyncio.Semaphore(1)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        path = scope.get("path", "")
        if not self.settings.offload or scope["type"] != "http" or scope["method"] != "POST" or not path.startswith("/v1/"):
            await self.app(scope, receive, send)
            return
        message = await receive()
        body = message.get("body", b"")
        receive = replay(body, receive)
        # Parsing and validating a large body is work: off the event loop, which answers
        # /health, and one request at a time, so the loop competes for the GIL with one thread
        # rather than with every waiting request.
        async with self._planning:
            plan = await asyncio.to_thread(self._plan, scope, path, body)
        if plan is None:
            await self.app(scope, receive, send)
            return
        jobs = scope["app"].state.jobs
        engine = None if jobs is None else jobs.engine
        if engine is None or not engine.started:
            # Started in the background at startup; until it is ready (or if it cannot start)
            # the route answers, rather than a request waiting for a cluster to start.
            await self.app(scope, receive, send)
            return
        outcome = await self._run(engine, path, *plan, receive)
        if outcome is not None:
            await _send(send, *outcome)

    def _plan(self, scope: Scope, path: str, body: bytes) -> tuple[dict[str, Any], Callable] | None:
        """The request to offload and the task that answers it, or None to answer it inline."""
        if path not in OPERATIONS and path not in FILE_ROUTES:
            return None
        try:
            request = json.loads(body)
        except ValueError:
            return None
        try:
            if not isinstance(request, dict) or not heavy(path, request):
                return None
        except (TypeError, ValueError, AttributeError, OverflowError):
            return None  # fields of the wrong type: the route answers with its validation error
        if len(body) > VALIDATE_HERE_BYTES:
            return request, execute_unvalidated
        try:
            if path in OPERATIONS:
                validated(path, request)
                return request, execute_request
            _body_model(_route(path)).model_validate(request)
            return request, execute_file_route
        except (RequestRefused, ValidationError):
            return None  # the route answers with its own error body

    async def _run(self, engine, endpoint: str, request: dict[str, Any], task: Callable,
                   receive: Receive) -> tuple | None:
        """(status, body[, headers]) of the request run on a worker; None when the client left."""
        budget = self.settings.time_budget_s
        # The request's own budget, started when its body was read (LimitsAndAuth): what is
        # left of it after validation is the worker's, and the answer comes by its end however
        # long the submission takes. No slack past it: the event loop's own latency while a
        # large request is handed to Dask (0.1-0.2 s for 5 MB, measured) comes on top and must
        # fit in the 10 % the budget allows.
        left_s = remaining()
        left_s = budget if left_s is None else left_s
        if left_s <= 0:  # reading and validating a large body took the whole budget
            return _too_expensive(budget)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + left_s
        future = await asyncio.to_thread(engine.run_request, endpoint, request, left_s, task)
        done = loop.create_future()
        future.add_done_callback(lambda _: done.get_loop().call_soon_threadsafe(_settle, done))
        left = asyncio.ensure_future(_disconnected(receive))
        finished, _ = await asyncio.wait({done, left}, timeout=max(deadline - loop.time(), 0.0),
                                         return_when=asyncio.FIRST_COMPLETED)
        left.cancel()
        if done in finished:
            return engine.request_outcome(future)
        # Stopped in the background: the answer does not wait for a worker to restart.
        threading.Thread(target=engine.stop_request, args=(future,), name="zeromode-stop", daemon=True).start()
        return None if left in finished else _too_expensive(budget)


def _too_expensive(budget: float) -> tuple[int, bytes]:
    return 422, json.dumps(error_body(
        "too_expensive",
        f"the computation needs more than its time budget of {budget:g} s and was stopped; "
        "ask for a smaller problem, or run it as a job (POST /v1/jobs).",
    )).encode()


def _settle(future: asyncio.Future) -> None:
    if not future.done():
        future.set_result(None)


async def _disconnected(receive: Receive) -> None:
    """Returns when the client disconnects."""
    while (await receive())["type"] != "http.disconnect":
        pass


async def _send(send: Send, status: int, content: bytes, headers: list[tuple[str, str]] = JSON_HEADERS) -> None:
    raw = [(k.encode("latin-1"), v.encode("latin-1")) for k, v in headers]
    await send({"type": "http.response.start", "status": status,
                "headers": [*raw, (b"content-length", str(len(content)).encode())]})
    await send({"type": "http.response.body", "body": content})
