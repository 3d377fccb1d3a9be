"""Results as small frozen dataclasses holding read-only numpy arrays.

Every result keeps the decoded JSON answer in ``raw``, so fields the service adds later are
reachable before this client names them. Arrays compare by identity (``eq=False``): compare
them with numpy, not with ``==`` on the dataclass.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def readonly(values: Any, tail: tuple[int, ...] = (), dtype: type = np.float64) -> np.ndarray:
    """``values`` as a read-only array of shape (n, *tail); an empty list becomes shape (0, *tail)."""
    array: np.ndarray = np.array(values, dtype=dtype)
    if tail and array.size == 0:
        array = array.reshape((0, *tail))
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Frame:
    """A bar-and-joint frame: N nodes in d = 2 or 3 dimensions joined by N_B bars.

    ``positions`` is N×d, ``edges`` N_B×2 (0-based node indices), ``specified`` the indices of
    the specified nodes. Only shapes are checked here; the service validates the rest
    (finiteness, index ranges, self-loops, duplicate edges, ...) and answers with a code.
    """

    positions: FloatArray
    edges: IntArray
    specified: tuple[int, ...]

    def __init__(self, positions: ArrayLike, edges: ArrayLike = (), specified: Sequence[int] = ()):
        x = readonly(positions)
        if x.ndim != 2:
            raise ValueError(f"positions must be an N×d array, got shape {x.shape}.")
        e = np.asarray(edges)
        if e.size and e.dtype.kind not in "iu":
            raise ValueError("edges must hold integer node indices.")
        e = readonly(e, (2,), np.int64)
        if e.ndim != 2 or e.shape[1] != 2:
            raise ValueError(f"edges must be an N_B×2 array, got shape {e.shape}.")
        object.__setattr__(self, "positions", x)
        object.__setattr__(self, "edges", e)
        object.__setattr__(self, "specified", tuple(int(i) for i in specified))

    @property
    def dim(self) -> int:
        return int(self.positions.shape[1])

    def to_json(self) -> dict[str, Any]:
        """The API's Frame object (plain lists, ready for ``json.dumps``)."""
        return {
            "dim": self.dim,
            "positions": self.positions.tolist(),
            "edges": self.edges.tolist(),
            "specified": list(self.specified),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Frame:
        """Read the API's Frame object (as decoded by ``json.loads``)."""
        frame = cls(data["positions"], data.get("edges", ()), data.get("specified", ()))
        if "dim" in data and data["dim"] != frame.dim:
            raise ValueError(f"dim is {data['dim']} but the positions have {frame.dim} columns.")
        return frame


@dataclass(frozen=True)
class Health:
    status: str
    version: str


@dataclass(frozen=True)
class RankGap:
    """Singular values σ_r and σ_{r+1} of the scale-normalised compatibility matrix; a singular
    value lies within the relative distance ``last_nonzero_error`` of ``last_nonzero`` (0 from
    servers that do not report it)."""

    last_nonzero: float
    first_zero: float
    last_nonzero_error: float = 0.0


@dataclass(frozen=True, eq=False)
class Analysis:
    """POST /v1/analyze: counts of a frame's zero modes and self-stresses, and their bases.

    ``modes`` has shape (nontrivial_zero_modes, N, d) and ``stresses`` (self_stresses, N_B)
    when the service included the bases (``bases_included``); both are empty otherwise.
    """

    nodes: int
    edges: int
    dim: int
    maxwell_count: int
    rank: int
    zero_modes: int
    rigid_body_modes: int
    nontrivial_zero_modes: int
    self_stresses: int
    rank_gap: RankGap
    modes: FloatArray
    stresses: FloatArray
    bases_included: bool
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Analysis:
        n, d = int(data["nodes"]), int(data["dim"])
        gap = data["rank_gap"]
        return cls(
            nodes=n,
            edges=int(data["edges"]),
            dim=d,
            maxwell_count=int(data["maxwell_count"]),
            rank=int(data["rank"]),
            zero_modes=int(data["zero_modes"]),
            rigid_body_modes=int(data["rigid_body_modes"]),
            nontrivial_zero_modes=int(data["nontrivial_zero_modes"]),
            self_stresses=int(data["self_stresses"]),
            rank_gap=RankGap(
                float(gap["last_nonzero"]), float(gap["first_zero"]), float(gap.get("last_nonzero_error", 0.0))
            ),
            modes=readonly(data.get("modes", []), (n, d)),
            stresses=readonly(data.get("stresses", []), (int(data["edges"]),)),
            bases_included=bool(data.get("bases_included", True)),
            raw=data,
        )


@dataclass(frozen=True, eq=False)
class SolutionSpace:
    """POST /v1/solution-space: the (x_U, u_U) of one unspecified node joined to all k specified nodes.

    ``basis`` is W̃ ((2d+1)×(m+1), rows ordered x_U, u_U, c), ``quadric`` is Q ((m+1)×(m+1))
    with α̃ᵀQα̃ = 0, and the real samples are split into ``sample_positions`` and
    ``sample_motions`` (both n×d).
    """

    nullity: int
    dimension: int
    kind: str
    basis: FloatArray
    quadric: FloatArray
    sample_positions: FloatArray
    sample_motions: FloatArray
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, data: dict[str, Any], dim: int) -> SolutionSpace:
        m = int(data["nullity"])
        samples = data.get("samples", [])
        return cls(
            nullity=m,
            dimension=int(data["dimension"]),
            kind=str(data["kind"]),
            basis=readonly(data["basis"], (m + 1,)),
            quadric=readonly(data["quadric"], (m + 1,)),
            sample_positions=readonly([s["position"] for s in samples], (dim,)),
            sample_motions=readonly([s["motion"] for s in samples], (dim,)),
            raw=data,
        )


