"""The library: its functions and the results they return.

Each function validates its arguments as the REST request of the same call
(zeromode.service.wire.schemas: the same defaults, limits and 4xx-worthy refusals, raised here as
zeromode.solver.errors.InvalidInput), runs the endpoint's operation (zeromode.operations.endpoints:
the one its route, its job and the CLI run) and wraps the solver's result and the REST body in a
result object.

A result holds the validated request, the solver's own result (``solution``: a PipelineResult,
an Analysis, a MotionPath, …) and the REST body (``to_dict()``). It draws itself as POST
/v1/plot draws the same document (zeromode.operations.plotting and viz/), writes files as POST
/v1/export does (zeromode.operations.exporting), and continues the pipeline on its frame
(``refine``, ``certify``, ``motion``: the functions below, so results and functions live in one
module). Attributes it does not define are read from ``solution`` (``zm.analyze(f).rank``).

Domain failures are raised as the solver raises them (a DomainError with ``code``: the 422 of
the REST call; refinement, motion and allostery failures carry their best result).

Examples below use the paper's Fig. 3b: four specified nodes on a square moving outward,
u_S = x_S.
"""

from __future__ import annotations

import copy
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import count
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import networkx as nx
    import numpy as np
    from matplotlib.figure import Figure
    from pydantic import BaseModel

    from zeromode.solver.frame import Frame
    from zeromode.viz.picture import Picture

__all__ = [
    "Result",
    "allosteric",
    "analyze",
    "auxetic",
    "certify",
    "design",
    "module_map",
    "motion",
    "multistable",
    "refine",
    "sequential",
    "solution_space",
    "two_configuration",
]

Points = Sequence[Sequence[float]]


# ----------------------------------------------------------------------------- results


# Numbers the inline pictures of _repr_html_ blocks in this process: their SVG ids differ.
_HTML_PICTURES = count()

# Suffixes that name the picture itself (as ``zeromode plot`` writes it).
_PICTURE_SUFFIXES = (".svg", ".png", ".pdf")


