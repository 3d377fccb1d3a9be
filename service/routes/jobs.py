"""POST /v1/jobs and GET /v1/jobs/{id} — any long endpoint as a job, polled for progress."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any, get_args

from fastapi import APIRouter, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ValidationError

from zeromode.service.errors import error_body
from zeromode.service.jobs import JobFailed, JobRejected, JobStore
from zeromode.service.routes import analyze, certify, design, lattice, motion
from zeromode.service.schemas.common import ERROR_RESPONSES, ErrorResponse
from zeromode.service.schemas.jobs import JobAccepted, JobEndpoint, JobRequest, JobStatus

router = APIRouter(prefix="/v1", tags=["jobs"])


@dataclass(frozen=True)
class Runnable:
    """An endpoint that can run as a job: its route function, request and response models."""

    run: Callable[[BaseModel], Any]
    request_model: type[BaseModel]
    response_model: type[BaseModel]


def _runnable(run: Callable[[BaseModel], Any]) -> Runnable:
    """The route function with the models its own signature and route declare."""
    route = next(
        r for module in (analyze, certify, design, lattice, motion) for r in module.router.routes
        if getattr(r, "endpoint", None) is run
    )
    (param,) = route.dependant.body_params
    return Runnable(run, param.field_info.annotation, route.response_model)


# The job endpoints, declared once. JobEndpoint (the schema's enum) must name the same paths.
JOBS: dict[str, Runnable] = {
    "/v1/analyze": _runnable(analyze.post_analyze),
    "/v1/design": _runnable(design.post_design),
    "/v1/design/auxetic": _runnable(lattice.post_auxetic),
    "/v1/design/allosteric": _runnable(lattice.post_allosteric),
    "/v1/motion": _runnable(motion.post_motion),
    "/v1/refine": _runnable(motion.post_refine),
    "/v1/certify": _runnable(certify.post_certify),
}
assert set(JOBS) == set(get_args(JobEndpoint)), "JOBS and schemas.jobs.JobEndpoint disagree"
UNAVAILABLE = {503: {"model": ErrorResponse, "description": "The job directory cannot be used."}}
_STORE_LOCK = threading.Lock()


def _store(request: Request) -> JobStore:
    """One store per app, made on first use (an app that never runs a job starts no threads)."""
    state = request.app.state
    with _STORE_LOCK:
        if not hasattr(state, "job_store"):
            settings = state.settings
            try:
                state.job_store = JobStore(settings)
            except OSError as exc:  # the operator's ZEROMODE_JOB_DIR, not the request, is wrong
                raise HTTPException(
                    503,
                    detail={
                        "code": "jobs_unavailable",
                        "message": f"the job directory {settings.job_dir} cannot be used "
                        f"({exc.strerror}).",
                    },
                ) from exc
        return state.job_store


def _client(request: Request) -> str:
    """Who a job belongs to, for the fair share of job slots: the API key, else the address."""
    key = request.headers.get("x-api-key")
    return f"key:{key}" if key else f"address:{request.client.host if request.client else ''}"


def _run(job: Runnable, body: BaseModel) -> dict[str, Any]:
    """Run the endpoint's function and return the JSON body the endpoint would have answered."""
    out = job.run(body)
    if isinstance(out, Response):  # endpoints answer some domain failures with a JSONResponse
        data = json.loads(out.body)
        if out.status_code >= 400:
            raise JobFailed(data.get("detail", {}))
        return data
    return job.response_model.model_validate(out).model_dump(mode="json")


@router.post(
    "/jobs",
    status_code=202,
    response_model=JobAccepted,
    responses={
        **ERROR_RESPONSES,
        429: {"model": ErrorResponse, "description": "Too many jobs."},
        **UNAVAILABLE,
    },
)
def submit_job(job: JobRequest, request: Request) -> JSONResponse:
    """Run a long request as a job: the request is validated now (422 with the endpoint's own
    error body if invalid) and runs in the background under ZEROMODE_JOB_TIME_BUDGET_S
    (default 900 s) instead of the per-request budget. Poll GET /v1/jobs/{id}."""
    runnable = JOBS[job.endpoint]  # the schema admits only the registered endpoints
    try:
        body = runnable.request_model.model_validate(job.request)
    except ValidationError as exc:
        raise RequestValidationError(
            [{**e, "loc": ("body", "request", *e["loc"])} for e in exc.errors()]
        ) from exc
    try:
        accepted = _store(request).submit(job.endpoint, partial(_run, runnable, body), _client(request))
    except JobRejected as exc:
        return JSONResponse(status_code=429, content=error_body(exc.code, exc.message))
    return JSONResponse(
        status_code=202,
        content={"id": accepted["id"], "status": "queued", "endpoint": job.endpoint},
        headers={"location": f"/v1/jobs/{accepted['id']}"},
    )


@router.get(
    "/jobs/{job_id}",
    response_model=JobStatus,
    responses={
        404: {"model": ErrorResponse, "description": "Unknown or expired job id."},
        **UNAVAILABLE,
    },
)
def get_job(job_id: str, request: Request) -> dict:
    """Status, progress (0..1) and message of a job; its result when done, its error when failed.
    Any worker answers: job state is shared through ZEROMODE_JOB_DIR."""
    state = _store(request).get(job_id)
    if state is None:
        raise HTTPException(
            404,
            detail={
                "code": "unknown_job",
                "message": f"there is no job {job_id[:64]}; it never existed or has expired.",
            },
        )
    return state