@dataclass(frozen=True, eq=False)
class Design:
    """POST /v1/design: the designed frame, its M zero modes (M×N×d) and the service's report."""

    frame: Frame
    modes: FloatArray
    report: dict[str, Any]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Design:
        frame = Frame.from_json(data["frame"])
        return cls(
            frame=frame,
            modes=readonly(data["modes"], frame.positions.shape),
            report=data.get("report", {}),
            raw=data,
        )


@dataclass(frozen=True, eq=False)
class EpsilonCurve:
    """The service's finite-motion fidelity ε(b) at amplitudes b in (0, a] (``epsilon_curve`` of
    POST /v1/refine, or of POST /v1/motion when asked): ``amplitudes`` (m,), and ``curves`` by
    name, each (m,): ``before`` and ``after`` (refine) or ``epsilon`` (motion). A value the service
    could not measure (null) is NaN."""

    amplitudes: FloatArray
    curves: dict[str, FloatArray]

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EpsilonCurve:
        # numpy reads null (None) as NaN in a float array.
        names = [k for k in ("before", "after", "epsilon") if k in data]
        return cls(amplitudes=readonly(data["amplitudes"]), curves={k: readonly(data[k]) for k in names})

    def __getitem__(self, name: str) -> FloatArray:
        return self.curves[name]


@dataclass(frozen=True, eq=False)
class Result:
    """The answer of a capability endpoint (certify, motion, refine, design/auxetic, ...).

    Their fields grow with the service, so the answer is kept whole: ``result["field"]`` or
    ``result.raw``; ``result.array("field")`` gives a read-only float array, and ``frame`` /
    ``modes`` are parsed when the answer carries them.
    """

    path: str
    raw: dict[str, Any]

    def __getitem__(self, key: str) -> Any:
        return self.raw[key]

    def __contains__(self, key: object) -> bool:
        return key in self.raw

    def array(self, key: str) -> FloatArray:
        return readonly(self.raw[key])

    @property
    def frame(self) -> Frame | None:
        return Frame.from_json(self.raw["frame"]) if "frame" in self.raw else None

    @property
    def modes(self) -> FloatArray | None:
        if "modes" not in self.raw:
            return None
        frame = self.frame
        return readonly(self.raw["modes"], frame.positions.shape if frame is not None else ())

    @property
    def epsilon_curve(self) -> EpsilonCurve | None:
        """ε(b) of a refinement, or of a motion asked for it; None when the answer has none."""
        data = self.raw.get("epsilon_curve")
        return None if data is None else EpsilonCurve.from_json(data)