@dataclass(frozen=True, eq=False)
class Result:
    """A library result: ``request`` (the REST request model), ``solution`` (the solver's
    result) and ``body`` (the REST response body; read it through ``to_dict()``)."""

    request: BaseModel
    solution: Any
    body: dict = field(repr=False)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or name in ("request", "solution", "body"):
            raise AttributeError(name)
        return getattr(self.solution, name)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} of {type(self.solution).__name__}>"

    # --- what it is -------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The REST response body of the same request (a fresh copy): POST /v1/… returns exactly
        this, apart from ``timings_ms``, which measure this call."""
        return copy.deepcopy(self.body)

    def document(self) -> dict:
        """The document /v1/plot and /v1/export read for this result (documents.kind): its body,
        or for a body without a frame, the frame with its modes."""
        return self.body

    def frame_body(self) -> dict:
        """The contract's Frame of this result (the designed, refined or given frame)."""
        return self.document()["frame"]

    @property
    def frame(self) -> Frame:
        """The result's frame as a zeromode Frame (positions (N, d), edges (B, 2), specified)."""
        from zeromode.service.wire.convert import frame_from_model
        from zeromode.service.wire.schemas.common import FrameModel

        return frame_from_model(FrameModel.model_validate(self.frame_body()))

    @property
    def modes(self) -> np.ndarray:
        """The result's zero modes beyond rigid motions (M, N, d): designed, refined or found."""
        import numpy as np

        frame = self.frame
        modes = self.body.get("modes") or self.document().get("modes")
        return np.asarray(modes or np.zeros((0, frame.n_nodes, frame.dim)), dtype=float)

    # --- pictures ---------------------------------------------------------------------------

    def picture(self, solution_space: bool = True) -> Picture:
        """The viz Picture POST /v1/plot (and ``zeromode plot``) draws for this result's document:
        specified nodes red, unspecified blue, bars grey, requested motions hollow green arrows,
        zero modes solid green, the solution space light blue (paper, Fig. 3)."""
        from zeromode.operations.plotting import picture_for_document

        return picture_for_document(self.document(), solution_space=solution_space)

    def _repr_svg_(self) -> str:
        from zeromode.viz.svg import picture_svg

        return picture_svg(self.picture())

    def _repr_html_(self) -> str:
        """The picture of ``_repr_svg_`` beside a table of the result's figures (``figures()``),
        one self-contained block: inline styles, no external CSS or script. The SVG's ids are
        numbered per block, as a page of several inline pictures needs (viz.svg.scene_svg)."""
        from html import escape

        from zeromode.viz.svg import picture_svg

        rows = "".join(
            f"<tr><td><code>{escape(name)}</code></td><td style='text-align:right'>{escape(_shown(value))}</td>"
            f"<td>{escape(unit)}</td><td>{escape(meaning)}</td></tr>"
            for name, value, unit, meaning in self.figures()
        )
        table = (
            "<table style='border-collapse:collapse;font-size:12px'><thead><tr><th>figure</th><th>value</th>"
            f"<th>unit</th><th>meaning</th></tr></thead><tbody>{rows}</tbody></table>"
        )
        return (
            f"<div style='display:flex;flex-wrap:wrap;gap:16px;align-items:flex-start'>"
            f"<div>{picture_svg(self.picture(), f'zm{next(_HTML_PICTURES)}-')}</div><div>{table}</div></div>"
        )

    def figures(self) -> list[tuple[str, Any, str, str]]:
        """The key figures of the REST body as (name, value, unit, meaning) rows: every number,
        flag and short text, by its dotted path (``report.analysis.rank``), and every list of
        records by its length (``samples``, unit ``count``; arrays are not figures); the meaning is the response model's description of
        the field (service.wire.schemas, the one place the contract describes it), the unit
        ``ms`` or ``s`` for timings and ``count`` for lengths, blank for the paper's
        dimensionless figures (counts, gaps, residuals, ε, ν)."""
        from zeromode.operations.endpoints import OPERATIONS

        model = next((op.response_model for op in OPERATIONS.values() if type(self.request) is op.request_model), None)
        return _figures(self.body, model, ())

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The picture of ``_repr_svg_`` as a matplotlib Figure (``scale`` pixels per SVG pixel)."""
        from zeromode.viz.layout import layout
        from zeromode.viz.raster import draw_shapes, scene_figure

        scene = layout(self.picture(solution_space))
        figure, axes = scene_figure(scene, scale)
        draw_shapes(axes, scene.shapes)
        return _shown_in_jupyter(figure)

    # --- taking it away ---------------------------------------------------------------------

    def export(self, path: str | Path, format: str | None = None, **options: Any) -> Path:
        """Write the result to ``path``, its format named by the suffix as ``zeromode export``
        names it (.vtu, .xdmf, .graphml, .json, .dxf, .stl, .csv, .gif, .mp4) or by ``format``
        (a /v1/export format: ``cut_svg``, ``svg_animation``, …); ``.svg``, ``.png`` and ``.pdf``
        without ``format`` are the picture.  ``options``: the other fields of a /v1/export
        request (fabrication, animation, motion, tolerance).  Returns the path."""
        path = Path(path)
        suffix = path.suffix.lower()
        if format is None and suffix in _PICTURE_SUFFIXES:
            from zeromode.viz.layout import layout

            scene = layout(self.picture())
            if suffix == ".svg":
                from zeromode.viz.svg import scene_svg

                path.write_text(scene_svg(scene), encoding="utf-8")
            else:
                from zeromode.viz.raster import write_raster

                write_raster(scene, path)
            return path
        from zeromode.operations.exporting import export_file, format_for_suffix

        fmt = format or format_for_suffix(suffix, self.document())
        if fmt is None:
            raise ValueError(f"the suffix {suffix or '(none)'} names no export format; give format=.")
        content, _, _ = export_file(self._export_request(fmt, **options))
        path.write_bytes(content)
        return path

    def _export_request(self, fmt: str, **options: Any):
        """The /v1/export request that writes this result in format ``fmt``."""
        from zeromode.operations.documents import plain, validated
        from zeromode.service.wire.schemas.export import ExportRequest

        return validated(plain({"format": fmt, **self._exported(), **options}), ExportRequest)

    def _exported(self) -> dict:
        """What a /v1/export request carries of this result: its document."""
        return {"document": self.document()}

    def animate(self, **options: Any) -> str:
        """The finite motion as an animated SVG (SMIL), as /v1/export writes ``svg_animation``:
        the result's own path, or one traced along its first mode. ``options``: the other
        fields of a /v1/export request (animation, motion)."""
        from zeromode.operations.exporting import export_file

        content, _, _ = export_file(self._export_request("svg_animation", **options))
        return content.decode()

    def to_networkx(self) -> nx.Graph:
        """The frame as a networkx Graph, as the GraphML export writes it: node positions
        (``x``, ``y``[, ``z``]), ``role``, ``site``, mode components; bar ``length`` and index."""
        from zeromode.export.graphs import frame_graph
        from zeromode.operations.exporting import takeaway_for

        return frame_graph(takeaway_for(self._export_request("node_link_json")), nested_metadata=True)

    # --- the pipeline, continued on this result's frame -------------------------------------

    def refine(self, motion: Any = None, **fields: Any) -> Result:
        """Refine this frame for finite-motion fidelity (POST /v1/refine; ``zm.refine``): the
        specified nodes follow ``motion`` (k, d), by default the first mode's rows on them."""
        if motion is None and "targets" not in fields:
            motion = self.modes[0][list(self.frame.specified)]
        return refine(self, motion, **fields)

    def certify(self, modes: Any = None, **options: Any) -> Result:
        """Certificates of this frame and its modes (POST /v1/certify; ``zm.certify``)."""
        return certify(self, self.modes if modes is None else modes, **options)

    def motion(self, mode: int | Any = 0, **fields: Any) -> Result:
        """The finite motion of this frame along its mode number ``mode`` (or a given (N, d)
        mode) (POST /v1/motion; ``zm.motion``)."""
        return motion(self, mode, **fields)


class AnalysisResult(Result):
    """``zm.analyze``: counts and bases of the zero modes and self-stresses (solution: Analysis)."""

    def document(self) -> dict:
        return {"frame": self.request.frame.model_dump(), "modes": self.body["modes"][:_plot_modes()]}


