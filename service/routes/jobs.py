"""POST /v1/jobs and GET /v1/jobs/{id} — any long endpoint as a job, polled for progress."""

from __future__ import annotations

import importlib
import json
import pkgutil
import threading
from functools import cache, partial
from typing import Any, get_args

from fastapi import APIRouter, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.routing import APIRoute
from pydantic import BaseModel, ValidationError

import zeromode.service.routes as routes_package
from zeromode.service.errors import error_body
from zeromode.service.jobs import JobFailed, JobRejected, JobStore
from zeromode.service.schemas.common import ERROR_RESPONSES, ErrorResponse
from zeromode.service.schemas.jobs import JobAccepted, JobEndpoint, JobRequest, JobStatus

router = APIRouter(prefix="/v1", tags=["jobs"])

JOB_ENDPOINTS = frozenset(get_args(JobEndpoint))
UNAVAILABLE = {503: {"model": ErrorResponse, "description": "The job directory cannot be used."}}
_STORE_LOCK = threading.Lock()


@cache
def _job_routes() -> dict[str, APIRoute]:
    """The POST routes of the job endpoints, found in the route modules (whichever defines them)."""
    found = {}
    for info in pkgutil.iter_modules(routes_package.__path__):
        module = importlib.import_module(f"{routes_package.__name__}.{info.name}")
        for route in getattr(getattr(module, "router", None), "routes", ()):
            if (
                isinstance(route, APIRoute)
                and route.path in JOB_ENDPOINTS
                and "POST" in route.methods
            ):
                found[route.path] = route
    return found


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


def _run_route(route: APIRoute, argument: str, body: BaseModel) -> dict[str, Any]:
    """Call the endpoint's function and return the JSON body it would have answered."""
    out = route.endpoint(**{argument: body})
    if isinstance(out, Response):  # endpoints answer some domain failures with a JSONResponse
        data = json.loads(out.body)
        if out.status_code >= 400:
            raise JobFailed(data.get("detail", {}))
        return data
    model = route.response_model
    if isinstance(model, type) and issubclass(model, BaseModel):
        return model.model_validate(out).model_dump(mode="json", by_alias=True)
    return out


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
    route = _job_routes().get(job.endpoint)
    if route is None or job.endpoint not in request.app.openapi()["paths"]:
        raise HTTPException(
            422,
            detail={
                "code": "unsupported_endpoint",
                "message": f"{job.endpoint} is not served by this version; see /openapi.json.",
            },
        )
    (param,) = route.dependant.body_params
    try:
        body = param.field_info.annotation.model_validate(job.request)
    except ValidationError as exc:
        raise RequestValidationError(
            [{**e, "loc": ("body", "request", *e["loc"])} for e in exc.errors()]
        ) from exc
    try:
        accepted = _store(request).submit(
            job.endpoint, partial(_run_route, route, param.name, body)
        )
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
