"""The job engine: jobs and sweep points run as Dask tasks; their records live in the store.

One engine per service instance. It connects to the Dask cluster named by
``ZEROMODE_DASK_SCHEDULER`` (one started by hand, by dask-jobqueue or by the Dask Kubernetes
operator), or starts an embedded ``LocalCluster`` of worker processes sized to the machine.
Tasks run ``service.jobs.tasks.execute_chunk``; their progress arrives as worker events, their end through
their futures; one recorder thread writes both to the store in batches, so the service's own
thread answers requests (``/health`` included) while the workers compute.

What is not lost: a finished result is in the store before anything reports it. A worker that
dies mid-task has its task re-run on another worker by Dask's scheduler (up to Dask's
``allowed-failures``; after that the job fails with ``worker_lost``). A service that dies leaves
its queued and running jobs to its lease (service/jobs/store.py): the next live instance, or this
one restarted, adopts them once its lease (``ZEROMODE_JOB_LEASE_S``) has run out, and runs them again while they have attempts
left (``ZEROMODE_JOB_MAX_ATTEMPTS``), else marks them ``interrupted``.
"""

from __future__ import annotations

import json
import logging
import queue
import threading
import time
import uuid
from collections.abc import Callable, Iterable
from typing import Any

from zeromode.service.jobs.cluster import chunked, dask_client
from zeromode.service.jobs.heavy import heavy
from zeromode.service.jobs.store import Store, Submission
from zeromode.service.jobs.tasks import PROGRESS_TOPIC, chunk_of, execute_chunk, execute_request
from zeromode.service.wire.errors import error_body
from zeromode.service.wire.settings import Settings

log = logging.getLogger("zeromode")

# A job's worker answers too_expensive itself at the job budget; this much later the engine's
# watchdog stops it (below).
OVERRUN_SLACK = 0.03
# Single jobs go ahead of sweep points in the cluster's queue.
JOB_PRIORITY, SWEEP_PRIORITY = 10, 0
# A heavy request a client waits for goes ahead of every job.
REQUEST_PRIORITY = 100
# The recorder writes progress at most this often (one transaction per batch).
RECORD_INTERVAL_S = 0.25
# How long a worker restarted to stop a task may take to stop and come back (stop_request runs
# in its own thread, so nothing waits on it): a niced worker starting Python, Dask and the
# kernels again on a saturated machine has taken more than Dask's default 30 s.
RESTART_TIMEOUT_S = 120.0


def _processing_on(dask_scheduler, key: str) -> str | None:
    """Run on the scheduler: the address of the worker running task ``key`` (None if none)."""
    task = dask_scheduler.tasks.get(key)
    worker = None if task is None else task.processing_on
    return None if worker is None else worker.address


def _in_own_thread(function, *args):
    """``function(*args)`` called on a fresh thread: Dask then runs the client's (and the
    embedded cluster's) event loop on a thread of its own, never on the loop of the request
    that happened to start the engine, which may close when that request ends."""
    outcome: list = []

    def call() -> None:
        try:
            outcome.append((True, function(*args)))
        except BaseException as exc:  # noqa: BLE001 — re-raised on the caller's thread
            outcome.append((False, exc))

    thread = threading.Thread(target=call, name="zeromode-engine-start")
    thread.start()
    thread.join()
    ok, value = outcome[0]
    if not ok:
        raise value
    return value