class SolutionSpaceResult(Result):
    """``zm.solution_space``: where one unspecified node joined to every specified node may sit
    (solution: SolutionSpace; ``kind``, ``nullity``, ``quadric``, … are read from it). It draws
    itself as the paper's Fig. 2: the specified nodes with their motions and the space (a /v1/plot
    body with the motion as the requested one and ``solution_space``)."""

    @property
    def sample_positions(self) -> np.ndarray:
        """x_U of the returned samples (n, d), each verified against all k bars."""
        return self._samples("position")

    @property
    def sample_motions(self) -> np.ndarray:
        """u_U of the returned samples (n, d), row for row with ``sample_positions``."""
        return self._samples("motion")

    def _samples(self, which: str) -> np.ndarray:
        import numpy as np

        rows = [s[which] for s in self.body["samples"]]
        return np.asarray(rows, dtype=float).reshape(len(rows), self.request.dim)

    def document(self) -> dict:
        """A /v1/plot body: the specified nodes, the motion as the requested one, the solution
        space; isolated solutions (``points``, the whole space) also as unspecified nodes, so
        that the picture's window holds every one of them."""
        r = self.request
        found = [s["position"] for s in self.body["samples"]] if self.body["kind"] == "points" else []
        frame = {"dim": r.dim, "positions": [*r.positions, *found], "edges": [],
                 "specified": list(range(len(r.positions)))}
        return {"frame": frame, "targets": [r.motions], "solution_space": True, "seed": r.seed}


class DesignResult(Result):
    """``zm.design``, ``zm.auxetic``, ``zm.allosteric``: a designed frame (and, as
    TwoConfigurationResult, ``zm.two_configuration``)."""


class TwoConfigurationResult(DesignResult):
    """``zm.two_configuration``: one frame that sits at both configurations (solution:
    TwoConfigurationDesign); it draws itself at x_S and at y_S side by side."""

    def picture(self, solution_space: bool = True) -> Picture:
        """The frame at ``initial`` and at ``final`` (``final_positions``), every bar the same
        length in both (a /v1/plot body)."""
        from zeromode.operations.plotting import picture_for_document

        return picture_for_document(
            {"frame": self.body["frame"], "configurations": [self.body["final_positions"]],
             "labels": ["initial", "final"]},
            solution_space=False,
        )


class MotionResult(Result):
    """``zm.motion``: a finite motion (solution: MotionPath); its document carries the frame it moved."""

    def document(self) -> dict:
        return {**self.body, "frame": self.request.frame.model_dump()}

    def picture(self, solution_space: bool = True) -> Picture:
        """The given frame, with the two ends of its path beside it (a /v1/plot body)."""
        from zeromode.operations.plotting import picture_for_document

        ends = [self.body["path"][0], self.body["path"][-1]]
        return picture_for_document(
            {"frame": self.request.frame.model_dump(), "configurations": ends,
             "labels": ["given", "one end of the path", "the other end"]},
            solution_space=False,
        )

    def _exported(self) -> dict:
        """A /v1/motion response with the frame it moved (the response has none)."""
        return {"document": self.body, "frame": self.request.frame.model_dump()}


class RefineResult(Result):
    """``zm.refine``: the refined frame with its path (solution: Refinement)."""

    def picture(self, solution_space: bool = True) -> Picture:
        """The refined frame with its refined mode (a /v1/plot body)."""
        from zeromode.operations.plotting import picture_for_document

        return picture_for_document(
            {"frame": self.body["frame"], "modes": self.body["modes"] or []}, solution_space=solution_space
        )


class CertificateResult(Result):
    """``zm.certify``: self-stress, prestress-stability and rigidity-margin certificates
    (solution: Certificate) of the request's frame and modes."""

    def document(self) -> dict:
        return {"frame": self.request.frame.model_dump(), "modes": self.request.modes[:_plot_modes()]}

    @property
    def modes(self) -> np.ndarray:
        """The modes the certificates were asked about (M, N, d)."""
        import numpy as np

        frame = self.frame
        return np.asarray(self.request.modes or np.zeros((0, frame.n_nodes, frame.dim)), dtype=float)


class MultistableResult(Result):
    """``zm.multistable``: rods and springs whose conformations are energy minima (solution:
    MultistableDesign). ``plot()`` draws the energy landscape under the motion; the picture
    (``_repr_svg_``) is the rods in the first conformation."""

    def plot(self, width: float = 6.4, height: float = 3.6) -> Figure:
        """E(s) along the motion with each minimum, its curvature and the barriers (a matplotlib
        Figure)."""
        from zeromode.viz.landscape import landscape_figure

        return _shown_in_jupyter(landscape_figure(self.body, width, height))


