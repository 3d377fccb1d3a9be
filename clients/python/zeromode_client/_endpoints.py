"""One builder per endpoint of the REST contract: the request body and the parser of the answer."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any
from urllib.parse import quote

import numpy as np
from numpy.typing import ArrayLike

from zeromode_client._core import Call, jsonable
from zeromode_client._models import (
    Analysis,
    Design,
    ExportFile,
    Frame,
    Health,
    JobStatus,
    Result,
    SolutionSpace,
    SweepStatus,
)


def as_frame(frame: Frame | Mapping[str, Any]) -> Frame:
    return frame if isinstance(frame, Frame) else Frame.from_json(frame)


def points(values: ArrayLike, name: str) -> np.ndarray:
    """A k×d array of specified positions or motions (shape errors caught before sending)."""
    array = np.asarray(values, dtype=float)
    if array.ndim != 2:
        raise ValueError(f"{name} must be a k×d array, got shape {array.shape}.")
    return array


def health() -> Call[Health]:
    return Call(
        "GET", "/health", None, lambda data: Health(str(data["status"]), str(data["version"]))
    )


def analyze(frame: Frame | Mapping[str, Any], options: Mapping[str, Any]) -> Call[Analysis]:
    body: dict[str, Any] = {"frame": as_frame(frame).to_json()}
    if options:
        body["options"] = jsonable(options)
    return Call("POST", "/v1/analyze", body, Analysis.from_json)


def solution_space(
    positions: ArrayLike, motions: ArrayLike, samples: int, fields: Mapping[str, Any]
) -> Call[SolutionSpace]:
    """``fields`` (e.g. ``seed``) are sent beside dim, positions, motions and samples."""
    x_s, u_s = points(positions, "positions"), points(motions, "motions")
    dim = x_s.shape[1]
    body = {
        "dim": dim,
        "positions": x_s.tolist(),
        "motions": u_s.tolist(),
        "samples": samples,
        **jsonable(fields),
    }
    return Call("POST", "/v1/solution-space", body, lambda data: SolutionSpace.from_json(data, dim))


def design(positions: ArrayLike, motions: ArrayLike, options: Mapping[str, Any]) -> Call[Design]:
    """``motions`` is one k×d target motion or a stack of M of them (M×k×d)."""
    x_s = points(positions, "positions")
    u_s = np.asarray(motions, dtype=float)
    if u_s.ndim == 2:
        u_s = u_s[np.newaxis]
    if u_s.ndim != 3:
        raise ValueError(f"motions must be k×d or M×k×d, got shape {u_s.shape}.")
    body = {
        "dim": x_s.shape[1],
        "positions": x_s.tolist(),
        "motions": u_s.tolist(),
        "options": jsonable(options),
    }
    return Call("POST", "/v1/design", body, Design.from_json)


def capability(
    path: str, fields: Mapping[str, Any], frame: Frame | Mapping[str, Any] | None = None
) -> Call[Result]:
    """A capability endpoint: ``{"frame": frame, **fields}`` is sent as the JSON object, unchanged."""
    body = {"frame": as_frame(frame), **fields} if frame is not None else dict(fields)
    return Call("POST", path, jsonable(body), lambda data: Result(path, data))


def allosteric_network(frame: Frame | Mapping[str, Any], fields: Mapping[str, Any],
                       response: str | None) -> Call[Result]:
    """POST /v1/design/allosteric/network; ``response`` ("mechanism" or "elastic"), when given,
    goes into the request's options beside any the caller set."""
    if response is not None:
        fields = {**fields, "options": {**(fields.get("options") or {}), "response": response}}
    return capability("/v1/design/allosteric/network", fields, frame)


def motion(frame: Frame | Mapping[str, Any], options: Mapping[str, Any]) -> Call[Result]:
    """POST /v1/motion: the frame and the options the caller set."""
    return capability("/v1/motion", options, frame)


