"""POST /v1/motion — finite motion along a zero mode; POST /v1/refine — IPOPT refinement."""

from __future__ import annotations

import time

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from zeromode.service.convert import frame_from_model
from zeromode.service.errors import error_body
from zeromode.service.prechecks import motion_frame
from zeromode.service.responses import motion_body, refinement_body
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.motion import (
    MotionErrorResponse,
    MotionRequest,
    MotionResponse,
    RefineRequest,
    RefineResponse,
)
from zeromode.solver.applications.lattice import path_strains
from zeromode.solver.motion.finite_motion import SingularPath, trace_motion
from zeromode.solver.motion.periodic import trace_motion_through_cell
from zeromode.solver.motion.refine import RefinementFailed, refine
from zeromode.solver.motion.target import MotionTarget, TargetUnreachable, aim_motion

router = APIRouter(prefix="/v1", tags=["finite motion"])

RESPONSES = {
    **ERROR_RESPONSES,
    422: {
        "model": MotionErrorResponse,
        "description": (
            "Invalid request or domain failure; `singular_path` and `refinement_failed` carry the "
            "best result found in detail.best."
        ),
    },
}


@router.post("/motion", response_model=MotionResponse, responses=RESPONSES)
def post_motion(request: MotionRequest):
    """Follow the finite motion of a frame along a zero mode by predictor–corrector continuation.

    Every configuration keeps every bar length (max_relative_bar_error ≤ 1e-9) and is aligned to
    the input frame (rigid motion removed). Singular points (extra zero modes: a branch point, or
    the frame locks) end the path in their direction and are reported; by default they answer
    422 `singular_path` with the path up to them. Sparse linear algebra above 400 degrees of
    freedom; frames beyond the continuation's limit (finite_motion.MAX_DOF) answer 422
    `too_expensive` before any work. With a lattice's `boundary`, every configuration's strain
    and secant Poisson ratio are reported, and a frame tiled by translations (recognised from its
    geometry) is followed through one cell and checked on the whole frame (method `periodic`: bar
    lengths at every configuration, the tiled tangent a zero mode, singular points of the frame
    located); where that check fails, the frame's own continuation answers. With a `target`
    (a distance, an angle, a lattice strain, a fraction of the usable range) the path ends
    exactly where it is reached (solver.motion.target), or 422 names why it cannot be.
    """
    t0 = time.perf_counter()
    frame = motion_frame(request)
    aimed = None
    if request.target is not None:
        target = MotionTarget(**request.target.model_dump(exclude={"nodes"}), nodes=tuple(request.target.nodes or ()), boundary=request.boundary)
        try:
            aimed = aim_motion(
                frame, target, periodic=request.boundary is not None,
                **request.model_dump(include={"mode", "max_step", "direction", "max_steps"}),
            )
        except TargetUnreachable as exc:
            body = _motion_body(frame, request, exc.best.path, t0, exc.best)
            return JSONResponse(status_code=422, content=error_body(exc.code, exc.message, best=body))
        path = aimed.path
    else:
        # A lattice (its boundary given) is followed through one cell when it is tiled, checked on the frame.
        trace = trace_motion if request.boundary is None else trace_motion_through_cell
        path = trace(frame, **request.model_dump(include={"mode", "amplitude", "max_step", "direction", "max_steps"}))
    body = _motion_body(frame, request, path, t0, aimed)
    if path.singularities and request.on_singularity == "error":
        exc = SingularPath(path)
        return JSONResponse(status_code=422, content=error_body(exc.code, exc.message, best=body))
    return body


def _motion_body(frame, request: MotionRequest, path, t0: float, aimed) -> dict:
    strains = None if request.boundary is None else path_strains(frame.positions, path.positions, request.boundary)
    return motion_body(path, {"total": 1e3 * (time.perf_counter() - t0)}, strains, aimed)


@router.post("/refine", response_model=RefineResponse, responses=RESPONSES)
def post_refine(request: RefineRequest):
    """Move the unspecified nodes (casadi + IPOPT, exact derivatives) so that the finite motion
    carries the specified nodes to x_S + Δ_S along a continuous path.

    Reports ε before and after (finite-motion fidelity, measured by continuation), IPOPT's
    status, iterations and time. The refined frame is re-verified: no new self-stress and one
    nontrivial zero mode at both ends. Failure answers 422 `refinement_failed` with the best
    result in detail.best.
    """
    frame = frame_from_model(request.frame)
    opts = request.options
    try:
        result = refine(
            frame,
            motion_s=request.motion,
            amplitude=request.amplitude,
            targets=request.targets,
            **opts.model_dump(include={"K", "tol", "max_iter", "max_time_s", "stay_on_solution_space"}),
        )
    except RefinementFailed as exc:
        return JSONResponse(
            status_code=422,
            content=error_body(exc.code, exc.message, best=refinement_body(exc.best)),
        )
    return refinement_body(result)