def _shown_in_jupyter(figure: Figure) -> Figure:
    """The figure, shown as a PNG when it ends a Jupyter cell. ``plot()`` figures are plain
    matplotlib Figures (no pyplot state, nothing left open in a script), and IPython draws a Figure
    only once its PNG formatter is registered, which ``%matplotlib inline`` or a pyplot figure does;
    without either, ``d.plot()`` showed ``<Figure size … with 1 Axes>``. Under IPython, the
    formatter is registered here where none is (IPython's own, drawing the page as laid out)."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    if shell is not None:
        from IPython.core.pylabtools import print_figure
        from matplotlib.figure import Figure

        png = shell.display_formatter.formatters["image/png"]
        try:
            png.lookup_by_type(Figure)
        except KeyError:
            png.for_type(Figure, lambda fig: print_figure(fig, "png", bbox_inches=None))
    return figure


# Texts longer than this are sentences (a path's verdict, a message), not figures of a table.
_FIGURE_TEXT = 40


def _figures(value: Mapping, model: Any, path: tuple[str, ...]) -> list[tuple[str, Any, str, str]]:
    """Result.figures of ``value`` (a body or a part of it) described by ``model`` (a pydantic
    model class, or None where the contract types the part as a plain dict)."""
    rows: list[tuple[str, Any, str, str]] = []
    fields = getattr(model, "model_fields", {})
    for key, v in value.items():
        info = fields.get(key)
        meaning = (info.description or "") if info is not None else ""
        name = ".".join((*path, key))
        if isinstance(v, Mapping):
            rows += _figures(v, _described_model(info.annotation) if info is not None else None, (*path, key))
        elif isinstance(v, list) and v and all(isinstance(item, Mapping) for item in v):
            rows.append((name, len(v), "count", meaning))
        elif isinstance(v, (bool, int, float)) or (isinstance(v, str) and len(v) <= _FIGURE_TEXT):
            timed = "timings_ms" in path or key.endswith("_ms")
            rows.append((name, v, "ms" if timed else "s" if key.endswith("_s") else "", meaning))
    return rows


def _described_model(annotation: Any) -> Any:
    """The pydantic model inside a field's annotation (``Model``, ``Model | None``), else None."""
    from typing import get_args

    from pydantic import BaseModel

    for t in (annotation, *get_args(annotation)):
        if isinstance(t, type) and issubclass(t, BaseModel):
            return t
    return None


def _shown(value: Any) -> str:
    """A figure as the table shows it: numbers to 6 significant digits."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _plot_modes() -> int:
    """How many modes a /v1/plot body draws at most (the first ones are drawn)."""
    from zeromode.service.wire.schemas.plot import MAX_PLOT_MODES

    return MAX_PLOT_MODES


class MapResult(Result):
    """``zm.module_map``: a module's map d_out = f(d_in) (solution: ModuleMap); ``plot()`` charts
    the module beside f, the drawing (``_repr_svg_``) is the module with its pairs marked; its
    document is the /v1/map answer (documents.MAP)."""

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The module (its pairs marked) beside the graph of f on its usable range, the diagonal,
        fixed points (filled: stable) and folds (viz.sequential.map_figure)."""
        from zeromode.viz.sequential import map_figure

        return _shown_in_jupyter(map_figure(self.body, self.frame, scale))

    def export(self, path: str | Path, format: str | None = None, **options: Any) -> Path:
        """As Result.export, but ``.svg``, ``.png`` and ``.pdf`` without ``format`` are the chart
        of ``plot()`` (as ``zeromode plot`` writes it) and ``.csv`` the sampled map (map_csv);
        the frame formats write the module, its input pair as source and output pair as target."""
        path = Path(path)
        if format is None and path.suffix.lower() in _PICTURE_SUFFIXES:
            self.plot().savefig(path)
            return path
        return super().export(path, format, **options)


