"""Sweeps: one endpoint's request template and a grid of parameters (or a list of requests),
every point validated before any runs, run as Dask tasks, read back as NDJSON or a table.

A grid ``{"poisson_ratio": [-0.3, -0.5], "options.seed": [0, 1, 2]}`` sets each dotted path of
the template to each value: the points are the Cartesian product, the last key varying fastest.
A list of requests instead gives one point per request, each merged over the template. The same
expansion, validation and table serve the REST sweeps (service/rest/routes/sweeps.py), the CLI and
``sweep`` here, which a notebook calls without any server.
"""

from __future__ import annotations

import copy
import csv
import io
import itertools
import json
import math
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from zeromode.service.jobs.tasks import (
    RUNNABLE,
    RequestRefused,
    chunk_of,
    execute_chunk,
    settings_of,
    validated,
)
from zeromode.service.wire.extras import require
from zeromode.service.wire.settings import Settings, current_settings, settings_scope

if TYPE_CHECKING:
    import pandas as pd

class SweepRefused(Exception):
    """A sweep that cannot be accepted: ``detail`` is the 422 body's {"code", "message", ...}."""

    def __init__(self, code: str, message: str, **extra: Any):
        super().__init__(message)
        self.detail = {"code": code, "message": message, **extra}


@dataclass(frozen=True)
class Point:
    """One point of a sweep: its index, the parameters that define it and its full request."""

    index: int
    params: dict[str, Any]
    request: dict[str, Any]


def _set_path(doc: dict[str, Any], path: str, value: Any) -> None:
    *parents, last = path.split(".")
    for key in parents:
        child = doc.get(key)
        if not isinstance(child, dict):
            child = doc[key] = {}
        doc = child
    doc[last] = copy.deepcopy(value)


