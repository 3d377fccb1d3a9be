"""The record store of jobs and sweeps: one small interface over a SQL database.

Every job (a single request run in the background, or one point of a sweep) is a row of
``jobs``: its request, state, progress, result or error and times. A sweep is a row of
``sweeps`` plus one job row per point. The service instances that run work hold a lease in
``instances``: a row they touch every quarter of the lease (``ZEROMODE_JOB_LEASE_S``). Work owned
by an instance whose lease is older than that (a service killed with -9, a crashed replica) is
*orphaned*; the
next live instance adopts it (``claim_orphans``): resubmitted while it has attempts left,
``interrupted`` after that. A finished result is written once, in the transaction that marks
its job done, so no restart loses it.

The database is SQLAlchemy Core, so one URL chooses it: SQLite by default (one file in WAL
mode: readers never wait for the writer; ``synchronous=NORMAL``: a committed result survives a
crash of the process), PostgreSQL for several replicas (``postgresql+psycopg://user@host/db``,
with ``pip install "zeromode[postgres]"``). The SQL used here is the portable subset both accept;
the tables are created under an advisory lock on PostgreSQL, so replicas may start together on
an empty database (tests/test_replicas_postgres.py).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

ACTIVE = ("queued", "running")
FINISHED = ("done", "failed", "cancelled", "interrupted")
# SQLite waits this long for another writer's lock before failing (replicas on one file).
SQLITE_BUSY_MS = 10_000
# The stored results' total (the disk quota) is summed again at most this often; in between it
# counts what this instance stores (a SUM over every stored job for each batch of results cost
# ~4 % of the service's CPU during a sweep). Other replicas' results are seen within this time.
STORED_BYTES_REFRESH_S = 1.0
# The PostgreSQL advisory lock (one 64-bit key per database) held while the tables are created:
# "zeromod" in ASCII, a key no other application is likely to take.
SCHEMA_LOCK_KEY = int.from_bytes(b"zeromod", "big")

metadata = sa.MetaData()
jobs = sa.Table(
    "jobs",
    metadata,
    sa.Column("id", sa.String(32), primary_key=True),
    sa.Column("sweep_id", sa.String(32), nullable=True),
    sa.Column("point", sa.Integer, nullable=True),
    sa.Column("params", sa.Text, nullable=True),
    sa.Column("endpoint", sa.String(64), nullable=False),
    sa.Column("request", sa.Text, nullable=False),
    sa.Column("client", sa.String(200), nullable=False, default=""),
    sa.Column("status", sa.String(16), nullable=False),
    sa.Column("progress", sa.Float, nullable=False, default=0.0),
    sa.Column("message", sa.Text, nullable=False, default=""),
    sa.Column("result", sa.Text, nullable=True),
    sa.Column("error", sa.Text, nullable=True),
    sa.Column("bytes", sa.Integer, nullable=False, default=0),
    sa.Column("created", sa.Float, nullable=False),
    sa.Column("started", sa.Float, nullable=True),
    sa.Column("finished", sa.Float, nullable=True),
    sa.Column("attempts", sa.Integer, nullable=False, default=1),
    sa.Column("owner", sa.String(32), nullable=False),
    sa.Column("seq", sa.Integer, nullable=True),
    sa.Index("jobs_sweep_seq", "sweep_id", "seq"),
    # A sweep's counts by state from the index alone (a poll of a running sweep).
    sa.Index("jobs_sweep_status", "sweep_id", "status"),
    sa.Index("jobs_status_owner", "status", "owner"),
    sa.Index("jobs_created", "created"),
)
sweeps = sa.Table(
    "sweeps",
    metadata,
    sa.Column("id", sa.String(32), primary_key=True),
    sa.Column("endpoint", sa.String(64), nullable=False),
    sa.Column("spec", sa.Text, nullable=False),
    sa.Column("client", sa.String(200), nullable=False, default=""),
    sa.Column("total", sa.Integer, nullable=False),
    sa.Column("finished_count", sa.Integer, nullable=False, default=0),
    sa.Column("cancelled", sa.Boolean, nullable=False, default=False),
    sa.Column("created", sa.Float, nullable=False),
    sa.Column("finished", sa.Float, nullable=True),
)
instances = sa.Table(
    "instances",
    metadata,
    sa.Column("id", sa.String(32), primary_key=True),
    sa.Column("seen", sa.Float, nullable=False),
)


@dataclass(frozen=True)
class Submission:
    """What a worker needs to run one job: its id, endpoint and request (a JSON object)."""

    id: str
    endpoint: str
    request: dict[str, Any]
    sweep_id: str | None = None


def _sqlite_pragmas(dbapi_connection, _record) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_MS}")
    cursor.close()


def connect(url: str) -> Engine:
    """The database at ``url``, its tables created if missing (on PostgreSQL under
    ``SCHEMA_LOCK_KEY``: one creator at a time)."""
    is_sqlite = url.startswith("sqlite")
    path = sa.engine.make_url(url).database if is_sqlite else None
    if path and path != ":memory:":
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    engine = sa.create_engine(
        url, connect_args={"check_same_thread": False} if is_sqlite else {}, pool_pre_ping=not is_sqlite
    )
    if is_sqlite:
        sa.event.listen(engine, "connect", _sqlite_pragmas)
    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            # Replicas started together on an empty database would each see no table and each
            # create one: all but the first fail (a duplicate type "jobs"). Under this lock the
            # others wait for the first's commit (PostgreSQL's DDL is transactional), then find
            # the tables.
            conn.execute(sa.text("SELECT pg_advisory_xact_lock(:key)"), {"key": SCHEMA_LOCK_KEY})
        metadata.create_all(conn)
        for index in jobs.indexes:  # an index added since the file was created (create_all skips existing tables)
            index.create(conn, checkfirst=True)
    return engine


def _decoded(text: str | None) -> Any:
    return None if text is None else json.loads(text)


class Store:
    """Job and sweep records. Every method is one short transaction; safe from any thread."""

    def __init__(self, url: str):
        self.db = connect(url)
        self._stored = (0, -float("inf"))  # (bytes, monotonic time of the last sum)

    def close(self) -> None:
        self.db.dispose()

    # --- instances (leases) ----------------------------------------------------------------

    def touch(self, instance: str, now: float | None = None) -> None:
        """Renew ``instance``'s lease."""
        now = time.time() if now is None else now
        with self.db.begin() as conn:
            if conn.execute(sa.update(instances).where(instances.c.id == instance).values(seen=now)).rowcount == 0:
                conn.execute(sa.insert(instances).values(id=instance, seen=now))

    def release(self, instance: str) -> None:
        """A clean shutdown gives its lease up: its unfinished work is adopted at once."""
        with self.db.begin() as conn:
            conn.execute(sa.update(instances).where(instances.c.id == instance).values(seen=0.0))

    def claim_orphans(self, instance: str, max_attempts: int, lease_s: float,
                      now: float | None = None) -> list[Submission]:
        """Adopt the queued or running jobs of instances whose lease is stale (or that never
        held one): those with attempts left become ``instance``'s, queued again with one more
        attempt, and are returned to be resubmitted; the others are marked ``interrupted``."""
        now = time.time() if now is None else now
        live = sa.select(instances.c.id).where(instances.c.seen >= now - lease_s)
        orphaned = sa.and_(jobs.c.status.in_(ACTIVE), jobs.c.owner.not_in(live))
        with self.db.begin() as conn:
            rows = conn.execute(
                sa.select(jobs.c.id, jobs.c.endpoint, jobs.c.request, jobs.c.sweep_id, jobs.c.attempts).where(orphaned)
            ).all()
            again = [r for r in rows if r.attempts < max_attempts]
            spent = [r.id for r in rows if r.attempts >= max_attempts]
            claimed: set[str] = set()
            for chunk in _chunks([r.id for r in again]):
                # Only the rows this update changed are ours: another instance adopting at the
                # same moment gets the others (RETURNING: SQLite ≥ 3.35, PostgreSQL).
                claimed.update(conn.execute(
                    sa.update(jobs)
                    .where(jobs.c.id.in_(chunk), orphaned)
                    .values(owner=instance, status="queued", progress=0.0, started=None,
                            attempts=jobs.c.attempts + 1, message="resubmitted after its service stopped")
                    .returning(jobs.c.id)
                ).scalars())
            for chunk in _chunks(spent):
                self._finish_many(conn, chunk, "interrupted", now, error={
                    "code": "interrupted",
                    "message": f"the service running this job stopped {max_attempts} times before it "
                    "finished; submit it again.",
                })
        return [Submission(r.id, r.endpoint, json.loads(r.request), r.sweep_id) for r in again if r.id in claimed]

    # --- writing ---------------------------------------------------------------------------

    def add_job(self, record: dict[str, Any]) -> None:
        with self.db.begin() as conn:
            conn.execute(sa.insert(jobs), [record])

    def add_sweep(self, sweep: dict[str, Any], points: list[dict[str, Any]]) -> None:
        """The sweep and all its points, in one transaction (all or nothing)."""
        with self.db.begin() as conn:
            conn.execute(sa.insert(sweeps), [sweep])
            for chunk in _chunks(points, 500):
                conn.execute(sa.insert(jobs), chunk)

    def started(self, ids: Iterable[str], now: float) -> None:
        with self.db.begin() as conn:
            for chunk in _chunks(list(ids)):
                conn.execute(
                    sa.update(jobs).where(jobs.c.id.in_(chunk), jobs.c.status == "queued")
                    .values(status="running", started=now, message="running")
                )

    def progressed(self, updates: dict[str, tuple[float, str]]) -> None:
        """Progress of running jobs: {id: (fraction, message)}; it never moves backwards."""
        with self.db.begin() as conn:
            for job_id, (fraction, message) in updates.items():
                conn.execute(
                    sa.update(jobs)
                    .where(jobs.c.id == job_id, jobs.c.status.in_(ACTIVE), jobs.c.progress <= fraction)
                    .values(progress=fraction, message=message[:500])
                )

    def finish_all(self, outcomes: list[tuple[str, str, bytes | None, dict[str, Any] | None]],
                   now: float) -> None:
        """Record the ends of jobs, (id, status, result, error) each, in one transaction and
        once: a job already finished (a task Dask ran twice after a worker died, a cancelled
        one) is left as it is."""
        with self.db.begin() as conn:
            self._finish(conn, outcomes, now)

    def _finish_many(self, conn: Connection, ids: list[str], status: str, now: float, *,
                     error: dict[str, Any] | None = None) -> None:
        """The same end (``status``, ``error``, no result) for all of ``ids``."""
        self._finish(conn, [(job_id, status, None, error) for job_id in ids], now)

    def _finish(self, conn: Connection, outcomes: list[tuple[str, str, bytes | None, dict[str, Any] | None]],
                now: float) -> None:
        """Three statements whatever the number of jobs: which are still active, one counter
        update per sweep (the finishing order, ``seq``, readers page by), one executemany for
        the rows (a 1000-point sweep recorded as three statements a point cost the service
        ~2 ms of CPU a point; a 10 000-point cancel held the write lock for half a minute)."""
        active: dict[str, str | None] = {}
        for chunk in _chunks([o[0] for o in outcomes]):
            active.update(conn.execute(
                sa.select(jobs.c.id, jobs.c.sweep_id).where(jobs.c.id.in_(chunk), jobs.c.status.in_(ACTIVE))
            ).all())
        if not active:
            return
        by_sweep: dict[str | None, list[str]] = {}
        for job_id, sweep_id in active.items():
            by_sweep.setdefault(sweep_id, []).append(job_id)
        seqs: dict[str, int | None] = dict.fromkeys(by_sweep.pop(None, []))
        for sweep_id, members in by_sweep.items():
            seq = conn.execute(
                sa.update(sweeps).where(sweeps.c.id == sweep_id)
                .values(finished_count=sweeps.c.finished_count + len(members))
                .returning(sweeps.c.finished_count, sweeps.c.total)
            ).one()
            seqs.update(zip(members, range(seq.finished_count - len(members) + 1, seq.finished_count + 1), strict=True))
            if seq.finished_count >= seq.total:
                conn.execute(sa.update(sweeps).where(sweeps.c.id == sweep_id).values(finished=now))
        rows = [
            {"row_id": job_id, "row_seq": seqs[job_id], "row_status": status,
             "row_progress": 1.0 if status == "done" else 0.0,
             "row_result": None if result is None else result.decode(),
             "row_bytes": 0 if result is None else len(result),
             "row_error": None if error is None else json.dumps(error)}
            for job_id, status, result, error in outcomes if job_id in seqs
        ]
        written = sum(r["row_bytes"] for r in rows)
        self._stored = (self._stored[0] + written, self._stored[1])
        conn.execute(
            # (IN lists cannot be executemany's: the states one by one)
            sa.update(jobs).where(jobs.c.id == sa.bindparam("row_id"), sa.or_(*(jobs.c.status == s for s in ACTIVE)))
            .values(status=sa.bindparam("row_status"), message=sa.bindparam("row_status"), finished=now,
                    progress=sa.case((jobs.c.progress > sa.bindparam("row_progress"), jobs.c.progress),
                                     else_=sa.bindparam("row_progress")),
                    result=sa.bindparam("row_result"), bytes=sa.bindparam("row_bytes"),
                    error=sa.bindparam("row_error"), seq=sa.bindparam("row_seq")),
            rows,
        )

    def cancel_queued(self, ids: list[str], now: float) -> list[str]:
        """Cancel those of ``ids`` that have not started; the ids cancelled."""
        with self.db.begin() as conn:
            queued = [r.id for r in conn.execute(
                sa.select(jobs.c.id).where(jobs.c.id.in_(ids), jobs.c.status == "queued")).all()]
            for chunk in _chunks(queued):
                self._finish_many(conn, chunk, "cancelled", now, error={
                    "code": "cancelled", "message": "cancelled before it ran."})
        return queued

    def cancel_sweep(self, sweep_id: str, now: float) -> list[str]:
        """Mark the sweep cancelled and cancel its points that have not started."""
        with self.db.begin() as conn:
            # A sweep whose points have all ended stays as it ended: nothing is left to cancel.
            conn.execute(sa.update(sweeps).where(sweeps.c.id == sweep_id, sweeps.c.finished.is_(None)).values(cancelled=True))
            ids = [r.id for r in conn.execute(
                sa.select(jobs.c.id).where(jobs.c.sweep_id == sweep_id, jobs.c.status == "queued")).all()]
        return self.cancel_queued(ids, now)

    def expire(self, now: float, ttl_s: float, max_jobs: int) -> int:
        """Forget finished records older than ``ttl_s``, then past ``max_jobs`` rows the oldest
        finished single jobs, then the oldest finished sweeps; the number of rows removed."""
        removed = 0
        with self.db.begin() as conn:
            old = conn.execute(
                sa.select(sweeps.c.id).where(sweeps.c.finished.is_not(None), sweeps.c.finished < now - ttl_s)
            ).scalars().all()
            removed += self._drop_sweeps(conn, old)
            removed += conn.execute(
                sa.delete(jobs).where(jobs.c.sweep_id.is_(None), jobs.c.status.in_(FINISHED),
                                      jobs.c.finished < now - ttl_s)
            ).rowcount
            excess = conn.execute(sa.select(sa.func.count()).select_from(jobs)).scalar_one() - max_jobs
            if excess > 0:
                oldest = conn.execute(
                    sa.select(jobs.c.id).where(jobs.c.sweep_id.is_(None), jobs.c.status.in_(FINISHED))
                    .order_by(jobs.c.finished).limit(excess)
                ).scalars().all()
                for chunk in _chunks(list(oldest)):
                    removed += conn.execute(sa.delete(jobs).where(jobs.c.id.in_(chunk))).rowcount
                excess -= len(oldest)
            # Still too many: whole finished sweeps go, the oldest first.
            for sweep_id in conn.execute(
                sa.select(sweeps.c.id).where(sweeps.c.finished.is_not(None)).order_by(sweeps.c.finished)
            ).scalars().all():
                if excess <= 0:
                    break
                dropped = self._drop_sweeps(conn, [sweep_id])
                excess, removed = excess - dropped, removed + dropped
        return removed

    def delete_sweep(self, sweep_id: str) -> None:
        with self.db.begin() as conn:
            self._drop_sweeps(conn, [sweep_id])

    def _drop_sweeps(self, conn: Connection, ids: list[str]) -> int:
        removed = 0
        for chunk in _chunks(ids):
            removed += conn.execute(sa.delete(jobs).where(jobs.c.sweep_id.in_(chunk))).rowcount
            conn.execute(sa.delete(sweeps).where(sweeps.c.id.in_(chunk)))
        return removed

    # --- reading ---------------------------------------------------------------------------

    def job(self, job_id: str, with_result: bool = True, raw_result: bool = False) -> dict[str, Any] | None:
        """The job's record; its result decoded, or with ``raw_result`` the stored JSON text
        (to be sent on as it is)."""
        columns = [c for c in jobs.c if with_result or c.name != "result"]
        with self.db.connect() as conn:
            row = conn.execute(sa.select(*columns).where(jobs.c.id == job_id)).first()
        return None if row is None else _job_dict(row._mapping, raw_result)

    def active_jobs(self, client: str | None = None) -> int:
        """Queued or running single jobs (not sweep points), of ``client`` when given."""
        query = sa.select(sa.func.count()).select_from(jobs).where(
            jobs.c.status.in_(ACTIVE), jobs.c.sweep_id.is_(None))
        if client is not None:
            query = query.where(jobs.c.client == client)
        with self.db.connect() as conn:
            return conn.execute(query).scalar_one()

    def unfinished(self) -> int:
        """Queued or running jobs and sweep points, of any instance."""
        with self.db.connect() as conn:
            return conn.execute(
                sa.select(sa.func.count()).select_from(jobs).where(jobs.c.status.in_(ACTIVE))
            ).scalar_one()

    def active_sweeps(self, client: str) -> int:
        with self.db.connect() as conn:
            return conn.execute(
                sa.select(sa.func.count()).select_from(sweeps)
                .where(sweeps.c.client == client, sweeps.c.finished.is_(None), sweeps.c.cancelled.is_(False))
            ).scalar_one()

    def stored_bytes(self) -> int:
        """Bytes of the stored results: summed at most every ``STORED_BYTES_REFRESH_S``, counted
        in between."""
        total, at = self._stored
        if time.monotonic() - at > STORED_BYTES_REFRESH_S:
            with self.db.connect() as conn:
                total = conn.execute(sa.select(sa.func.coalesce(sa.func.sum(jobs.c.bytes), 0))).scalar_one()
            self._stored = (total, time.monotonic())
        return total

    def sweep(self, sweep_id: str) -> dict[str, Any] | None:
        """The sweep's record (its spec left out) and the count of its points in each state."""
        with self.db.connect() as conn:
            # (not the spec: a poll of a long grid would parse it each time, and it is never read)
            row = conn.execute(sa.select(*(c for c in sweeps.c if c.name != "spec")).where(sweeps.c.id == sweep_id)).first()
            if row is None:
                return None
            counts = dict(conn.execute(
                sa.select(jobs.c.status, sa.func.count()).where(jobs.c.sweep_id == sweep_id)
                .group_by(jobs.c.status)
            ).all())
        record = dict(row._mapping)
        record["counts"] = counts
        return record

    def sweep_points(self, sweep_id: str, *, after: int = 0, limit: int | None = None,
                     with_result: bool = True) -> list[dict[str, Any]]:
        """Finished points in the order they finished (``seq`` > ``after``)."""
        columns = [c for c in jobs.c if with_result or c.name != "result"]
        query = (sa.select(*columns).where(jobs.c.sweep_id == sweep_id, jobs.c.seq > after)
                 .order_by(jobs.c.seq))
        if limit is not None:
            query = query.limit(limit)
        with self.db.connect() as conn:
            return [_job_dict(r._mapping) for r in conn.execute(query)]

    def iter_sweep_points(self, sweep_id: str, page: int = 200) -> Iterator[dict[str, Any]]:
        """Every finished point, in finishing order, a page at a time (bounded memory)."""
        after = 0
        while batch := self.sweep_points(sweep_id, after=after, limit=page):
            yield from batch
            after = batch[-1]["seq"]

    def queued_of_sweep(self, sweep_id: str) -> list[str]:
        with self.db.connect() as conn:
            return list(conn.execute(
                sa.select(jobs.c.id).where(jobs.c.sweep_id == sweep_id, jobs.c.status.in_(ACTIVE))
            ).scalars())


def _job_dict(row, raw_result: bool = False) -> dict[str, Any]:
    record = dict(row)
    for key in ("request", "error", "params"):
        if key in record:
            record[key] = _decoded(record[key])
    if "result" in record and not raw_result:
        record["result"] = _decoded(record["result"])
    return record


def _chunks(items: list, size: int = 500) -> Iterator[list]:
    """SQLite binds at most 32 766 parameters per statement: IN lists go in chunks."""
    for i in range(0, len(items), size):
        yield items[i : i + size]