class SequentialResult(Result):
    """``zm.sequential``: a module designed for map features and its verified chain (solution:
    SequentialDesign); ``plot()`` charts the map with the chain's orbit and d_k along the chain;
    the drawings are of the chained frame (or the module without a chain)."""

    def document(self) -> dict:
        chain = self.body["chain"]
        return {"frame": (chain or self.body["module"])["frame"]}

    def _exported(self) -> dict:
        """The whole response: exports mark the chain's input and output pairs and carry its
        figures (exporting.takeaway_for)."""
        return {"document": self.body}

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The designed map (with the chain's cobweb) and the chain's distances; for a soliton,
        the chain at several drives with its switched copies coloured, the wall and the energy
        against the drive."""
        from zeromode.viz.sequential import sequential_figure, soliton_figure

        return _shown_in_jupyter((soliton_figure if self.body.get("soliton") else sequential_figure)(self.body, scale))


# ----------------------------------------------------------------------------- helpers


def _frame_body(frame: Frame | Result | Mapping) -> dict:
    """The contract's Frame of a Frame, a library result (its frame) or a Frame body."""
    if isinstance(frame, Result):
        return frame.frame_body()
    from zeromode.operations.documents import plain
    from zeromode.service.wire.responses import frame_body

    if isinstance(frame, Mapping):
        return plain(frame)

    return frame_body(frame)


def _run(endpoint: str, body: dict, result: type[Result]) -> Any:
    """``body`` validated as the endpoint's request (InvalidInput naming the first bad field, as
    documents.validated refuses a document), run by the endpoint's operation (the one its route
    and its job run), wrapped with the body as the endpoint sends it (absent optional fields as
    null, as a job's answer is made: service.jobs.tasks.answer)."""
    from zeromode.operations.documents import plain, validated
    from zeromode.operations.endpoints import OPERATIONS, wire_body

    operation = OPERATIONS[endpoint]
    request = validated(plain(body), operation.request_model)
    outcome = operation.run(request)
    return result(request, outcome.solution, wire_body(endpoint, outcome.body))


def _dim(points: Points, dim: int | None) -> int:
    return dim if dim is not None else len(points[0])


# ----------------------------------------------------------------------------- analysis


def analyze(frame: Frame | Result | Mapping, **options: Any) -> AnalysisResult:
    """Zero modes, rigid motions and self-stresses of a frame (POST /v1/analyze).

    The compatibility matrix C (paper, Eq. 3, C u = 0: row e = (i, j) holds (x_i − x_j)ᵀ at node
    i and (x_j − x_i)ᵀ at node j, the edge constraint of Eq. 1) is ranked; its null space holds
    the zero modes, the null space of Cᵀ the self-stresses; without self-stresses the zero modes
    number N_D = dN − N_B (Eq. 2), d(d+1)/2 of them rigid motions.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame (a ``Frame``, a library result's frame, or {"dim", "positions", "edges"}).
    **options
        The request's ``options``: ``rtol``, ``method`` ("auto", "dense", "sparse"), ``bases``,
        ``gap_rtol``.

    Returns
    -------
    AnalysisResult
        Counts (``rank``, ``zero_modes``, ``nontrivial_zero_modes``, ``self_stresses``, …) read
        from the solver's Analysis; ``modes`` (M, N, d) orthonormal and ⟂ rigid motions.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = zm.Frame.build([[1, 1], [-1, 1], [-1, -1], [1, -1]], [[0, 1], [1, 2], [2, 3], [3, 0]])
    >>> a = zm.analyze(square); (a.rank, a.nontrivial_zero_modes, a.self_stresses)
    (4, 1, 0)
    """
    return _run("/v1/analyze", {"frame": _frame_body(frame), "options": options}, AnalysisResult)


# ----------------------------------------------------------------------------- design


def solution_space(positions: Points, motions: Points, *, dim: int | None = None, samples: int = 8,
                   seed: int = 0) -> SolutionSpaceResult:
    """Where an unspecified node joined by bars to all k specified nodes may sit, with its motion
    (POST /v1/solution-space; the paper's Fig. 2).

    Each bar keeps its length at first order when (x_Si − x_U)·(u_Si − u_U) = 0 (Eq. 1); with
    c = x_U·u_U these k equations are linear in ṽ = (x_U, u_U, c): Ã ṽ = b (Eqs. 4–5), solved by
    ṽ = ṽ* + W α, α ∈ ℝᵐ, m = dim N(Ã). The one nonlinear condition c = x_U·u_U is the quadric
    α̃ᵀ Q α̃ = 0 in α̃ = (α, 1) (Eq. 6). The space is ``points`` (m ≤ 1), a ``conic`` (m = 2) or a
    quadric (m ≥ 3). solver.construction.solution_space.

    Parameters
    ----------
    positions : (k, d) array_like
        x_S, the specified nodes.
    motions : (k, d) array_like
        u_S, one row per specified node.
    dim : {2, 3}, optional
        The dimension (by default the width of ``positions``).
    samples : int
        How many real solutions (x_U, u_U) to return, found on seeded random lines in α-space.
    seed : int
        Seed of those lines: same request, same samples.

    Returns
    -------
    SolutionSpaceResult
        ``kind``, ``nullity`` (m), ``w_tilde`` (W̃, (2d+1) × (m+1)), ``quadric`` (Q) from the
        solver's SolutionSpace; ``sample_positions`` and ``sample_motions`` (n, d). Raises
        DomainError ``no_solution`` when Ã ṽ = b has no solution.

    Examples
    --------
    The outward square (Fig. 3b, u_S = x_S): its four rows of Ã are dependent, so m = 2 and the
    space is a conic, the circle |x_U| = √2 through the nodes.

    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> s = zm.solution_space(square, square, samples=4); (s.kind, s.nullity)
    ('conic', 2)
    >>> import numpy as np; bool(np.allclose(np.linalg.norm(s.sample_positions, axis=1), np.sqrt(2)))
    True
    """
    return _run("/v1/solution-space", {
        "dim": _dim(positions, dim), "positions": positions, "motions": motions, "samples": samples, "seed": seed,
    }, SolutionSpaceResult)


def design(positions: Points, motions: Points | Sequence[Points], *, dim: int | None = None,
           **options: Any) -> DesignResult:
    """A frame whose only non-rigid zero modes are the given motions (POST /v1/design).

    Judicious constraint placement: each unspecified node is placed on the solution space of
    the specified nodes' motions (paper, Eqs. 4–6: the edge constraints Ã ṽ = b and the quadric
    α̃ᵀ Q α̃ = 0), joined to them by bars that the motions keep at first order (Eq. 1), until
    N_D = d(N_S + N_U) − N_B = d(d+1)/2 + M (Eq. 7 for M = 1); several motions share the nodes
    where their quadrics intersect (Eq. 8, Fig. 4). The designed frame is verified by one
    rigidity analysis. solver.pipeline.design_pipeline, with the stages ``options`` ask for.

    Parameters
    ----------
    positions : (k, d) array_like
        x_S, the specified nodes.
    motions : (k, d) or (M, k, d) array_like
        One motion u_S or M motions, each a row per specified node.
    dim : {2, 3}, optional
        The dimension (by default the width of ``positions``).
    **options
        The request's ``options``: ``seed``, ``n_unspecified``, ``refine`` (a dict of refinement
        options), ``certify`` (bool), ``tolerance`` (a dict).

    Returns
    -------
    DesignResult
        ``frame`` (specified nodes first), ``modes`` (M, N, d): the designed motions extended to
        every node; ``solution`` is the solver's PipelineResult.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> d = zm.design(square, square); d.to_dict()["report"]["bars"], d.modes.shape
    (8, (1, 6, 2))
    """
    import numpy as np

    from zeromode.operations.documents import plain

    motions = plain(motions)
    if np.ndim(motions) == 2:  # one motion
        motions = [motions]
    return _run("/v1/design", {
        "dim": _dim(positions, dim), "positions": positions, "motions": motions, "options": options,
    }, DesignResult)


def auxetic(poisson_ratio: float, cells: Sequence[int] = (4, 4), **fields: Any) -> DesignResult:
    """A lattice of coupled symmetric modules with one nontrivial zero mode of Poisson ratio ν
    (POST /v1/design/auxetic; the paper's Fig. 5a).

    ν = −ε_y / ε_x of the lattice's mode, measured on its boundary; a 2D sheet of n_x × n_y
    modules (``cells`` of two) or a 3D chain of n blocks (``cells`` of one), each module designed
    by judicious placement (Eqs. 4–7) and joined to its neighbours by merged nodes. Its usable strain
    range and expanded and contracted finite states come with it.

    Parameters
    ----------
    poisson_ratio : float
        ν of the mode.
    cells : sequence of int
        (n_x, n_y) modules of a sheet, or (n,) blocks of a chain.
    **fields
        The request's other fields: ``cell``, ``strain``, ``seed``, ``refine``, ``certify``,
        ``tolerance``, ``finite_strain``.

    Returns
    -------
    DesignResult
        ``solution`` is the solver's AuxeticResult (``solution.lattice``).

    Examples
    --------
    >>> import zeromode as zm
    >>> sheet = zm.auxetic(-0.5, (2, 2)); print(round(sheet.to_dict()["poisson_ratio"], 6))
    -0.5
    """
    return _run("/v1/design/auxetic", {
        "dim": 2 if len(cells) == 2 else 3, "cells": cells, "poisson_ratio": poisson_ratio, **fields,
    }, DesignResult)


def allosteric(source: Any, target: Any, *, frame: Frame | Result | Mapping | None = None,
               dim: int | None = None, source_motion: Points | None = None,
               target_motion: Points | None = None, strain_ratio: float | None = None,
               **options: Any) -> DesignResult:
    """Allostery: driving the source moves the distal target exactly as prescribed
    (POST /v1/design/allosteric; with ``frame``, POST /v1/design/allosteric/network).

    From scratch, each site is specified nodes with a motion, and the network between them is
    designed as in ``design`` (paper, Fig. 5b: relays on the sites' solution spaces, Eqs. 4–6). In a given
    ``frame``, the smallest change found (bars removed, nodes added on solution spaces) makes
    the source's motion (or strain) move the target's (or strain it by ``strain_ratio``).

    Parameters
    ----------
    source, target : site or node indices
        From scratch: {"positions": (k, d), "motion": (k, d)} or a pair (positions, motion).
        In a frame: the node indices of each site.
    frame : Frame, result or Frame body, optional
        The given network.
    dim : {2, 3}, optional
        From scratch: the dimension (by default the sites' width).
    source_motion, target_motion, strain_ratio
        In a frame: the motions of the sites, or the target pair's strain over the source pair's.
    **options
        The request's ``options`` (seed; from scratch also relay_spacing, relay_growth, tolerance;
        in a frame also ``response="elastic"`` — the bars are springs, the source strain is imposed,
        and bars are removed and one stiffness changed so that η = ``strain_ratio`` exactly for the
        stated ``stiffness`` (default 1 each, the tuned bar within ``max_stiffness`` × its own,
        default 10); the report gives that bar's dη/dk).

    Returns
    -------
    DesignResult
        ``solution``: the solver's AllostericDesign or NetworkAllostery.

    Examples
    --------
    >>> import zeromode as zm
    >>> site = lambda x0: {"positions": [[x0, 0], [x0 + 1, 0], [x0, 1]], "motion": [[1, 0], [0, 1], [1, 1]]}
    >>> a = zm.allosteric(site(0), site(6)); a.to_dict()["report"]["target_error"] < 1e-8
    True
    """
    if frame is not None:
        return _run("/v1/design/allosteric/network", {
            "frame": _frame_body(frame), "source": source, "target": target, "source_motion": source_motion,
            "target_motion": target_motion, "strain_ratio": strain_ratio, "options": options,
        }, DesignResult)
    sites = [s if isinstance(s, Mapping) else {"positions": s[0], "motion": s[1]} for s in (source, target)]
    return _run("/v1/design/allosteric", {
        "dim": _dim(sites[0]["positions"], dim), "source": sites[0], "target": sites[1], "options": options,
    }, DesignResult)


def two_configuration(initial: Points, final: Points, *, dim: int | None = None,
                      seed: int = 0) -> TwoConfigurationResult:
    """A frame whose specified nodes can sit at ``initial`` and at ``final`` with every bar
    keeping its length (POST /v1/design/two-configuration).

    The averaging principle: the midpoint frame (x_S + y_S)/2 designed with the flex
    (y_S − x_S)/2 keeps every bar length at both ends (|l(y) − l(x)| = 0 by Eq. 1 on the
    midpoint). Whether one continuous motion joins them is traced and reported.

    Parameters
    ----------
    initial, final : (k, d) array_like
        x_S and y_S.
    dim : {2, 3}, optional
        The dimension (by default the width of ``initial``).
    seed : int
        The design's seed.

    Returns
    -------
    TwoConfigurationResult
        ``solution`` is the solver's TwoConfigurationDesign; it draws the frame at both
        configurations.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> t = zm.two_configuration(square, [[1.5 * x, 1.5 * y] for x, y in square])
    >>> t.to_dict()["report"]["max_length_mismatch"] < 1e-9
    True
    """
    return _run("/v1/design/two-configuration", {
        "dim": _dim(initial, dim), "initial": initial, "final": final, "options": {"seed": seed},
    }, TwoConfigurationResult)


def multistable(conformations: Sequence[Points], *, barrier: float | None = None, max_stiffness: float = 1.0,
                dim: int | None = None, seed: int = 0, bifurcation: int | None = None) -> MultistableResult:
    """Rods and springs whose specified nodes rest in each of 2 or 3 conformations: a strict
    local minimum of the elastic energy E = Σ_s k_s (|x_i − x_j| − L_s)²/2 along the rods'
    one-degree-of-freedom motion, which passes through them in order (POST
    /v1/design/multistable).

    The linkage generalises the two-configuration design: for three conformations each new
    node solves, per anchor, two linear equations in (p^a, p^b, p^c, s_ab, s_ac) and two
    quadrics; the path is verified by continuation of the exact finite motion. The springs
    solve a cone program (E′ = 0, E″ ≥ floor, barriers ≥ ``barrier``, least stored energy).
    Every minimum is verified by the Hessian of the full energy (rods as stiff springs) and by
    seeded relaxations before the result is returned.

    Parameters
    ----------
    conformations : sequence of 2 or 3 (k, d) array_like
        The specified nodes in each conformation, k ≥ d + 1, in the order of the motion.
    barrier : float, optional
        Smallest barrier between neighbouring minima (default: half the largest the springs can make).
    max_stiffness : float
        Largest spring stiffness.
    dim : {2, 3}, optional
        The dimension (by default the width of the first conformation).
    seed : int
        Seed of the placement and the relaxations.
    bifurcation : int, optional
        Index of one of three 2D conformations where the rods' motion is to branch (the body's
        ``bifurcation``: both tangents, the rank drop, both continuations); the other two are
        the minima.

    Returns
    -------
    MultistableResult
        ``solution`` is the solver's MultistableDesign; ``plot()`` the energy landscape.

    Examples
    --------
    >>> import zeromode as zm
    >>> apex = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]
    >>> r = zm.multistable([[[0, 0], [1, 0], p] for p in apex])
    >>> [m["curvature"] > 0 for m in r.to_dict()["minima"]]
    [True, True, True]
    """
    return _run("/v1/design/multistable", {
        "dim": _dim(conformations[0], dim), "conformations": conformations,
        "options": {"barrier": barrier, "max_stiffness": max_stiffness, "seed": seed, "bifurcation": bifurcation},
    }, MultistableResult)


# ----------------------------------------------------------------------------- beyond the linear design


def motion(frame: Frame | Result | Mapping, mode: int | Points | None = None, **fields: Any) -> MotionResult:
    """The finite motion of a frame along a zero mode (POST /v1/motion).

    Predictor–corrector continuation: every configuration keeps every bar length (Eq. 1 at
    finite amplitude, max_relative_bar_error ≤ 1e-9) and is aligned to the input frame.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame to move.
    mode : int or (N, d) array_like, optional
        A mode, or the number of one of the result's ``modes``; by default the frame's one
        nontrivial zero mode.
    **fields
        The request's other fields: ``amplitude``, ``max_step``, ``max_steps``, ``direction``,
        ``on_singularity``, ``boundary``, ``target``, ``epsilon_curve`` (``{"amplitude": a}``:
        the body's ``epsilon_curve``, ε along the path for the specified nodes' linear target).

    Returns
    -------
    MotionResult
        ``solution`` is the solver's MotionPath (``positions`` (P, N, d), ``parameter``).

    Raises
    ------
    SingularPath
        A singular point on the path with ``on_singularity="error"`` (the default), as the
        route's 422 ``singular_path``; ``exc.path`` is the path up to it.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> m = zm.design(square, square).motion(amplitude=0.2); m.to_dict()["max_relative_bar_error"] < 1e-9
    True
    """
    if isinstance(mode, int):  # the number of one of the result's modes, or of the frame's
        mode = (frame if isinstance(frame, Result) else analyze(frame)).modes[mode]
    return _run("/v1/motion", {"frame": _frame_body(frame), "mode": mode, **fields}, MotionResult)


def refine(frame: Frame | Result | Mapping, motion: Points | None = None, **fields: Any) -> RefineResult:
    """Move the unspecified nodes so that the finite motion carries the specified nodes to
    x_S + a Δ_S along a continuous path (POST /v1/refine).

    The paper's design keeps bar lengths to first order (Eq. 1); at finite amplitude the path
    drifts. casadi + IPOPT with exact derivatives minimise that finite-motion infidelity ε(a)
    (the specified nodes' distance from x_S + a Δ_S along the traced path, over K
    configurations), reported before and after; the refined frame is re-verified (no new self-stress, one
    nontrivial zero mode at both ends).

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame, its ``specified`` nodes first.
    motion : (k, d) array_like, optional
        Δ_S; or give ``targets`` (k, d) instead.
    **fields
        The request's other fields: ``amplitude``, ``targets``, ``options`` (K, tol, max_iter,
        max_time_s, stay_on_solution_space).

    Returns
    -------
    RefineResult
        ``solution`` is the solver's Refinement (``epsilon_before``, ``epsilon_after``, …, and
        ``curve_before``/``curve_after``: ε at 12 amplitudes in (0, a], the body's
        ``epsilon_curve``, ending on ε before and after).

    Raises
    ------
    RefinementFailed
        IPOPT found no better frame (the route's 422); ``exc.best`` is the best one found.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> r = zm.design(square, square).refine().to_dict()
    >>> r["status"], r["epsilon_after"] <= r["epsilon_before"]
    ('ok', True)
    >>> r["epsilon_curve"]["after"][-1] == r["epsilon_after"]
    True
    """
    return _run("/v1/refine", {"frame": _frame_body(frame), "motion": motion, **fields}, RefineResult)


def certify(frame: Frame | Result | Mapping, modes: Sequence[Points] = (), **options: Any) -> CertificateResult:
    """Self-stress, prestress-stability and rigidity-margin certificates (POST /v1/certify).

    Self-stresses (Cᵀ s = 0, the left null space of Eq. 3's C; the paper's count N_D = dN − N_B,
    Eq. 2, holds only without them) with their singular-value evidence; prestress stability decided by
    an SDP over the stresses, with its margin; the rigidity margin of the frame's motions beyond
    rigid motions and the designed ``modes``, for uniform and SDP-optimal bar stiffness.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame.
    modes : sequence of (N, d) array_like
        The designed motions the margin leaves out.
    **options
        The request's ``options``: ``solver``, ``stiffness``, ``max_iters``.

    Returns
    -------
    CertificateResult
        ``solution`` is the solver's Certificate (``self_stress``, ``prestress``,
        ``rigidity_margin``).

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> c = zm.design(square, square).certify(); c.to_dict()["self_stress"]["count"]
    0
    """
    return _run("/v1/certify", {"frame": _frame_body(frame), "modes": modes, "options": options}, CertificateResult)


# ----------------------------------------------------------------------------- modules as maps


def module_map(frame: Frame | Result | Mapping, input_pair: Sequence[int], output_pair: Sequence[int], *,
               at: Sequence[float] = ()) -> MapResult:
    """The map d_out = f(d_in) of a one-mode module between its input and output node pairs,
    from its exact finite motion (POST /v1/map; arXiv 1906.08400's modules as maps).

    Parameters
    ----------
    frame : Frame, result or Frame body
        A frame with exactly one nontrivial zero mode.
    input_pair, output_pair : (2,) node indices
        d_in = |x_a − x_b|, d_out = |x_c − x_e| (neither pair a bar).
    at : input distances
        Where f and f′ are evaluated exactly (inside the usable range).

    Returns
    -------
    MapResult
        ``solution`` is the solver's ModuleMap; ``to_dict()`` the samples, the usable range
        between folds, the fixed points and the values at ``at``; ``plot()`` the graph of f.

    Examples
    --------
    >>> import zeromode as zm
    >>> module = zm.Frame.build([[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.15, 0.45]],
    ...                         [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]])
    >>> m = zm.module_map(module, (0, 1), (2, 3), at=[1.0])
    >>> m.to_dict()["lower"]["kind"], round(m.to_dict()["evaluated"][0]["d_out"], 6)
    ('fold', 1.944466)
    """
    return _run("/v1/map", {
        "frame": _frame_body(frame), "input_pair": input_pair, "output_pair": output_pair, "at": at,
    }, MapResult)


def sequential(features: Sequence[Mapping], *, n_modules: int | None = None, d0: float | None = None,
               start: Mapping | None = None, reach: float = 3.0, soliton: Mapping | None = None) -> SequentialResult:
    """A module whose map has the requested features, and optionally a chain of ``n_modules``
    copies verified by continuation against the map's iterates (POST /v1/design/sequential).

    Parameters
    ----------
    features : list of dicts
        ``{"kind": "fixed_point", "d": d*, "slope": f′(d*)}``,
        ``{"kind": "period_two", "d1": …, "d2": …}`` or
        ``{"kind": "range", "source": [a, b], "target": [c, e]}``; met together, to map_rtol.
    n_modules : int, optional
        Chain this many copies (the output pair of one is the input pair of the next).
    d0 : float, optional
        The first copy's input distance (default: the first feature's first input).
    start : dict, optional
        ``{"frame": …, "input_pair": …, "output_pair": …}``, the module optimised (default: the
        two-triangle module).
    reach : float
        Nodes stay within this many RMS radii of the start's centre.
    soliton : dict, optional
        ``{"n_modules": n, "stiffness": k}`` (instead of ``n_modules``): a soliton chain, for two
        fixed-point features (one slope > 1, one in (0, 1)); one spring per copy makes both
        uniform states zero-energy minima and the domain wall travels along the chain as d_0 is
        driven (solver.sequential.soliton; docs/module_maps.md).

    Returns
    -------
    SequentialResult
        ``solution`` is the solver's SequentialDesign (``solution.soliton`` the Soliton); a
        feature out of reach raises DomainError ``feature_out_of_reach`` with ``best``, a soliton
        that fails its checks ``soliton_not_verified``.

    Examples
    --------
    >>> import zeromode as zm
    >>> s = zm.sequential([{"kind": "fixed_point", "d": 1.5, "slope": -0.5}])
    >>> s.to_dict()["deviation"] <= s.to_dict()["map_rtol"]
    True
    """
    chain = None if n_modules is None else {"n_modules": n_modules, "d0": d0}
    return _run("/v1/design/sequential", {
        "features": list(features), "start": start, "chain": chain, "reach": reach,
        "soliton": None if soliton is None else dict(soliton),
    }, SequentialResult)