def _merged(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``over`` merged into a copy of ``base``, objects key by key, everything else replaced."""
    out = copy.deepcopy(base)
    for key, value in over.items():
        out[key] = _merged(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else copy.deepcopy(value)
    return out


def _leaves(doc: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """The scalar fields of a JSON document with their dotted paths (lists are skipped)."""
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield from _leaves(value, f"{prefix}{key}.")
    elif doc is None or isinstance(doc, bool | int | float | str):
        yield prefix[:-1], doc


def _flat(doc: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A request's fields by dotted path, objects flattened, lists kept whole: the parameters
    of a point given as a request, in the grid's own terms."""
    out: dict[str, Any] = {}
    for key, value in doc.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def points(template: dict[str, Any], grid: dict[str, list[Any]] | None,
           requests: list[dict[str, Any]] | None, max_points: int) -> list[Point]:
    """The sweep's points; SweepRefused ``too_many_points`` (before expanding anything) when
    there would be more than ``max_points``."""
    if grid is not None and requests is not None:
        raise SweepRefused("invalid_sweep", "give either grid or requests, not both.")
    if grid is not None:
        empty = [key for key, values in grid.items() if not values]
        if empty:
            raise SweepRefused("invalid_sweep", f"grid.{empty[0]} has no values.")
        count = math.prod(len(values) for values in grid.values())
    else:
        count = 1 if requests is None else len(requests)
    if count > max_points:
        raise SweepRefused(
            "too_many_points",
            f"the sweep has {count} points; the limit is {max_points} (ZEROMODE_MAX_SWEEP_POINTS).",
        )
    if count == 0:
        raise SweepRefused("invalid_sweep", "the sweep has no points.")
    if grid is not None:
        keys = list(grid)
        out = []
        for index, values in enumerate(itertools.product(*(grid[k] for k in keys))):
            request = copy.deepcopy(template)
            for key, value in zip(keys, values, strict=True):
                _set_path(request, key, value)
            out.append(Point(index, dict(zip(keys, values, strict=True)), request))
        return out
    if requests is None:
        return [Point(0, {}, copy.deepcopy(template))]
    return [Point(i, _flat(r), _merged(template, r)) for i, r in enumerate(requests)]


def validate_points(endpoint: str, sweep_points: list[Point]) -> None:
    """Every point through the endpoint's full validation; the first bad one is SweepRefused
    ``invalid_point`` naming its index, parameters and the endpoint's own error
    (``invalid_sweep`` for an endpoint that does not run as a job)."""
    if endpoint not in RUNNABLE:
        raise SweepRefused("invalid_sweep", f"endpoint must be one of {', '.join(RUNNABLE)}; got {endpoint!r}.")
    for point in sweep_points:
        try:
            validated(endpoint, point.request)
        except RequestRefused as exc:
            shown = ", ".join(f"{k}={json.dumps(v)}" for k, v in point.params.items())[:300]
            raise SweepRefused(
                "invalid_point",
                f"point {point.index}{f' ({shown})' if shown else ''}: {exc.detail.get('code')}: "
                f"{exc.detail.get('message')}",
                point=point.index,
                params=point.params,
                error=exc.detail,
                **({"errors": exc.errors} if exc.errors else {}),
            ) from exc


def first_refusal(endpoint: str, sweep_points: list[Point], settings_json: str) -> dict[str, Any] | None:
    """``validate_points`` under the service's settings as a Dask task: the 422 detail of the
    first bad point, or None."""
    with settings_scope(settings_of(settings_json)):
        try:
            validate_points(endpoint, sweep_points)
        except SweepRefused as exc:
            return exc.detail
    return None


def validation_on(client, endpoint: str, sweep_points: list[Point], settings_json: str,
                  workers: int) -> Callable[[], None]:
    """``validate_points`` started on the cluster's workers (the service's own process stays
    free for recording the points meanwhile, and W workers check a 1000-point sweep W times
    sooner); the call it returns waits for the verdict and raises the same refusal, the lowest
    bad point's."""
    size = max(len(sweep_points) // (2 * workers), 1)
    chunks = [sweep_points[i : i + size] for i in range(0, len(sweep_points), size)]
    futures = client.map(first_refusal, [endpoint] * len(chunks), chunks, [settings_json] * len(chunks),
                         key=[f"zeromode-validate-{uuid.uuid4().hex}" for _ in chunks], pure=False, priority=100)

    def verdict() -> None:
        refusals = [d for d in client.gather(futures) if d is not None]
        if refusals:
            raise SweepRefused(**min(refusals, key=lambda d: d["point"]))

    return verdict


# --- reading results back ------------------------------------------------------------------------


def row(record: dict[str, Any]) -> dict[str, Any]:
    """One table row of a finished point: its index, parameters, status, error code and every
    scalar field of its answer (dotted paths, e.g. ``report.mode_residual``)."""
    out: dict[str, Any] = {"point": record["point"], "status": record["status"]}
    for key, value in (record.get("params") or {}).items():
        out[f"param.{key}"] = value if value is None or isinstance(value, bool | int | float | str) else json.dumps(value)
    error = record.get("error")
    out["error"] = None if not error else error.get("code")
    if record.get("result"):
        out.update(_leaves(record["result"]))
    return out


def ndjson_line(record: dict[str, Any]) -> bytes:
    """One line of the NDJSON download: point, params, status, and result or error."""
    doc = {"point": record["point"], "params": record.get("params"), "status": record["status"]}
    doc["result" if record["status"] == "done" else "error"] = record.get("result") or record.get("error")
    return json.dumps(doc, separators=(",", ":")).encode() + b"\n"


def csv_text(rows: Iterable[dict[str, Any]]) -> str:
    rows = list(rows)
    columns = list(dict.fromkeys(key for r in rows for key in r))
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


# What the Parquet table needs (the ``tables`` extra): callers check it before any work.
PARQUET = ("a Parquet table", "pyarrow", "pyarrow.parquet")


def parquet_bytes(rows: Iterable[dict[str, Any]]) -> bytes:
    """The table as Parquet; MissingExtra where pyarrow is not installed (check ``PARQUET``
    with extras.require before the work that makes the rows)."""
    require(*PARQUET)
    import pyarrow as pa
    import pyarrow.parquet as pq

    def column(values: list[Any]):
        # A column whose values share no Arrow type (a parameter given as "-0.6" at one point
        # and -0.4 at another, as the endpoints' lax validation accepts) is its JSON texts.
        try:
            return pa.array(values)
        except (pa.ArrowException, OverflowError):
            return pa.array([None if v is None else json.dumps(v) for v in values], pa.string())

    rows = list(rows)
    columns = list(dict.fromkeys(key for r in rows for key in r))
    table = pa.table({c: column([r.get(c) for r in rows]) for c in columns})
    sink = io.BytesIO()
    pq.write_table(table, sink)
    return sink.getvalue()


# --- the library's sweep ---------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepProgress:
    """How far a sweep is: points ``done`` and ``failed`` of ``total``, ``elapsed`` seconds since
    it started. What ``on_progress`` receives (never the results: those are yielded). The
    client's zeromode_client.SweepProgress is its twin (the client imports no server code)."""

    done: int
    failed: int
    total: int
    elapsed: float

    @property
    def fraction(self) -> float:
        """Finished points (done or failed) over all points, in [0, 1]."""
        return (self.done + self.failed) / self.total if self.total else 1.0

    def __repr__(self) -> str:
        return f"SweepProgress(done={self.done}, failed={self.failed}, total={self.total}, elapsed={self.elapsed:.1f})"


def run_sweep(
    endpoint: str,
    template: dict[str, Any] | None = None,
    grid: dict[str, list[Any]] | None = None,
    requests: list[dict[str, Any]] | None = None,
    *,
    scheduler: str | None = None,
    settings: Settings | None = None,
    on_progress: Callable[[SweepProgress], None] | None = None,
) -> Iterator[dict[str, Any]]:
    """Run a sweep on Dask without any server, yielding each point's record as it finishes
    ({"point", "params", "status", "result" | "error"}); ``on_progress(SweepProgress)`` after
    each. The cluster is ``scheduler`` (tcp://host:8786), else ``settings.dask_scheduler``,
    else an embedded LocalCluster started for this call. Every point is validated first
    (SweepRefused names a bad one). Needs no optional package."""
    from distributed import as_completed

    from zeromode.service.jobs.cluster import chunked, dask_client

    started = time.monotonic()
    settings = current_settings() if settings is None else settings
    sweep_points = points(template or {}, grid, requests, settings.max_sweep_points)
    validate_points(endpoint, sweep_points)
    client, cluster = dask_client(settings, scheduler)
    try:
        workers = max(len(client.scheduler_info(n_workers=-1).get("workers", {})), 1)
        chunks = chunked(sweep_points, workers)
        futures = client.map(
            execute_chunk,
            [chunk_of([(str(p.index), endpoint, p.request) for p in chunk]) for chunk in chunks],
            [settings.model_dump_json()] * len(chunks),
            [True] * len(chunks),  # validated above
            key=[f"zeromode-sweep-{uuid.uuid4().hex}" for _ in chunks],
            pure=False,
        )
        done = failed = 0
        for future in as_completed(futures, loop=client.loop):
            for index, status, payload in future.result():
                done, failed = done + (status == "done"), failed + (status != "done")
                point = sweep_points[int(index)]
                record = {"point": point.index, "params": point.params, "status": status}
                record["result" if status == "done" else "error"] = json.loads(payload) if status == "done" else payload
                if on_progress is not None:
                    on_progress(SweepProgress(done, failed, len(sweep_points), time.monotonic() - started))
                yield record
            future.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# What the library's table needs (the ``tables`` extra).
DATAFRAME = ("sweep()'s DataFrame (run_sweep yields the records without it)", "pandas")


def sweep(endpoint: str, template: Mapping | None = None, grid: Mapping[str, Sequence] | None = None,
          requests: Sequence[Mapping] | None = None, **options: Any) -> pd.DataFrame:
    """A sweep over one endpoint's requests, run on Dask without a server, as a pandas DataFrame
    in point order (``zeromode.sweep``; the REST sweeps and ``zeromode sweep`` expand, validate
    and run the same points).

    Parameters
    ----------
    endpoint : str
        "/v1/design", "/v1/design/auxetic", … (or without "/v1/").
    template : dict, optional
        The request every point starts from (numpy arrays allowed).
    grid : dict of list, optional
        Dotted paths of the template and their values: every combination, the last fastest.
    requests : list of dict, optional
        Instead of a grid, one point per request merged over the template.
    **options
        As for ``run_sweep``: ``scheduler`` (tcp://host:8786; by default a LocalCluster for this
        call), ``settings``, ``on_progress``.

    Returns
    -------
    pandas.DataFrame
        One row per point: its parameters (``param.<path>``), status, error code and the
        answer's scalar fields (dotted paths).

    Needs pandas (``pip install 'zeromode[tables]'``): without it, MissingExtra (an ImportError
    whose message is the install line) is raised before anything is validated or run.
    ``run_sweep`` needs no optional package and yields the records as dicts.

    Examples
    --------
    The outward square (the paper's Fig. 3b) with 2 and 4 unspecified nodes: 8 and 12 bars.

    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> zm.sweep("design", {"dim": 2, "positions": square, "motions": [square]},
    ...          {"options.n_unspecified": [2, 4]})["report.bars"].tolist()
    [8, 12]
    """
    from zeromode.operations.documents import plain

    require(*DATAFRAME)
    import pandas as pd

    path = endpoint if endpoint.startswith("/") else f"/v1/{endpoint}"
    records = run_sweep(path, plain(template), plain(grid), plain(requests), **options)
    return pd.DataFrame([row(r) for r in sorted(records, key=lambda r: r["point"])])
