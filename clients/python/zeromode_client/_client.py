"""Client and AsyncClient: one typed method per endpoint, over httpx."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator, Callable, Iterator, Mapping, Sequence
from types import TracebackType
from typing import Any, Literal, Self, TypeVar

import httpx
from numpy.typing import ArrayLike

from zeromode_client import _endpoints as ep
from zeromode_client._core import DEFAULT_TIMEOUT, VERSION, Call, Retry, build_request, parse
from zeromode_client._errors import ZeromodeError, ZeromodeTimeoutError
from zeromode_client._models import (
    Analysis,
    Design,
    ExportFile,
    Frame,
    Health,
    JobStatus,
    Result,
    SolutionSpace,
    SweepPoint,
    SweepProgress,
    SweepStatus,
)

T = TypeVar("T")
# Finished points fetched per poll of a sweep; a full page is followed at once by the next.
SWEEP_PAGE = 500
FrameLike = Frame | Mapping[str, Any]
TimeoutLike = float | httpx.Timeout | None


class _BaseClient:
    """Configuration shared by both clients (nothing here sends anything)."""

    def __init__(
        self,
        base_url: str,
        *,
        api_key: str | None,
        timeout: TimeoutLike,
        retries: int,
        backoff: float,
        headers: Mapping[str, str] | None,
    ) -> None:
        self._retry = Retry(retries, backoff)
        self._options: dict[str, Any] = {
            "base_url": base_url.rstrip("/"),
            "timeout": timeout,
            "headers": {
                "user-agent": f"zeromode-client/{VERSION}",
                **({"x-api-key": api_key} if api_key is not None else {}),
                **(headers or {}),
            },
        }

    @property
    def base_url(self) -> str:
        return str(self._options["base_url"])

    @property
    def retries(self) -> int:
        return self._retry.retries


class Client(_BaseClient):
    """Synchronous client for the zeromode REST service.

    ``Client("http://127.0.0.1:8000", api_key=None, timeout=DEFAULT_TIMEOUT, retries=2,
    backoff=0.5)``. Use it as a context manager (or call ``close()``). Every method raises
    ``ZeromodeError`` on an error answer (``.status``, ``.code``, ``.message``),
    ``ZeromodeConnectionError`` once ``retries`` reconnections have failed, and
    ``ZeromodeTimeoutError`` when an answer takes longer than ``timeout``.
    """

    def __init__(
        self,
        base_url: str,
        *,
        api_key: str | None = None,
        timeout: TimeoutLike = DEFAULT_TIMEOUT,
        retries: int = 2,
        backoff: float = 0.5,
        headers: Mapping[str, str] | None = None,
        transport: httpx.BaseTransport | None = None,
    ) -> None:
        super().__init__(
            base_url,
            api_key=api_key,
            timeout=timeout,
            retries=retries,
            backoff=backoff,
            headers=headers,
        )
        self._http = httpx.Client(**self._options, transport=transport)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def _send(self, call: Call[T]) -> T:
        request = build_request(self._http, call)
        attempt = 1
        while True:
            try:
                return parse(call, self._http.send(request))
            except httpx.TransportError as exc:
                delay = self._retry.delay_after(exc, request, attempt)
            time.sleep(delay)
            attempt += 1

    def health(self) -> Health:
        """GET /health."""
        return self._send(ep.health())

    def analyze(
        self,
        frame: FrameLike,
        *,
        rtol: float | None = None,
        method: Literal["auto", "dense", "sparse"] | None = None,
        bases: bool | None = None,
        gap_rtol: float | None = None,
    ) -> Analysis:
        """POST /v1/analyze: rank, zero modes, rigid motions and self-stresses of ``frame``
        (``gap_rtol``: σ_r converged to this relative error bound)."""
        return self._send(ep.analyze(frame, _given(rtol=rtol, method=method, bases=bases, gap_rtol=gap_rtol)))

    def solution_space(
        self, positions: ArrayLike, motions: ArrayLike, samples: int = 8, **fields: Any
    ) -> SolutionSpace:
        """POST /v1/solution-space for x_S and u_S (both k×d); ``fields`` such as ``seed`` are sent too."""
        return self._send(ep.solution_space(positions, motions, samples, fields))

    def design(self, positions: ArrayLike, motions: ArrayLike, **options: Any) -> Design:
        """POST /v1/design: ``motions`` is k×d or M×k×d; ``options`` go to the request's options."""
        return self._send(ep.design(positions, motions, options))

    def certify(self, frame: FrameLike, **fields: Any) -> Result:
        """POST /v1/certify with ``{"frame": frame, **fields}``."""
        return self._send(ep.capability("/v1/certify", fields, frame))

    def motion(
        self,
        frame: FrameLike,
        *,
        mode: ArrayLike | None = None,
        amplitude: float | None = None,
        target: Mapping[str, Any] | None = None,
        max_step: float | None = None,
        max_steps: int | None = None,
        direction: Literal["both", "forward", "backward"] | None = None,
        on_singularity: Literal["error", "report"] | None = None,
        boundary: Mapping[str, Any] | None = None,
        epsilon_curve: Mapping[str, Any] | None = None,
    ) -> Result:
        """POST /v1/motion: the finite motion of ``frame`` along ``mode`` (default its single
        nontrivial mode), to ``amplitude`` or, instead, until ``target`` is reached exactly —
        ``{"kind": "distance", "nodes": [i, j], "value": L}``, ``{"kind": "angle", "nodes":
        [i, j, k], "value": θ}`` (radians at j; signed in 2D), ``{"kind": "strain", "axis": "x",
        "value": ε}`` (with ``boundary``) or ``{"kind": "fraction", "value": f}``; the answer's
        ``["target"]`` says where. ``epsilon_curve={"amplitude": a}`` (and optionally
        ``"motion": u_S``) also answers the fidelity ε along the path for the specified nodes'
        linear target (``result.epsilon_curve``). Unset keywords take the service's defaults."""
        return self._send(ep.motion(frame, _given(
            mode=mode, amplitude=amplitude, target=target, max_step=max_step, max_steps=max_steps,
            direction=direction, on_singularity=on_singularity, boundary=boundary,
            epsilon_curve=epsilon_curve,
        )))

    def refine(self, frame: FrameLike, **fields: Any) -> Result:
        """POST /v1/refine with ``{"frame": frame, **fields}``."""
        return self._send(ep.capability("/v1/refine", fields, frame))

    def design_auxetic(self, **fields: Any) -> Result:
        """POST /v1/design/auxetic with ``fields`` as the request object."""
        return self._send(ep.capability("/v1/design/auxetic", fields))

    def design_allosteric(self, **fields: Any) -> Result:
        """POST /v1/design/allosteric with ``fields`` as the request object."""
        return self._send(ep.capability("/v1/design/allosteric", fields))

    def design_allosteric_network(self, frame: FrameLike, *, response: str | None = None, **fields: Any) -> Result:
        """POST /v1/design/allosteric/network with ``{"frame": frame, **fields}`` (source, target,
        and source_motion with target_motion, or strain_ratio): the given network changed so
        that its response is exact; ``result.frame`` is the modified network. ``response``:
        "mechanism" (the server's default: one exact mechanism, bars removed and nodes added) or
        "elastic" (springs under an imposed source strain: bars removed and one stiffness
        changed; ``result["stiffness"]``, ``result["report"]["tuned"]``), sent as options.response."""
        return self._send(ep.allosteric_network(frame, fields, response))

    def design_two_configuration(self, **fields: Any) -> Result:
        """POST /v1/design/two-configuration with ``fields`` (dim, initial, final, options)."""
        return self._send(ep.capability("/v1/design/two-configuration", fields))

    def design_multistable(self, **fields: Any) -> Result:
        """POST /v1/design/multistable with ``fields`` (dim, conformations, options: barrier,
        max_stiffness, seed, bifurcation): rods and springs whose 2 or 3 conformations are energy
        minima, or whose motion branches at the conformation ``bifurcation`` names."""
        return self._send(ep.capability("/v1/design/multistable", fields))

    def module_map(self, frame: FrameLike, input_pair: Sequence[int], output_pair: Sequence[int],
                   **fields: Any) -> Result:
        """POST /v1/map: the module's map d_out = f(d_in) between the pairs (``fields``: at)."""
        return self._send(ep.capability("/v1/map", {"input_pair": list(input_pair),
                                                    "output_pair": list(output_pair), **fields}, frame))

    def design_sequential(self, **fields: Any) -> Result:
        """POST /v1/design/sequential with ``fields`` (features, start, chain, reach)."""
        return self._send(ep.capability("/v1/design/sequential", fields))

    def plot(self, frame: FrameLike, **fields: Any) -> str:
        """POST /v1/plot with ``{"frame": frame, **fields}`` (modes, targets, solution_space, …):
        the picture as SVG text."""
        return self._send(ep.plot(frame, fields))

    def examples(self) -> list[dict[str, str]]:
        """GET /v1/examples: the named examples, each ``{"name", "description", "endpoint"}`` (the
        path its request is for)."""
        return self._send(ep.examples())

    def example(self, name: str) -> dict[str, Any]:
        """GET /v1/examples/{name}/request: a ready /v1/design request body."""
        return self._send(ep.example(name))

    def export(self, document: Any = None, format: str = "vtk", **fields: Any) -> ExportFile:
        """POST /v1/export: ``document`` — a result of this client (its JSON answer is sent), a
        response or request body, or None with ``frame=`` — written in ``format`` (vtk, xdmf,
        graphml, node_link_json, dxf, cut_svg, stl, kit_csv, svg_animation, gif, mp4);
        ``fields`` are the request's other fields (frame, modes, path, springs, fabrication,
        animation, motion, tolerance). A multistable design's springs are exported as springs
        (their own cell kind, edge kind, DXF layer and kit rows), never as rods. Returns an
        ExportFile (``.content``, ``.save(path)``)."""
        return self._send(ep.export(document, format, fields))

    def export_formats(self) -> list[dict[str, Any]]:
        """GET /v1/export/formats: name, media type, suffix and availability of each format."""
        return self._send(ep.export_formats())

    def submit_job(self, endpoint: str, request: Mapping[str, Any]) -> str:
        """POST /v1/jobs: run ``endpoint`` (e.g. ``"/v1/design/auxetic"``) with ``request`` as its
        body in the background, under the service's longer job time budget; returns the job id.
        An invalid ``request`` is refused at once (ZeromodeError, status 422)."""
        return self._send(ep.submit_job(endpoint, request))

    def job(self, job_id: str) -> JobStatus:
        """GET /v1/jobs/{id}: status, progress (0..1) and message; the result once done."""
        return self._send(ep.job(job_id))

    def wait(self, job_id: str, poll: float = 0.5, timeout: float | None = None) -> Result:
        """Poll the job every ``poll`` s until it finishes and return its result. A failed job
        raises ZeromodeError with the endpoint's code and message (``status`` None); a job still
        running after ``timeout`` s raises ZeromodeTimeoutError (it keeps running)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            status = self.job(job_id)
            if status.finished_running:
                return _job_result(status)
            time.sleep(_poll_delay(f"job {job_id}", poll, deadline, timeout))


    def cancel_job(self, job_id: str) -> JobStatus:
        """DELETE /v1/jobs/{id}: cancel the job if it has not finished (a running one is stopped); its status after."""
        return self._send(ep.cancel_job(job_id))

    def submit_sweep(
        self,
        endpoint: str,
        template: Mapping[str, Any] | None = None,
        grid: Mapping[str, Any] | None = None,
        requests: list[Mapping[str, Any]] | None = None,
    ) -> str:
        """POST /v1/sweeps: every combination of ``grid`` (dotted paths of ``template`` and their
        values, e.g. ``{"poisson_ratio": [-0.3, -0.5], "options.seed": [0, 1]}``), or one point
        per request of ``requests``; all are validated first (a bad point is a ZeromodeError
        ``invalid_point`` naming it). Returns the sweep id."""
        return self._send(ep.submit_sweep(endpoint, template, grid, requests))

    def sweep_status(self, sweep_id: str, after: int = 0, limit: int = 100) -> SweepStatus:
        """GET /v1/sweeps/{id}: counts by state and the points finished after cursor ``after``."""
        return self._send(ep.sweep_status(sweep_id, after, limit))

    def cancel_sweep(self, sweep_id: str) -> SweepStatus:
        """DELETE /v1/sweeps/{id}: cancel the points that have not run."""
        return self._send(ep.cancel_sweep(sweep_id))

    def sweep_results(self, sweep_id: str, format: str = "ndjson") -> bytes:
        """The finished points as a file: ``"ndjson"`` (whole answers), ``"csv"`` or
        ``"parquet"`` (a table of the answers' scalar fields)."""
        return self._send(ep.sweep_results(sweep_id, format))

    def sweep(
        self,
        endpoint: str,
        template: Mapping[str, Any] | None = None,
        grid: Mapping[str, Any] | None = None,
        requests: list[Mapping[str, Any]] | None = None,
        *,
        on_progress: Callable[[SweepProgress], None] | None = None,
        poll: float = 0.5,
        timeout: float | None = None,
    ) -> Iterator[SweepPoint]:
        """Submit a sweep (as ``submit_sweep``) and yield its points as they finish;
        ``on_progress(SweepProgress)`` after every poll (``.done``, ``.failed``, ``.total``,
        ``.elapsed``: the counts only, never the results). Past ``timeout`` s raises
        ZeromodeTimeoutError (the sweep keeps running)."""
        started = time.monotonic()
        sweep_id = self.submit_sweep(endpoint, template, grid, requests)
        deadline = None if timeout is None else started + timeout
        after = 0
        while True:
            status = self.sweep_status(sweep_id, after, SWEEP_PAGE)
            if on_progress is not None:
                on_progress(_progress(status, started))
            yield from status.results
            after = status.next
            if len(status.results) < SWEEP_PAGE:  # every finished point is read
                if status.finished_running:
                    return
                time.sleep(_poll_delay(f"sweep {sweep_id}", poll, deadline, timeout))


class AsyncClient(_BaseClient):
    """Asynchronous twin of ``Client``: same constructor, same methods, each awaited."""

    def __init__(
        self,
        base_url: str,
        *,
        api_key: str | None = None,
        timeout: TimeoutLike = DEFAULT_TIMEOUT,
        retries: int = 2,
        backoff: float = 0.5,
        headers: Mapping[str, str] | None = None,
        transport: httpx.AsyncBaseTransport | None = None,
    ) -> None:
        super().__init__(
            base_url,
            api_key=api_key,
            timeout=timeout,
            retries=retries,
            backoff=backoff,
            headers=headers,
        )
        self._http = httpx.AsyncClient(**self._options, transport=transport)

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        await self._http.aclose()

    async def _send(self, call: Call[T]) -> T:
        request = build_request(self._http, call)
        attempt = 1
        while True:
            try:
                return parse(call, await self._http.send(request))
            except httpx.TransportError as exc:
                delay = self._retry.delay_after(exc, request, attempt)
            await asyncio.sleep(delay)
            attempt += 1

    async def health(self) -> Health:
        return await self._send(ep.health())

    async def analyze(
        self,
        frame: FrameLike,
        *,
        rtol: float | None = None,
        method: Literal["auto", "dense", "sparse"] | None = None,
        bases: bool | None = None,
        gap_rtol: float | None = None,
    ) -> Analysis:
        return await self._send(
            ep.analyze(frame, _given(rtol=rtol, method=method, bases=bases, gap_rtol=gap_rtol))
        )

    async def solution_space(
        self, positions: ArrayLike, motions: ArrayLike, samples: int = 8, **fields: Any
    ) -> SolutionSpace:
        return await self._send(ep.solution_space(positions, motions, samples, fields))

    async def design(self, positions: ArrayLike, motions: ArrayLike, **options: Any) -> Design:
        return await self._send(ep.design(positions, motions, options))

    async def certify(self, frame: FrameLike, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/certify", fields, frame))

    async def motion(
        self,
        frame: FrameLike,
        *,
        mode: ArrayLike | None = None,
        amplitude: float | None = None,
        target: Mapping[str, Any] | None = None,
        max_step: float | None = None,
        max_steps: int | None = None,
        direction: Literal["both", "forward", "backward"] | None = None,
        on_singularity: Literal["error", "report"] | None = None,
        boundary: Mapping[str, Any] | None = None,
        epsilon_curve: Mapping[str, Any] | None = None,
    ) -> Result:
        return await self._send(ep.motion(frame, _given(
            mode=mode, amplitude=amplitude, target=target, max_step=max_step, max_steps=max_steps,
            direction=direction, on_singularity=on_singularity, boundary=boundary,
            epsilon_curve=epsilon_curve,
        )))

    async def refine(self, frame: FrameLike, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/refine", fields, frame))

    async def design_auxetic(self, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/design/auxetic", fields))

    async def design_allosteric(self, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/design/allosteric", fields))

    async def design_allosteric_network(self, frame: FrameLike, *, response: str | None = None,
                                        **fields: Any) -> Result:
        return await self._send(ep.allosteric_network(frame, fields, response))

    async def design_two_configuration(self, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/design/two-configuration", fields))

    async def design_multistable(self, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/design/multistable", fields))

    async def module_map(self, frame: FrameLike, input_pair: Sequence[int], output_pair: Sequence[int],
                         **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/map", {"input_pair": list(input_pair),
                                                          "output_pair": list(output_pair), **fields}, frame))

    async def design_sequential(self, **fields: Any) -> Result:
        return await self._send(ep.capability("/v1/design/sequential", fields))

    async def plot(self, frame: FrameLike, **fields: Any) -> str:
        return await self._send(ep.plot(frame, fields))

    async def examples(self) -> list[dict[str, str]]:
        return await self._send(ep.examples())

    async def example(self, name: str) -> dict[str, Any]:
        return await self._send(ep.example(name))

    async def export(self, document: Any = None, format: str = "vtk", **fields: Any) -> ExportFile:
        return await self._send(ep.export(document, format, fields))

    async def export_formats(self) -> list[dict[str, Any]]:
        return await self._send(ep.export_formats())

    async def submit_job(self, endpoint: str, request: Mapping[str, Any]) -> str:
        return await self._send(ep.submit_job(endpoint, request))

    async def job(self, job_id: str) -> JobStatus:
        return await self._send(ep.job(job_id))

    async def wait(self, job_id: str, poll: float = 0.5, timeout: float | None = None) -> Result:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            status = await self.job(job_id)
            if status.finished_running:
                return _job_result(status)
            await asyncio.sleep(_poll_delay(f"job {job_id}", poll, deadline, timeout))


    async def cancel_job(self, job_id: str) -> JobStatus:
        return await self._send(ep.cancel_job(job_id))

    async def submit_sweep(
        self,
        endpoint: str,
        template: Mapping[str, Any] | None = None,
        grid: Mapping[str, Any] | None = None,
        requests: list[Mapping[str, Any]] | None = None,
    ) -> str:
        return await self._send(ep.submit_sweep(endpoint, template, grid, requests))

    async def sweep_status(self, sweep_id: str, after: int = 0, limit: int = 100) -> SweepStatus:
        return await self._send(ep.sweep_status(sweep_id, after, limit))

    async def cancel_sweep(self, sweep_id: str) -> SweepStatus:
        return await self._send(ep.cancel_sweep(sweep_id))

    async def sweep_results(self, sweep_id: str, format: str = "ndjson") -> bytes:
        return await self._send(ep.sweep_results(sweep_id, format))

    async def sweep(
        self,
        endpoint: str,
        template: Mapping[str, Any] | None = None,
        grid: Mapping[str, Any] | None = None,
        requests: list[Mapping[str, Any]] | None = None,
        *,
        on_progress: Callable[[SweepProgress], None] | None = None,
        poll: float = 0.5,
        timeout: float | None = None,
    ) -> AsyncIterator[SweepPoint]:
        started = time.monotonic()
        sweep_id = await self.submit_sweep(endpoint, template, grid, requests)
        deadline = None if timeout is None else started + timeout
        after = 0
        while True:
            status = await self.sweep_status(sweep_id, after, SWEEP_PAGE)
            if on_progress is not None:
                on_progress(_progress(status, started))
            for point in status.results:
                yield point
            after = status.next
            if len(status.results) < SWEEP_PAGE:  # every finished point is read
                if status.finished_running:
                    return
                await asyncio.sleep(_poll_delay(f"sweep {sweep_id}", poll, deadline, timeout))


def _given(**options: Any) -> dict[str, Any]:
    """The options the caller set (None means: the service's default)."""
    return {k: v for k, v in options.items() if v is not None}


def _progress(status: SweepStatus, started: float) -> SweepProgress:
    return SweepProgress(status.done, status.failed, status.total, time.monotonic() - started)


def _job_result(status: JobStatus) -> Result:
    """A finished job's result, or its failure as the ZeromodeError the endpoint would have raised."""
    if status.result is not None:
        return status.result
    error = status.error or {"code": "job_failed", "message": status.message}
    code, message = str(error.get("code", "job_failed")), str(error.get("message", ""))
    raise ZeromodeError(message, code=code, detail=error)


def _poll_delay(what: str, poll: float, deadline: float | None, timeout: float | None) -> float:
    """Seconds to sleep before the next poll; raises ZeromodeTimeoutError past the deadline."""
    if deadline is None:
        return poll
    left = deadline - time.monotonic()
    if left <= 0:
        raise ZeromodeTimeoutError(f"{what} did not finish within {timeout:g} s.")
    return min(poll, left)
