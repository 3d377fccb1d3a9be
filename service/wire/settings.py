"""Service settings: one pydantic-settings object, read from ZEROMODE_* environment variables
and injected into ``create_app``; every limit is enforced with a 4xx naming it.

Nothing reads settings at import time. The app built by ``create_app(settings)`` makes them the
*current* settings (a context variable, ``settings_scope``) of each request it serves (set by its
pure-ASGI middleware), of each job it runs and of the OpenAPI document it describes itself by;
request validation reads the limits from there (``current_settings``, service/wire/schemas/limits.py).
A context variable rather than a FastAPI dependency: pydantic checks the limits while it parses a
body, before any dependency runs, and the same models are validated outside FastAPI too (job
requests, documents given to ``zeromode plot``), where the environment's settings apply.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from functools import cache
from typing import Annotated

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict


class Settings(BaseSettings):
    """Limits and deployment options (docs/reference/limits.md, "Errors and limits"). Environment: ZEROMODE_<NAME>."""

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
    database_url: str = Field(
        default_factory=lambda: default_database_url(),
        description="Job and sweep records (SQLAlchemy URL): a SQLite file of this user by default; "
        "postgresql+psycopg://user@host/db for several replicas.",
    )
    dask_scheduler: str | None = Field(
        default=None,
        description="Address of an existing Dask scheduler (tcp://host:8786) that runs jobs and "
        "sweeps; unset: an embedded LocalCluster of worker processes.",
    )
    dask_workers: int = Field(
        default=0, ge=0, description="Worker processes of the embedded cluster (0: one per core)."
    )
    dask_worker_memory_bytes: int = Field(
        default=0, ge=0, description="Memory of one embedded worker (0: the machine's divided by the workers)."
    )
    offload: bool = Field(
        default=True,
        description="Heavy requests (service/rest/offload.py) run on the job engine's worker processes: the "
        "time budget holds inside long calls and work stops when the client leaves.",
    )
    job_max_attempts: int = Field(
        default=2, ge=1, description="Runs of a job whose service stopped before it finished; then interrupted."
    )
    job_lease_s: float = Field(
        default=20.0, gt=0,
        description="A service silent this long is taken for dead: its unfinished jobs are adopted.",
    )
    max_pending_jobs: int = Field(default=8, ge=0, description="Queued or running single jobs.")
    max_stored_jobs: int = Field(default=100_000, ge=0, description="Job records kept (sweep points included).")
    max_sweep_points: int = Field(default=10_000, gt=0, description="Points of one sweep.")
    max_sweeps_per_client: int = Field(
        default=2, ge=1, description="Unfinished sweeps of one client (API key or address)."
    )
    max_jobs_per_client: int = Field(
        default=4, ge=1, description="Queued or running single jobs of one client (API key or address)."
    )
    max_job_result_bytes: int = Field(
        default=20_000_000, gt=0, description="Largest stored job result; a larger one fails the job."
    )
    max_job_store_bytes: int = Field(
        default=2_000_000_000, gt=0, description="Bytes of stored job results in all."
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


# h11 buffers up to this many times max_header_bytes per connection (128 KiB by default: 64 MiB
# at the 512-connection cap), so an oversized header block is answered with a code, not bare.
HEADER_PARSER_FACTOR = 8


def server_options(settings: Settings) -> dict:
    """uvicorn's options for these settings: the h11 parser (it bounds the header bytes; the
    httptools parser does not), the connection cap and the keep-alive timeout. h11's bound is
    HEADER_PARSER_FACTOR × ``max_header_bytes``: a block between the two reaches the app, which
    answers 431 ``headers_too_large`` with its JSON body; only a larger one gets h11's bare 400."""
    return {
        "http": "h11",
        "h11_max_incomplete_event_size": HEADER_PARSER_FACTOR * settings.max_header_bytes,
        "limit_concurrency": settings.max_connections,
        "timeout_keep_alive": settings.keep_alive_s,
    }


def current_settings() -> Settings:
    """The settings of the request being served; outside any request (the library, a script
    validating a document), the environment's, read once."""
    settings = _CURRENT.get()
    return _environment_settings() if settings is None else settings


def default_database_url() -> str:
    """A SQLite file of this user: under $XDG_STATE_HOME (default ~/.local/state), where it
    survives a reboot, and never shared with another user's service."""
    state = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return "sqlite:///" + os.path.join(state, "zeromode", "jobs.sqlite3")


@cache
def _environment_settings() -> Settings:
    return Settings()
