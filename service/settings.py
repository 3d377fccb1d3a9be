"""Service settings: one pydantic-settings object, read from ZEROMODE_* environment variables
and injected into ``create_app``; every limit is enforced with a 4xx naming it.

Nothing reads settings at import time. The app built by ``create_app(settings)`` makes them the
*current* settings (a context variable, ``settings_scope``) of each request it serves (set by its
pure-ASGI middleware), of each job it runs and of the OpenAPI document it describes itself by;
request validation reads the limits from there (``current_settings``, service/schemas/limits.py).
A context variable rather than a FastAPI dependency: pydantic checks the limits while it parses a
body, before any dependency runs, and the same models are validated outside FastAPI too (job
requests, documents given to ``zeromode plot``), where the environment's settings apply.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from functools import cache
from typing import Annotated

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict


class Settings(BaseSettings):
    """Limits and deployment options (README, "Errors and limits"). Environment: ZEROMODE_<NAME>."""

    # An empty variable (ZEROMODE_JOB_DIR=) means "the default", as an unset one does.
    model_config = SettingsConfigDict(
        env_prefix="ZEROMODE_", env_ignore_empty=True, frozen=True, extra="forbid"
    )

    max_body_bytes: int = Field(default=20_000_000, gt=0, description="Largest request body.")
    max_nodes: int = Field(default=100_000, gt=0, description="Nodes of a frame.")
    max_edges: int = Field(default=400_000, gt=0, description="Bars of a frame.")
    max_specified: int = Field(default=64, gt=0, description="Specified nodes of a design.")
    max_motions: int = Field(default=4, gt=0, description="Target motions of a design.")
    max_samples: int = Field(default=1000, ge=0, description="Samples of a solution space.")
    max_basis_numbers: int = Field(
        default=250_000,
        ge=0,
        description="Numbers of mode and stress bases /v1/analyze returns (about 5 MB of JSON); "
        "larger bases are left out with bases_included false, the counts stay exact.",
    )
    time_budget_s: float = Field(default=60.0, gt=0, description="Wall time of one request.")
    job_time_budget_s: float = Field(default=900.0, ge=0, description="Wall time of one job.")
    job_dir: str = Field(
        default_factory=lambda: os.path.join(tempfile.gettempdir(), "zeromode-jobs"),
        description="Directory of the job store (shared by the workers).",
    )
    job_threads: int = Field(default=1, ge=1)
    max_pending_jobs: int = Field(default=8, ge=0)
    max_stored_jobs: int = Field(default=1000, ge=0)
    max_jobs_per_client: int = Field(
        default=4, ge=1, description="Queued or running jobs of one client (API key or address) per worker."
    )
    max_job_result_bytes: int = Field(
        default=20_000_000, gt=0, description="Largest stored job result; a larger one fails the job."
    )
    max_job_store_bytes: int = Field(
        default=2_000_000_000, gt=0, description="Disk the job directory may use in all."
    )
    job_ttl_s: float = Field(default=86_400.0, ge=0)
    max_connections: int = Field(
        default=512, gt=0, description="Open connections and requests per process; more get 503."
    )
    max_header_bytes: int = Field(default=16_384, gt=0, description="Request line and headers.")
    keep_alive_s: float = Field(default=5.0, gt=0, description="Idle time of a kept-alive connection.")
    api_key: str | None = Field(default=None, description="Required X-API-Key on /v1/ when set.")
    cors_origins: Annotated[tuple[str, ...], NoDecode] = Field(
        default=(), description="Allowed CORS origins (comma-separated in the environment)."
    )

    @field_validator("api_key", mode="before")
    @classmethod
    def _empty_key_is_none(cls, value):
        return value or None

    @field_validator("cors_origins", mode="before")
    @classmethod
    def _comma_separated(cls, value):
        if isinstance(value, str):
            return tuple(origin.strip() for origin in value.split(",") if origin.strip())
        return value


_CURRENT: ContextVar[Settings | None] = ContextVar("zeromode_settings", default=None)


@contextmanager
def settings_scope(settings: Settings) -> Iterator[None]:
    """Within this block (one request of an app), ``current_settings()`` is ``settings``."""
    token = _CURRENT.set(settings)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def server_options(settings: Settings) -> dict:
    """uvicorn's options for these settings: the h11 parser (it bounds the header bytes; the
    httptools parser does not), the connection cap and the keep-alive timeout."""
    return {
        "http": "h11",
        "h11_max_incomplete_event_size": settings.max_header_bytes,
        "limit_concurrency": settings.max_connections,
        "timeout_keep_alive": settings.keep_alive_s,
    }


def current_settings() -> Settings:
    """The settings of the request being served; outside any request (the library, a script
    validating a document), the environment's, read once."""
    settings = _CURRENT.get()
    return _environment_settings() if settings is None else settings


@cache
def _environment_settings() -> Settings:
    return Settings()
