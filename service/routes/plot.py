"""POST /v1/plot — pictures in the paper's visual language (SVG) — and the /v1/plot body that
draws any of the service's design documents (what `zeromode plot` renders)."""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter
from fastapi.responses import Response
from pydantic import ValidationError

from zeromode.service.convert import frame_from_model
from zeromode.service.schemas.allostery import AllostericRequest
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.lattice import AuxeticRequest
from zeromode.service.schemas.plot import PlotRequest
from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.plot import MAX_ARROW_NODES, figure_svg
from zeromode.solver.rigidity import rigid_motions

router = APIRouter(prefix="/v1", tags=["plot"])

# Arrows per boundary side of a lattice with more than MAX_ARROW_NODES nodes.
ARROWS_PER_SIDE = 9
# The view (azimuth, elevation) of a 3D auxetic chain, whose blocks are strung along x.
CHAIN_VIEW = (-82.0, 22.0)


@router.post(
    "/plot",
    response_class=Response,
    responses={200: {"content": {"image/svg+xml": {}}, "description": "An SVG document."}, **ERROR_RESPONSES},
)
def post_plot(request: PlotRequest) -> Response:
    """Draw a frame: specified nodes red, unspecified blue, bars grey, requested motions as hollow
    green arrows, zero modes as solid green arrows, optionally the solution space (light blue),
    further configurations beside it with labels and captions, and source/target markers.  3D
    frames are shown in a fixed orthographic view with depth cues."""
    return Response(content=render_plot(request), media_type="image/svg+xml")


def render_plot(request: PlotRequest) -> str:
    """The SVG document for a validated /v1/plot body."""
    return figure_svg(
        frame_from_model(request.frame),
        modes=request.modes,
        targets=request.targets,
        solution_space=request.solution_space,
        configurations=request.configurations,
        labels=request.labels,
        source=request.source,
        target_nodes=request.target_nodes,
        title=request.title,
        seed=request.seed,
        captions=request.captions,
        frame_panel=request.frame_panel,
        arrow_nodes=request.arrow_nodes,
        view=request.view,
    )


def plot_request_for(doc: dict, solution_space: bool = True) -> PlotRequest:
    """The /v1/plot body that draws a document, recognised by its fields.

    - a /v1/design/auxetic response (``states``, ``poisson_ratio``): contracted state, reference
      with its mode, expanded state, left to right, each captioned with its boundary strain ε_x
      and Poisson ratio (the reference: the mode's linear ν; the states: the secant ν); a
      lattice of more than MAX_ARROW_NODES nodes carries arrows on ARROWS_PER_SIDE nodes of each
      boundary set only;
    - a /v1/design/allosteric response (``report`` with ``source``, ``target``, ``relays``):
      source and target marked, relays as ordinary unspecified nodes, the mode as solid arrows
      and the achieved target motion (equal to the prescribed one to ``report.target_error``)
      as hollow arrows on the target nodes;
    - a /v1/design response (``frame``, ``modes``, ``report``): the modes, and their rows on the
      specified nodes as the requested motions (a design's modes equal them there);
    - any other document with a ``frame`` is taken as a /v1/plot body;
    - requests of /v1/design/allosteric (``source``, ``target``), /v1/design/auxetic (``cells``
      or ``poisson_ratio``) and /v1/design (``positions``, ``motions``) are designed first; an
      allosteric request's own target motion is then drawn as the requested one.

    ``solution_space`` (design documents and plot bodies only) draws the solution space when
    there is a motion and specified nodes.  Raises InvalidInput on a document of no such kind.
    """
    if not isinstance(doc, dict):
        raise InvalidInput("invalid_document", "the document must be a JSON object.")
    report = doc.get("report") if isinstance(doc.get("report"), dict) else {}
    if "frame" not in doc:
        return _plot_request_for_request(doc, solution_space)
    if "states" in doc and "poisson_ratio" in doc:
        return _validated(_auxetic_body(doc))
    if {"source", "target", "relays"} <= report.keys():
        return _validated(_allosteric_body(doc))
    body = dict(doc)
    if "report" in doc:
        body = {"frame": doc["frame"], "modes": doc.get("modes")}
        if doc.get("modes"):
            # A design response's modes equal the requested motions on the specified nodes.
            specified = list(doc["frame"].get("specified", []))
            body["targets"] = [np.asarray(m, dtype=float)[specified].tolist() for m in doc["modes"]]
    request = _validated(body)
    has_motion = bool(request.modes or request.targets)
    request.solution_space = bool(
        solution_space and doc.get("solution_space", True) and has_motion and request.frame.specified
    )
    return request


