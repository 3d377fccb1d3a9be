"""Pictures of the service's documents: what POST /v1/plot and ``zeromode plot`` draw.

A /v1/plot body becomes a viz Picture field by field. A request or response document of
/v1/design, /v1/design/auxetic or /v1/design/allosteric is recognised by its fields; a request
is designed first (``_respond``) and drawn as its response is, so a request and its response
give the same picture.
"""

from __future__ import annotations

from pydantic import BaseModel, ValidationError

from zeromode.service.convert import frame_from_model
from zeromode.service.responses import allosteric_body, auxetic_body, design_body
from zeromode.service.schemas.allostery import AllostericRequest
from zeromode.service.schemas.common import FrameModel, Points
from zeromode.service.schemas.design import DesignRequest
from zeromode.service.schemas.lattice import AuxeticRequest, LatticeState
from zeromode.service.schemas.plot import PlotRequest
from zeromode.solver.allostery import design_allosteric
from zeromode.solver.errors import InvalidInput
from zeromode.solver.lattice import Lattice, auxetic_chain_3d, auxetic_sheet
from zeromode.solver.pipeline import design_pipeline
from zeromode.viz.designs import allosteric_picture, design_picture, lattice_picture
from zeromode.viz.picture import Picture


def picture_from_request(request: PlotRequest) -> Picture:
    """The Picture of a validated /v1/plot body: its fields are Picture.build's arguments (raises
    InvalidInput as Picture.build does)."""
    return Picture.build(frame_from_model(request.frame), **{k: v for k, v in request if k != "frame"})


# The fields of each response a picture reads (pydantic ignores the rest).
class _Design(BaseModel):
    frame: FrameModel
    modes: list[Points] = []


class _AuxeticReport(BaseModel):
    boundary: dict[str, list[int]] | None = None


class _Auxetic(_Design):
    poisson_ratio: float
    states: list[LatticeState]
    report: _AuxeticReport = _AuxeticReport()


class _AllostericReport(BaseModel):
    source: list[int]
    target: list[int]
    achieved_target_motion: Points = []


class _Allosteric(_Design):
    report: _AllostericReport


def picture_for_document(doc: dict, solution_space: bool = True) -> Picture:
    """The picture of a document, recognised by its fields.

    - a /v1/design/auxetic response (``states``, ``poisson_ratio``): viz.designs.lattice_picture;
    - a /v1/design/allosteric response (``report`` with ``source``, ``target``, ``relays``):
      viz.designs.allosteric_picture with the achieved target motion (equal to the prescribed
      one to ``report.target_error``);
    - a /v1/design response (``frame``, ``modes``, ``report``): viz.designs.design_picture;
    - any other document with a ``frame``: a /v1/plot body, whose ``solution_space`` defaults
      to true here;
    - requests of /v1/design/allosteric (``source``, ``target``), /v1/design/auxetic (``cells``
      or ``poisson_ratio``) and /v1/design (``positions``, ``motions``) are designed first; an
      allosteric request's own target motion is then drawn as the requested one.

    ``solution_space`` false never draws the solution space; true draws it for designs and
    plot bodies with a motion and specified nodes.  Raises InvalidInput on anything else.
    """
    if not isinstance(doc, dict):
        raise InvalidInput("invalid_document", "the document must be a JSON object.")
    if "frame" not in doc:
        response, request = _respond(doc)
        if isinstance(request, AllostericRequest):
            a = _validated(response, _Allosteric)
            return allosteric_picture(
                frame_from_model(a.frame), a.modes, a.report.source, a.report.target, request.target.motion
            )
        return picture_for_document(response, solution_space)
    report = doc.get("report") if isinstance(doc.get("report"), dict) else {}
    if "states" in doc and "poisson_ratio" in doc:
        a = _validated(doc, _Auxetic)
        states = {s.name: (s.positions, s.poisson_ratio) for s in a.states}
        return lattice_picture(frame_from_model(a.frame), a.modes, a.poisson_ratio, states, a.report.boundary)
    if {"source", "target", "relays"} <= report.keys():
        a = _validated(doc, _Allosteric)
        return allosteric_picture(
            frame_from_model(a.frame), a.modes, a.report.source, a.report.target, a.report.achieved_target_motion
        )
    if "report" in doc:
        d = _validated(doc, _Design)
        return design_picture(frame_from_model(d.frame), d.modes, solution_space)
    request = _validated(doc, PlotRequest)
    wanted = solution_space and doc.get("solution_space", True)
    has_motion = bool(request.modes or request.targets)
    return picture_from_request(
        request.model_copy(update={"solution_space": bool(wanted and has_motion and request.frame.specified)})
    )


def _respond(doc: dict) -> tuple[dict, BaseModel]:
    """Design a request document: (the response body, the validated request). The one place
    plotting calls the designers."""
    if "source" in doc and "target" in doc:
        r = _validated(doc, AllostericRequest)
        result = design_allosteric(
            r.source.positions, r.source.motion, r.target.positions, r.target.motion,
            dim=r.dim, seed=r.options.seed, relay_spacing=r.options.relay_spacing,
        )
        return allosteric_body(result, {}), r
    if "cells" in doc or "poisson_ratio" in doc:
        r = _validated(doc, AuxeticRequest)
        return auxetic_body(_lattice(r), {}), r
    if "positions" in doc and "motions" in doc:
        r = _validated(doc, DesignRequest)
        result = design_pipeline(r.positions, r.motions, dim=r.dim, seed=r.options.seed,
                                 n_unspecified=r.options.n_unspecified)
        return design_body(result, {}), r
    raise InvalidInput(
        "invalid_document",
        "the document is neither a /v1/plot body nor a request or response of /v1/design, "
        "/v1/design/auxetic or /v1/design/allosteric.",
    )


def _lattice(r: AuxeticRequest) -> Lattice:
    """A 2D sheet (cells [n_x, n_y], cell [w, h]) or a 3D chain (cells [n], block [w, h, l])."""
    cells, sizes = (2, 2) if r.dim == 2 else (1, 3)
    if len(r.cells) != cells:
        raise InvalidInput("invalid_size", f"a {r.dim}D lattice needs {cells} cell count(s).")
    if r.cell is not None and len(r.cell) != sizes:
        raise InvalidInput("invalid_cell", f"a {r.dim}D module has {sizes} half-sizes.")
    if r.dim == 2:
        return auxetic_sheet(*r.cells, poisson=r.poisson_ratio, cell=tuple(r.cell or (1.0, 1.0)), strain=r.strain)
    return auxetic_chain_3d(
        r.cells[0], poisson=r.poisson_ratio, block=tuple(r.cell or (1.0, 1.0, 1.0)), strain=r.strain, seed=r.seed
    )


def _validated(body: dict, model: type[BaseModel]):
    try:
        return model.model_validate(body)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "document"
        raise InvalidInput("invalid_request", f"{where}: {first.get('msg', 'invalid value')}.") from exc
