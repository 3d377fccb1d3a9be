"""Long-running jobs: a request to an endpoint, run in a background thread under a longer budget.

Each uvicorn worker is its own process, so job state lives in a directory the workers share
(``Settings.job_dir``): one small JSON status file per job, ``<id>.json``, and the answer of a
finished job in ``<id>.result.json``. Every write goes to a temporary file first and is moved
into place with ``os.replace``, so a reader in another worker sees the old state or the new,
never half a file.

The worker that accepted a job runs it on one of its ``job_threads`` daemon threads and keeps
its state in memory while it is active; a heartbeat thread rewrites the status files of its
active jobs every few seconds. A queued or running job whose file has not been touched for
``LOST_AFTER_S`` belongs to a worker that stopped: readers report it as failed (``job_lost``).
Limits: ``max_pending_jobs`` active jobs per worker and ``max_jobs_per_client`` of them for one
client (its API key, else its address), ``max_stored_jobs`` files (the oldest finished ones go
first), ``job_ttl_s`` before a job is forgotten, ``max_job_result_bytes`` per result and
``max_job_store_bytes`` for the whole directory (a result that does not fit fails its job with a
code instead of filling the disk).
"""

from __future__ import annotations

import json
import logging
import os
import queue
import re
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fastapi import HTTPException

from zeromode.service.settings import Settings, settings_scope
from zeromode.solver.budget import time_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.progress import progress_scope

log = logging.getLogger("zeromode")

HEARTBEAT_S = 2.0
LOST_AFTER_S = 60.0
# Progress reports closer together than this are kept in memory and written by the heartbeat.
MIN_WRITE_INTERVAL_S = 0.2
ACTIVE = ("queued", "running")
_ID = re.compile(r"[0-9a-f]{32}")


