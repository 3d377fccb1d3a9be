"""What the library's functions return: a thin wrapper of one solver result and its request.

A result holds the validated request (a model of zeromode.service.schemas, the REST request
of the same call), the solver's own result (``solution``: a PipelineResult, an Analysis, a
MotionPath, …) and the REST body (``to_dict()``, made by zeromode.service.responses).  It
draws itself as POST /v1/plot draws the same document (zeromode.service.plotting and viz/),
writes files as POST /v1/export does (zeromode.service.exporting), and continues the pipeline
on its frame (``refine``, ``certify``, ``motion``).  Attributes it does not define are read
from ``solution`` (``zm.analyze(f).rank``).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import networkx as nx
    import numpy as np
    from matplotlib.figure import Figure
    from pydantic import BaseModel

    from zeromode.solver.frame import Frame
    from zeromode.viz.picture import Picture

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
        from zeromode.service.convert import frame_from_model
        from zeromode.service.schemas.common import FrameModel

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
        from zeromode.service.plotting import picture_for_document

        return picture_for_document(self.document(), solution_space=solution_space)

    def _repr_svg_(self) -> str:
        from zeromode.viz.svg import picture_svg

        return picture_svg(self.picture())

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The picture of ``_repr_svg_`` as a matplotlib Figure (``scale`` pixels per SVG pixel)."""
        from zeromode.viz.layout import layout
        from zeromode.viz.raster import draw_shapes, scene_figure

        scene = layout(self.picture(solution_space))
        figure, axes = scene_figure(scene, scale)
        draw_shapes(axes, scene.shapes)
        return figure

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
        from zeromode.service.cli import EXPORT_SUFFIXES
        from zeromode.service.exporting import export_file

        fmt = format or EXPORT_SUFFIXES.get(suffix)
        if fmt is None:
            raise ValueError(f"the suffix {suffix or '(none)'} names no export format; give format=.")
        content, _, _ = export_file(self._export_request(fmt, **options))
        path.write_bytes(content)
        return path

    def _export_request(self, fmt: str, **options: Any):
        """The /v1/export request that writes this result in format ``fmt``."""
        from zeromode._library import plain
        from zeromode.service.documents import validated
        from zeromode.service.schemas.export import ExportRequest

        return validated(plain({"format": fmt, **self._exported(), **options}), ExportRequest)

    def _exported(self) -> dict:
        """What a /v1/export request carries of this result: its document."""
        return {"document": self.document()}

    def animate(self, **options: Any) -> str:
        """The finite motion as an animated SVG (SMIL), as /v1/export writes ``svg_animation``:
        the result's own path, or one traced along its first mode. ``options``: the other
        fields of a /v1/export request (animation, motion)."""
        from zeromode.service.exporting import export_file

        content, _, _ = export_file(self._export_request("svg_animation", **options))
        return content.decode()

    def to_networkx(self) -> nx.Graph:
        """The frame as a networkx Graph, as the GraphML export writes it: node positions
        (``x``, ``y``[, ``z``]), ``role``, ``site``, mode components; bar ``length`` and index."""
        from zeromode.export.graphs import frame_graph
        from zeromode.service.exporting import takeaway_for

        return frame_graph(takeaway_for(self._export_request("node_link_json")), nested_metadata=True)

    # --- the pipeline, continued on this result's frame -------------------------------------

    def refine(self, motion: Any = None, **fields: Any) -> Result:
        """Refine this frame for finite-motion fidelity (POST /v1/refine; ``zm.refine``): the
        specified nodes follow ``motion`` (k, d), by default the first mode's rows on them."""
        from zeromode._library import refine

        if motion is None and "targets" not in fields:
            motion = self.modes[0][list(self.frame.specified)]
        return refine(self, motion, **fields)

    def certify(self, modes: Any = None, **options: Any) -> Result:
        """Certificates of this frame and its modes (POST /v1/certify; ``zm.certify``)."""
        from zeromode._library import certify

        return certify(self, self.modes if modes is None else modes, **options)

    def motion(self, mode: int | Any = 0, **fields: Any) -> Result:
        """The finite motion of this frame along its mode number ``mode`` (or a given (N, d)
        mode) (POST /v1/motion; ``zm.motion``)."""
        from zeromode._library import motion

        return motion(self, mode, **fields)


class AnalysisResult(Result):
    """``zm.analyze``: counts and bases of the zero modes and self-stresses (solution: Analysis)."""

    def document(self) -> dict:
        return {"frame": self.request.frame.model_dump(), "modes": self.body["modes"][:_plot_modes()]}


class DesignResult(Result):
    """``zm.design``, ``zm.auxetic``, ``zm.allosteric``, ``zm.two_configuration``: a designed frame."""


class MotionResult(Result):
    """``zm.motion``: a finite motion (solution: MotionPath); its document carries the frame it moved."""

    def document(self) -> dict:
        return {**self.body, "frame": self.request.frame.model_dump()}

    def picture(self, solution_space: bool = True) -> Picture:
        """The given frame, with the two ends of its path beside it (a /v1/plot body)."""
        from zeromode.service.plotting import picture_for_document

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
        from zeromode.service.plotting import picture_for_document

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


def _plot_modes() -> int:
    """How many modes a /v1/plot body draws at most (the first ones are drawn)."""
    from zeromode.service.schemas.plot import MAX_PLOT_MODES

    return MAX_PLOT_MODES


class MapResult(Result):
    """``zm.module_map``: a module's map d_out = f(d_in) (solution: ModuleMap); ``plot()`` charts
    f, the drawings are of the module's frame."""

    def document(self) -> dict:
        return {"frame": self.request.frame.model_dump()}

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The graph of f on its usable range, the diagonal, fixed points and folds."""
        from zeromode.viz.sequential import map_figure

        return map_figure(self.body, scale)


class SequentialResult(Result):
    """``zm.sequential``: a module designed for map features and its verified chain (solution:
    SequentialDesign); ``plot()`` charts the map with the chain's orbit and d_k along the chain;
    the drawings are of the chained frame (or the module without a chain)."""

    def document(self) -> dict:
        chain = self.body["chain"]
        return {"frame": (chain or self.body["module"])["frame"]}

    def plot(self, scale: float = 1.0, solution_space: bool = True) -> Figure:
        """The designed map (with the chain's cobweb) and the chain's distances."""
        from zeromode.viz.sequential import sequential_figure

        return sequential_figure(self.body, scale)