@dataclass(frozen=True, eq=False)
class ExportFile:
    """A file written by POST /v1/export: its bytes, media type and the file name the service
    suggests. ``save(path)`` writes it (default: that name, in the working directory)."""

    content: bytes = field(repr=False)
    media_type: str
    filename: str

    def save(self, path: str | os.PathLike[str] | None = None) -> Path:
        target = Path(self.filename if path is None else path)
        target.write_bytes(self.content)
        return target


@dataclass(frozen=True, eq=False)
class JobStatus:
    """GET /v1/jobs/{id}: a job's state, ``progress`` in [0, 1]; ``result`` (the endpoint's
    answer) once ``status`` is ``"done"``, ``error`` (``{"code", "message"}``) once ``"failed"``."""

    id: str
    endpoint: str
    status: str
    progress: float
    message: str
    result: Result | None
    error: dict[str, Any] | None
    created: str
    finished: str | None
    raw: dict[str, Any] = field(repr=False)

    @property
    def finished_running(self) -> bool:
        """Done, failed, cancelled, or interrupted (its service stopped too often)."""
        return self.status in ("done", "failed", "cancelled", "interrupted")

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> JobStatus:
        endpoint = str(data["endpoint"])
        result = data.get("result")
        return cls(
            id=str(data["id"]),
            endpoint=endpoint,
            status=str(data["status"]),
            progress=float(data["progress"]),
            message=str(data.get("message", "")),
            result=Result(endpoint, result) if result is not None else None,
            error=data.get("error"),
            created=str(data["created"]),
            finished=data.get("finished"),
            raw=data,
        )


@dataclass(frozen=True, eq=False)
class SweepPoint:
    """One finished point of a sweep: its index and parameters, its status, and ``result`` (the
    endpoint's answer) when ``status`` is ``"done"``, else ``error`` (``{"code", "message"}``)."""

    point: int
    params: dict[str, Any]
    status: str
    result: Result | None
    error: dict[str, Any] | None

    @classmethod
    def from_json(cls, endpoint: str, data: dict[str, Any]) -> SweepPoint:
        result = data.get("result")
        return cls(
            point=int(data["point"]),
            params=dict(data.get("params") or {}),
            status=str(data["status"]),
            result=Result(endpoint, result) if result is not None else None,
            error=data.get("error"),
        )


@dataclass(frozen=True)
class SweepProgress:
    """How far a sweep is: points ``done`` and ``failed`` of ``total``, ``elapsed`` seconds since
    it was submitted. What ``sweep``'s ``on_progress`` receives (never the results: those are
    yielded). The library's zeromode.service.jobs.sweeps.SweepProgress is its twin (this package
    imports no server code)."""

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


@dataclass(frozen=True, eq=False)
class SweepStatus:
    """GET /v1/sweeps/{id}: counts of points by state, and a page of finished points
    (``results``; pass ``next`` as ``after`` for the following page)."""

    id: str
    endpoint: str
    status: str
    total: int
    done: int
    failed: int
    running: int
    queued: int
    cancelled: int
    interrupted: int
    progress: float
    results: list[SweepPoint]
    next: int
    raw: dict[str, Any] = field(repr=False)

    @property
    def finished_running(self) -> bool:
        return self.status in ("done", "cancelled")

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SweepStatus:
        endpoint = str(data["endpoint"])
        counts = {k: int(data[k]) for k in ("total", "done", "failed", "running", "queued", "cancelled", "interrupted")}
        return cls(
            id=str(data["id"]),
            endpoint=endpoint,
            status=str(data["status"]),
            progress=float(data["progress"]),
            results=[SweepPoint.from_json(endpoint, r) for r in data.get("results", [])],
            next=int(data["next"]),
            raw=data,
            **counts,
        )
