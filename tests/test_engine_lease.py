"""An engine holds its lease while its Dask cluster starts (a real SQLite store, a real Dask
client): a replica sharing the store must not take a starting instance for a stopped one.

Before the lease was kept from the first touch, the lease thread started only once the cluster
was up: 3.4 s for an embedded cluster at load 2, longer than the replica test's 3 s lease, and
the other replica adopted the whole sweep of a live one (its points ran twice)."""

from __future__ import annotations

import threading
import time

import sqlalchemy as sa
from client.conftest import loopback_socket

from zeromode.service.jobs.cluster import EngineUnavailable
from zeromode.service.jobs.engine import Engine
from zeromode.service.jobs.store import Store, instances
from zeromode.service.wire.settings import Settings

LEASE_S = 1.0


def test_the_lease_is_kept_while_the_cluster_starts(tmp_path):
    # A scheduler address nobody answers (bound, not listening): the client retries until its
    # connect timeout, far longer than the lease.
    sock = loopback_socket()
    address = f"tcp://127.0.0.1:{sock.getsockname()[1]}"
    store = Store(f"sqlite:///{tmp_path}/jobs.sqlite3")
    engine = Engine(Settings(dask_scheduler=address, job_lease_s=LEASE_S,
                             database_url=f"sqlite:///{tmp_path}/jobs.sqlite3"), store)
    ages: list[float] = []
    raised: list[BaseException] = []

    def start() -> None:
        try:
            engine.start()
        except BaseException as exc:  # noqa: BLE001 — asserted below, in the test's thread
            raised.append(exc)

    starting = threading.Thread(target=start, daemon=True)
    try:
        starting.start()
        t0 = time.monotonic()
        while starting.is_alive() and time.monotonic() - t0 < 6 * LEASE_S:
            time.sleep(LEASE_S / 5)
            with store.db.connect() as conn:
                seen = conn.execute(sa.select(instances.c.seen).where(instances.c.id == engine.instance)).scalar()
            if seen is not None:
                ages.append(time.time() - seen)
        assert starting.is_alive(), "the cluster answered: this test needs a start longer than the lease"
        # Sampled over six leases while the start ran: never stale (a tick is a quarter lease).
        assert len(ages) >= 20 and max(ages) < LEASE_S, ages
    finally:
        sock.close()
        starting.join(timeout=60)
        engine.close()
        store.close()
    assert len(raised) == 1 and isinstance(raised[0], EngineUnavailable), raised