def plot(frame: Frame | Mapping[str, Any], fields: Mapping[str, Any]) -> Call[str]:
    """POST /v1/plot: the SVG document (text)."""
    body = jsonable({"frame": as_frame(frame), **fields})
    return Call("POST", "/v1/plot", body, lambda response: response.text, raw=True)


def examples() -> Call[list[dict[str, str]]]:
    return Call("GET", "/v1/examples", None, lambda data: [dict(item) for item in data])


def example(name: str) -> Call[dict[str, Any]]:
    return Call("GET", f"/v1/examples/{quote(name, safe='')}/request", None, dict)


def export(document: Any, fmt: str, fields: Mapping[str, Any]) -> Call[ExportFile]:
    """POST /v1/export: ``document`` (a result of this client, or any JSON document) in ``fmt``."""
    body = {"format": fmt, **({"document": document} if document is not None else {}), **fields}

    def read(response: Any) -> ExportFile:
        disposition = response.headers.get("content-disposition", "")
        name = disposition.split("filename=")[-1].strip('"') if "filename=" in disposition else f"zeromode-export.{fmt}"
        media_type = response.headers.get("content-type", "application/octet-stream").split(";")[0]
        return ExportFile(response.content, media_type, name)

    return Call("POST", "/v1/export", jsonable(body), read, raw=True)


def export_formats() -> Call[list[dict[str, Any]]]:
    return Call("GET", "/v1/export/formats", None, lambda data: [dict(item) for item in data])


def submit_job(endpoint: str, request: Mapping[str, Any]) -> Call[str]:
    """POST /v1/jobs: ``request`` is ``endpoint``'s body; the answer's job id."""
    body = {"endpoint": endpoint, "request": jsonable(request)}
    return Call("POST", "/v1/jobs", body, lambda data: str(data["id"]))


def job(job_id: str) -> Call[JobStatus]:
    return Call("GET", f"/v1/jobs/{quote(job_id, safe='')}", None, JobStatus.from_json)


def cancel_job(job_id: str) -> Call[JobStatus]:
    return Call("DELETE", f"/v1/jobs/{quote(job_id, safe='')}", None, JobStatus.from_json)


def submit_sweep(
    endpoint: str,
    template: Mapping[str, Any] | None,
    grid: Mapping[str, Any] | None,
    requests: list[Mapping[str, Any]] | None,
) -> Call[str]:
    """POST /v1/sweeps: a template with a grid of dotted paths (or a list of requests); the id."""
    body: dict[str, Any] = {"endpoint": endpoint, "template": jsonable(template or {})}
    if grid is not None:
        body["grid"] = jsonable(grid)
    if requests is not None:
        body["requests"] = jsonable(list(requests))
    return Call("POST", "/v1/sweeps", body, lambda data: str(data["id"]))


def sweep_status(sweep_id: str, after: int = 0, limit: int = 100) -> Call[SweepStatus]:
    path = f"/v1/sweeps/{quote(sweep_id, safe='')}?after={int(after)}&limit={int(limit)}"
    return Call("GET", path, None, SweepStatus.from_json)


def cancel_sweep(sweep_id: str) -> Call[SweepStatus]:
    return Call("DELETE", f"/v1/sweeps/{quote(sweep_id, safe='')}", None, SweepStatus.from_json)


SWEEP_FORMATS = ("ndjson", "csv", "parquet")


def sweep_results(sweep_id: str, fmt: str) -> Call[bytes]:
    """GET /v1/sweeps/{id}/results.{ndjson|csv|parquet}: the file's bytes."""
    if fmt not in SWEEP_FORMATS:
        raise ValueError(f"format must be one of {', '.join(SWEEP_FORMATS)}, got {fmt!r}.")
    return Call("GET", f"/v1/sweeps/{quote(sweep_id, safe='')}/results.{fmt}", None,
                lambda response: response.content, raw=True)
