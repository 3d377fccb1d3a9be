"""Jobs and sweeps of one service instance: limits, records (service/jobs/store.py) and the Dask
engine (service/jobs/engine.py) behind the routes of service/rest/routes/jobs.py and sweeps.py.

Limits, checked before anything is recorded (HTTP 429, or 422 for a sweep that cannot fit):
``max_pending_jobs`` queued or running single jobs in the store and ``max_jobs_per_client`` of
them for one client (its API key, else its address), ``max_sweeps_per_client`` unfinished
sweeps, ``max_sweep_points`` points per sweep and ``max_job_store_bytes`` of stored results.
Records expire after ``job_ttl_s``; past ``max_stored_jobs`` rows the oldest finished jobs go.
"""

from __future__ import annotations

import json
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any

from zeromode.service.jobs.engine import JOB_PRIORITY, SWEEP_PRIORITY, Engine
from zeromode.service.jobs.store import Store, Submission
from zeromode.service.jobs.sweeps import Point
from zeromode.service.wire.settings import Settings


class JobRejected(Exception):
    """The work cannot be accepted now (HTTP 429): too many jobs or sweeps, or a full store."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code, self.message = code, message


_OPEN_LOCK = threading.Lock()


def jobs_of_app(state) -> Jobs:
    """The app's Jobs (``state.jobs``), opened on first use; raises what opening the store raises."""
    with _OPEN_LOCK:
        if state.jobs is None:
            state.jobs = Jobs(state.settings)
        return state.jobs


class Jobs:
    """The store, opened at once, and the engine, started on first use (an app that never runs
    a job starts no cluster) or at startup when the store holds unfinished work to adopt."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self.store = Store(settings.database_url)
        self.engine = Engine(settings, self.store)
        self._lock = threading.Lock()

    def close(self) -> None:
        self.engine.close()
        self.store.close()

    def has_orphans(self) -> bool:
        """Unfinished work in the store that some instance may have to adopt."""
        return self.store.unfinished() > 0

    def _room(self) -> None:
        s = self.settings
        if (used := self.store.stored_bytes()) >= s.max_job_store_bytes:
            raise JobRejected(
                "job_store_full",
                f"stored results use {used} bytes of the {s.max_job_store_bytes}-byte quota; fetch "
                "or let expire older results.",
            )

    def submit_job(self, endpoint: str, request: dict[str, Any], client: str) -> dict[str, Any]:
        """Record a validated request as a queued job of ``client`` and send it to the cluster."""
        s = self.settings
        with self._lock:
            if (active := self.store.active_jobs()) >= s.max_pending_jobs:
                raise JobRejected(
                    "too_many_jobs",
                    f"{active} jobs are queued or running (the limit is {s.max_pending_jobs}); wait for "
                    "one to finish, or submit a sweep.",
                )
            if (mine := self.store.active_jobs(client)) >= s.max_jobs_per_client:
                raise JobRejected(
                    "too_many_jobs_for_client",
                    f"you already have {mine} queued or running jobs (the limit per client is "
                    f"{s.max_jobs_per_client}); wait for one to finish.",
                )
            self._room()
            self.engine.start()
            record = _record(uuid.uuid4().hex, endpoint, request, client, self.engine.instance)
            self.store.add_job(record)
        self.engine.submit([Submission(record["id"], endpoint, request)], JOB_PRIORITY)
        return record

    def submit_sweep(self, endpoint: str, spec: dict[str, Any], sweep_points: list[Point],
                     client: str, verdict: Callable[[], None] | None = None) -> dict[str, Any]:
        """Record a sweep and its validated points as queued, and send them to the cluster.
        ``verdict``: the wait for a validation still running on the workers, called once the
        records are built (while the workers check, this process builds them) and before
        anything is stored; it raises SweepRefused for a bad point."""
        s = self.settings
        sweep_id, now = uuid.uuid4().hex, time.time()
        records = [
            {**_record(uuid.uuid4().hex, endpoint, p.request, client, self.engine.instance, now),
             "sweep_id": sweep_id, "point": p.index, "params": json.dumps(p.params)}
            for p in sweep_points
        ]
        sweep = {"id": sweep_id, "endpoint": endpoint, "spec": json.dumps(spec), "client": client,
                 "total": len(records), "finished_count": 0, "cancelled": False, "created": now}
        if verdict is not None:
            verdict()
        with self._lock:
            if (mine := self.store.active_sweeps(client)) >= s.max_sweeps_per_client:
                raise JobRejected(
                    "too_many_sweeps_for_client",
                    f"you already have {mine} unfinished sweeps (the limit per client is "
                    f"{s.max_sweeps_per_client}); wait for one to finish or cancel it.",
                )
            self._room()
            self.engine.start()
            self.store.add_sweep(sweep, records)
        self.engine.submit(
            [Submission(r["id"], endpoint, p.request, sweep_id) for r, p in zip(records, sweep_points, strict=True)],
            SWEEP_PRIORITY,
            prechecked=True,  # every point passed the endpoint's checks before the sweep was accepted
        )
        return sweep

    def cancel_job(self, job_id: str) -> bool:
        """Cancel the job if it has not finished: a queued one is dropped, one running on this
        instance's engine stopped (its worker restarted); whether it was cancelled."""
        cancelled = self.store.cancel_queued([job_id], time.time())
        if cancelled and self.engine.started:
            self.engine.cancel(cancelled)
        return bool(cancelled) or (self.engine.started and self.engine.stop_job(
            job_id, "cancelled", {"code": "cancelled", "message": "cancelled while it ran; its worker was stopped."}))

    def cancel_sweep(self, sweep_id: str) -> int:
        """Cancel the sweep's points that have not started; how many."""
        cancelled = self.store.cancel_sweep(sweep_id, time.time())
        if cancelled and self.engine.started:
            self.engine.cancel(cancelled)
        return len(cancelled)


def _record(job_id: str, endpoint: str, request: dict[str, Any], client: str, owner: str,
            now: float | None = None) -> dict[str, Any]:
    return {
        "id": job_id, "sweep_id": None, "point": None, "params": None, "endpoint": endpoint,
        "request": json.dumps(request), "client": client, "status": "queued", "progress": 0.0,
        "message": "queued", "result": None, "error": None, "bytes": 0,
        "created": time.time() if now is None else now, "started": None, "finished": None,
        "attempts": 1, "owner": owner, "seq": None,
    }
