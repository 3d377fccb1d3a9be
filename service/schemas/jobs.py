"""POST /v1/jobs and GET /v1/jobs/{id}."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

from zeromode.service.schemas.common import ErrorDetail, RequestModel

JobEndpoint = Literal[
    "/v1/design/auxetic",
    "/v1/design",
    "/v1/design/allosteric",
    "/v1/refine",
    "/v1/motion",
    "/v1/certify",
    "/v1/analyze",
]


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
    status: Literal["queued", "running", "done", "failed"]
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
