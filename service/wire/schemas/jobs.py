"""POST /v1/jobs, GET and DELETE /v1/jobs/{id}; POST /v1/sweeps, GET and DELETE /v1/sweeps/{id}."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

from zeromode.service.wire.schemas.common import ErrorDetail, RequestModel

JobEndpoint = Literal[
    "/v1/design/auxetic",
    "/v1/design",
    "/v1/design/allosteric",
    "/v1/design/multistable",
    "/v1/design/sequential",
    "/v1/map",
    "/v1/refine",
    "/v1/motion",
    "/v1/certify",
    "/v1/analyze",
]


# queued → running → done | failed; cancelled (DELETE, queued or running); interrupted when the
# services running it stopped more often than ZEROMODE_JOB_MAX_ATTEMPTS allows.
JobState = Literal["queued", "running", "done", "failed", "cancelled", "interrupted"]


class JobRequest(RequestModel):
    endpoint: JobEndpoint = Field(description="The endpoint to run (POST) as a job.")
    request: dict[str, Any] = Field(
        description="That endpoint's request body; validated against its model when submitted."
    )


class JobAccepted(BaseModel):
    id: str = Field(description="The job id, for GET /v1/jobs/{id}.")
    status: Literal["queued"]
    endpoint: JobEndpoint


class JobStatus(BaseModel):
    id: str
    endpoint: JobEndpoint
    status: JobState
    progress: float = Field(ge=0, le=1, description="Fraction of the work done (1 when done).")
    message: str = Field(description="What the job is doing, e.g. 'placed 2 unspecified nodes'.")
    result: dict[str, Any] | None = Field(
        default=None,
        description="When done: the endpoint's answer, exactly as it would have sent it.",
    )
    error: ErrorDetail | None = Field(
        default=None,
        description="When failed: the code and message the endpoint would have answered.",
    )
    created: str = Field(description="When the job was accepted (ISO 8601, UTC).")
    started: str | None = Field(
        default=None, description="When it started running (ISO 8601, UTC)."
    )
    finished: str | None = Field(default=None, description="When it finished (ISO 8601, UTC).")
    attempts: int = Field(default=1, description="Runs started (more than 1 after a service restart).")


class SweepRequest(RequestModel):
    endpoint: JobEndpoint = Field(description="The endpoint every point runs (POST).")
    template: dict[str, Any] = Field(
        default_factory=dict, description="The request body every point starts from."
    )
    grid: dict[str, list[Any]] | None = Field(
        default=None,
        description="Dotted paths of the template (e.g. 'options.seed') and the values each takes; "
        "the points are every combination, the last key varying fastest.",
    )
    requests: list[dict[str, Any]] | None = Field(
        default=None, description="Instead of a grid: one point per request, merged over the template."
    )


class SweepAccepted(BaseModel):
    id: str = Field(description="The sweep id, for GET /v1/sweeps/{id}.")
    status: Literal["running"]
    endpoint: JobEndpoint
    total: int = Field(description="Points of the sweep, all validated.")


class SweepPoint(BaseModel):
    point: int = Field(description="Index of the point in the grid's order (or the request list's).")
    params: dict[str, Any] = Field(description="What defines the point: grid values or request fields.")
    status: JobState
    seq: int = Field(description="Order in which it finished (the cursor of ?after=).")
    result: dict[str, Any] | None = Field(default=None, description="When done: the endpoint's answer.")
    error: ErrorDetail | None = Field(default=None, description="When not done: why.")


class SweepStatus(BaseModel):
    id: str
    endpoint: JobEndpoint
    status: Literal["running", "done", "cancelled"]
    total: int
    done: int
    failed: int
    running: int
    queued: int
    cancelled: int
    interrupted: int
    progress: float = Field(ge=0, le=1, description="Fraction of the points finished.")
    created: str
    finished: str | None = None
    results: list[SweepPoint] = Field(
        description="Finished points after the cursor ?after= (at most ?limit=), in finishing order."
    )
    next: int = Field(description="The cursor for the next page: pass it as ?after=.")
