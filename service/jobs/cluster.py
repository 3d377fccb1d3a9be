"""The Dask cluster the job engine and the library's sweeps run on: a client of an existing
cluster (``ZEROMODE_DASK_SCHEDULER``), or of an embedded ``LocalCluster`` of lean, low-priority
worker processes prepared before their first task; and the cutting of work into tasks."""

from __future__ import annotations

import asyncio
import logging
import os

from zeromode.service.wire.settings import Settings

# Embedded workers run at this niceness: the service process (and /health) comes first on a
# machine whose cores the workers saturate.
WORKER_NICENESS = 10
# One BLAS thread per worker process: parallelism comes from the processes (a threaded BLAS on
# small matrices was measured 50x slower per SVD on a busy 2-core machine).
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
CONNECT_TIMEOUT_S = 10.0
# At most this many jobs in one Dask task: a cancelled sweep runs on at most this many points a
# worker, a single job waits at most this many points for a worker.
MAX_CHUNK = 64
# Dask's diagnostics off in the embedded cluster: its statistical profiler samples every
# worker's stack each 10 ms and its system monitor reads /proc twice a second, together ~5 % of
# a worker's CPU on small designs (py-spy, 1000-point sweep), for a dashboard nobody opens here.
# (An existing cluster keeps its own configuration.)
LEAN_DASK_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.admin.system-monitor.disk": False,
    "distributed.admin.tick.interval": "200ms",
}
# A LocalCluster closes the nanny of a worker that has been gone from its scheduler for
# Dask's lost-worker timeout (15 s), and the cluster shrinks for good. A worker the engine
# restarts to stop an overrunning task (engine.stop_request) is such a worker while it starts
# again: niced on a saturated 2-core machine it took longer than 15 s (load 12), and the cluster
# lost it. Dask reads the timeout when the worker leaves, so it is set for the process.
LOST_WORKER_TIMEOUT = "600s"



class EngineUnavailable(Exception):
    """The Dask cluster cannot be reached or started (an operator's problem: HTTP 503)."""


def _prepare_plugin(niceness: int):
    """A Dask worker plugin run on every worker, restarted ones included: for the embedded
    workers, lowers their priority below the service's; imports zeromode's endpoints (seconds on
    a busy machine, which would otherwise fall on the first task and its time budget) and loads
    the analysis's compiled kernels (rigidity.warm_up: after the service's warm-up, from the
    cache it shares), in a thread (the worker's event loop keeps answering). The engine is
    started once every worker has done so: the service's watchdog, which stops a task at its
    budget, never meets a worker still compiling."""
    from distributed import WorkerPlugin

    class Prepare(WorkerPlugin):
        async def setup(self, worker) -> None:
            if niceness:
                try:
                    os.nice(niceness)
                except OSError:  # not permitted here: the workers keep their priority
                    pass
            await asyncio.to_thread(_prepare_worker)

    return Prepare()


def _prepare_worker() -> None:
    import zeromode.service.jobs.tasks  # noqa: F401 — the import is half the point
    from zeromode.solver.analysis.rigidity import warm_up

    warm_up()


def local_cluster(settings: Settings):
    """The embedded cluster: ``dask_workers`` single-threaded worker processes (default: one per
    core), each limited to ``dask_worker_memory_bytes`` (Dask restarts a worker that passes it
    and re-runs its task elsewhere), without Dask's diagnostics (``LEAN_DASK_CONFIG``)."""
    import dask
    from distributed import LocalCluster

    dask.config.set({"distributed.deploy.lost-worker-timeout": LOST_WORKER_TIMEOUT})
    with dask.config.set(LEAN_DASK_CONFIG):  # the nannies hand this configuration to their workers
        return LocalCluster(
            n_workers=settings.dask_workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",  # the embedded cluster listens on loopback only
            memory_limit=settings.dask_worker_memory_bytes or "auto",
            # The scheduler's HTTP routes (and dashboard, if bokeh is installed) on a free port of
            # loopback only: two services on one machine must not fight over Dask's default 8787.
            dashboard_address="127.0.0.1:0",
            silence_logs=logging.WARNING,
            env=WORKER_ENV,
        )


def dask_client(settings: Settings, scheduler: str | None = None):
    """(client, cluster or None): a client of ``scheduler`` (default ``settings.dask_scheduler``)
    or of a new embedded cluster."""
    from distributed import Client

    address = scheduler or settings.dask_scheduler
    try:
        if address:
            client, cluster = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False), None
        else:
            cluster = local_cluster(settings)
            client = Client(cluster, set_as_default=False)
        client.register_plugin(_prepare_plugin(0 if address else WORKER_NICENESS), name="zeromode-prepare")
        return client, cluster
    except (OSError, TimeoutError) as exc:
        where = address or "the embedded LocalCluster"
        raise EngineUnavailable(f"the Dask cluster at {where} cannot be used ({exc}).") from exc


def chunked(items: list, workers: int) -> list[list]:
    """``items`` cut into consecutive chunks, one Dask task each, largest first (guided
    self-scheduling): each chunk takes a (2·workers)-th of what remains, at most ``MAX_CHUNK``.
    A task costs the service ~8 ms of CPU in the embedded cluster's scheduler, client and
    nannies (measured: 0.7 ms a point with chunks of 16, 0.33 with 64, on a sweep of small
    designs), so chunks are large while much remains; they shrink to one item at the end, so
    the workers finish together (Dask runs one map's tasks of one priority in order)."""
    chunks, start = [], 0
    while start < len(items):
        size = min(max((len(items) - start) // (2 * workers), 1), MAX_CHUNK)
        chunks.append(items[start : start + size])
        start += size
    return chunks
