"""Pictures of the service's documents: what POST /v1/plot and ``zeromode plot`` draw.

A /v1/plot body becomes a viz Picture field by field. A request or response document of
/v1/design, /v1/design/auxetic or /v1/design/allosteric is recognised by its fields; a request
is designed first (``endpoints.respond``) and drawn as its response is, so a request and its response
give the same picture.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from zeromode.operations import endpoints
from zeromode.operations.documents import (
    ALLOSTERIC,
    AUXETIC,
    DESIGN,
    MULTISTABLE,
    AllostericDocument,
    AuxeticDocument,
    DesignDocument,
    MapDocument,
    framed,
    kind,
    validated,
)
from zeromode.service.wire.convert import frame_from_model
from zeromode.service.wire.schemas.allostery import AllostericRequest
from zeromode.service.wire.schemas.plot import PlotRequest
from zeromode.solver.errors import InvalidInput
from zeromode.viz.designs import allosteric_picture, design_picture, lattice_picture
from zeromode.viz.picture import Picture
from zeromode.viz.sequential import map_figure, module_picture

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def picture_from_request(request: PlotRequest) -> Picture:
    """The Picture of a validated /v1/plot body: its fields are Picture.build's arguments (raises
    InvalidInput as Picture.build does)."""
    return Picture.build(frame_from_model(request.frame), **{k: v for k, v in request if k != "frame"})


def picture_for_document(doc: dict, solution_space: bool = True) -> Picture:
    """The picture of a document, recognised by its fields.

    - a /v1/design/auxetic response (``states``, ``poisson_ratio``): viz.designs.lattice_picture;
    - a /v1/design/allosteric response (``report`` with ``source``, ``target``, ``relays``):
      viz.designs.allosteric_picture with the achieved target motion (equal to the prescribed
      one to ``report.target_error``);
    - a /v1/design response (``frame``, ``modes``, ``report``): viz.designs.design_picture;
    - any other document with a ``frame``: a /v1/plot body, whose ``solution_space`` defaults
      to true here;
    - a /v1/design/sequential response: its chain's frame (else its module's) (documents.framed);
    - a /v1/map request or response: the module with its input pair marked as the source and its
      output pair as the target (viz.sequential.module_picture; its chart beside the map is
      figure_for_document's);
    - requests of /v1/design/allosteric (``source``, ``target``), /v1/design/auxetic (``cells``
      or ``poisson_ratio``), /v1/design (``positions``, ``motions``), /v1/design/multistable and
      /v1/design/sequential (``features``) are designed first; an allosteric request's own
      target motion is then drawn as the requested one.

    ``solution_space`` false never draws the solution space; true draws it for designs and
    plot bodies with a motion and specified nodes.  Raises InvalidInput on anything else.
    """
    if not isinstance(doc, dict):
        raise InvalidInput("invalid_document", "the document must be a JSON object.")
    answer = endpoints.map_answer(doc)
    if answer is not None:
        return module_picture(*map_module(answer))
    doc = framed(doc)
    if "frame" not in doc:
        response, request = endpoints.respond(doc)
        if isinstance(request, AllostericRequest):
            a = validated(response, AllostericDocument)
            return allosteric_picture(
                frame_from_model(a.frame), a.modes, a.report.source, a.report.target, request.target.motion
            )
        return picture_for_document(response, solution_space)
    what = kind(doc)
    if what == AUXETIC:
        a = validated(doc, AuxeticDocument)
        states = {s.name: (s.positions, s.poisson_ratio) for s in a.states}
        return lattice_picture(frame_from_model(a.frame), a.modes, a.poisson_ratio, states, a.report.boundary)
    if what == ALLOSTERIC:
        a = validated(doc, AllostericDocument)
        return allosteric_picture(
            frame_from_model(a.frame), a.modes, a.report.source, a.report.target, a.report.achieved_target_motion
        )
    if what in (DESIGN, MULTISTABLE):
        d = validated(doc, DesignDocument)
        return design_picture(frame_from_model(d.frame), d.modes, solution_space)
    request = validated(doc, PlotRequest)
    wanted = solution_space and doc.get("solution_space", True)
    has_motion = bool(request.modes or request.targets)
    return picture_from_request(
        request.model_copy(update={"solution_space": bool(wanted and has_motion and request.frame.specified)})
    )


def map_module(answer: dict):
    """(frame, input_pair, output_pair) of a /v1/map answer; InvalidInput ``invalid_document``
    for an answer without its frame (one from before answers carried it)."""
    m = validated(answer, MapDocument)
    if m.frame is None:
        raise InvalidInput(
            "invalid_document", "this /v1/map answer has no frame (it predates them): draw its request instead."
        )
    return frame_from_model(m.frame), m.input_pair, m.output_pair


def figure_for_document(doc, scale: float = 1.0, title: str | None = None) -> Figure | None:
    """The matplotlib chart of a /v1/map request or response (a request answered first): the
    module beside its map f with the diagonal, usable range, fixed points (filled: stable) and
    folds, ``title`` above (viz.sequential.map_figure; the map alone for an answer without its
    frame); None for any other document, whose picture is picture_for_document's."""
    answer = endpoints.map_answer(doc)
    if answer is None:
        return None
    frame = validated(answer, MapDocument).frame
    return map_figure(answer, None if frame is None else frame_from_model(frame), scale, title)