def _plot_request_for_request(doc: dict, solution_space: bool) -> PlotRequest:
    # Imported here: the plot route needs the design routes only to draw their requests.
    from zeromode.service.routes.lattice import post_allosteric, post_auxetic

    if "source" in doc and "target" in doc:
        request = _validated(doc, AllostericRequest)
        plot = _validated(_allosteric_body(post_allosteric(request)))
        target = {i: row for i, row in zip(plot.target_nodes, request.target.motion)}
        plot.targets = [[target.get(i, [0.0] * request.dim) for i in plot.frame.specified]]
        return plot
    if "cells" in doc or "poisson_ratio" in doc:
        return _validated(_auxetic_body(post_auxetic(_validated(doc, AuxeticRequest))))
    if "positions" in doc and "motions" in doc:
        from zeromode.solver.design import design

        opts = doc.get("options", {})
        result = design(
            doc["positions"], doc["motions"], dim=doc.get("dim"),
            seed=opts.get("seed", 0), n_unspecified=opts.get("n_unspecified"),
        )
        body = {"frame": result.frame.to_dict(), "modes": result.modes.tolist(), "targets": doc["motions"],
                "solution_space": solution_space and bool(result.frame.specified)}
        return _validated(body)
    raise InvalidInput(
        "invalid_document",
        "the document is neither a /v1/plot body nor a request or response of /v1/design, "
        "/v1/design/auxetic or /v1/design/allosteric.",
    )


def _validated(body: dict, model=PlotRequest):
    try:
        return model.model_validate(body)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "document"
        raise InvalidInput("invalid_request", f"{where}: {first.get('msg', 'invalid value')}.") from exc


def _signed(v: float) -> str:
    """A number with a typographic minus sign."""
    return f"{v:+.2f}".replace("-", "\u2212")


def _auxetic_body(doc: dict) -> dict:
    """Contracted | reference (with the mode) | expanded.  The mode is drawn modulo rigid motions
    (its component orthogonal to the d(d+1)/2 rigid-body motions): any zero mode plus a rigid
    motion is the same deformation, and the 3D chain's mode carries a large one."""
    from zeromode.solver.lattice import (
        boundary_strains,  # (imports the continuation code: only when needed)
    )

    f = doc["frame"]
    frame = Frame.build(f["positions"], f.get("edges", []), f.get("specified", []), dim=f.get("dim"))
    rigid = rigid_motions(frame.normalised_positions())
    modes = []
    for m in doc.get("modes") or []:
        u = np.asarray(m, dtype=float).ravel()
        modes.append((u - rigid @ (rigid.T @ u)).reshape(frame.n_nodes, frame.dim).tolist())
    states = {s["name"]: s for s in doc["states"]}
    boundary = (doc.get("report") or {}).get("boundary")
    panels = [("contracted", states.get("contracted")), ("reference", None), ("expanded", states.get("expanded"))]
    panels = [(name, s) for name, s in panels if name == "reference" or s is not None]
    captions = []
    for name, state in panels:
        if state is None:
            captions.append(f"mode: \u03bd = {_signed(doc['poisson_ratio'])}")
            continue
        nu = f"\u03bd = {_signed(state['poisson_ratio'])}"
        if boundary:
            x = np.asarray(state["positions"], dtype=float)
            eps_x, _ = boundary_strains(frame.positions, x - frame.positions, boundary)
            nu = f"\u03b5\u2093 = {_signed(eps_x)}, " + nu  # ε_x
        captions.append(nu)
    body = {
        "frame": f,
        "modes": modes,
        "configurations": [s["positions"] for _, s in panels if s is not None],
        "frame_panel": [name for name, _ in panels].index("reference"),
        "labels": [name for name, _ in panels],
        "captions": captions,
    }
    if frame.dim == 3:
        # The chain runs along x: seen from nearly −y its blocks stand side by side instead of
        # overlapping along the default view's diagonal.
        body["view"] = CHAIN_VIEW
    if frame.n_nodes > MAX_ARROW_NODES and boundary:
        # A big sheet: arrows on a few evenly spaced nodes of each boundary set, the sets whose
        # motion defines ε_x, ε_y and ν (arrows on every node would hide the lattice).
        body["arrow_nodes"] = sorted(
            {int(side[i]) for side in boundary.values() if len(side)
             for i in np.unique(np.round(np.linspace(0, len(side) - 1, min(len(side), ARROWS_PER_SIDE))).astype(int))}
        )
    return body


def _allosteric_body(doc: dict) -> dict:
    """Source and target marked; the achieved target motion as the requested one on the target
    nodes (zero rows, which draw nothing, on the source nodes)."""
    report, frame = doc["report"], doc["frame"]
    dim = frame.get("dim") or len(frame["positions"][0])
    achieved = dict(zip(report["target"], report.get("achieved_target_motion") or []))
    targets = [[achieved.get(i, [0.0] * dim) for i in frame.get("specified", [])]] if achieved else None
    return {"frame": frame, "modes": doc.get("modes"), "targets": targets,
            "source": report["source"], "target_nodes": report["target"]}