class Engine:
    """Submits jobs to Dask and records what becomes of them."""

    def __init__(self, settings: Settings, store: Store):
        self.settings = settings
        self.store = store
        self.instance = uuid.uuid4().hex
        self._settings_json = settings.model_dump_json()
        self._client = None
        self._cluster = None
        # Dask futures by task key, the job ids of each task, and the task of each job id.
        self._futures: dict[str, Any] = {}
        self._chunks: dict[str, list[str]] = {}
        self._chunk_of: dict[str, str] = {}
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        # When (monotonic, as its start event arrived) each running task of one job began: the
        # watchdog stops it past the job time budget.
        self._since: dict[str, float] = {}
        self._lock = threading.Lock()
        self._closing = threading.Event()
        self._threads: list[threading.Thread] = []

    @property
    def started(self) -> bool:
        """Connected, its threads running and not closing."""
        return self._client is not None and bool(self._threads) and not self._closing.is_set()

    def start(self) -> None:
        """Connect (or start the embedded cluster), take the lease and adopt orphaned work.
        Idempotent; raises EngineUnavailable."""
        with self._lock:
            if self._client is not None:
                return
            self.store.touch(self.instance)
            # The lease is kept from here on: an embedded cluster takes seconds to start (3.4 s
            # at load 2, more on a busy machine), longer than a short lease lasts, and a replica
            # sharing the store would take this live instance for stopped and adopt its work.
            if not self._threads:
                self._spawn(self._keep_lease, "lease")
            self._client, self._cluster = _in_own_thread(dask_client, self.settings)
            self._client.subscribe_topic(PROGRESS_TOPIC, self._on_progress)
            self._spawn(self._record, "recorder")
            self._spawn(self._watch, "watchdog")
        self._adopt()

    def _spawn(self, target: Callable[[], None], name: str) -> None:
        thread = threading.Thread(target=target, name=f"zeromode-engine-{name}", daemon=True)
        thread.start()
        self._threads.append(thread)

    def close(self) -> None:
        """Stop recording, give the lease up (unfinished work is adopted by the next instance)
        and close the cluster connection."""
        if self._closing.is_set():
            return
        self._closing.set()
        for thread in self._threads:
            thread.join(timeout=5)
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()
        self.store.release(self.instance)

    # --- submitting ----------------------------------------------------------------------------

    def submit(self, submissions: list[Submission], priority: int, prechecked: bool = False) -> None:
        """Send jobs already recorded as queued (and owned by this instance) to the cluster, in
        chunks (``chunked``): one Dask task per chunk. Heavy requests (heavy.heavy) go one
        per task, so the watchdog can stop one that overruns its budget inside a library call
        without losing finished neighbours (a task's scheduling is negligible beside a heavy request).
        ``prechecked``: their requests passed their endpoint's up-front checks when they were
        accepted (work adopted from a stopped instance is checked again)."""
        if any(heavy(s.endpoint, s.request) for s in submissions):
            chunks = [[s] for s in submissions]
        else:
            chunks = chunked(submissions, self._workers())
        if not chunks:
            return
        keys = [f"zeromode-{chunk[0].id}-{len(chunk)}" for chunk in chunks]
        futures = self._client.map(
            execute_chunk,
            [chunk_of([(s.id, s.endpoint, s.request) for s in chunk]) for chunk in chunks],
            [self._settings_json] * len(chunks),
            [prechecked] * len(chunks),
            key=keys,
            pure=False,
            priority=priority,
        )
        with self._lock:
            for key, chunk, future in zip(keys, chunks, futures, strict=True):
                self._futures[key] = future
                self._chunks[key] = [s.id for s in chunk]
                for s in chunk:
                    self._chunk_of[s.id] = key
        for future in futures:
            future.add_done_callback(self._on_done)

    def validation(self, endpoint: str, sweep_points: list):
        """A sweep's points being validated on the cluster's workers: the call that waits for
        the verdict (sweeps.validation_on)."""
        from zeromode.service.jobs.sweeps import validation_on

        return validation_on(self._client, endpoint, sweep_points, self._settings_json, self._workers())

    def cancel(self, ids: Iterable[str]) -> None:
        """Drop the cluster's tasks whose jobs were all cancelled in the store (a chunk that
        also holds a job still wanted runs on; its cancelled jobs' answers are not recorded)."""
        cancelled = set(ids)
        with self._lock:
            keys = {self._chunk_of[i] for i in cancelled if i in self._chunk_of}
            whole = [k for k in keys if cancelled.issuperset(self._chunks[k])]
            futures = [self._futures[k] for k in whole]
        if futures:
            self._client.cancel(futures)

    def _workers(self) -> int:
        """Workers of the cluster now (at least 1)."""
        return max(len(self._client.scheduler_info(n_workers=-1).get("workers", {})), 1)

    # --- heavy requests (service/rest/offload.py) ---------------------------------------------------

    def run_request(self, endpoint: str, request: dict[str, Any], budget_s: float, task=execute_request):
        """A Dask future of the request's answer by ``task`` (default: its (status, body)), ahead of
        every job in the queue."""
        return self._client.submit(task, endpoint, request, self._settings_json, budget_s,
                                   key=f"zeromode-request-{uuid.uuid4().hex}", pure=False, priority=REQUEST_PRIORITY)

    @staticmethod
    def request_outcome(future) -> tuple[int, bytes]:
        if future.status == "finished":
            return future.result()
        return 503, json.dumps(error_body(
            "worker_lost", "the worker process answering this request died; try again.")).encode()

    def stop_request(self, future) -> None:
        """Cancel the request's task and restart the worker running it, if any (the only way to
        stop a long library call); without a nanny (``dask worker --no-nanny``) it runs on."""
        key = future.key
        where = self._client.run_on_scheduler(_processing_on, key=key)
        future.cancel()
        if where:
            try:
                self._client.restart_workers([where], timeout=RESTART_TIMEOUT_S, raise_for_error=False)
            except Exception:  # noqa: BLE001 — a worker without a nanny cannot be restarted
                log.warning("could not restart worker %s to stop an overrunning request", where)

    def load(self) -> dict[str, int]:
        """Workers of the cluster and tasks they are running now (GET /v1/engine)."""
        processing = self._client.processing()
        return {"workers": len(processing), "processing": sum(len(keys) for keys in processing.values())}

    # --- recording -----------------------------------------------------------------------------

    def _on_progress(self, event) -> None:
        _, message = event
        if len(message["ids"]) == 1:  # a task of one job (a chunk of several has no watchdog)
            self._since.setdefault(message["ids"][0], time.monotonic())
        for job_id in message["ids"]:
            self._events.put(("progress", job_id, message))

    def _on_done(self, future) -> None:
        self._events.put(("done", future.key, future))

    def _record(self) -> None:
        """The one thread that writes what the cluster reports: batches of progress, ends."""
        running: set[str] = set()
        while not self._closing.is_set():
            try:
                events = [self._events.get(timeout=RECORD_INTERVAL_S)]
            except queue.Empty:
                continue
            time.sleep(RECORD_INTERVAL_S / 5)  # let a burst of events arrive: one transaction
            while True:
                try:
                    events.append(self._events.get_nowait())
                except queue.Empty:
                    break
            try:
                self._write(events, running)
            except Exception:
                log.exception("the job engine could not record %d events", len(events))

    def _write(self, events: list, running: set[str]) -> None:
        now = time.time()
        progress: dict[str, tuple[float, str]] = {}
        ends = []
        for kind, ref, payload in events:
            if kind == "progress":
                progress[ref] = (float(payload["progress"]), str(payload["message"]))
            else:
                ends.append((ref, payload))
        new = [i for i in progress if i not in running]
        if new:
            self.store.started(new, now)
            running.update(new)
        outcomes = []
        for key, future in ends:
            with self._lock:
                ids = self._chunks.pop(key, [])
                self._futures.pop(key, None)
                for job_id in ids:
                    self._chunk_of.pop(job_id, None)
                    self._since.pop(job_id, None)
            if not (future.cancelled() and self._closing.is_set()):
                outcomes += _outcomes(ids, future)
        ended = {job_id for job_id, *_ in outcomes}
        # A chunk's start marks its jobs running (above); only real fractions are written.
        progress = {i: p for i, p in progress.items() if i not in ended and p[0] > 0.0}
        if progress:
            self.store.progressed(progress)
        if outcomes:
            self.store.finish_all(self._within_quota(outcomes), now)
            running.difference_update(ended)

    def _within_quota(self, outcomes: list) -> list:
        """The outcomes, a result that would take the store past ``max_job_store_bytes``
        turned into a ``job_store_full`` failure (the disk never fills with results)."""
        quota = self.settings.max_job_store_bytes
        used = self.store.stored_bytes()
        kept = []
        for job_id, status, result, error in outcomes:
            if result is not None and used + len(result) > quota:
                status, result, error = "failed", None, {
                    "code": "job_store_full",
                    "message": f"the result ({len(result)} bytes) would pass the job store's "
                    f"{quota}-byte quota; fetch or let expire older results.",
                }
            used += 0 if result is None else len(result)
            kept.append((job_id, status, result, error))
        return kept

    # --- stopping running jobs ---------------------------------------------------------------------

    def _watch(self) -> None:
        """The watchdog: a task of one job still running ``OVERRUN_SLACK`` of the job time budget
        past it (the job checks its budget between steps, so only a long library call gets here)
        is recorded failed ``too_expensive`` and stopped (``stop_job``)."""
        budget = self.settings.job_time_budget_s
        while not self._closing.wait(min(1.0, max(budget * OVERRUN_SLACK / 4, 0.01))):
            late = time.monotonic() - budget * (1 + OVERRUN_SLACK)
            for job_id in [i for i, since in list(self._since.items()) if since < late]:
                self.stop_job(job_id, "failed", {
                    "code": "too_expensive",
                    "message": f"the job needs more than its time budget of {budget:g} s and was stopped; "
                    "ask for a smaller problem or a larger ZEROMODE_JOB_TIME_BUDGET_S.",
                })

    def stop_job(self, job_id: str, status: str, error: dict[str, Any]) -> bool:
        """Record a running job of this instance as ended (``status``, ``error``), then stop its
        task: cancelled and its worker restarted, in the background (``stop_request``). Whether
        the job was running here alone in its task (else nothing is done)."""
        with self._lock:
            key = self._chunk_of.get(job_id)
            future = None if key is None or self._chunks[key] != [job_id] else self._futures[key]
        if future is None or self._since.pop(job_id, None) is None:
            return False
        self.store.finish_all([(job_id, status, None, error)], time.time())
        threading.Thread(target=self.stop_request, args=(future,), name="zeromode-stop", daemon=True).start()
        return True

    # --- lease ---------------------------------------------------------------------------------

    def _keep_lease(self) -> None:
        # Renewed four times per lease: a busy machine may delay a tick, and adopting the work
        # of a live instance would run it twice.
        while not self._closing.wait(self.settings.job_lease_s / 4):
            try:
                self.store.touch(self.instance)
                if self._client is None:  # the cluster is still starting (start adopts once it is up)
                    continue
                self._adopt()
                self.store.expire(time.time(), self.settings.job_ttl_s, self.settings.max_stored_jobs)
            except Exception:
                log.exception("the job engine could not renew its lease")

    def _adopt(self) -> None:
        orphans = self.store.claim_orphans(self.instance, self.settings.job_max_attempts, self.settings.job_lease_s)
        if orphans:
            log.warning("resubmitting %d jobs left unfinished by a stopped service", len(orphans))
            self.submit([o for o in orphans if o.sweep_id is None], JOB_PRIORITY)
            self.submit([o for o in orphans if o.sweep_id is not None], SWEEP_PRIORITY)


def _outcomes(ids: list[str], future) -> list[tuple[str, str, bytes | None, dict | None]]:
    """(id, status, result, error) of each job of a finished chunk."""
    if future.cancelled():
        error = {"code": "cancelled", "message": "cancelled before it finished."}
        return [(job_id, "cancelled", None, error) for job_id in ids]
    if future.status == "error":
        exc = future.exception()
        error = {
            "code": "worker_lost",
            "message": f"the workers running this job died repeatedly ({type(exc).__name__}); "
            "it may need more memory than a worker has.",
        }
        return [(job_id, "failed", None, error) for job_id in ids]
    return [
        (job_id, "done", payload, None) if status == "done" else (job_id, "failed", None, payload)
        for job_id, status, payload in future.result()
    ]
