"""The work of one job, as it runs on a Dask worker: an endpoint's request in, its answer out.

``RUNNABLE`` maps each job endpoint to its operation (zeromode.operations.endpoints, which the
endpoint's route calls too) and models, so a job answers exactly what the endpoint would; a heavy
request (service/rest/offload.py) runs any endpoint's operation the same way (``execute_request``).
``execute_chunk`` is the task Dask runs: for each job it parses the
request, runs the endpoint under the job time budget and the service's settings (``execute``),
reports progress as Dask worker events (topic ``PROGRESS_TOPIC``, read by the service's engine)
and returns the encoded answer or the error body; it never raises for a failure of a request,
so a Dask-level error means the worker itself was lost.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from functools import lru_cache
from typing import Any, get_args

from pydantic import BaseModel, ValidationError

from zeromode.operations.endpoints import OPERATIONS, Operation, wire_body
from zeromode.operations.prechecks import PRECHECKS, precheck
from zeromode.service.wire.errors import failure_detail
from zeromode.service.wire.schemas.jobs import JobEndpoint
from zeromode.service.wire.settings import Settings, settings_scope
from zeromode.solver.budget import time_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.progress import progress_scope

log = logging.getLogger("zeromode")

PROGRESS_TOPIC = "zeromode-progress"
# A task sends a progress event when it moved by this fraction or this many seconds passed:
# enough for "every second or every 5 %", few enough not to load the scheduler.
PROGRESS_STEP = 0.01
PROGRESS_INTERVAL_S = 0.5


# The job endpoints, declared once (schemas.jobs.JobEndpoint names them): their operations.
RUNNABLE: dict[str, Operation] = {endpoint: OPERATIONS[endpoint] for endpoint in get_args(JobEndpoint)}


class RequestRefused(Exception):
    """A job's request that its endpoint would refuse up front: ``detail`` is the error body's
    {"code", "message", ...}; ``errors`` the schema errors when the schema refused it."""

    def __init__(self, detail: dict[str, Any], errors: list[dict[str, Any]] | None = None, status: int = 422):
        super().__init__(detail.get("message", ""))
        self.detail, self.errors, self.status = detail, errors, status


def validated(endpoint: str, request: dict[str, Any], prechecked: bool = False) -> BaseModel:
    """The request parsed by the model of the endpoint (one of OPERATIONS) and passed through
    its up-front checks, if it has any (zeromode/operations/prechecks.py: the job endpoints';
    skipped when ``prechecked``: a sweep's points passed them when the sweep was accepted): what
    the endpoint would refuse at once raises RequestRefused with the endpoint's own error."""
    try:
        body = OPERATIONS[endpoint].request_model.model_validate(request)
        if not prechecked and endpoint in PRECHECKS:
            precheck(endpoint, body)
    except ValidationError as exc:
        errors = exc.errors(include_url=False, include_context=False)
        first = errors[0]
        where = ".".join(str(p) for p in first["loc"]) or "request"
        raise RequestRefused(
            {"code": "invalid_request", "message": f"{where}: {first['msg']}."},
            [{"loc": [str(p) for p in e["loc"]], "msg": e["msg"]} for e in errors[:20]],
        ) from exc
    except DomainError as exc:
        raise RequestRefused(error_detail(exc)) from exc
    return body


def error_detail(exc: Exception) -> dict[str, Any]:
    """The {"code", "message", ...} an endpoint answers for ``exc``."""
    if isinstance(exc, RequestRefused):
        return exc.detail
    if isinstance(exc, DomainError):
        return failure_detail(exc)
    log.error("a job failed with an unexpected error", exc_info=exc)
    return {"code": "internal_error", "message": "an unexpected error occurred."}


def error_status(exc: Exception) -> int:
    """The HTTP status an endpoint answers for ``exc`` (domain failures are 422)."""
    return exc.status if isinstance(exc, RequestRefused) else 422


def answer(endpoint: str, body: BaseModel) -> dict[str, Any]:
    """Run the endpoint's operation: the JSON body the endpoint would have answered (a domain
    failure raises, as the endpoint's 422)."""
    return wire_body(endpoint, OPERATIONS[endpoint].run(body).body)


@lru_cache(maxsize=8)
def settings_of(doc: str) -> Settings:
    """The service's settings as a worker receives them (JSON), parsed once per process."""
    return Settings.model_validate_json(doc)


def _worker():
    """The Dask worker running this task, or None (the library's inline runs)."""
    try:
        from distributed import get_worker

        return get_worker()
    except (ImportError, ValueError):
        return None


def _event_sender(worker, job_id: str) -> Callable[[float, str], None]:
    """Progress of one job as Dask worker events, throttled."""
    last = [-1.0, 0.0]

    def send(fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction - last[0] >= PROGRESS_STEP or now - last[1] >= PROGRESS_INTERVAL_S:
            last[0], last[1] = fraction, now
            worker.log_event(PROGRESS_TOPIC, {"ids": [job_id], "progress": fraction, "message": message[:200]})

    return send


def _answered(endpoint: str, request: dict[str, Any], settings: Settings, budget_s: float,
              progress: Callable[[float, str], None] | None, stated_s: float | None = None,
              prechecked: bool = False) -> bytes:
    """The endpoint's answer as JSON bytes, under ``settings`` and a time budget of
    ``budget_s`` seconds (named ``stated_s`` in a refusal)."""
    with settings_scope(settings), time_budget(budget_s, stated_s), progress_scope(progress):
        return json.dumps(answer(endpoint, validated(endpoint, request, prechecked)), allow_nan=False,
                          separators=(",", ":")).encode()


def execute_request(endpoint: str, request: dict[str, Any], settings_json: str, budget_s: float) -> tuple[int, bytes]:
    """The Dask task of a heavy request to an endpoint of OPERATIONS, answered through the
    engine (service/rest/offload.py): (HTTP status, body) exactly as the endpoint answers, under
    the request's time budget."""
    try:
        settings = settings_of(settings_json)
        return 200, _answered(endpoint, request, settings, budget_s, None, settings.time_budget_s)
    except Exception as exc:  # noqa: BLE001 — every failure is the endpoint's error answer
        return error_status(exc), json.dumps({"detail": error_detail(exc)}, separators=(",", ":")).encode()


def execute(job_id: str, endpoint: str, request: dict[str, Any], settings_json: str,
            progress: Callable[[float, str], None] | None = None, prechecked: bool = False) -> tuple[str, Any]:
    """One job: ``("done", answer as JSON bytes)`` or ``("failed", error detail)``, its
    progress reported to ``progress``. Runs under the settings' job time budget; a result over
    ``max_job_result_bytes`` fails with ``result_too_large`` here, before it is shipped."""
    settings = settings_of(settings_json)
    try:
        data = _answered(endpoint, request, settings, settings.job_time_budget_s, progress, prechecked=prechecked)
    except Exception as exc:  # noqa: BLE001 — every failure of the request is the job's answer
        return "failed", error_detail(exc)
    limit = settings.max_job_result_bytes
    if len(data) > limit:
        return "failed", {
            "code": "result_too_large",
            "message": f"the result has {len(data)} bytes; a stored job result may have {limit} "
            "(ask for less, e.g. options.bases false, or run the request directly).",
        }
    return "done", data


def chunk_of(jobs: list[tuple[str, str, dict[str, Any]]]) -> str:
    """Jobs, (id, endpoint, request) each, as the one JSON text ``execute_chunk`` takes: Dask
    walks every list and dict of a task's arguments looking for futures (measured: a tenth of
    the service's CPU on a sweep of small designs), and a text is one leaf."""
    return json.dumps(jobs, separators=(",", ":"))


def execute_chunk(chunk: str, settings_json: str, prechecked: bool = False) -> list[tuple[str, str, Any]]:
    """The Dask task: a chunk of jobs (``chunk_of``), run one after the other; (id, status,
    payload) of each, as ``execute`` returns them. One event marks them all running; a chunk of
    one job (a single job) also reports that job's progress, a chunk of sweep points only their
    ends (a sweep's progress is its count of finished points). ``prechecked``: the requests
    passed their endpoint's up-front checks already (a sweep's, when it was accepted)."""
    jobs = json.loads(chunk)
    worker = _worker()
    if worker is not None:
        worker.log_event(PROGRESS_TOPIC, {"ids": [job_id for job_id, _, _ in jobs], "progress": 0.0, "message": "running"})
    out = []
    for job_id, endpoint, request in jobs:
        progress = _event_sender(worker, job_id) if worker is not None and len(jobs) == 1 else None
        out.append((job_id, *execute(job_id, endpoint, request, settings_json, progress, prechecked)))
    return out
