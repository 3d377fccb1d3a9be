"""Heavy requests answered by the job engine's worker processes instead of the service's own.

A request that can take long (``heavy``) is validated here exactly as its endpoint validates it
(schema and up-front checks, service/tasks.py ``validated``), then run on a Dask worker of the
engine (service/engine.py), while the service's event loop stays free (``/health`` answers at
once) and several requests use several cores. Two things only a separate process allows:

- **The time budget holds.** The worker checks the budget cooperatively between steps; if it
  has not answered ``OVERRUN_SLACK`` past the budget (a long library call), its process is
  restarted and the answer is 422 ``too_expensive``.
- **Work stops when the client leaves.** A disconnect cancels the task and restarts the worker
  running it.

Everything else (an invalid request, a cheap one, an engine not started yet or unavailable)
goes to the route as usual, so answers and error bodies are the endpoint's own either way.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
from typing import Any

from starlette.types import ASGIApp, Receive, Scope, Send

from zeromode.service.body import replay
from zeromode.service.errors import error_body
from zeromode.service.settings import Settings
from zeromode.service.tasks import RequestRefused, validated
from zeromode.solver.budget import remaining

log = logging.getLogger("zeromode")

# The worker answers too_expensive itself at the budget; this much later it is stopped.
OVERRUN_SLACK = 0.05
# Requests whose answer can take long, by endpoint: the rest are cheap enough to answer inline.
ALWAYS = frozenset({"/v1/motion", "/v1/refine", "/v1/certify", "/v1/design/allosteric"})
# Above these sizes an analysis or an auxetic design is heavy (both take well under 0.1 s below).
HEAVY_NODES = 2_000
HEAVY_CELLS = 400


def heavy(endpoint: str, request: dict[str, Any]) -> bool:
    """Whether the request should run on a worker process (see the module's docstring)."""
    if endpoint in ALWAYS:
        return True
    options = request.get("options") or {}
    if endpoint == "/v1/design":
        return any(options.get(stage) for stage in ("refine", "certify", "tolerance"))
    if endpoint == "/v1/design/auxetic":
        cells = request.get("cells") or [1]
        count = 1
        for c in cells:
            count *= int(c)
        return count > HEAVY_CELLS or any(request.get(k) for k in ("refine", "certify", "finite_strain", "tolerance"))
    if endpoint == "/v1/analyze":
        return len((request.get("frame") or {}).get("positions") or []) > HEAVY_NODES
    return False


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
        outcome = await self._run(engine, path, plan, receive)
        if outcome is not None:
            await _send_json(send, *outcome)

    def _plan(self, scope: Scope, path: str, body: bytes) -> dict[str, Any] | None:
        """The request to offload, or None to answer it inline."""
        from zeromode.service.tasks import RUNNABLE

        if path not in RUNNABLE:
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
        try:
            validated(path, request)
        except RequestRefused:
            return None  # the route answers with its own error body
        return request

    async def _run(self, engine, endpoint: str, request: dict[str, Any], receive: Receive) -> tuple[int, bytes] | None:
        """(status, body) of the request run on a worker; None when the client left."""
        budget = self.settings.time_budget_s
        # The request's own budget, started when its body was read (LimitsAndAuth): what is
        # left of it after validation and submission is the worker's.
        left_s = remaining()
        left_s = budget if left_s is None else left_s
        task = await asyncio.to_thread(engine.run_request, endpoint, request, left_s)
        done = asyncio.get_running_loop().create_future()
        task.add_done_callback(lambda _: done.get_loop().call_soon_threadsafe(_settle, done))
        left = asyncio.ensure_future(_disconnected(receive))
        finished, _ = await asyncio.wait({done, left}, timeout=left_s + OVERRUN_SLACK * budget,
                                         return_when=asyncio.FIRST_COMPLETED)
        left.cancel()
        if done in finished:
            return engine.request_outcome(task)
        # Stopped in the background: the answer does not wait for a worker to restart.
        threading.Thread(target=engine.stop_request, args=(task,), name="zeromode-stop", daemon=True).start()
        if left in finished:
            return None
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


async def _send_json(send: Send, status: int, content: bytes) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(content)).encode())]})
    await send({"type": "http.response.body", "body": content})
