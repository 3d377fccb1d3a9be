"""Service settings and size limits, read once from the environment (ZEROMODE_*)."""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field


def _int(name: str, default: int) -> int:
    return int(os.environ.get(name, default))


def _float(name: str, default: float) -> float:
    return float(os.environ.get(name, default))


@dataclass(frozen=True)
class Settings:
    """Limits are documented in the README; every one is enforced with a 4xx naming it."""

    max_body_bytes: int = field(default_factory=lambda: _int("ZEROMODE_MAX_BODY_BYTES", 20_000_000))
    max_nodes: int = field(default_factory=lambda: _int("ZEROMODE_MAX_NODES", 100_000))
    max_edges: int = field(default_factory=lambda: _int("ZEROMODE_MAX_EDGES", 400_000))
    max_specified: int = field(default_factory=lambda: _int("ZEROMODE_MAX_SPECIFIED", 64))
    max_motions: int = field(default_factory=lambda: _int("ZEROMODE_MAX_MOTIONS", 4))
    max_samples: int = field(default_factory=lambda: _int("ZEROMODE_MAX_SAMPLES", 1000))
    time_budget_s: float = field(default_factory=lambda: _float("ZEROMODE_TIME_BUDGET_S", 60.0))
    job_time_budget_s: float = field(default_factory=lambda: _float("ZEROMODE_JOB_TIME_BUDGET_S", 900.0))
    job_dir: str = field(
        default_factory=lambda: os.environ.get("ZEROMODE_JOB_DIR")
        or os.path.join(tempfile.gettempdir(), "zeromode-jobs")
    )
    job_threads: int = field(default_factory=lambda: _int("ZEROMODE_JOB_THREADS", 1))
    max_pending_jobs: int = field(default_factory=lambda: _int("ZEROMODE_MAX_PENDING_JOBS", 8))
    max_stored_jobs: int = field(default_factory=lambda: _int("ZEROMODE_MAX_STORED_JOBS", 1000))
    job_ttl_s: float = field(default_factory=lambda: _float("ZEROMODE_JOB_TTL_S", 86_400.0))
    api_key: str | None = field(default_factory=lambda: os.environ.get("ZEROMODE_API_KEY") or None)
    cors_origins: tuple[str, ...] = field(
        default_factory=lambda: tuple(
            o.strip() for o in os.environ.get("ZEROMODE_CORS_ORIGINS", "").split(",") if o.strip()
        )
    )


SETTINGS = Settings()