class JobRejected(Exception):
    """The job cannot be accepted now (too many active jobs, of all or of one client, or a full
    store: HTTP 429), or its result cannot be stored (the job fails with this code)."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code, self.message = code, message


class JobFailed(Exception):
    """The endpoint answered with an error body; ``detail`` is its {"code", "message", ...}."""

    def __init__(self, detail: dict[str, Any]):
        super().__init__(detail.get("message", ""))
        self.detail = detail


def _now_iso() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


@dataclass
class _Active:
    """A job this worker is running or about to run; ``state`` is what its status file says."""

    state: dict[str, Any]
    run: Callable[[], dict[str, Any]]
    client: str = ""
    lock: threading.Lock = field(default_factory=threading.Lock)
    written: float = 0.0
    dirty: bool = False


class JobStore:
    """The shared job directory plus this worker's job threads."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self.dir = Path(settings.job_dir)
        self.dir.mkdir(parents=True, exist_ok=True, mode=0o700)
        self._active: dict[str, _Active] = {}
        self._lock = threading.Lock()
        self._queue: queue.Queue[_Active] = queue.Queue()
        # Daemon threads: a shutting-down worker must not wait for a 15-minute job; the job
        # is then reported lost, as it would be if the worker were killed.
        for i in range(max(settings.job_threads, 1)):
            threading.Thread(target=self._work, name=f"zeromode-job-{i}", daemon=True).start()
        threading.Thread(target=self._heartbeat, name="zeromode-job-heartbeat", daemon=True).start()

    # --- files -------------------------------------------------------------------------------

    def _status_path(self, job_id: str) -> Path:
        return self.dir / f"{job_id}.json"

    def _result_path(self, job_id: str) -> Path:
        return self.dir / f"{job_id}.result.json"

    def _write(self, path: Path, doc: dict[str, Any] | bytes) -> None:
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
        with open(tmp, "wb") as fh:
            fh.write(doc if isinstance(doc, bytes) else _encoded(doc))
        os.replace(tmp, path)

    def _used_bytes(self) -> int:
        """Bytes the job directory holds now (status and result files)."""
        total = 0
        for path in self.dir.iterdir():
            try:
                total += path.stat().st_size
            except FileNotFoundError:  # removed by another worker meanwhile
                continue
        return total

    def _storable(self, result: dict[str, Any]) -> bytes:
        """The result as stored, or JobRejected when it is over its own or the store's limit."""
        data = _encoded(result)
        limit = self.settings.max_job_result_bytes
        if len(data) > limit:
            raise JobRejected(
                "result_too_large",
                f"the result has {len(data)} bytes; a stored job result may have {limit} "
                "(ask for less, e.g. options.bases false, or run the request directly).",
            )
        quota = self.settings.max_job_store_bytes
        if self._used_bytes() + len(data) > quota:
            raise JobRejected(
                "job_store_full",
                f"the job store would pass its {quota}-byte quota; fetch or let expire older results.",
            )
        return data

    def _read(self, path: Path) -> dict[str, Any] | None:
        try:
            with open(path) as fh:
                doc = json.load(fh)
        except (FileNotFoundError, json.JSONDecodeError):
            return None
        return doc if isinstance(doc, dict) else None

    def _save(self, job: _Active, *, force: bool = True) -> None:
        """Write the job's status file (called with ``job.lock`` held)."""
        now = time.monotonic()
        if not force and now - job.written < MIN_WRITE_INTERVAL_S:
            job.dirty = True
            return
        job.state["updated"] = time.time()
        self._write(self._status_path(job.state["id"]), job.state)
        job.written, job.dirty = now, False

    def _update(self, job: _Active, force: bool = True, **changes: Any) -> None:
        with job.lock:
            job.state.update(changes)
            self._save(job, force=force)

    # --- accepting and reading jobs ------------------------------------------------------------

    def submit(self, endpoint: str, run: Callable[[], dict[str, Any]], client: str = "") -> dict[str, Any]:
        """Queue ``run`` (the endpoint's work) as a new job of ``client``; its first status record."""
        with self._lock:
            if len(self._active) >= self.settings.max_pending_jobs:
                raise JobRejected(
                    "too_many_jobs",
                    f"this worker already has {len(self._active)} queued or running jobs (the limit "
                    f"is {self.settings.max_pending_jobs}); wait for one to finish.",
                )
            # Fair share: one client cannot hold every slot of the worker.
            mine = sum(job.client == client for job in self._active.values())
            if mine >= self.settings.max_jobs_per_client:
                raise JobRejected(
                    "too_many_jobs_for_client",
                    f"you already have {mine} queued or running jobs here (the limit per client is "
                    f"{self.settings.max_jobs_per_client}); wait for one to finish.",
                )
            if self._used_bytes() >= self.settings.max_job_store_bytes:
                raise JobRejected(
                    "job_store_full",
                    f"the job store holds its {self.settings.max_job_store_bytes}-byte quota; try again later.",
                )
            self._make_room()
            job_id = uuid.uuid4().hex
            state = {
                "id": job_id,
                "endpoint": endpoint,
                "status": "queued",
                "progress": 0.0,
                "message": "waiting for a job thread",
                "created": _now_iso(),
                "started": None,
                "finished": None,
                "worker": os.getpid(),
            }
            job = _Active(state, run, client)
            self._active[job_id] = job
        self._update(job)
        self._queue.put(job)
        return dict(state)

    def get(self, job_id: str) -> dict[str, Any] | None:
        """The job's status (with ``result`` when done), or None for an unknown or expired id."""
        if not _ID.fullmatch(job_id):
            return None
        state = self._read(self._status_path(job_id))
        if state is None or "status" not in state:
            return None
        if state["status"] in ACTIVE and time.time() - state.get("updated", 0.0) > LOST_AFTER_S:
            state.update(
                status="failed",
                finished=_now_iso(),
                message="lost",
                error={
                    "code": "job_lost",
                    "message": "the worker running this job stopped before it finished; submit it again.",
                },
            )
            self._write(self._status_path(job_id), state)
        if state["status"] == "done":
            state["result"] = self._read(self._result_path(job_id))
        return state

    def _make_room(self) -> None:
        """Forget jobs older than the TTL, then the oldest finished ones past max_stored_jobs."""
        now = time.time()
        for tmp in self.dir.glob(".*.tmp"):  # left by a worker killed in the middle of a write
            try:
                if now - tmp.stat().st_mtime > self.settings.job_ttl_s:
                    tmp.unlink()
            except FileNotFoundError:
                continue
        files = []
        for path in self.dir.glob("*.json"):
            job_id = path.name.split(".", 1)[0]
            if not _ID.fullmatch(job_id) or path.name != f"{job_id}.json" or job_id in self._active:
                continue
            try:
                mtime = path.stat().st_mtime
            except FileNotFoundError:  # another worker removed it meanwhile
                continue
            if now - mtime > self.settings.job_ttl_s:
                self._forget(job_id)
            else:
                files.append((mtime, job_id))
        excess = len(files) + len(self._active) + 1 - self.settings.max_stored_jobs
        for _, job_id in sorted(files):
            if excess <= 0:
                break
            state = self._read(self._status_path(job_id))
            if state is None or state["status"] not in ACTIVE:
                self._forget(job_id)
                excess -= 1
        if excess > 0:
            raise JobRejected(
                "too_many_jobs",
                f"{self.settings.max_stored_jobs} jobs are stored and none has finished; wait for "
                "one to finish.",
            )

    def _forget(self, job_id: str) -> None:
        for path in (self._result_path(job_id), self._status_path(job_id)):
            path.unlink(missing_ok=True)

    # --- running -------------------------------------------------------------------------------

    def _work(self) -> None:
        while True:
            job = self._queue.get()
            try:
                self._run(job)
            except Exception:  # e.g. the job directory vanished: keep the thread alive
                log.exception("job %s could not be recorded", job.state["id"])
            finally:
                with self._lock:
                    self._active.pop(job.state["id"], None)

    def _run(self, job: _Active) -> None:
        self._update(job, status="running", started=_now_iso(), message="running")

        def progress(fraction: float, message: str) -> None:
            self._update(job, force=False, progress=fraction, message=message)

        try:
            # A fresh thread starts from an empty context: the request's budget does not apply,
            # and the app's settings are made current again.
            with (
                settings_scope(self.settings),
                time_budget(self.settings.job_time_budget_s),
                progress_scope(progress),
            ):
                result = job.run()
            self._write(self._result_path(job.state["id"]), self._storable(result))
        except Exception as exc:  # noqa: BLE001 — every failure is the job's answer
            self._update(
                job, status="failed", finished=_now_iso(), message="failed", error=_error(exc)
            )
            return
        self._update(job, status="done", progress=1.0, finished=_now_iso(), message="done")

    def _heartbeat(self) -> None:
        """Keep the status files of this worker's active jobs fresh (and flush throttled reports)."""
        while True:
            time.sleep(HEARTBEAT_S / 4)
            with self._lock:
                jobs = list(self._active.values())
            now = time.monotonic()
            for job in jobs:
                with job.lock:
                    if job.dirty or now - job.written >= HEARTBEAT_S:
                        try:
                            self._save(job)
                        except OSError:
                            log.exception("cannot write the status of job %s", job.state["id"])


def _encoded(doc: dict[str, Any]) -> bytes:
    return json.dumps(doc, allow_nan=False, separators=(",", ":")).encode()


def _error(exc: Exception) -> dict[str, str]:
    """The {"code", "message"} a failed job reports: those the endpoint would have answered."""
    if isinstance(exc, DomainError | JobRejected):
        return {"code": exc.code, "message": exc.message}
    detail = exc.detail if isinstance(exc, JobFailed | HTTPException) else None
    if isinstance(detail, dict) and "code" in detail:
        return {"code": str(detail["code"]), "message": str(detail.get("message", ""))}
    log.error("job failed with an unexpected error", exc_info=exc)
    return {"code": "internal_error", "message": "an unexpected error occurred."}
