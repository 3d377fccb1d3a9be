"""POST /v1/sweeps, GET and DELETE /v1/sweeps/{id}, and the results of a sweep as NDJSON, CSV
or Parquet — a grid of requests to one endpoint, every point validated before any runs."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.responses import JSONResponse, Response, StreamingResponse

from zeromode.service.jobs import sweeps
from zeromode.service.rest.routes.jobs import (
    TOO_MANY,
    UNAVAILABLE,
    UNKNOWN,
    accepted_or_refused,
    client_of,
    jobs_of,
    unknown,
)
from zeromode.service.wire.extras import MissingExtra, require
from zeromode.service.wire.responses import sweep_body
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.jobs import SweepAccepted, SweepRequest, SweepStatus

router = APIRouter(prefix="/v1", tags=["sweeps"])
# Results of one GET: a page, so a poll of a 10 000-point sweep stays small.
PAGE_DEFAULT, PAGE_MAX = 100, 1000
# From this many points a running engine's workers validate a sweep (a round trip costs more
# than checking a few points here).
VALIDATE_ON_WORKERS_FROM = 64


@router.post("/sweeps", status_code=202, response_model=SweepAccepted,
             responses={**ERROR_RESPONSES, **TOO_MANY, **UNAVAILABLE})
def submit_sweep(spec: SweepRequest, request: Request) -> JSONResponse:
    """A request template and a parameter grid (or a list of requests): every point is
    validated as its endpoint would validate it, and a bad point is a 422 `invalid_point` naming
    it, before anything runs. Accepted points run as jobs on the Dask engine."""
    settings = request.app.state.settings
    try:
        points = sweeps.points(spec.template, spec.grid, spec.requests, settings.max_sweep_points)
        jobs = request.app.state.jobs
        if jobs is not None and jobs.engine.started and len(points) >= VALIDATE_ON_WORKERS_FROM:
            verdict = jobs.engine.validation(spec.endpoint, points)  # awaited once the points are recorded
        else:
            sweeps.validate_points(spec.endpoint, points)
            verdict = None
        record = accepted_or_refused(
            lambda: jobs_of(request).submit_sweep(spec.endpoint, spec.model_dump(mode="json"), points,
                                                  client_of(request), verdict)
        )
    except sweeps.SweepRefused as exc:
        raise HTTPException(422, detail=exc.detail) from exc
    if isinstance(record, JSONResponse):
        return record
    return JSONResponse(
        status_code=202,
        content={"id": record["id"], "status": "running", "endpoint": spec.endpoint, "total": record["total"]},
        headers={"location": f"/v1/sweeps/{record['id']}"},
    )


def _sweep(request: Request, sweep_id: str) -> dict:
    record = jobs_of(request).store.sweep(sweep_id)
    if record is None:
        raise unknown("sweep", sweep_id)
    return record


@router.get("/sweeps/{sweep_id}", response_model=SweepStatus, responses={**ERROR_RESPONSES, **UNKNOWN, **UNAVAILABLE})
def get_sweep(
    sweep_id: str,
    request: Request,
    after: int = Query(0, ge=0, le=2**63 - 1, description="Cursor: results finished after this one (the last `next`)."),
    limit: int = Query(PAGE_DEFAULT, ge=0, le=PAGE_MAX, description="Results in this answer at most."),
) -> dict:
    """Progress (done / failed / running / queued / total) and the results finished since the
    cursor, in finishing order; page through them with `after` = the previous answer's `next`."""
    record = _sweep(request, sweep_id)
    finished = jobs_of(request).store.sweep_points(sweep_id, after=after, limit=limit) if limit else []
    return sweep_body(record, finished, after)


@router.delete("/sweeps/{sweep_id}", response_model=SweepStatus, responses={**UNKNOWN, **UNAVAILABLE})
def cancel_sweep(sweep_id: str, request: Request) -> dict:
    """Cancel the points that have not run (running ones finish; finished ones stay)."""
    _sweep(request, sweep_id)
    jobs_of(request).cancel_sweep(sweep_id)
    return sweep_body(_sweep(request, sweep_id), [], 0)


@router.get("/sweeps/{sweep_id}/results.ndjson", responses={**UNKNOWN, 200: {"content": {"application/x-ndjson": {}}}})
def sweep_ndjson(sweep_id: str, request: Request) -> StreamingResponse:
    """Every finished point, one JSON object per line ({point, params, status, result | error}),
    streamed in finishing order."""
    _sweep(request, sweep_id)
    lines = (sweeps.ndjson_line(p) for p in jobs_of(request).store.iter_sweep_points(sweep_id))
    return StreamingResponse(lines, media_type="application/x-ndjson")


def _rows(request: Request, sweep_id: str) -> list[dict]:
    _sweep(request, sweep_id)
    points = jobs_of(request).store.iter_sweep_points(sweep_id)
    return sorted((sweeps.row(p) for p in points), key=lambda r: r["point"])


@router.get("/sweeps/{sweep_id}/results.csv", responses={**UNKNOWN, 200: {"content": {"text/csv": {}}}})
def sweep_csv(sweep_id: str, request: Request) -> Response:
    """The finished points as a table, in point order: parameters, status, error code and every
    scalar field of the answers (e.g. report.mode_residual)."""
    return Response(sweeps.csv_text(_rows(request, sweep_id)), media_type="text/csv")


@router.get("/sweeps/{sweep_id}/results.parquet",
            responses={**UNKNOWN, 501: {"description": "pyarrow is not installed on the server."},
                       200: {"content": {"application/vnd.apache.parquet": {}}}})
def sweep_parquet(sweep_id: str, request: Request) -> Response:
    """The same table as Parquet (where the server has pyarrow installed: else 501
    `parquet_unavailable`, before any row is read)."""
    _sweep(request, sweep_id)
    try:
        require(*sweeps.PARQUET)
    except MissingExtra as exc:
        raise HTTPException(501, detail={
            "code": "parquet_unavailable",
            "message": f"pyarrow is not installed on the server ({exc.install}); use results.csv.",
        }) from exc
    return Response(sweeps.parquet_bytes(_rows(request, sweep_id)), media_type="application/vnd.apache.parquet")
