"""POST /v1/jobs, GET and DELETE /v1/jobs/{id} — any long endpoint as a job on the Dask
engine, polled for progress; records in the store (service/jobs/manager.py)."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, Field

from zeromode.service.jobs.cluster import EngineUnavailable
from zeromode.service.jobs.manager import JobRejected, Jobs, jobs_of_app
from zeromode.service.jobs.tasks import RequestRefused, validated
from zeromode.service.wire.errors import error_body
from zeromode.service.wire.responses import job_body, job_json
from zeromode.service.wire.schemas.common import ERROR_RESPONSES, ErrorResponse
from zeromode.service.wire.schemas.jobs import JobAccepted, JobRequest, JobStatus

router = APIRouter(prefix="/v1", tags=["jobs"])
UNAVAILABLE = {503: {"model": ErrorResponse, "description": "The job store or the Dask cluster cannot be used."}}
TOO_MANY = {429: {"model": ErrorResponse, "description": "Too many jobs or sweeps."}}
UNKNOWN = {404: {"model": ErrorResponse, "description": "Unknown or expired id."}}


def jobs_of(request: Request) -> Jobs:
    """The app's jobs (store and engine), opened on first use."""
    try:
        return jobs_of_app(request.app.state)
    except Exception as exc:  # the operator's ZEROMODE_DATABASE_URL, not the request, is wrong
        url = request.app.state.settings.database_url
        raise unavailable(f"the job store {url} cannot be used ({exc}).") from exc


def unavailable(message: str) -> HTTPException:
    return HTTPException(503, detail={"code": "jobs_unavailable", "message": message[:500]})


def client_of(request: Request) -> str:
    """Who submits, for the fair share of job slots: the API key, else the address."""
    key = request.headers.get("x-api-key")
    return f"key:{key}" if key else f"address:{request.client.host if request.client else ''}"


def refused(exc: RequestRefused, prefix: tuple[str, ...]) -> Exception:
    """The endpoint's own refusal of a job's request, as the 422 the endpoint would answer."""
    if exc.errors is not None:
        return RequestValidationError([{**e, "loc": ("body", *prefix, *e["loc"])} for e in exc.errors])
    return HTTPException(422, detail=exc.detail)


def unknown(kind: str, given: str) -> HTTPException:
    return HTTPException(
        404,
        detail={"code": f"unknown_{kind}", "message": f"there is no {kind} {given[:64]}; it never existed or has expired."},
    )


def accepted_or_refused(submit) -> Any:
    """Run a submission; its refusals as 429 or 503 bodies."""
    try:
        return submit()
    except JobRejected as exc:
        return JSONResponse(status_code=429, content=error_body(exc.code, exc.message))
    except EngineUnavailable as exc:
        raise unavailable(str(exc)) from exc


@router.post("/jobs", status_code=202, response_model=JobAccepted,
             responses={**ERROR_RESPONSES, **TOO_MANY, **UNAVAILABLE})
def submit_job(job: JobRequest, request: Request) -> JSONResponse:
    """Run a long request as a job: it is validated now exactly as its endpoint validates it
    (422 with the endpoint's own error body) and runs on the Dask engine under
    ZEROMODE_JOB_TIME_BUDGET_S (default 900 s). Poll GET /v1/jobs/{id}."""
    try:
        validated(job.endpoint, job.request)
    except RequestRefused as exc:
        raise refused(exc, ("request",)) from exc
    record = accepted_or_refused(lambda: jobs_of(request).submit_job(job.endpoint, job.request, client_of(request)))
    if isinstance(record, JSONResponse):
        return record
    return JSONResponse(
        status_code=202,
        content={"id": record["id"], "status": "queued", "endpoint": job.endpoint},
        headers={"location": f"/v1/jobs/{record['id']}"},
    )


@router.get("/jobs/{job_id}", response_model=JobStatus, responses={**UNKNOWN, **UNAVAILABLE})
def get_job(job_id: str, request: Request) -> Response:
    """Status, progress (0..1) and message of a job; its result when done, its error when not.
    Any replica answers: records live in the store (ZEROMODE_DATABASE_URL)."""
    record = jobs_of(request).store.job(job_id, raw_result=True)
    if record is None or record["sweep_id"] is not None:
        raise unknown("job", job_id)
    return Response(job_json(record), media_type="application/json")


@router.delete("/jobs/{job_id}", response_model=JobStatus, responses={**UNKNOWN, **UNAVAILABLE})
def cancel_job(job_id: str, request: Request) -> dict:
    """Cancel a job that has not finished (a running one is stopped); its status after."""
    jobs = jobs_of(request)
    record = jobs.store.job(job_id, with_result=False)
    if record is None or record["sweep_id"] is not None:  # a sweep's points are the sweep's
        raise unknown("job", job_id)
    jobs.cancel_job(job_id)
    return job_body(jobs.store.job(job_id))


class EngineStatus(BaseModel):
    status: Literal["running", "idle"] = Field(description="'idle' until the engine has started.")
    workers: int = Field(description="Dask workers of its cluster.")
    processing: int = Field(description="Tasks (jobs, sweep chunks, heavy requests) running on them now.")


@router.get("/engine", response_model=EngineStatus, responses=UNAVAILABLE)
def engine_status(request: Request) -> dict:
    """The job engine's cluster: its workers and what they are running now."""
    jobs = request.app.state.jobs
    if jobs is None or not jobs.engine.started:
        return {"status": "idle", "workers": 0, "processing": 0}
    return {"status": "running", **jobs.engine.load()}
